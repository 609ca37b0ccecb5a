"""Write every figure of the papers that the project reproduces into docs/figures/, with an index page.

    python scripts/make_figures.py                     # every figure, then docs/figures/README.md
    python scripts/make_figures.py power-weights       # only the named ones (the index lists them all)
    python scripts/make_figures.py --index             # only the index

Each figure is one ``wdendrite`` command (a subprocess), printed as it runs; the index page
(docs/figures/README.md) shows each picture under the papers' figure numbers and the exact command
that made it. A further figure is one more :class:`Figure` in :data:`FIGURES`.
"""

from __future__ import annotations

import shlex
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

OUT = Path(__file__).resolve().parent.parent / "docs" / "figures"

PAPERS = {
    "2007": "Xu & Mould, *Modeling Dendritic Shapes Using Path Planning*, GRAPP 2007",
    "constructive": "Xu & Mould, *Constructive path planning for natural phenomena modeling*",
    "thesis": "Ling Xu, *Modeling Dendritic Shapes Using Path Planning*, MSc thesis, 2008",
    "dendry": "Gaillard et al., *Dendry: A Procedural Model for Dendritic Patterns*, I3D 2019",
}
"""Papers by key, as the index names them (in this order)."""

SHORT = {"2007": "2007 paper", "constructive": "constructive path planning", "thesis": "thesis", "dendry": "Dendry"}
"""Papers by key, as a figure reproduced from several names the others."""


@dataclass(frozen=True)
class Figure:
    """One reproduced figure: the command that makes it and what to compare with the paper."""

    name: str
    """File name without suffix (docs/figures/NAME.png)."""
    refs: tuple[tuple[str, str], ...]
    """(paper key of :data:`PAPERS`, figure number) of every figure it reproduces; the first files it in the index."""
    args: str
    """The ``wdendrite`` command's arguments, without ``-o``."""
    caption: str
    """What the paper's figure shows, and what to look for in ours."""


