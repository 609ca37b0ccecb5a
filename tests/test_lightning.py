"""The papers' lightning (wdendrite.lightning through presets.lightning): its channel, branches, picture and inputs.

The properties are measured on the pictures and dendrites the preset returns, at the papers'
600^2 size, for seeds 0, 1 and 2 (every seed run is here).
"""

import numpy as np
import pytest
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra
from skimage.measure import euler_number
from skimage.morphology import skeletonize

import wdendrite as wd
from wdendrite import lightning as lt
from wdendrite import presets
from wdendrite.presets import LightningParams

SEEDS = (0, 1, 2)
_MADE = {}


def bolt(seed, **kw):
    key = (seed, tuple(sorted(kw.items())))
    if key not in _MADE:
        _MADE[key] = presets.lightning((600, 600), params=LightningParams(**kw), seed=seed)
    return _MADE[key]


def _main_path(res):
    main = res.parts["main"]
    return main.nodes[main.path(int(main.endpoints[0]))[::-1]]  # top to bottom


def _strip_widths(value, path, radius=15.0, level=0.5):
    """Width of the stroke along ``path``: the area brighter than ``level`` within ``radius`` of a
    node, over the length of the path inside that disc (nodes a full disc away from the border)."""
    h, w = value.shape
    bright = value >= level
    mid = 0.5 * (path[1:] + path[:-1])
    length = np.linalg.norm(np.diff(path, axis=0), axis=1)
    g = int(radius)
    yy, xx = np.mgrid[-g: g + 1, -g: g + 1]
    disc = yy * yy + xx * xx <= radius * radius
    out = []
    for y, x in path:
        if g <= y < h - g and g <= x < w - g:
            area = np.count_nonzero(bright[y - g: y + g + 1, x - g: x + g + 1] & disc)
            out.append(area / length[np.linalg.norm(mid - (y, x), axis=1) <= radius].sum())
    return np.array(out)


@pytest.mark.parametrize("seed", SEEDS)
def test_the_main_channel_keeps_a_nearly_constant_width(seed):
    res = bolt(seed)
    widths = _strip_widths(res.parts["value"], _main_path(res))
    spread = (np.percentile(widths, 90) - np.percentile(widths, 10)) / np.median(widths)
    assert spread < 0.30, spread
    # thick: wider than the branches' strokes, about 8 pixels at half brightness (T = 4.0 to 3.6)
    assert 4.0 < np.median(widths) < 7.0


def test_the_main_channel_tapers_by_eq_2_and_the_branches_are_thinner():
    res = bolt(0)
    main, widths, graph = res.parts["main"], res.parts["widths"], res.parts["graph"]
    cost = main.cost.astype(np.float64)
    u = (cost - cost.min()) / (cost.max() - cost.min())
    np.testing.assert_allclose(widths[: len(main)], 4.0 * (1 - u) + 3.6 * u, rtol=1e-5)
    assert widths[graph == 1].max() <= 2.2 + 1e-6 and widths[graph == 2].max() <= 1.6 + 1e-6
    # every branch is no wider than the node it leaves, and thins out toward its tip
    den = res.dendrite
    child = np.flatnonzero(den.parent >= 0)
    assert np.all(widths[child] <= widths[den.parent[child]] + 1e-6)


@pytest.mark.parametrize("seed", SEEDS)
def test_no_branch_climbs_above_where_it_leaves_the_channel(seed):
    res = bolt(seed)
    den, graph = res.dendrite, res.parts["graph"]
    assert (graph == 0).sum() == len(res.parts["main"]) and (graph == 1).any() and (graph == 2).any()
    # followed outward from the main channel, no branch rises more than 3 rows above the lowest
    # point it has passed (the node it left the channel at included)
    low = np.where(graph == 0, den.nodes[:, 0], -1)
    for row in den.order:
        p = den.parent[row]
        if graph[row] > 0:
            low[row] = max(low[p], den.nodes[row, 0])
            assert den.nodes[row, 0] >= low[p] - lt.CLIMB, (row, den.nodes[row], low[p])
    # the endpoints lie low: more branch tips in the lower half of the picture than in the upper
    tips = den.nodes[den.endpoints[graph[den.endpoints] > 0], 0]
    assert (tips >= 300).sum() > (tips < 300).sum()


def _holes(mask, smaller_than=0):
    """Areas of the background pieces that touch no border (4-connected background, 8-connected strokes)."""
    bg, n = ndimage.label(~mask)
    edge = set(np.unique(np.concatenate([bg[0], bg[-1], bg[:, 0], bg[:, -1]])))
    sizes = np.bincount(bg.ravel())
    return [int(sizes[k]) for k in range(1, n + 1) if k not in edge and sizes[k] >= smaller_than]


