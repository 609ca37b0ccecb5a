"""Run one measurement in a fresh process and report its time and peak memory.

``run_isolated(fn_path, kwargs)`` starts ``python -c`` in a child that imports
the function, builds its inputs, resets the kernel's peak-RSS counter
(``/proc/self/clear_refs``), runs it, and prints a JSON line with the wall
time and the growth of the peak resident set over the inputs. A result entry
``_save: (path, array)`` is written to disk after the measurement. Running each
case in its own process keeps one method's memory from hiding another's.
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
mod, name, kwargs = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
fn = getattr(importlib.import_module(mod), name)
prepare, run = fn(**kwargs)
state = prepare()
base = rss_kib('VmRSS')
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
print('RESULT ' + json.dumps({'seconds': dt, 'peak_mib': (peak - base) / 1024.0, 'result': result}))
"""


def run_isolated(module: str, name: str, *, python: str | None = None, **kwargs) -> dict:
    """Run ``module.name(**kwargs)`` -> ``(prepare, run)`` in a child process; return its measurement.

    ``python``: the interpreter of the child (default: this one), for a peer that lives in
    an environment of its own."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.path.dirname(os.path.abspath(__file__)) + os.pathsep + env.get("PYTHONPATH", "")
    proc = subprocess.run(
        [python or sys.executable, "-c", _CHILD, module, name, json.dumps(kwargs)],
        capture_output=True, text=True, env=env,
    )
    for line in proc.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[7:])
    raise RuntimeError(f"measurement {name}({kwargs}) failed:\n{proc.stderr[-3000:]}")


def now() -> str:
    return time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
