"""Build and run the authors' Dendry (a peer for ``bench_dendry.py``) through ``dendry_peer.cpp``.

The peer's library (GPL, in ``../shared/peers/dendry-authors/NoiseLib`` beside the
checkout, or where ``WDENDRITE_DENDRY_PEER`` points) is compiled with our driver
the way its users would get the most from it on this machine: ``-O3
-march=native`` (Warp also compiles its CPU kernels for the host CPU), release
(``-DNDEBUG``), single-threaded, without ``imagecontrolfunction.cpp`` (it needs
OpenCV; no benchmark uses an image control). The executable goes to a cache folder
outside the repository (``$XDG_CACHE_HOME/wdendrite-bench``, else
``~/.cache/wdendrite-bench``), keyed by the compiler, the flags and every source
file, so a changed peer or driver is built again. Nothing of the peer or its build
enters the repository.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
DRIVER = HERE / "dendry_peer.cpp"
FLAGS = ("-O3", "-march=native", "-DNDEBUG", "-std=c++17")
_SKIPPED = ("imagecontrolfunction.cpp",)


def default_root() -> Path:
    """The peer's folder: ``$WDENDRITE_DENDRY_PEER``, else ``../shared/peers/dendry-authors`` beside the checkout."""
    env = os.environ.get("WDENDRITE_DENDRY_PEER")
    return Path(env) if env else HERE.parent.parent / "shared" / "peers" / "dendry-authors"


def compiler() -> str | None:
    """The C++ compiler to use: ``$CXX``, else the first of g++, c++, clang++ on the PATH (None: none)."""
    for name in filter(None, (os.environ.get("CXX"), "g++", "c++", "clang++")):
        found = shutil.which(name)
        if found:
            return found
    return None


def _cache_folder() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "wdendrite-bench"


def build(root: Path | None = None) -> tuple[Path | None, str]:
    """The driver linked with the peer, built once per compiler, flags and sources.

    Returns ``(executable, description)``, or ``(None, why)`` when there is no compiler or no
    peer source. A failed compilation raises ``RuntimeError`` with the compiler's message.
    """
    root = Path(root) if root is not None else default_root()
    lib = root / "NoiseLib"
    if not (lib / "include" / "noise.h").is_file():
        return None, f"no peer source at {lib} (set WDENDRITE_DENDRY_PEER to the folder holding NoiseLib/)"
    cxx = compiler()
    if cxx is None:
        return None, "no C++ compiler found ($CXX, g++, c++, clang++)"
    sources = sorted(p for p in (lib / "source").glob("*.cpp") if p.name not in _SKIPPED)
    version = subprocess.run([cxx, "--version"], capture_output=True, text=True).stdout.splitlines()[:1]
    key = hashlib.sha256()
    for part in (cxx, *version, *FLAGS):
        key.update(part.encode() + b"\0")
    for path in (DRIVER, *sources, *sorted((lib / "include").glob("*.h"))):
        key.update(path.name.encode() + b"\0" + path.read_bytes())
    exe = _cache_folder() / f"dendry-peer-{key.hexdigest()[:16]}" / "dendry_peer"
    what = f"{Path(cxx).name} {' '.join(FLAGS)} ({version[0] if version else 'unknown version'}), one thread"
    if exe.is_file():
        return exe, what
    exe.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=exe.parent) as tmp:
        built = Path(tmp) / "dendry_peer"
        proc = subprocess.run([cxx, *FLAGS, "-I", str(lib / "include"), *map(str, sources), str(DRIVER),
                               "-o", str(built)], capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"building the Dendry peer failed:\n{proc.stderr[-4000:]}")
        os.replace(built, exe)  # (whole or not at all: another run may be building the same key)
    return exe, what


@dataclass(frozen=True)
class PeerRun:
    """One run of the peer: the timed evaluation loop and what it computed."""

    seconds: float
    pixels: int
    finite: int
    min: float
    max: float
    mean: float


def run(exe: Path, case: str, *, levels: int, shape: tuple[int, int], pixels: tuple[int, int, int, int, int],
        seed: int = 0) -> PeerRun:
    """Evaluate pixels of an ``shape`` = (H, W) image with the peer: ``pixels`` = (row0, col0, rows,
    cols, step), ``rows`` rows ``row0``, ``row0 + step``, ... of ``cols`` pixels from column ``col0``.

    ``case``: ``"table1-elevation"``, ``"table1-distance"`` or ``"lichtenberg-distance"``."""
    h, w = shape
    proc = subprocess.run([str(exe), case, str(seed), str(levels), str(w), str(h), *map(str, pixels)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"the Dendry peer failed on {case}: {proc.stderr.strip()}")
    fields = dict(item.split("=", 1) for item in proc.stdout.split())
    return PeerRun(float(fields["seconds"]), int(fields["pixels"]), int(fields["finite"]), float(fields["min"]),
                   float(fields["max"]), float(fields["mean"]))