@pytest.mark.parametrize("seed", SEEDS)
def test_the_bolt_is_one_tree_and_its_picture_has_no_loops(seed):
    res = bolt(seed)
    den = res.dendrite
    assert len(den.roots) == 1 and den.nodes[den.roots[0], 0] == 2
    # two edges that cross inside a lattice cell belong to one path from the root (a path's own
    # zigzag), never to two branches
    child = np.flatnonzero(den.parent >= 0)
    step = den.nodes[den.parent[child]] - den.nodes[child]
    diag = child[np.all(np.abs(step) == 1, axis=1)]
    cells = {}
    for r in diag:
        a, b = den.nodes[r], den.nodes[den.parent[r]]
        cells.setdefault((tuple(np.minimum(a, b)), int((b - a).prod() > 0)), []).append(int(r))
    for (cell, kind), rows in cells.items():
        for other in cells.get((cell, 1 - kind), []):
            assert other in den.path(rows[0]) or rows[0] in den.path(other), (cell, rows, other)
    # the lit strokes: one piece without holes (pockets under 9 pixels, a notch where a branch
    # leaves, aside), whose skeleton is a tree
    lit = res.parts["value"] >= 0.3
    assert _holes(lit, smaller_than=9) == []
    filled = ndimage.binary_fill_holes(lit)
    assert ndimage.label(filled, structure=np.ones((3, 3)))[1] == 1
    skeleton = skeletonize(filled)
    assert euler_number(skeleton, connectivity=2) == 1


def test_brightness_is_exp_of_a_scipy_dijkstra_path_cost():
    # the brightness of a small bolt's strokes against SciPy's Dijkstra over the same brightness lattice
    lat = wd.Lattice((40, 40), 8, weights=wd.weights.Power(alpha=0.3, seed=5))
    den = wd.trace(wd.shortest_paths(lat, [[2, 20]]), [[37, 12], [36, 30]])
    widths = np.linspace(3.0, 1.0, len(den))
    peak = np.minimum(widths / 2.0, 1.0)
    rows = np.arange(len(den))
    v = lt._brightness(den, rows, widths, peak, "path", lat)
    src = np.ravel_multi_index(tuple(den.nodes.T), den.shape)
    d, _, near = dijkstra(lat.to_csgraph(), indices=src, min_only=True, return_predecessors=True)
    where = np.full(den.shape, -1).ravel()
    where[src] = rows
    t, a = widths[where[near]], peak[where[near]]
    ref = np.where(d <= 3 * t, a * np.exp(-((d / t) ** 2)), 0.0).reshape(den.shape)
    np.testing.assert_allclose(v, ref, atol=1e-5)


def test_the_glow_is_an_option_and_euclidean_strokes_are_smooth():
    kw = dict(forks=2, minor_forks=4)
    plain = presets.lightning((160, 160), params=LightningParams(**kw), seed=4)
    assert not plain.parts["glow"].any()  # none by default: the paper's renderings lack it
    glowing = presets.lightning((160, 160), params=LightningParams(glow_gain=1.0, **kw), seed=4)
    np.testing.assert_array_equal(glowing.dendrite.nodes, plain.dendrite.nodes)
    assert (glowing.parts["glow"] > 0.02).sum() > (plain.parts["value"] > 0.5).sum()
    assert glowing.image.sum() > plain.image.sum()
    smooth = presets.lightning((160, 160), params=LightningParams(metric="euclidean", **kw), seed=4)
    np.testing.assert_array_equal(smooth.dendrite.nodes, plain.dendrite.nodes)
    assert not np.allclose(smooth.parts["value"], plain.parts["value"])


@pytest.mark.parametrize("call, match", [
    (lambda: LightningParams(descent=1.0), r"'descent' in \(0, 1\)"),
    (lambda: LightningParams(descent=0.0), "'descent'"),
    (lambda: LightningParams(gap=1.0), "'gap' >= 2"),
    (lambda: LightningParams(fork_width=wd.render.Taper(2.0, 0.5, along="path")), r"'fork_width' to taper along"),
    (lambda: LightningParams(glow_alpha=1e30), r"'glow_alpha' of the lightning's power weights"),
    (lambda: LightningParams(glow_alpha=-1.0), "'glow_alpha'"),
    (lambda: LightningParams(metric="manhattan"), "'metric'"),
])
def test_bad_lightning_parameters_are_named(call, match):
    with pytest.raises(ValueError, match=match):
        call()
