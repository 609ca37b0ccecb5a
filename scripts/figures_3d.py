"""The papers' 3D figures and the lichen clusters, each made by one ``wdendrite`` command.

    python scripts/figures_3d.py docs/figures            # every figure below, as PNGs in that folder
    python scripts/figures_3d.py docs/figures moss coral # only the named ones

A figures page imports :data:`FIGURES_3D` (what each picture reproduces, its caption and its
command) and calls :func:`make_figures_3d`, which runs each command in this process through the
command's own entry point (:func:`wdendrite.cli.main`), so the caption's command is exactly what
made the picture. Sizes and endpoint counts are the papers' where they give them; every figure
uses seed 0 (no seed was picked for its result).
"""

from __future__ import annotations

import shlex
import sys
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Figure:
    """One reproduced figure."""

    paper: str
    """The figure it reproduces (paper and number)."""
    caption: str
    """What it shows."""
    args: str
    """The command's arguments (without ``-o``)."""

    @property
    def command(self) -> str:
        """The command line, as a caption shows it."""
        return f"wdendrite {self.args}"


FIGURES_3D = {
    "elm-20": Figure("Constructive path planning Fig. 6 (left), Figs. 7-8; thesis Fig. 4.13",
                     "An elm on an 80^3 lattice with 20 endpoints in the crown, tapered by eq. 2 (beta 0.3 on the "
                     "main branches, 0.2 on the twigs): smooth centre lines meshed as one closed body.",
                     "tree --size 80 --endpoints 20 --seed 0"),
    "elm-36": Figure("Constructive path planning Fig. 6 (right)",
                     "The same lattice with 36 endpoints: a denser crown.",
                     "tree --size 80 --endpoints 36 --seed 0"),
    "tropism-objects": Figure("Constructive path planning Fig. 5; thesis Fig. 4.6",
                              "The same 24 endpoints over weights biased toward a vertical axis, away from it, and "
                              "upward (60^3).",
                              "tropism-objects --size 60 --seed 0"),
    "coral": Figure("2007 paper Fig. 12 and Table 1 (coral with refinement); thesis Fig. 4.1",
                    "Staghorn coral on a 50^3 lattice, 24 endpoints over a dome, the dendrite refined on 7^3 "
                    "sublattices (thesis section 4.4, e = 0.75) and meshed as one closed body.",
                    "coral --size 50 --seed 0"),
    "rock": Figure("2007 paper Fig. 10 and Table 2",
                   "A rock: the region of a 128^3 lattice nearest in path cost to a central generator.",
                   "rock --size 128 --seed 0"),
    "lichen-on-rock": Figure("2007 paper Fig. 16 and Table 2; thesis Fig. 5.4 (bottom, 3D)",
                             "Lichen over a 128^3 rock: a dendrite on the rock's surface, then crusts of two kinds "
                             "chosen by bands of path cost along the surface from it (orange within 1 node, "
                             "grey-green between 1 and 3.5), rock, crust and ropes one closed body.",
                             "lichen --size 128 --seed 0"),
    "lichen-cluster": Figure("Thesis Fig. 5.4 (bottom, 2D)",
                             "A lichen cluster by cost bands in 2D: orange within 2.5 nodes of path cost of a "
                             "fractal dendrite, grey-green embracing it out to 8.",
                             "lichen-cluster --size 256 --seed 0"),
    "moss": Figure("2007 paper Fig. 15",
                   "Moss: 800 strands up from a ground plane of a 40 x 96 x 96 lattice, coloured from a picture (a "
                   "procedural mossy one; the paper used the peppers photograph) at their roots, on a ground "
                   "showing it.",
                   "moss --size 96 --seed 0"),
}
"""Figure name (its PNG's stem) -> what it reproduces and the command that makes it."""


def make_figures_3d(out_dir, names=None) -> list[tuple[Path, Figure]]:
    """Write ``<out_dir>/<name>.png`` for each named figure (default: all), overwriting; return
    ``(path, figure)`` pairs. Raises ValueError for an unknown name and RuntimeError when a
    command fails (its message is on stderr)."""
    from wdendrite import cli

    out = Path(out_dir)
    names = list(FIGURES_3D) if names is None else list(names)
    unknown = [n for n in names if n not in FIGURES_3D]
    if unknown:
        raise ValueError(f"unknown figure(s) {unknown}; known: {', '.join(FIGURES_3D)}")
    out.mkdir(parents=True, exist_ok=True)
    done = []
    for name in names:
        fig = FIGURES_3D[name]
        path = out / f"{name}.png"
        code = cli.main([*shlex.split(fig.args), "-o", str(path), "--force", "--quiet"])
        if code:
            raise RuntimeError(f"{fig.command} -o {path} exited with {code}")
        done.append((path, fig))
    return done


if __name__ == "__main__":
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    for p, f in make_figures_3d(sys.argv[1], sys.argv[2:] or None):
        print(f"{p}  ({f.paper})  {f.command}")
