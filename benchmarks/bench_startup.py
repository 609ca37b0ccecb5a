"""What a fresh process pays before its first result: start-up, imports and kernel compilation.

Each case runs as a new-user's process would, in a child process of its own: the README's first
command (``wdendrite fractal --size 256 -o fractal.png --force``), ``wdendrite terrain --size
256``, the README's "API in a screenful" block (read from the README, run as a script),
``wdendrite --help``, ``wdendrite --version``, ``python -c "import wdendrite"`` and, for
reference, ``python -c "import warp"``. The cases that compile kernels run

- *cold*: with ``WARP_CACHE_PATH`` set to a new empty folder, so every kernel module they use
  is compiled (``--cold`` runs of each, default 2);
- *warm*: with the folder one of their cold runs filled (``--warm`` runs, default 5).

The other cases need no kernel and run warm only. Runs go in turns (one of each case, then
again), so a disturbance on the shared machine hits every case alike. For each case the
script prints the median and range of the child's CPU seconds (user + system, from
``os.wait4``), its wall seconds and its peak resident set, and for the cold and warm runs each
kernel module's load time as Warp reports it (``Module NAME HASH load on device 'cpu' took X ms
(compiled|cached)``). The CLI and the README's block turn Warp's module-load lines off; the
child turns them on for the duration of each module load (a wrapper around
``warp``'s module loader), which changes nothing else the command does.

Run: ``python benchmarks/bench_startup.py`` (``--cold 1 --warm 1`` for a smoke test;
``--cases fractal,help`` for some cases only).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path

from _measure import cpu_model, now, shown

ROOT = Path(__file__).resolve().parent.parent

# Warp's module-load lines on while a module loads (the CLI and the README's block turn them off)
_LOUD_LOADS = r"""
import warp as wp
from warp._src import context as _ctx
_load = _ctx.Module.load
def _loud(self, *args, **kwargs):
    level = wp.config.log_level
    wp.config.log_level = min(level, wp.LOG_INFO)
    try:
        return _load(self, *args, **kwargs)
    finally:
        wp.config.log_level = level
_ctx.Module.load = _loud
"""

_CLI = _LOUD_LOADS + "import sys\nfrom wdendrite.cli import main\nsys.exit(main(sys.argv[1:]))\n"

_LOAD_LINE = re.compile(r"Module (\S+) (?:\S+ )?load on device '([^']+)' took ([\d.]+) ms\s*\((compiled|cached)\)")


def readme_api_block() -> str:
    """The Python block under the README's "The API in a screenful" heading."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    m = re.search(r"^## The API in a screenful\s*\n.*?```python\n(.*?)```", text, re.S | re.M)
    if m is None:
        raise SystemExit("README.md has no 'The API in a screenful' Python block")
    return m.group(1)


def cases(folder: Path) -> dict:
    """name -> (argv, compiles kernels)."""
    py, cli = sys.executable, shutil.which("wdendrite") or "wdendrite"
    return {
        "fractal": ([py, "-c", _CLI, "fractal", "--size", "256", "-o", str(folder / "fractal.png"), "--force"], True),
        "terrain": ([py, "-c", _CLI, "terrain", "--size", "256", "-o", str(folder / "terrain.png"), "--force"], True),
        "api": ([py, "-c", _LOUD_LOADS + readme_api_block()], True),
        "help": ([cli, "--help"], False),
        "version": ([cli, "--version"], False),
        "import": ([py, "-c", "import wdendrite"], False),
        "import-warp": ([py, "-c", "import warp"], False),
    }