FIGURES = [
    # Xu & Mould 2007
    Figure("simple-dendrite", (("2007", "Fig. 1 (above)"), ("thesis", "Fig. 3.1")), "simple-dendrite",
           "Least-cost paths from a central generator to 15 random endpoints (Table 1: 600 x 600): erratic "
           "branches that share the early part of their way and split."),
    Figure("fractal", (("2007", "Fig. 7"), ("thesis", "Fig. 3.15")), "fractal --size 512",
           "A fractal dendrite in four iterations: each places more endpoints at a smaller path cost from "
           "the dendrite so far."),
    Figure("fractal-grid", (("2007", "Fig. 8"), ("thesis", "Fig. 3.13")), "fractal-grid",
           "Fractal dendrites, three iterations each, from one first cost d: alpha = 2, 1.5, 1.2 left to "
           "right (the 2007 paper puts them right to left), beta = 2, 3, 4 top to bottom. A larger alpha "
           "shrinks d faster, so later endpoints lie closer to the dendrite and it stays compact and sparse; "
           "a larger beta places more of them, denser."),
    Figure("rock", (("2007", "Fig. 10, Table 2"),), "rock --size 128 --seed 0",
           "A \"rock\": the region of a 128^3 lattice nearest in path cost to a central generator, meshed."),
    Figure("dla-imitation", (("2007", "Fig. 11 (bottom)"), ("thesis", "Fig. 5.10")), "dla-imitation",
           "A path-planned fractal (4 iterations, 500 x 500) imitating diffusion-limited aggregation."),
    Figure("coral", (("2007", "Fig. 12, Table 1"), ("thesis", "Fig. 4.1")), "coral --size 50 --seed 0",
           "Staghorn coral on a 50^3 lattice: 24 endpoints over a dome, the dendrite refined on 7^3 sublattices "
           "(thesis section 4.4, e = 0.75), smooth centre lines meshed as one closed body."),
    Figure("letters", (("2007", "Fig. 13"), ("thesis", "Fig. 5.6")), "letters --text Hello --height 300",
           "\"Hello\" written with dendrites: paths fill letter-shaped regions (the thesis: 600 paths in a "
           "300 x 300 lattice per letter)."),
    Figure("competition", (("2007", "Fig. 14 (left)"), ("thesis", "Fig. 5.3")), "competition",
           "Two dendrites grown at once compete for space: each node belongs to the nearer generator in path "
           "cost, so they seem to avoid each other."),
    Figure("moss", (("2007", "Fig. 15"),), "moss --size 96 --seed 0",
           "Moss: 800 strands grown up from a ground plane of a 40 x 96 x 96 lattice, coloured at their roots "
           "from a picture (the paper used a photograph; here a procedural mossy one), on a ground showing it."),
    Figure("lichen", (("2007", "Fig. 16, Table 2"), ("thesis", "Fig. 5.4 (3D)")), "lichen --size 128 --seed 0",
           "Lichen over a 128^3 rock: a dendrite on the rock's surface, then crusts of two kinds chosen by bands "
           "of path cost along the surface from it (orange within 1 node, grey-green between 1 and 3.5)."),
    Figure("tropisms-constructive", (("constructive", "Fig. 1"),),
           "tropisms --toward axis,away_from_axis,top,bottom --roots center",
           "Spatially varying weights: edges dearer away from the centre line (paths hug it), dearer near it "
           "(paths bend outward), cheaper near the top (tree-like), cheaper near the bottom (shrub-like)."),
    Figure("power-weights", (("constructive", "Fig. 2"),), "power-weights",
           "The same endpoints under power weights e = R^alpha: alpha = 0.3 \"very direct branches, nearly "
           "straight lines\", 1.0 \"a conventional model\", 3.0 paths \"more erratic yet\"."),
    Figure("widths", (("constructive", "Fig. 3"), ("thesis", "Fig. 4.9")), "width-demo --size 400",
           "One stroke, brightness V = exp(-(d/T)^2) of the path cost d from it: T = 5.0, wider, with \"a weak "
           "halo around it, obtained without additional computation\", and T = 1.6, narrower; then the "
           "thesis' width factors 0.6 and 0.2 (a smaller factor, a wider path; values above 0.7 set to 1)."),
    Figure("taper", (("constructive", "Fig. 4"), ("thesis", "Fig. 4.10")), "taper-demo",
           "Constant width beside tapering by eq. 2 (beta = 1) along each path and along each branch."),
    Figure("tropism-objects", (("constructive", "Fig. 5"), ("thesis", "Fig. 4.6")), "tropism-objects --size 60 --seed 0",
           "The same 24 endpoints over 3D weights biased toward a vertical axis, away from it, and upward (60^3)."),
    Figure("elm-20", (("constructive", "Fig. 6 (left), Figs. 7-8"), ("thesis", "Figs. 4.13, 5.1")),
           "tree --size 80 --endpoints 20 --seed 0",
           "An elm on an 80^3 lattice with 20 endpoints in the crown, tapered by eq. 2: long, curving branches, "
           "no single straight trunk, spreading from the base into a wide crown; one closed body."),
    Figure("elm-36", (("constructive", "Fig. 6 (right)"),), "tree --size 80 --endpoints 36 --seed 0",
           "The same lattice with 36 endpoints: a denser crown."),
    Figure("lightning", (("constructive", "Figs. 9, 11, 12"), ("thesis", "Figs. 4.11, 5.8"), ("2007", "Fig. 14 (right)")),
           "lightning --seed 3",
           "Lightning from two graphs of power weights (alpha = 3): \"a single main lightning stroke, with "
           "multiple side branches. The main branch is thicker and has a fairly constant width, while the side "
           "branches taper visibly\"; branches also split from one another. Brightness by path cost, no halo "
           "(\"largely absent in our rendering\")."),
    # thesis
    Figure("cheap-paths", (("thesis", "Fig. 3.14"),), "cheap-paths",
           "Later paths (red) and the former ones (black) whose edges cost D times as much, D = 1, 0.8, 0.6, "
           "0.3: \"when D decreases from 1 to 0.3, the added paths attach to the former structure more eagerly "
           "and the paths look more outspread\"."),
    Figure("lichen-cluster", (("thesis", "Fig. 5.4 (2D)"),), "lichen-cluster --size 256 --seed 0",
           "A lichen cluster by bands of path cost in 2D: orange within 2.5 nodes of path cost of a fractal "
           "dendrite, grey-green embracing it out to 8."),
    Figure("weight-distributions", (("thesis", "Fig. 4.4"),), "weight-distributions",
           "The same endpoints under W = 1 + v^n, n = 0, 1, 4, 8: Manhattan paths at n = 0, ever more erratic "
           "ones as n grows."),
    Figure("tropisms", (("thesis", "Fig. 4.5"),), "tropisms",
           "The same random endpoints reached from a root on the bottom row, over weights cheaper toward one "
           "side, panels a to h as in the thesis: cheaper toward the left, the root at the bottom left (a, "
           "\"trees blown by wind from left\") and right (b, \"a bush growing up from the right corner\"); the "
           "same toward the right (c, d); cheaper near the centre line (e) and dearer near it (f, \"bending "
           "outward\"); cheaper toward the top (g, \"a tree\") and the bottom (h, \"a shrub\")."),
    # Dendry
    Figure("dendry-terrain", (("dendry", "Fig. 1 (centre), Fig. 16"),), "terrain --size 768 --levels 2 --delta 0.075 --seed 0",
           "A terrain on a Perlin control at the paper's Table 2 settings for Fig. 1 (centre) and Fig. 16 (768^2, "
           "4 x 4 level-1 cells, 2 levels, eps 0.25, delta 0.075, beta 0.5), shaded, with its D8 drainage network in "
           "blue. The command's defaults add level-1 outlets, free jitter below level 1 and primitives nearly on a "
           "grid to the paper's method (`DendryParams.terrain()`), so that it drains (BENCHMARKS.md)."),
    Figure("dendry-terrain-3", (("dendry", "Fig. 1 (right), Fig. 18 (right)"),),
           "terrain --size 1024 --levels 3 --delta 0.075 --beta 0.1 --seed 0",
           "The same at 3 levels and beta 0.1 (1024^2): finer branches, slopes nearly uniform."),
    Figure("lichtenberg", (("dendry", "section 1 (Lichtenberg figures)"),),
           "dendry --size 768 --levels 5 --control lichtenberg --rule lichtenberg",
           "A Lichtenberg figure: branches joined 45 degrees downstream on the bowl control x^2 + (y + 1)^2, drawn "
           "with a width per level."),
]
"""Every reproduced figure, in the index's order within each paper."""


