"""Write the notebooks in notebooks/ from the cells below (without outputs; CI executes them).

    python scripts/make_notebooks.py

Every notebook reads ``WDENDRITE_SMALL=1`` to shrink its sizes, so the test suite
runs it top to bottom in seconds (tests/test_notebooks.py).
"""

from __future__ import annotations

from pathlib import Path

import nbformat

HERE = Path(__file__).resolve().parent.parent / "notebooks"

SETUP = '''\
import logging, os
import numpy as np
import warp as wp
from IPython.display import display
from PIL import Image, ImageDraw

wp.config.log_level = logging.WARNING          # no start-up banner
wp.init()   # (without an NVIDIA driver, Warp prints one harmless CUDA warning here and runs on the CPU)
import wdendrite as wd
from wdendrite import presets, io

SMALL = os.environ.get("WDENDRITE_SMALL") == "1"   # CI runs every notebook at small sizes


def show(img, scale=1, labels=None):
    """An RGB or grey float image in [0, 1] as a picture the notebook displays inline; a list of
    them side by side, a white gap between, each over its label when ``labels`` are given."""
    if isinstance(img, (list, tuple)):
        img = wd.figure.panels(img, labels=labels)
    a = (np.clip(np.asarray(img, np.float32), 0, 1) * 255 + 0.5).astype(np.uint8)
    pic = Image.fromarray(a)
    return pic.resize((pic.width * scale, pic.height * scale), Image.NEAREST) if scale != 1 else pic'''