def run(argv, *, cache: Path, cwd: Path) -> dict:
    """Run ``argv`` to its end; its CPU, wall, peak RSS and Warp's module-load lines."""
    env = dict(os.environ, WARP_CACHE_PATH=str(cache))
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        import subprocess

        t = time.perf_counter()
        proc = subprocess.Popen(argv, stdout=out, stderr=err, cwd=cwd, env=env)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        text, errors = out.read().decode(errors="replace"), err.read().decode(errors="replace")
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(argv[:1] + argv[3:] if '-c' in argv else argv)} failed "
                           f"({proc.returncode}):\n{errors[-3000:]}")
    modules = {}
    for name, device, ms, how in _LOAD_LINE.findall(text + errors):
        modules[name] = (float(ms) / 1000.0, how)
    return {"cpu": usage.ru_utime + usage.ru_stime, "wall": wall, "rss_mib": usage.ru_maxrss / 1024.0,
            "modules": modules}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cold", type=int, default=2, help="runs with an empty kernel cache per case (default 2)")
    ap.add_argument("--warm", type=int, default=5, help="runs with a filled kernel cache per case (default 5)")
    ap.add_argument("--cases", default=None, help="comma-separated subset of: fractal, terrain, api, help, "
                                                   "version, import, import-warp")
    args = ap.parse_args()
    if args.cold < 1 or args.warm < 1:
        ap.error(f"--cold and --warm must be at least 1, got {args.cold} and {args.warm}")
    work = Path(tempfile.mkdtemp(prefix="bench-startup-"))
    try:
        table = cases(work)
        if args.cases:
            wanted = args.cases.split(",")
            unknown = [c for c in wanted if c not in table]
            if unknown:
                ap.error(f"--cases: unknown {unknown}; known: {', '.join(table)}")
            table = {k: v for k, v in table.items() if k in wanted}
        print(f"# bench_startup  {now()}  {cpu_model()}")
        print(f"# CPU s = user + system of the child; median (range) of {args.cold} cold and {args.warm} warm runs, "
              f"in turns")
        results = {(name, phase): [] for name in table for phase in ("cold", "warm")}
        warm_cache = {}
        for r in range(args.cold):
            for name, (argv, kernels) in table.items():
                if kernels:
                    cache = Path(tempfile.mkdtemp(dir=work, prefix="cache-"))
                    results[name, "cold"].append(run(argv, cache=cache, cwd=work))
                    old = warm_cache.get(name)
                    if old is not None:
                        shutil.rmtree(old, ignore_errors=True)
                    warm_cache[name] = cache
        empty = Path(tempfile.mkdtemp(dir=work, prefix="cache-"))
        for r in range(args.warm):
            for name, (argv, kernels) in table.items():
                results[name, "warm"].append(run(argv, cache=warm_cache.get(name, empty), cwd=work))
        print("| case | cache | CPU s | wall s | peak RSS MiB | modules compiled (cold) or loaded (warm) |")
        print("| --- | --- | ---: | ---: | ---: | ---: |")
        for (name, phase), runs in results.items():
            if not runs:
                continue
            mods = runs[-1]["modules"]
            count = (f"{sum(how == 'compiled' for _, how in mods.values())} compiled" if phase == "cold"
                     else f"{sum(how == 'cached' for _, how in mods.values())} cached"
                     + (f", {sum(how == 'compiled' for _, how in mods.values())} compiled"
                        if any(how == "compiled" for _, how in mods.values()) else ""))
            print(f"| {name} | {phase if table[name][1] else '-'} | {shown([x['cpu'] for x in runs])} | "
                  f"{shown([x['wall'] for x in runs])} | {shown([x['rss_mib'] for x in runs], '.0f')} | "
                  f"{count if mods else '-'} |")
        print()
        print("Module load times (Warp's own figure, wall seconds; median (range) over the runs):")
        print("| case | cache | module | s |")
        print("| --- | --- | --- | ---: |")
        for (name, phase), runs in results.items():
            names = dict.fromkeys(m for x in runs for m in x["modules"])
            for m in names:
                times = [x["modules"][m][0] for x in runs if m in x["modules"]]
                print(f"| {name} | {phase} | {m} | {shown(times)} |")
        print(f"# done {now()}  load average {' / '.join(f'{x:.1f}' for x in os.getloadavg())}")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