def _runner(args: list[str]) -> list[str]:
    """The installed console script when present, else the same entry point through this Python."""
    exe = shutil.which("wdendrite")
    return [exe, *args] if exe else [sys.executable, "-m", "wdendrite.cli", *args]


def command(fig: Figure) -> str:
    """The command the index shows under a figure (it writes the picture into the current folder)."""
    return f"wdendrite {fig.args} -o {fig.name}.png"


def index() -> str:
    """The index page: every figure under its papers' figure numbers, with its command."""
    lines = ["# The papers' figures, reproduced", "",
             "Each picture below is made by the command under it (run from this folder; "
             "`python scripts/make_figures.py` makes them all again). The figure numbers are the papers'; "
             "the captions quote what the papers say their figures show, so the two can be put side by side.",
             ""]
    for key, paper in PAPERS.items():
        figs = [f for f in FIGURES if f.refs[0][0] == key]
        if not figs:
            continue
        lines += [f"## {paper}", ""]
        for f in figs:
            also = ", ".join(f"{SHORT[k]} {n}" for k, n in f.refs[1:])
            lines += [f"### {f.refs[0][1]}" + (f"; also {also}" if also else ""), "", f"![{f.name}]({f.name}.png)", "", f.caption, "", f"`{command(f)}`", ""]
    return "\n".join(lines)


def main(names: list[str], only_index: bool = False) -> int:
    known = {f.name: f for f in FIGURES}
    unknown = [n for n in names if n not in known]
    if unknown:
        print(f"unknown figure(s) {unknown}; known: {', '.join(known)}", file=sys.stderr)
        return 2
    OUT.mkdir(parents=True, exist_ok=True)
    for fig in [] if only_index else [known[n] for n in names] or FIGURES:
        t0 = time.perf_counter()
        done = subprocess.run(_runner([*shlex.split(fig.args), "-o", str(OUT / f"{fig.name}.png"), "--force",
                                       "--quiet"]))
        print(f"{time.perf_counter() - t0:6.1f} s  {command(fig)}")
        if done.returncode:
            return done.returncode
    from wdendrite.io import atomic_write

    atomic_write(OUT / "README.md", lambda p: Path(p).write_text(index() + "\n"), overwrite=True)
    print(f"index: {OUT / 'README.md'}")
    return 0


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("names", nargs="*", metavar="NAME", help="figures to make (default: all): "
                    + ", ".join(f.name for f in FIGURES))
    ap.add_argument("--index", action="store_true", help="write only the index page")
    a = ap.parse_args()
    sys.exit(main(a.names, a.index))
