"""Every core: the ``dendry`` and ``terrain`` commands on one thread and on all of them.

Two parts:

- ``launches``: does Warp let go of Python's interpreter lock while a CPU launch runs?
  The same long kernel launched twice, one launch after the other in one thread, then
  at once from two threads (its own output each): wall and CPU seconds of this process.
  Where the lock is released and two cores are free, two threads take about half the
  wall time for the same CPU time. A second probe counts how far a pure-Python loop in
  the main thread gets while another thread's launch runs (against the same loop alone).
- ``commands``: whole processes, as a user runs them: ``wdendrite dendry --size N`` and
  ``wdendrite terrain --size N`` (pictures, ``.png``), ``terrain`` writing only the
  elevation (``.npy``), whole and in tiles of N / 8 (``--tile``), each with ``--workers 1`` and ``--workers W`` in turns, repeated.
  For each run: the wall seconds of the process, its CPU seconds (user + system, from
  the kernel's accounting of the finished child), and the compute seconds the command
  prints (``in X s``: the model and its picture, without Python's and Warp's start and
  the file writes). The outputs of every run are compared byte for byte with the first
  run's with one worker.

Other work on a shared machine takes cores from the threads: the load average is printed
before and after every run, and the speed-up is only the machine's to give when it is idle.
The CPU-time ratio shows what the split costs in extra work whatever the load.

Run: ``python benchmarks/bench_cores.py`` (``--size 4096 --repeat 5``; ``--quick``: 512, 2 runs).
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from _measure import cpu_model, now, shown, spread


def _launch_probe(repeat: int) -> None:
    import logging

    import warp as wp

    wp.config.log_level = logging.WARNING  # (no start-up banner or module-load lines)
    wp.init()

    @wp.kernel
    def spin(n: int, out: wp.array(dtype=float)):
        i = wp.tid()
        x = float(i)
        for _ in range(n):
            x = wp.sin(x) * 0.999 + 0.001
        out[i] = x

    size = 1 << 16
    outs = [wp.zeros(size, dtype=float, device="cpu") for _ in range(2)]
    wp.launch(spin, dim=size, inputs=[1, outs[0]], device="cpu")  # (compiled or loaded before any timing)

    def one(k: int) -> None:
        wp.launch(spin, dim=size, inputs=[400, outs[k]], device="cpu")

    def timed(fn):
        t, c = time.perf_counter(), time.process_time()
        fn()
        return time.perf_counter() - t, time.process_time() - c

    def serial():
        one(0)
        one(1)

    def threads():
        ts = [threading.Thread(target=one, args=(k,)) for k in range(2)]
        for t in ts:
            t.start()
        for t in ts:
            t.join()

    runs = {"one thread, 2 launches in turn": [], "two threads, 1 launch each": []}
    for _ in range(repeat):
        for name, fn in zip(runs, (serial, threads)):
            runs[name].append(timed(fn) + (os.getloadavg()[0],))
    print("\nlaunches: the same kernel (65536 threads x 400 sines) twice on Warp's CPU device")
    print("| how | wall s | CPU s | CPU / wall | load (1 min) |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for name, rs in runs.items():
        wall, cpu, load = zip(*rs)
        print(f"| {name} | {shown(wall)} | {shown(cpu)} | {spread(cpu)[0] / spread(wall)[0]:.2f} | "
              f"{shown(load, '.2f')} |")
    ratio = spread([w for w, _, _ in runs["one thread, 2 launches in turn"]])[0] / \
        spread([w for w, _, _ in runs["two threads, 1 launch each"]])[0]
    print(f"wall-time ratio, one thread / two threads: {ratio:.2f}")

    # the interpreter while a launch runs: the main thread's loop against the same loop alone
    done = threading.Event()

    def launch_then_flag():
        one(0)
        done.set()

    th = threading.Thread(target=launch_then_flag)
    n, t = 0, time.perf_counter()
    th.start()
    while not done.is_set():
        n += 1
    during = n / (time.perf_counter() - t)
    th.join()
    n, t = 0, time.perf_counter()
    while time.perf_counter() - t < 0.5:
        n += 1
    alone = n / (time.perf_counter() - t)
    print(f"a Python loop in the main thread while another thread's launch runs: {during / alone:.2f} of its "
          "speed alone (0 would mean the launch holds the interpreter lock)")


def _command(args: list[str], cwd: Path) -> tuple[float, float, float, str]:
    """Run ``wdendrite ARGS``; return (wall s, CPU s of the child, the compute seconds it printed, stdout)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "wdendrite", *args], cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise RuntimeError(f"wdendrite {' '.join(args)} failed:\n{p.stderr[-3000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    found = re.search(r"(?: in|tiles:) ([0-9.]+) s ", p.stdout)
    return wall, cpu, float(found.group(1)) if found else float("nan"), p.stdout


def _commands(size: int, workers: int, repeat: int) -> None:
    tile = max(8, size // 8)
    cases = {
        f"dendry --size {size} -o d.png": ["dendry", "--size", str(size), "-o", "d.png"],
        f"terrain --size {size} -o t.png": ["terrain", "--size", str(size), "-o", "t.png"],
        f"terrain --size {size} -o t.npy": ["terrain", "--size", str(size), "-o", "t.npy"],
        f"terrain --size {size} --tile {tile} -o u.npy": ["terrain", "--size", str(size), "--tile", str(tile), "-o",
                                                             "u.npy"],
    }
    tmp = Path(tempfile.mkdtemp(prefix="bench-cores-"))
    try:
        rows = []
        for name, args in cases.items():
            out = args[-1]
            runs = {1: [], workers: []}
            reference = None
            _command([*args, "--force", "--quiet", "--workers", "1"], tmp)  # (kernels loaded, files cached)
            for _ in range(repeat):
                for n in runs:
                    load = os.getloadavg()[0]
                    wall, cpu, compute, _ = _command([*args, "--force", "--quiet", "--workers", str(n)], tmp)
                    runs[n].append((wall, cpu, compute, load, os.getloadavg()[0]))
                    data = (tmp / out).read_bytes()
                    if reference is None:
                        reference = data
                    elif data != reference:
                        raise RuntimeError(f"{name} --workers {n} wrote other bytes than --workers 1")
            rows.append((name, runs))
        print(f"\ncommands: whole processes, --workers 1 and --workers {workers} in turns, {repeat} runs each; "
              "outputs equal byte for byte across runs")
        print("| command | workers | wall s | CPU s | compute s (printed) | load before / after (1 min) |")
        print("| --- | ---: | ---: | ---: | ---: | --- |")
        for name, runs in rows:
            for n, rs in runs.items():
                wall, cpu, compute, l0, l1 = zip(*rs)
                print(f"| `{name}` | {n} | {shown(wall)} | {shown(cpu)} | {shown(compute)} | "
                      f"{shown(l0, '.2f')} / {shown(l1, '.2f')} |")
        print("\n| command | wall, 1 / W | compute, 1 / W | CPU, W / 1 |")
        print("| --- | ---: | ---: | ---: |")
        for name, runs in rows:
            one, many = ([spread(col)[0] for col in zip(*runs[n])][:3] for n in runs)
            print(f"| `{name}` | {one[0] / many[0]:.2f} | {one[2] / many[2]:.2f} | {many[1] / one[1]:.2f} |")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=4096, help="image side of the commands (default 4096)")
    ap.add_argument("--repeat", type=int, default=5, help="runs of each side, in turns (default 5)")
    ap.add_argument("--workers", type=int, default=None, help="threads of the many-thread side (default: every core)")
    ap.add_argument("--quick", action="store_true", help="size 512, 2 runs")
    ap.add_argument("--part", choices=("all", "launches", "commands"), default="all")
    args = ap.parse_args()
    if args.quick:
        args.size, args.repeat = 512, 2
    if args.repeat < 1:
        ap.error(f"--repeat must be at least 1, got {args.repeat}")
    from wdendrite._parallel import cores

    workers = args.workers or cores()
    print(f"# bench_cores, {now()}: {cpu_model()}; this process may use {cores()} cores")
    if args.part in ("all", "launches"):
        _launch_probe(args.repeat)
    if args.part in ("all", "commands"):
        if workers < 2:
            print("commands: one core only, nothing to compare")
        else:
            _commands(args.size, workers, args.repeat)


if __name__ == "__main__":
    main()
