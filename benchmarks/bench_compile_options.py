"""Kernel module options against both of their costs: compile time and run time.

A module option such as the CPU compiler flags, the optimisation level or the loop-unrolling
limit changes two figures at once: how long the module takes to compile on a new user's first
run, and how fast its kernels run afterwards. For each *variant* (a set of option overrides,
``{"*": {...}, "sssp": {...}}`` by kernel module; ``{}`` is the project's own settings) this
script measures

- *compile*: every kernel module of the package compiled for the CPU in a fresh process with
  an empty ``WARP_CACHE_PATH``, the CPU seconds of each module's load (``time.thread_time``
  around ``wp.load_module``; the first module also builds Warp's precompiled header, so the
  modules load in a fixed order and that cost falls on the same one each time);
- *run*: three workloads, each in a fresh process whose cache the compile step filled:
  ``sssp`` (``shortest_paths`` on a 2048^2 8-connected lattice), ``fractal`` (the ``fractal``
  model at size 768: growth, backtracking, strokes) and ``terrain`` (a 1024^2 Dendry elevation,
  the paper's Table 1 setup), the least of three calls after a warm-up call.

Variants run in turns, ``--repeat`` times (default 3 compiles, 5 runs); the median and range
are printed. ``--quick`` runs smaller workloads (a smoke test).

Run: ``python benchmarks/bench_compile_options.py --variant NAME='{"*": {"optimization_level": 1}}' ...``
(without ``--variant``: the project's settings beside Warp's defaults for every module).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from _measure import cpu_model, now, shown

_APPLY = r"""
import importlib, json, logging, pkgutil, sys, time
import warp as wp
wp.config.log_level = logging.WARNING
wp.init()
import wdendrite.kernels as pkg
overrides = json.loads(sys.argv[1])
names = sorted(m.name for m in pkgutil.iter_modules(pkg.__path__))
modules = {n: importlib.import_module(f"wdendrite.kernels.{n}") for n in names}
for n, m in modules.items():
    opts = {**overrides.get("*", {}), **overrides.get(n, {})}
    if opts:
        wm = wp.get_module(m.__name__)
        wm.options.update(opts)
        wm.mark_modified()
"""

_COMPILE = _APPLY + r"""
for n, m in modules.items():
    if not any(isinstance(v, wp.Kernel) for v in vars(m).values()):
        continue
    t = time.thread_time()
    wp.load_module(m, device="cpu")
    print("MODULE", n, time.thread_time() - t)
"""

_RUN = _APPLY + r"""
import numpy as np
import wdendrite as wd
from wdendrite._models import TABLE1, dendry_setup, fractal
work, quick = sys.argv[2], sys.argv[3] == "1"
if work == "sssp":
    n = 256 if quick else 2048
    lat = wd.Lattice((n, n), connectivity=8, weights=wd.weights.Uniform(r=10, seed=1))
    call = lambda: wd.shortest_paths(lat, [[n // 2, n // 2]])
elif work == "fractal":
    call = lambda: fractal(128 if quick else 768).image
else:
    setup = dendry_setup(128 if quick else 1024, TABLE1, extent=4.0, control="perlin", frequency=1.0, drained=True,
                         seed=0, output="elevation")
    call = lambda: wd.dendry(**setup, output="elevation")
call()
best = float("inf")
for _ in range(3):
    t = time.perf_counter()
    call()
    best = min(best, time.perf_counter() - t)
print("SECONDS", best)
"""

WORKLOADS = ("sssp", "fractal", "terrain")

WARP_DEFAULT_FLAGS = ("-march=native -mllvm=-inline-threshold=9000 -mllvm=-inline-cold-callsite-threshold=3000"
                      " -mllvm=-slp-recursion-max-depth=4")
"""``warp.config.cpu_compiler_flags``'s default in Warp 1.19 (a module's ``None`` inherits it)."""


def child(code: str, *args: str, cache: Path) -> str:
    env = dict(os.environ, WARP_CACHE_PATH=str(cache))
    proc = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        raise RuntimeError(f"child failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    return proc.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--variant", action="append", default=[], metavar="NAME=JSON",
                    help="a variant: its name and its option overrides by kernel module ('*': every module)")
    ap.add_argument("--repeat", type=int, default=3, help="compiles per variant (default 3)")
    ap.add_argument("--runs", type=int, default=5, help="runs per variant and workload (default 5)")
    ap.add_argument("--quick", action="store_true", help="small workloads")
    ap.add_argument("--workloads", default=",".join(WORKLOADS), help=f"comma-separated subset of {WORKLOADS}")
    args = ap.parse_args()
    if args.repeat < 1 or args.runs < 1:
        ap.error(f"--repeat and --runs must be at least 1, got {args.repeat} and {args.runs}")
    workloads = args.workloads.split(",")
    if not workloads or not set(workloads) <= set(WORKLOADS):
        ap.error(f"--workloads: expected names from {WORKLOADS}, got {args.workloads!r}")
    variants = {}
    for v in args.variant or ["project={}",
                              "warp-defaults=" + json.dumps({"*": {"cpu_compiler_flags": WARP_DEFAULT_FLAGS,
                                                                   "optimization_level": None,
                                                                   "max_unroll": None}})]:
        name, _, text = v.partition("=")
        try:
            variants[name] = json.loads(text)
        except json.JSONDecodeError as exc:
            ap.error(f"--variant {v!r}: not JSON after the '=': {exc}")
    work = Path(tempfile.mkdtemp(prefix="bench-compile-"))
    try:
        print(f"# bench_compile_options  {now()}  {cpu_model()}")
        for name, o in variants.items():
            print(f"# variant {name}: {json.dumps(o)}")
        compiles = {name: [] for name in variants}
        caches = {}
        for _ in range(args.repeat):
            for name, o in variants.items():
                cache = Path(tempfile.mkdtemp(dir=work))
                out = child(_COMPILE, json.dumps(o), cache=cache)
                compiles[name].append({ln.split()[1]: float(ln.split()[2]) for ln in out.splitlines()
                                       if ln.startswith("MODULE ")})
                if name in caches:
                    shutil.rmtree(caches[name], ignore_errors=True)
                caches[name] = cache
        runs = {(name, w): [] for name in variants for w in workloads}
        for _ in range(args.runs):
            for w in workloads:
                for name, o in variants.items():
                    out = child(_RUN, json.dumps(o), w, "1" if args.quick else "0", cache=caches[name])
                    runs[name, w].append(next(float(ln.split()[1]) for ln in out.splitlines()
                                              if ln.startswith("SECONDS ")))
        modules = list(dict.fromkeys(m for v in compiles.values() for c in v for m in c))
        print(f"\nCompile CPU seconds per module (median (range) of {args.repeat}):")
        print("| module | " + " | ".join(variants) + " |")
        print("| --- |" + " ---: |" * len(variants))
        for m in modules + ["total"]:
            cells = []
            for name in variants:
                vals = [sum(c.values()) if m == "total" else c.get(m, 0.0) for c in compiles[name]]
                cells.append(shown(vals))
            print(f"| {m} | " + " | ".join(cells) + " |")
        print(f"\nRun seconds (least of 3 calls per process; median (range) of {args.runs} processes):")
        print("| workload | " + " | ".join(variants) + " |")
        print("| --- |" + " ---: |" * len(variants))
        for w in workloads:
            print(f"| {w} | " + " | ".join(shown(runs[name, w]) for name in variants) + " |")
        print(f"# done {now()}  load average {' / '.join(f'{x:.1f}' for x in os.getloadavg())}")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
