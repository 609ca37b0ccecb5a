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