NOTEBOOKS = {
    "01_quickstart": [
        ("md", "# wdendrite quickstart\n\nA random-weighted lattice, least-cost paths from a generator, backtracking "
               "from endpoints into a dendrite, and a picture of it. The searches, the backtracking and the rendering "
               "are Warp kernels; the same code runs on the CPU and on CUDA (`wp.ScopedDevice('cuda:0')`).\n\nThe "
               "first run compiles Warp's kernels (about 10-20 s, once; they are cached in `~/.cache/warp` "
               "afterwards), and on a machine without an NVIDIA driver Warp prints one harmless warning line, `Warp "
               "CUDA warning: ... GPU execution will not be available.`, and runs everything on the CPU. The notebooks "
               "run in Jupyter: `pip install -e \".[notebooks]\"` in the project's folder installs it."),
        ("code", SETUP),
        ("md", "The least path cost from the generator at the centre to every node, divided by its largest value: dark "
               "is cheap to reach (black at the generator), bright is expensive (white at the costliest node). The "
               "printed numbers are the field's shape and that largest cost."),
        ("code", '''\
n = 96 if SMALL else 400
lat = wd.Lattice((n, n), connectivity=8, weights=wd.weights.Uniform(r=10, seed=1))
cf = wd.shortest_paths(lat, [[n // 2, n // 2]])
print("shape", cf.dist.shape, "- largest cost", round(float(cf.dist.max()), 1))
show(cf.dist / cf.dist.max())'''),
        ("md", "Endpoints drawn at random (at least `min_spacing` apart) are traced back to the generator all at once:"),
        ("code", '''\
ends = wd.endpoints.random(lat, 20, seed=2, min_spacing=n / 12)
den = wd.trace(cf, ends)
print(len(den), "nodes,", len(den.endpoints), "endpoints")
from wdendrite import render
show(1 - render.brightness(den, render.Taper(2.5, 0.8, along="path"), metric="euclidean"))'''),
        ("md", "Fractal growth repeats this with endpoints in shrinking cost bands around the dendrite (thesis Fig "
               "3.12):"),
        ("code", '''\
mean = float(lat.weights[0].mean())
params = wd.FractalParams(count=6, d=0.45 * n * mean, alpha=1.8, beta=2.5, epsilon=0.06 * n * mean)
tree = wd.grow(lat, [[n // 2, n // 2]], params, seed=3)
show(1 - render.brightness(tree, 1.0, metric="euclidean"), scale=2 if SMALL else 1)'''),
        ("md", "Every model of the papers is one call in `wdendrite.presets`, returning the data and a picture:"),
        ("code", '''\
res = presets.lightning((n, n), seed=4)
io.save_png("quickstart_lightning.png", res.image, overwrite=True)
show(res.image)'''),
    ],
    "02_path_planning": [
        ("md", "# Path-planning dendrites: the papers' figures\n\nXu & Mould's path-planning papers (the 2007 paper "
               "and constructive path planning, as cited in `wdendrite.presets`) and Xu's thesis (2008). Sizes are the "
               "papers' unless `SMALL`."),
        ("code", SETUP),
        ("md", "**Fractal dendrites** for attenuation alpha (columns) and branching beta (rows), thesis Fig. 3.13 "
               "(the 2007 paper's Fig. 8 puts the alphas right to left). Columns, left to right: alpha = 2.0, 1.5, 1.2; "
               "rows, top to bottom: beta = 2, 3, 4 (the preset's defaults, each panel labelled). Every panel grows "
               "3 iterations from the same weights, seed and first cost d: a larger alpha shrinks d faster, so later "
               "endpoints stay closer to the dendrite (compact, sparse); a larger beta places more of them:"),
        ("code", '''\
res = presets.fractal_grid(48 if SMALL else 170)
print("first cost d:", round(res.parts["d"], 1))
show(res.image)'''),
        ("md", "**Power weights** `e = R^alpha`, R uniform in (1, 11), the same 30 endpoints above a root at the bottom "
               "(constructive path planning, Fig. 2). Panels: alpha = 0.3 (\"very direct branches, nearly straight "
               "lines\"), 1.0 (\"a conventional model\"), 3.0 (\"more erratic yet\"):"),
        ("code", '''\
show(presets.power_weights((64, 64) if SMALL else (200, 200), endpoints=10 if SMALL else 30).image)'''),
        ("md", "**Cheap former paths** (thesis Fig. 3.14): four former paths from the centre (black), then later "
               "paths (red) traced over the lattice whose former edges cost D times their weight, D = 1, 0.8, 0.6, 0.3. "
               "The cheaper the former paths, the sooner the later ones join them (fewer new nodes):"),
        ("code", '''\
res = presets.cheap_paths((80, 80) if SMALL else (200, 200))
print({d: int((den.generation > 0).sum()) for d, den in res.parts["dendrites"].items()}, "new nodes per D")
show(res.image)'''),
        ("md", "**Weight distributions** `W = 1 + v^n`, the same 20 endpoints in every panel. Panels, left to right: n "
               "= 0 (Manhattan-like), n = 1, n = 4 and n = 8 (erratic); thesis 4.2 (for n > 4 the preset draws v from "
               "(0, 100^(4/n)), so that float32 path costs still resolve every edge):"),
        ("code", '''\
res = presets.weight_distributions((64, 64) if SMALL else (200, 200))
show(res.image)'''),
        ("md", "**Tropisms** (thesis Fig. 4.5): the same 20 random endpoints reached from a root on the bottom row "
               "over weights made cheaper toward one side (strength 12), so each dendrite leans that way. Panels a to "
               "h as in the thesis, each labelled with its tropism and its root: cheaper toward the left with the "
               "root at the bottom left (a, a tree blown by a wind from the left) and right (b, a bush growing from "
               "the corner), the same toward the right (c, d), cheaper near the vertical centre line (e) and dearer "
               "near it (f, bending outward), cheaper toward the top (g, a tree) and the bottom (h, a shrub):"),
        ("code", '''\
res = presets.tropisms((64, 64) if SMALL else (200, 200))
show(res.image)'''),
        ("md", "**Competition**: two dendrites grown at once never share a node (2007 paper, Fig. 14):"),
        ("code", '''\
res = presets.competition((96, 96) if SMALL else (300, 300))
show(res.image)'''),
        ("md", "First **DLA imitation** (2007 paper, Fig. 11: 4 iterations, alpha 2.0, beta 4.0), then **dendritic "
               'letters** "wd" (Fig. 13):'),
        ("code", '''\
display(show(presets.dla_imitation((96, 96) if SMALL else (500, 500)).image))
show(presets.letters("wd", height=48 if SMALL else 300).image)'''),
    ],
    "03_lightning": [
        ("md", "# Lightning\n\nThe constructive paper's lightning: a main channel from one graph of power weights "
               "(alpha = 3), thick and of nearly constant width; side branches from it and from a second graph, "
               "joining the structure above their endpoints; brightness `exp(-(d/T)^2)` of the path cost `d` from "
               "the strokes, `T` tapered by eq. 2; no halo unless asked for."),
        ("code", SETUP),
        ("code", '''\
n = 128 if SMALL else 600
res = presets.lightning((n, n), seed=7)
print(res.dendrite, "- nodes per graph (main channel, first graph's branches, second's):",
      np.bincount(res.parts["graph"]))
show(res.image)'''),
        ("md", "Every field of `LightningParams` is documented; the same settings are options of `wdendrite "
               "lightning`. First a calm stroke (alpha = 1.5, 3 forks, no minor forks), then a wild one with a halo "
               "(alpha = 4.0, 10 forks, 30 minor forks, glow gain 1, radius 20) (the picture above has the defaults: "
               "alpha = 3.0, 6 forks, 18 minor forks, no halo):"),
        ("code", '''\
calm = presets.LightningParams(alpha=1.5, forks=3, minor_forks=0)
wild = presets.LightningParams(alpha=4.0, forks=10, minor_forks=30, glow_gain=1.0, glow_radius=20)
display(show(presets.lightning((n, n), params=calm, seed=7).image))
show(presets.lightning((n, n), params=wild, seed=7).image)'''),
        ("md", "Brightness falls off with the path cost from the strokes (left, the default): the strokes keep a "
               "slightly irregular edge. `metric=\"euclidean\"` uses the distance in pixels instead (right): smooth "
               "strokes. The main channel keeps its width either way:"),
        ("code", '''\
import dataclasses
path = presets.lightning((n, n), seed=7)
smooth = presets.lightning((n, n), params=dataclasses.replace(presets.LightningParams(), metric="euclidean"), seed=7)
show([path.image, smooth.image], labels=["path cost", "euclidean"])'''),
        ("md", "One stroke at the papers' widths, brightness by path cost (constructive path planning Fig. 3, thesis "
               "Fig. 4.9). Panels, left to right: `exp(-(d/T)^2)` with T = 5.0 and T = 1.6 path cost units over the "
               "stroke's own weights `R^3`, R in (1, 2): the wider one has \"a weak halo around it, obtained without "
               "additional computation\"; then the thesis' rule `exp(-a (c d)^2)`, a = 1/10000, with width factor "
               "c = 0.6 and c = 0.2, on a path over weights `1 + 100 R`.\n\nThe width factor multiplies that cost, so "
               "a *smaller* factor gives a *wider* path: 0.6 is like T = 167 cost units, 0.2 like T = 500. Panels 3-4 "
               "look saturated white because the thesis then sets every brightness above 0.7 to 1."),
        ("code", '''\
show(presets.width_demo((100, 60) if SMALL else (200, 120)).image)'''),
        ("md", "Widths (constructive path planning Fig. 4), 6 endpoints, brightness by path cost as above; panels "
               "left to right: constant T = 5.0; tapering by eq. 2 from 5.0 at the generator to 0.8 at each path's "
               "tip; the same taper along branches (every side branch starts again at 5.0 where it leaves its "
               "parent):"),
        ("code", '''\
show(presets.taper_demo((80, 80) if SMALL else (200, 200)).image)'''),
    ],
    "04_3d": [
        ("md", "# 3D: trees, coral, lichen, rock and moss\n\nThe same path planning on 26-connected 3D lattices. "
               "A lattice path turns by 45 or 90 degrees at almost every node; the 3D presets use it only as a guide: "
               "each branch is smoothed (a Gaussian along it, ends held) and interpolated (centripetal Catmull-Rom), "
               "radii taper along branches and on across forks, and the tapered tubes around these centre lines are "
               "meshed as one closed body (the isosurface of their distance field, the papers' section 3.3 route). "
               "Previews are ray cast with Warp: several rays per pixel, smooth normals, soft shadows."),
        ("code", SETUP),
        ("md", "An elm (constructive path planning Figs. 6-8, 80^3 lattice; 17 endpoints as in thesis Table 5.1), "
               "and how sharply its centre lines turn between samples one node apart, before and after smoothing:"),
        ("code", '''\
from wdendrite.skeleton import skeleton, turning_angles
tree = presets.elm_tree((24, 24, 24) if SMALL else (80, 80, 80), endpoints=8 if SMALL else 17)
raw = skeleton(tree.dendrite, 1.0, sigma=0.0, samples=1)      # the lattice path itself
for name, lines in (("lattice path", raw), ("smooth centre lines", tree.parts["skeleton"])):
    print(f"{name}: 95th percentile turn {np.percentile(turning_angles(lines, 1.0), 95):.0f} degrees")
m = tree.mesh
print(f"{len(m.faces)} faces, watertight {m.is_watertight}, bodies {len(m.split(only_watertight=False))}, "
      f"volume {m.volume:.0f}")
show(tree.image)'''),
        ("md", "The papers draw a sphere at every node (`geometry=\"spheres\"`, left); the default `\"smooth\"` "
               "(right) is the same dendrite:"),
        ("code", '''\
beads = presets.elm_tree((24, 24, 24) if SMALL else (80, 80, 80), endpoints=8 if SMALL else 17, geometry="spheres")
show([beads.image, tree.image], labels=["spheres on the nodes", "smooth body"])'''),
        ("md", "The same endpoints (24; 8 at `SMALL` sizes) with weights biased toward a vertical axis, away from it, "
               "or upward (constructive path planning Fig. 5). Panels, left to right: toward the axis, away from the "
               "axis, toward the top (strength 3):"),
        ("code", '''\
show(presets.tropism_objects((20, 20, 20) if SMALL else (60, 60, 60), endpoints=8 if SMALL else 24).image)'''),
        ("md", "Staghorn coral (2007 paper Fig. 12 and Table 1: 50^3, 24 endpoints, with refinement). The dendrite is "
               "refined on 7 x 7 x 7 sublattices (thesis section 4.4: n = 7, 9 or 15, e = 0.75) before its centre lines "
               "are smoothed; `parts[\"coarse\"]` keeps the dendrite before refinement:"),
        ("code", '''\
coral = presets.staghorn_coral((20, 20, 20) if SMALL else (50, 50, 50), endpoints=8 if SMALL else 24)
print(f"{len(coral.parts['coarse'])} coarse nodes, {len(coral.dendrite)} refined (spacing {coral.dendrite.spacing:.3f})")
show(coral.image)'''),
        ("md", "A rock: the region nearest in path cost to a central generator, meshed (2007 paper Fig. 10):"),
        ("code", '''\
rock = presets.rock((24, 24, 24) if SMALL else (128, 128, 128), smooth=2 if SMALL else 6)
show(rock.image)'''),
        ("md", "Lichen as the thesis draws it (section 5.4, Fig. 5.4): a dendrite, then its nodes as generators, and "
               "the nodes between two isocontours of the path cost from it become one kind of lichen each, kept with "
               "the band's density: orange close to the dendrite, grey-green embracing it. In 2D, as crusty patches "
               "on a stone:"),
        ("code", '''\
cluster = presets.lichen_cluster((96, 96) if SMALL else (256, 256), count=4 if SMALL else 8)
print("nodes per kind (bare, orange, grey-green):", np.bincount(cluster.parts["kind"].ravel()))
show(cluster.image, scale=3 if SMALL else 2)'''),
        ("md", "In 3D, over a rock (2007 paper Fig. 16, 128^3): the dendrite grows over the rock's surface nodes, the "
               "bands are path costs along the surface, and the crust is a layer over the rock where the kinds' "
               "particles lie. Rock, crust and the dendrite's ropes are one closed body with vertex colours:"),
        ("code", '''\
lichen = presets.lichen_on_rock((32, 32, 32) if SMALL else (128, 128, 128), count=3 if SMALL else 4)
print(f"watertight {lichen.mesh.is_watertight}, bodies {len(lichen.mesh.split(only_watertight=False))}")
show(lichen.image)'''),
        ("md", "Moss (2007 paper Fig. 15, \"a mossy version of the peppers image\"): many strands up from a ground "
               "plane, each coloured from a picture at its root, on a ground showing the same picture. Without a "
               "picture the preset draws mossy greens; any RGB image works (here a colour ramp):"),
        ("code", '''\
shape = (12, 32, 32) if SMALL else (40, 96, 96)
moss = presets.moss(shape, endpoints=60 if SMALL else None)
yy, xx = np.mgrid[:64, :64] / 63.0
ramp = np.stack([0.25 + 0.6 * xx, 0.45 + 0.3 * yy, 0.15 + 0.2 * (1 - xx)], axis=-1)
ramped = presets.moss(shape, endpoints=60 if SMALL else None, image=ramp)
io.save_mesh("moss.glb", moss.mesh, overwrite=True)    # OBJ, PLY, STL or GLB from the suffix (colours in GLB and PLY)
show([moss.image, ramped.image], labels=["default picture", "a colour ramp"])'''),
    ],
    "05_dendry_terrain": [
        ("md", "# Dendry terrain and hydrology\n\nGaillard et al. (2019): a per-pixel function giving the distance to "
               "an implicit branching tree, and a terrain built on it. Every pixel is independent, so a window of a "
               "huge image is computed alone, bit for bit.\n\nIn the grey pictures below the distance is shown as "
               "`exp(-distance / median)`: white on the tree, darker away from it; elevations are scaled to [0, 1]: "
               "bright is high, and the tree's branches are the dark valleys.\n\nThe first Dendry call of a "
               "fresh install compiles its kernels (about 15 s, once; later runs load them from Warp's cache)."),
        ("code", SETUP),
        ("md", "`DendryParams.terrain()` is the paper's Table 1 setup (2 levels, eps 0.25, delta 0.1, beta 0.5, "
               "noise 0.05) with three additions of ours for terrains: level-1 `outlets` (no river ends in a closed "
               "basin), `fine_eps = 0` (no straight seams along level-1 cell borders) and `primitive_eps = 0.4` (valley "
               "floors follow their rivers). `DendryParams.table1()` is the method as published. Here at 3 levels:"),
        ("code", '''\
from wdendrite import control, hydrology
n = 128 if SMALL else 512
ctl = control.drained(control.perlin(seed=1, domain=((-0.2, -0.4), (1.4, 0.7))))
p = wd.DendryParams.terrain(levels=2 if SMALL else 3, seed=1)
kw = dict(domain=((0.0, 0.0), (4.0, 4.0)), params=p, control=ctl)
dist = wd.dendry((n, n), output="distance", **kw)
show(np.exp(-dist / np.median(dist)))'''),
        ("code", '''\
z = wd.dendry((n, n), output="elevation", **kw)
win = wd.dendry((n, n), output="elevation", window=(n // 4, n // 3, 20, 30), **kw)
assert np.array_equal(win, z[n // 4: n // 4 + 20, n // 3: n // 3 + 30])   # a window is the same region
show((z - z.min()) / (z.max() - z.min()))'''),
        ("md", "**Seams.** With the paper's `eps = 0.25` at every level, no key point of any level lies near a level-1 "
               "cell's border (here at x = 1, 2, 3 and y = 1, 2, 3), so the subtrees of neighbouring cells end short of "
               "it and their divide runs straight along it; where they hang at different altitudes the elevation "
               "(the altitude of the nearest tree point plus a slope, the paper's eq. 4) steps along a straight line "
               "(left). `fine_eps = 0` lets the finer branches reach across, so divides wander (right)."),
        ("code", '''\
import dataclasses
z_paper_eps = wd.dendry((n, n), output="elevation", **dict(kw, params=dataclasses.replace(p, fine_eps=None)))
show([wd.render.relief(a, 4.0 / n) for a in (z_paper_eps, z)], labels=["eps 0.25 at every level", "fine_eps = 0"])'''),
        ("md", "**Hydrology.** Depressions (cells a priority-flood fill raises) of the terrain, of the same terrain "
               "by the method as published (no outlets, the paper's jitter) and of an fBm baseline; then the drainage "
               "area on the filled terrain: D8 (left) and D-infinity (right; the paper's Figure 16 uses it). "
               "`benchmarks/table1_hydrology.py` measures the paper's Table 1 protocol on 100 terrains."),
        ("code", '''\
paper = wd.DendryParams.table1(levels=p.levels, seed=1)
z_paper = wd.dendry((n, n), output="elevation", **dict(kw, params=paper, control=ctl))
for name, terrain in [("terrain()", z), ("table1()", z_paper), ("fBm", hydrology.fbm_terrain((n, n), seed=1))]:
    d = hydrology.depressions(terrain)
    print(f"{name:10s} depressions: {d.count:4d}, {d.percent:5.2f} % of the surface")
d8 = hydrology.flow_accumulation(z, filled=True)
dinf = hydrology.flow_accumulation(z, filled=True, method="dinf")
show([hydrology.drainage_image(d8), hydrology.drainage_image(dinf)], labels=["D8", "D-infinity"])'''),
        ("md", "**The slope power beta** (the paper's Fig. 13 and eq. 7): around a tree point of elevation h the "
               "slope is `smootherstep` of `h^beta` between the control's minimum and maximum. With beta near 0 every "
               "slope is steep; larger values widen the valleys of the low ground, and beyond 1 the high ground rises "
               "in cliffs over wide plains. Its effect shows where the tree's elevations span the control's range: "
               "here a plane rising from 0 (top) to 1 (bottom), beta = 0, 0.5, 1 and 2. Below it the paper's Fig. 13 "
               "setup (a Perlin control, 2 levels, delta 0.08, seed 1, beta 0 to 1.5): our Perlin control spans only "
               "about 0.3 to 0.8 over Table 1's rectangle, and the finer branches lie above it, so there beta changes "
               "only the lowest valleys."),
        ("code", '''\
ramp = control.plane((0.0, 1.0))                                  # 0 at the top, 1 at the bottom
slopes = [wd.dendry((n, n), domain=((0.0, 0.0), (4.0, 4.0)), control=ramp, output="elevation",
                    params=dataclasses.replace(p, beta=b)) for b in (0.0, 0.5, 1.0, 2.0)]
display(show([wd.render.relief(a, 4.0 / n) for a in slopes], labels=["beta 0", "beta 0.5", "beta 1", "beta 2"]))
fig13 = [wd.dendry((n, n), domain=((0.0, 0.0), (4.0, 4.0)), control=ctl, output="elevation",
                   params=wd.DendryParams.terrain(seed=1, delta=0.08, beta=b)) for b in (0.0, 0.5, 1.0, 1.5)]
show([wd.render.relief(a, 4.0 / n) for a in fig13], labels=["beta 0", "beta 0.5", "beta 1", "beta 1.5"])'''),
        ("md", "**A sketch as the control** (the paper's Fig. 11: a U-shaped user sketch and the terrain made from "
               "it). Any drawing works: dark strokes are low ground, and the main valleys follow them. Here a U drawn "
               "with a few brush strokes, blurred, scaled to [0, 1] and drained so that it leads to the border:"),
        ("code", '''\
from scipy.ndimage import gaussian_filter
sketch = Image.new("L", (64, 64), 255)
pen = ImageDraw.Draw(sketch)
pen.line([(16, 4), (17, 34), (24, 48), (32, 52), (40, 48), (47, 34), (48, 4)], fill=40, width=9, joint="curve")
drawn = gaussian_filter(np.asarray(sketch, np.float32), 3.0)
drawn = (drawn - drawn.min()) / np.ptp(drawn)                      # 0 in the strokes, 1 on the paper
u_shape = control.drained(control.image(drawn, domain=((0.0, 0.0), (1.0, 1.0))))
z_u = wd.dendry((n, n), domain=((0.0, 0.0), (6.0, 6.0)), control=u_shape, output="elevation",
                params=wd.DendryParams.terrain(levels=p.levels, seed=5, beta=1.0))
big_sketch = np.kron(drawn, np.ones((n // 64, n // 64)))           # shown at the terrain's size
show([big_sketch, wd.render.relief(z_u, 6.0 / n, hydrology.flow_accumulation(z_u, filled=True))],
     labels=["the sketch", "the terrain and its rivers"])'''),
        ("md", "## The Lichtenberg figure, levels and points\n\nThe Lichtenberg variant joins each new branch 45 "
               "degrees downstream of the point nearest to it, on the paper's bowl control (lowest at its edge's "
               "middle, here the bottom). `wd.render.dendry_lines` draws the tree as antialiased lines, each level "
               "1.4 times wider than the next finer one (the picture `wdendrite dendry` draws): left as ink on "
               "paper, right as light with a glow. (`output=\"level\"` gives the level of the nearest branch, 1 "
               "for the trunk.) `wd.dendry_points` evaluates any (N, 2) points, a mesh's vertices say, with the "
               "values an image gives its pixel centres."),
        ("code", '''\
pl = wd.DendryParams(levels=3 if SMALL else 5, eps=0.25, delta=0.05, rule="lichtenberg", resolution=2.0, seed=3)
bowl = dict(domain=((-1.0, -1.0), (1.0, 1.0)), params=pl, control=control.lichtenberg())
lines = wd.render.dendry_lines((n, n), **bowl)[::-1]     # 1 on a branch; rows flipped: y up, the root at the bottom
light = wd.render.colorize(lines, colormap="lightning", glow=wd.render.glow(lines, radius=3))
show([1 - lines, light], labels=["1 - lines (ink)", "colorize(lines, glow=...)"])'''),
        ("code", '''\
rows, cols = np.array([5, n // 2, n - 3]), np.array([7, n // 3, n - 1])
step = 4.0 / n                                                          # the domain's width over n pixels
centres = np.stack([(cols + 0.5) * step, (rows + 0.5) * step], axis=1)  # (x, y) of those pixels' centres
print("at the points:", wd.dendry_points(centres, output="elevation", **kw))
print("in the image: ", z[rows, cols])'''),
        ("md", "## DEM amplification\n\nA low-resolution elevation map as the control of a 16 times larger "
               "terrain. A 16 x 16 fBm map stands in for the DEM here; scale a real DEM to [0, 1] first, as below "
               "(terrains take controls in [0, 1]), and `control.drained` fills its pits so that its valleys lead "
               "to the border. One level-1 cell per map pixel: the main valleys follow the map's low ground and the "
               "finer levels add the branches it cannot hold. Left: the map as the control reads it (bicubic); "
               "right: the terrain. Where the map's valleys are narrower than a level-1 cell, some key points lie "
               "below all their neighbours; with the paper's parameters the terrain keeps closed basins around "
               "them, and level-1 outlets (`DendryParams.terrain()`) give each an outlet instead "
               "(`benchmarks/dem_hydrology.py` measures both)."),
        ("code", '''\
coarse = hydrology.fbm_terrain((16, 16), seed=4)
coarse = (coarse - coarse.min()) / np.ptp(coarse)                      # scaled to [0, 1]
dem = control.drained(control.image(coarse, domain=((0.0, 0.0), (1.0, 1.0))))
pa = wd.DendryParams.terrain(levels=3, seed=2)
big = wd.dendry((256, 256), domain=((0.0, 0.0), (16.0, 16.0)), params=pa, control=dem, output="elevation")
smooth = dem.grid((256, 256))
print("correlation with the map:", round(float(np.corrcoef(smooth.ravel(), big.ravel())[0, 1]), 3))
print(f"depressions: {hydrology.depressions(big).percent:.2f} % of the surface")
show([smooth, (big - big.min()) / np.ptp(big)], labels=["the 16 x 16 map, smoothly sampled", "the terrain"])'''),
        ("md", "The command draws the same terrain, shaded, with its rivers: `wdendrite terrain --size 512 --levels 3 "
               "--seed 1 -o terrain.png`."),
        ("code", '''\
show(wd.render.relief(z, 4.0 / n, d8))   # the picture `wdendrite terrain` draws: shading, tint, D8 rivers'''),
    ],
    "06_batch": [
        ("md", "# Batch jobs on a GPU workstation\n\nA TOML job file lists presets with sweeps; `wdendrite batch "
               "jobs.toml` writes every output atomically with a manifest and skips what is complete when run again. "
               "`--scheduler local` spreads the tasks over a Dask `LocalCluster` (one worker per GPU: `--workers 2 "
               "--device cuda`), `--scheduler tcp://host:8786` over an existing cluster.\n\nThe notebooks run in "
               "Jupyter: `pip install -e \".[notebooks]\"` in the project's folder installs it and Dask. The two cells "
               'on a Dask `LocalCluster` (the `competition` jobs run with `scheduler="local"`, and the lazy Dask '
               'terrain) need Dask (`pip install -e ".[distributed]"` alone); the other cells need only wdendrite.'),
        ("code", SETUP),
        ("code", '''\
import json, tempfile
from pathlib import Path
from wdendrite import batch

folder = Path(tempfile.mkdtemp())
size = 48 if SMALL else 512
(folder / "jobs.toml").write_text(f"""
out = "runs"
device = "cpu"

[[job]]
preset = "lightning"
seeds = [1, 2]
size = {size}
formats = ["png", "npz"]

[[job]]
preset = "fractal"
size = {size}
grid = {{ cheap = [0.0, 0.5] }}

[[job]]
preset = "terrain"          # tiled: never whole in memory
size = {4 * size}
tile = {size}
formats = ["npy"]
""")
batch.run_file(folder / "jobs.toml", quiet=True)
sorted(p.name for p in (folder / "runs").iterdir())'''),
        ("code", '''\
man = json.loads((folder / "runs" / f"lightning_shape{size}x{size}_seed1.manifest.json").read_text())
{k: man[k] for k in ("preset", "seed", "device", "version", "seconds")}'''),
        ("md", "Running the file again does nothing: every task is complete."),
        ("code", '''\
code = batch.run_file(folder / "jobs.toml", quiet=True)
print("exit code", code, "(0: every task complete)")'''),
        ("md", "The same kind of file on a Dask `LocalCluster` (threads here; on a workstation, the command `wdendrite "
               "batch jobs.toml --scheduler local --workers 2 --device cuda` gives each worker a GPU):"),
        ("code", '''\
(folder / "more.toml").write_text(f"""
out = "runs"
device = "cpu"
[[job]]
preset = "competition"
seeds = [3, 4]
size = {2 * size}
""")
batch.run_file(folder / "more.toml", scheduler="local", workers=1, processes=False, quiet=True)
display(Image.open(folder / "runs" / f"competition_shape{2 * size}x{2 * size}_seed3.png"))'''),
        ("md", "A large Dendry terrain is a lazy Dask array, one block per tile (computed by the cluster's workers); "
               "the picture is the elevation of its top-left corner, scaled to [0, 1] (bright is high):"),
        ("code", '''\
from distributed import Client, LocalCluster
from wdendrite import control
# what wdendrite.dendry takes: the whole image's shape, its domain, the parameters and the control
setup = dict(shape=(4 * size, 4 * size), domain=((0.0, 0.0), (16.0, 16.0)),
             params=wd.DendryParams(levels=2, delta=0.1, noise=0.05, seed=0),
             control=control.perlin(seed=0, frequency=1.0, domain=((-0.2, -0.4), (1.4, 0.7))))
with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster, \\
        Client(cluster) as client:
    arr = batch.dendry_array(setup, tile=size, device="cpu")
    print(arr)
    corner = arr[:size, :2 * size].compute()
show((corner - corner.min()) / (corner.max() - corner.min()))'''),
        ("code", '''\
import json
name = folder / "runs" / f"terrain_size{4 * size}_seed0"
tiled = np.load(name.with_suffix(".npy"), mmap_mode="r")
extent = json.loads(name.with_suffix(".manifest.json").read_text())["params"]["extent"]
print(tiled.shape, tiled.dtype, "extent", extent)
# every 4th pixel: a pixel of the picture spans 4 of the file's
show(wd.render.relief(np.asarray(tiled[::4, ::4]), extent * 4 / tiled.shape[1]))'''),
    ],
}


def build() -> list[Path]:
    """Write every notebook; returns their paths."""
    HERE.mkdir(exist_ok=True)
    paths = []
    for name, cells in NOTEBOOKS.items():
        nb = nbformat.v4.new_notebook()
        nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
        nb.cells = [nbformat.v4.new_markdown_cell(src) if kind == "md" else nbformat.v4.new_code_cell(src)
                    for kind, src in cells]
        for i, cell in enumerate(nb.cells):
            cell["id"] = f"{name[:2]}-{i:02d}"  # stable ids: regenerating gives the same files
        path = HERE / f"{name}.ipynb"
        nbformat.write(nb, path)
        paths.append(path)
    return paths


if __name__ == "__main__":
    for p in build():
        print(p)
