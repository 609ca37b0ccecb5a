"""What an installation carries: the kernels as wdendrite.kernels, the version, the licence, typing."""

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# a child's own finders only: the editable install of the test environment removed, so the child
# sees what a regular installation (or none) gives
_NO_EDITABLE = ("import sys; sys.meta_path[:] = [f for f in sys.meta_path "
                "if not getattr(f, '__module__', '').startswith('__editable__')]; ")


def _built(tmp_path_factory, *args) -> Path:
    """pip's build of the checkout into a fresh folder (the build folders it leaves behind removed)."""
    out = tmp_path_factory.mktemp("pip")
    try:
        subprocess.run([sys.executable, "-m", "pip", *args, str(out), str(ROOT)], check=True, capture_output=True,
                       text=True)
    finally:
        shutil.rmtree(ROOT / "build", ignore_errors=True)
        for egg in ROOT.glob("*.egg-info"):
            shutil.rmtree(egg, ignore_errors=True)
    return out


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """A regular (non-editable) installation of the checkout into its own folder."""
    return _built(tmp_path_factory, "install", "-q", "--no-deps", "--target")


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> zipfile.ZipFile:
    folder = _built(tmp_path_factory, "wheel", "-q", "--no-deps", "-w")
    return zipfile.ZipFile(next(folder.glob("wdendrite-*.whl")))


def test_plain_install_includes_the_kernel_package(site, tmp_path):
    target = site
    kernels = sorted(p.name for p in (target / "wdendrite" / "kernels").glob("*.py"))
    assert kernels == sorted(p.name for p in (ROOT / "kernels").glob("*.py"))
    # the installed copy imports on its own, without the source tree on the path
    probe = "import wdendrite, wdendrite.kernels.sssp as k; print(wdendrite.__file__); print(k.__file__)"
    out = subprocess.run([sys.executable, "-c", probe], cwd=tmp_path, env={"PYTHONPATH": str(target)},
                         check=True, capture_output=True, text=True).stdout.split()
    assert all(str(target) in line for line in out)


def test_python_run_in_the_checkout_finds_its_kernels_beside_a_regular_install(site):
    # started in the checkout's root, Python imports the checkout's wdendrite/ ahead of the
    # installed one; its kernels live in the top-level kernels/ folder, which only an installation
    # maps into the package: the checkout must find them itself (it did not: ModuleNotFoundError)
    probe = (_NO_EDITABLE + "import wdendrite, wdendrite.kernels.sssp as k, numpy as np; "
             "cf = wdendrite.shortest_paths(wdendrite.Lattice((3, 4), 4), [[0, 0]], device='cpu'); "
             "print(wdendrite.__file__); print(k.__file__); print(int(cf.dist.sum()))")
    proc = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, env={"PYTHONPATH": str(site)},
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-2000:]
    host, kernel, total = proc.stdout.split()[-3:]
    assert Path(host) == ROOT / "wdendrite" / "__init__.py"
    assert Path(kernel) == ROOT / "kernels" / "sssp.py"
    assert int(total) == sum(r + c for r in range(3) for c in range(4))  # unit weights: Manhattan distances


def test_the_version_comes_from_the_package_metadata_alone():
    import importlib.metadata

    import wdendrite as wd

    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert wd.__version__ == importlib.metadata.version("wdendrite") == declared
    # no second copy of it in the package's code
    for path in (ROOT / "wdendrite").glob("*.py"):
        assert f'"{declared}"' not in path.read_text() and f"'{declared}'" not in path.read_text(), path
    out = subprocess.run([sys.executable, "-m", "wdendrite", "--version"], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["wdendrite", declared]


def test_the_wheel_carries_the_licence_the_classifiers_and_the_typing_marker(wheel):
    names = wheel.namelist()
    assert "wdendrite/py.typed" in names
    licence = [n for n in names if n.endswith(".dist-info/licenses/LICENSE")]
    assert len(licence) == 1 and b"Apache License" in wheel.read(licence[0])
    meta = wheel.read(next(n for n in names if n.endswith(".dist-info/METADATA"))).decode()
    assert "License-Expression: Apache-2.0" in meta
    assert "Classifier: Typing :: Typed" in meta and "Classifier: Programming Language :: Python :: 3" in meta
    assert any(n.startswith("wdendrite/kernels/") for n in names)


def test_extras_name_each_requirement_once():
    try:
        import tomllib
    except ModuleNotFoundError:
        import tomli as tomllib
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]
    core = {r.split(";")[0].split(">")[0].split("=")[0].strip().lower() for r in project["dependencies"]}
    seen = {}
    for extra, reqs in extras.items():
        for req in reqs:
            name = req.split(";")[0].split(">")[0].split("=")[0].split("<")[0].strip().lower()
            assert name not in core, (extra, req)  # already installed with the package
            if name.startswith("wdendrite["):  # another extra, by reference
                assert set(name[len("wdendrite["):-1].split(",")) <= set(extras), (extra, req)
                continue
            assert name not in seen, (extra, req, seen.get(name))
            seen[name] = extra
    assert "bench" not in extras  # (everything the benchmarks import comes with "test")


def test_help_shows_what_each_parameter_field_means():
    # the fields are documented by a string under each; help() shows only class docstrings, so
    # the package copies those strings into a Fields section after the summary
    import dataclasses

    import wdendrite as wd

    for cls in (wd.DendryParams, wd.FractalParams, wd.render.Taper, wd.presets.Result, wd.hydrology.Depressions,
                wd.weights.Uniform):
        doc = cls.__doc__
        head, fields = doc.split("\n\nFields:\n", 1)
        assert "\n" not in head.strip() or len(head) < 400, cls  # right after the summary paragraph
        for f in dataclasses.fields(cls):
            if not f.name.startswith("_"):
                assert f"\n    {f.name}" in "\n" + fields, (cls.__name__, f.name)
    assert "Number of tree levels n, 1-6" in wd.DendryParams.__doc__
    assert "Raised cells, in percent of all cells." in wd.hydrology.Depressions.__doc__


def test_the_package_docstrings_example_runs():
    # help(wdendrite) opens with it: a first example that fails would be the worst start
    import textwrap

    import numpy as np

    import wdendrite as wd

    block = wd.__doc__.split("Start here::\n\n", 1)[1].split("\n\n", 1)[0]
    scope = {}
    exec(textwrap.dedent(block), scope)
    assert scope["picture"].shape == (256, 256) and 0 < scope["picture"].max() <= 1
    assert scope["terrain"].shape == (512, 512) and np.isfinite(scope["terrain"]).all()
