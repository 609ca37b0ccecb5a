"""Compiling the kernels up front (``wd.load_kernels``, ``wdendrite warmup``) and a light start:
``import wdendrite``, ``wdendrite --help`` and ``--version`` import neither Warp nor NumPy."""

import importlib
import pkgutil
import re
import subprocess
import sys

import pytest
import warp as wp

import wdendrite as wd
import wdendrite.kernels as kernels_pkg
from wdendrite import cli
from wdendrite._spec import all_presets, preset_summaries


def _modules_with_kernels() -> set:
    # independently of wdendrite.warmup: every module of the kernels package defining a kernel
    found = set()
    for info in pkgutil.iter_modules(kernels_pkg.__path__):
        module = importlib.import_module(f"wdendrite.kernels.{info.name}")
        if any(isinstance(v, wp.Kernel) for v in vars(module).values()):
            found.add(info.name)
    return found


def test_load_kernels_loads_every_kernel_module():
    seconds = wd.load_kernels("cpu", workers=2, progress=False)
    assert set(seconds) == _modules_with_kernels() and {"sssp", "dendry", "render"} <= set(seconds)
    assert all(isinstance(s, float) and s >= 0 for s in seconds.values())
    device = wp.get_device("cpu")
    for name in seconds:  # each module is loaded on the device now: its executable is in place
        module = wp.get_module(f"wdendrite.kernels.{name}")
        assert any(ctx == device.context for ctx, _ in module.execs), name


@pytest.mark.parametrize("bad", [0, -1, 1.5, True])
def test_load_kernels_refuses_a_bad_worker_count(bad):
    with pytest.raises(ValueError, match="'workers'"):
        wd.load_kernels("cpu", workers=bad, progress=False)


def test_load_kernels_refuses_a_device_the_machine_lacks():
    with pytest.raises(ValueError, match="'device'"):
        wd.load_kernels("cuda:99", progress=False)


# Warp's own line for each module a process loads (on at log level INFO, which the command turns off:
# the child turns it on around each load)
_LOUD = r"""
import sys
import warp as wp
from warp._src import context as _ctx
_load = _ctx.Module.load
def _loud(self, *args, **kwargs):
    level = wp.config.log_level
    wp.config.log_level = wp.LOG_INFO
    try:
        return _load(self, *args, **kwargs)
    finally:
        wp.config.log_level = level
_ctx.Module.load = _loud
from wdendrite.cli import main
code = main(sys.argv[1:])
if code:
    sys.exit(code)
"""
_LINE = re.compile(r"Module wdendrite\.kernels\.(\w+) \S+ load on device 'cpu' took [\d.]+ ms\s*\((compiled|cached)\)")


