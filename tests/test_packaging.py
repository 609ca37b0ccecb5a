"""A regular (non-editable) install carries the top-level kernels/ folder as wdendrite.kernels."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_plain_install_includes_the_kernel_package(tmp_path):
    target = tmp_path / "site"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(target),
         str(ROOT)],
        check=True, capture_output=True, text=True,
    )
    kernels = sorted(p.name for p in (target / "wdendrite" / "kernels").glob("*.py"))
    assert kernels == sorted(p.name for p in (ROOT / "kernels").glob("*.py"))
    # the installed copy imports on its own, without the source tree on the path
    probe = "import wdendrite, wdendrite.kernels.sssp as k; print(wdendrite.__file__); print(k.__file__)"
    out = subprocess.run([sys.executable, "-c", probe], cwd=tmp_path, env={"PYTHONPATH": str(target)},
                         check=True, capture_output=True, text=True).stdout.split()
    assert all(str(target) in line for line in out)


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
