"""Measuring helpers shared by the benchmarks.

``run_isolated(module, name, **kwargs)`` starts ``python -c`` in a child that
imports the function, builds its inputs, resets the kernel's peak-RSS counter
(``/proc/self/clear_refs``), runs it, and prints a JSON line with the wall
time and the growth of the peak resident set over the inputs. A result entry
``_save: (path, array)`` is written to disk after the measurement. Running each
case in its own process keeps one method's memory from hiding another's. With
``whole_process=True`` the child also reports what a user's fresh process pays:
the seconds from its start to the end of ``module.name`` (which imports what the
case needs, and for Warp initializes it and loads the kernels), and the peak
resident set of the whole process (``VmHWM``, never reset).

``interleaved(sides, repeat)`` times several callables in turns (one run of each,
then again), so a disturbance on a shared machine hits every side alike;
``spread(values)`` and ``shown(values)`` give and print the median and the range
of repeated measurements; ``cpu_model()`` and ``now()`` name the machine (with its load) and the time.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

_CHILD = r"""
import importlib, json, os, sys, time
def rss_kib(field):
    with open('/proc/self/status') as f:
        for line in f:
            if line.startswith(field + ':'):
                return int(line.split()[1])
mod, name, kwargs, whole = sys.argv[1], sys.argv[2], json.loads(sys.argv[3]), sys.argv[4] == '1'
fn = getattr(importlib.import_module(mod), name)
prepare, run = fn(**kwargs)
started = time.time() - float(sys.argv[5])
state = prepare()
base = rss_kib('VmRSS')
if not whole:
    with open('/proc/self/clear_refs', 'w') as f:
        f.write('5')
t = time.perf_counter()
result = run(state)
dt = time.perf_counter() - t
peak = rss_kib('VmHWM')
if isinstance(result, dict) and '_save' in result:
    # writing the result for the cross-check is not part of the measured computation
    import numpy as np
    path, value = result.pop('_save')
    np.save(path, np.asarray(value, dtype=np.float32))
    result['file'] = path
out = {'seconds': dt, 'peak_mib': (peak - base) / 1024.0, 'result': result}
if whole:
    out.update(startup_seconds=started, process_peak_mib=peak / 1024.0)
print('RESULT ' + json.dumps(out))
"""


def run_isolated(module: str, name: str, *, python: str | None = None, whole_process: bool = False,
                 **kwargs) -> dict:
    """Run ``module.name(**kwargs)`` -> ``(prepare, run)`` in a child process; return its measurement.

    Returns ``seconds`` (of ``run``), ``peak_mib`` (growth of the peak resident set during ``run``
    over what ``prepare`` left) and ``result``; with ``whole_process``, also ``startup_seconds``
    (from the child's launch to the return of ``module.name``: interpreter, imports, Warp's start)
    and ``process_peak_mib`` (the child's peak resident set, imports and inputs included; the peak
    counter is then not reset, so ``peak_mib`` is the growth over the earlier peak).
    ``python``: the interpreter of the child (default: this one), for a peer that lives in
    an environment of its own."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.path.dirname(os.path.abspath(__file__)) + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.run(
        [python or sys.executable, "-c", _CHILD, module, name, json.dumps(kwargs), "1" if whole_process else "0",
         repr(time.time())],
        capture_output=True, text=True, env=env,
    )
    for line in proc.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    raise RuntimeError(f"measurement {name}({kwargs}) failed:\n{proc.stderr[-3000:]}")


def interleaved(sides: dict, repeat: int, *, warm: bool = False) -> dict:
    """Run each zero-argument callable of ``sides`` (name -> callable) ``repeat`` times, in turns.

    Returns ``{name: (seconds, result)}``: the list of wall seconds of its runs and the result
    of its last run. ``warm``: one untimed run of each first (compiling, loading, caching)."""
    if warm:
        for fn in sides.values():
            fn()
    out = {name: ([], None) for name in sides}
    for _ in range(repeat):
        for name, fn in sides.items():
            t = time.perf_counter()
            result = fn()
            seconds = time.perf_counter() - t
            out[name] = (out[name][0] + [seconds], result)
    return out


def spread(values) -> tuple[float, float, float]:
    """Median, least and greatest of repeated measurements."""
    v = sorted(float(x) for x in values)
    if not v:
        raise ValueError("no measurements")
    mid = len(v) // 2
    median = v[mid] if len(v) % 2 else 0.5 * (v[mid - 1] + v[mid])
    return median, v[0], v[-1]


def shown(values, fmt: str = ".3g", unit: str = "") -> str:
    """``median (least-greatest)`` of repeated measurements, e.g. ``1.23 (1.20-1.31)``."""
    median, lo, hi = spread(values)
    return f"{median:{fmt}}{unit} ({lo:{fmt}}-{hi:{fmt}}{unit})"


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo, the number of logical CPUs and the load average
    (other work on a shared machine slows every side: the spread of the repeats shows how much)."""
    name = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    name = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    load = " / ".join(f"{x:.1f}" for x in os.getloadavg())
    return f"{name}, {os.cpu_count()} logical CPUs, load average {load} (1 / 5 / 15 min)"


def now() -> str:
    return time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