def _loads(args, cwd) -> list:
    p = subprocess.run([sys.executable, "-c", _LOUD, *args], cwd=cwd, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr[-3000:]
    return _LINE.findall(p.stdout + p.stderr)


def test_after_warmup_a_new_process_compiles_nothing(tmp_path):
    # whatever the kernel cache held before, the command compiles what it lacked; then commands in
    # new processes using that cache load every module they use from it (same module hashes)
    # (one module at a time: the child's switch of Warp's log level is not meant for threads)
    first = _loads(["warmup", "--device", "cpu", "--quiet", "--workers", "1"], tmp_path)
    assert {name for name, _ in first} == _modules_with_kernels()
    used = set()
    for args in (["fractal", "--size", "24", "-o", "f.png", "--quiet"],
                 ["terrain", "--size", "16", "-o", "t.png", "--quiet"],
                 ["tree", "--size", "12", "--endpoints", "3", "-o", "t.obj", "--quiet"]):
        loads = _loads(args + ["--device", "cpu"], tmp_path)
        assert loads and all(how == "cached" for _, how in loads), (args, loads)
        used |= {name for name, _ in loads}
    assert {"sssp", "dendrite", "dendry", "render"} <= used


def test_a_command_loads_only_the_kernel_modules_it_uses(tmp_path):
    # what a new user's first command compiles: the fractal needs no Dendry, the terrain no search
    fractal = {name for name, _ in _loads(["fractal", "--size", "24", "-o", "f.png", "--quiet"], tmp_path)}
    terrain = {name for name, _ in _loads(["terrain", "--size", "16", "-o", "t.png", "--quiet"], tmp_path)}
    assert {"sssp", "dendrite"} <= fractal and not fractal & {"dendry", "dendry_pixels", "noise", "hydrology"}
    assert "dendry" in terrain and not terrain & {"sssp", "dendrite", "weights", "dendry_pixels"}


def test_warmup_command_prints_each_module(tmp_path):
    p = subprocess.run([sys.executable, "-m", "wdendrite.cli", "warmup", "--device", "cpu", "--quiet"],
                       cwd=tmp_path, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    names = {line.split()[0] for line in p.stdout.splitlines()[:-1]}
    assert names == _modules_with_kernels()
    assert re.search(r"\d+ kernel modules ready on cpu in [\d.]+ s", p.stdout.splitlines()[-1])
    p = subprocess.run([sys.executable, "-m", "wdendrite.cli", "warmup", "--workers", "0"], cwd=tmp_path,
                       capture_output=True, text=True)
    assert p.returncode == 2 and "--workers" in p.stderr and "Traceback" not in p.stderr


_IMPORTED = """
import sys
{code}
print("IMPORTED:", *sorted(m for m in ("warp", "numpy", "scipy") if m in sys.modules))
"""


@pytest.mark.parametrize("code", [
    "import wdendrite",
    "from wdendrite.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass",
    "from wdendrite.cli import main\ntry:\n    main(['--version'])\nexcept SystemExit:\n    pass",
])
def test_a_light_start_imports_neither_warp_nor_numpy(code, tmp_path):
    p = subprocess.run([sys.executable, "-c", _IMPORTED.format(code=code)], cwd=tmp_path, capture_output=True,
                       text=True)
    assert p.returncode == 0, p.stderr
    assert p.stdout.splitlines()[-1].split() == ["IMPORTED:"], p.stdout[-500:]


def test_the_names_load_their_modules_when_asked_for():
    code = ("import sys\nimport wdendrite as wd\nassert 'wdendrite.dendry' not in sys.modules\n"
            "assert wd.DendryParams().levels and 'wdendrite.dendry' in sys.modules\nassert callable(wd.dendry) and wd.dendry.__module__ == 'wdendrite.dendry'\n"
            "import wdendrite.dendry\nassert callable(wd.dendry)\nassert wd.render.Taper and 'warmup' in dir(wd)\n"
            "print(sorted(set(wd.__all__) - set(dir(wd))))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "[]"
    for name in wd.__all__:
        assert getattr(wd, name) is not None, name
    with pytest.raises(AttributeError, match="no_such_name"):
        wd.no_such_name  # noqa: B018


@pytest.mark.parametrize("name", ["dendry", "refine"])
@pytest.mark.parametrize("first", ["module", "name"])
def test_a_function_named_as_its_module_wins_whatever_imports_first(name, first):
    steps = [f"import wdendrite.{name}", f"from wdendrite import {name} as early"]
    code = "\n".join(["import wdendrite as wd", *(steps if first == "module" else steps[::-1]),
                      f"from wdendrite import {name} as late",
                      f"assert callable(wd.{name}) and late is wd.{name} and early is late",
                      f"assert wd.{name}.__module__ == 'wdendrite.{name}'", "print('ok')"])
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert p.returncode == 0 and p.stdout.strip() == "ok", p.stderr


def test_the_help_listing_matches_the_presets():
    # --help reads the presets' names and summaries from their sources, without importing them
    assert preset_summaries() == {name: p.summary for name, p in all_presets().items()}
    listing, full = cli.build_parser(listing=True), cli.build_parser()
    assert listing.format_help() == full.format_help()
