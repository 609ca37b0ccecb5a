"""Regenerate the README gallery (docs/gallery/*.png) with the project's own command.

    python scripts/make_gallery.py            # every picture
    python scripts/make_gallery.py lightning  # only the named ones

Each picture is one ``wdendrite`` subprocess; the commands are printed and are
the ones the README shows under each picture.
"""

from __future__ import annotations

import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

OUT = Path(__file__).resolve().parent.parent / "docs" / "gallery"

GALLERY = {
    "lightning": "lightning --size 384 --seed 3",
    "fractal": "fractal --size 384",
    "fractal-grid": "fractal-grid --cell 120",
    "competition": "competition --size 300 --seed 1",
    "letters": "letters --text wdendrite --height 120",
    "tropisms": "tropisms --size 160",
    "tree": "tree --size 56 --endpoints 24 --seed 2",
    "coral": "coral --size 40 --seed 1",
    "rock": "rock --size 64 --seed 1",
    "lichen": "lichen --size 72 --count 3 --seed 1",
    "lichen-cluster": "lichen-cluster --size 256 --seed 1",
    "moss": "moss --size 64",
    "terrain": "terrain --size 384 --levels 3 --seed 1",
    "dendry": "dendry --size 384 --levels 3 --delta 0.2 --seed 1",
}
"""Picture name -> the command's arguments (without -o)."""


def command(name: str) -> list[str]:
    """The full command line of a gallery picture."""
    return ["wdendrite", *shlex.split(GALLERY[name]), "-o", str(OUT / f"{name}.png"), "--force", "--quiet"]


def main(names: list[str]) -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    unknown = [n for n in names if n not in GALLERY]
    if unknown:
        print(f"unknown picture(s) {unknown}; known: {', '.join(GALLERY)}", file=sys.stderr)
        return 2
    for name in names or GALLERY:
        cmd = command(name)
        t0 = time.perf_counter()
        # the installed console script when present, else the same entry point through this Python
        exe = shutil.which("wdendrite")
        runner = [exe, *cmd[1:]] if exe else [sys.executable, "-m", "wdendrite.cli", *cmd[1:]]
        done = subprocess.run(runner)
        print(f"{time.perf_counter() - t0:6.1f} s  {' '.join(cmd[:-4])}")
        if done.returncode:
            return done.returncode
    return 0


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("names", nargs="*", metavar="NAME", help=f"pictures to make (default: all): {', '.join(GALLERY)}")
    sys.exit(main(ap.parse_args().names))
