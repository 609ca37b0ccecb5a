"""The papers' lightning: a main channel from one graph, branches from a second, brightness by path cost.

Constructive path planning (Fig. 9, section 3.1) and the thesis (section 4.3,
Fig. 4.11) build lightning from two 2D graphs with power weights ``R^alpha``
(alpha = 3): the first holds the main channel, from a generator at the top to
an endpoint at the bottom, and some side branches; the second, with other
weights, only side branches, their endpoints placed near the channel and
biased toward the bottom (2007 paper, section 4). Each node's brightness is
``V = exp(-(d/T)^2)`` with ``d`` a Dijkstra path cost from the structure and
``T`` tapered along each path by eq. 2,
``T_i = Ts (1 - (d_i/d_max)^beta) + Tf (d_i/d_max)^beta`` with beta = 1.

How branches meet the channel is ours, in the thesis' own terms (cheap former
paths, section 3.3.2): a branch's least path runs to the generator over a
lattice where the structure's edges cost ``descent`` times the lattice's least
path cost per node for each row they descend, so it joins the structure where
the way up pays, above its endpoint: on a vertical channel at about
``asin(descent)`` from the horizontal. A branch ends where it first comes within
``gap`` pixels of the structure and joins it by a straight step, so branches
never run alongside the channel or each other, and the picture stays a tree.
Three candidate endpoints are drawn per branch asked for; in the order drawn,
a branch is kept unless its endpoint lies that close already or, followed
outward, it rises more than :data:`CLIMB` rows above the lowest point it has
passed (lightning does not branch upward), until as many as asked are kept.

The papers do not say over which weights their brightness search runs; over
the strokes' own ``R^3`` weights the light creeps along cheap edges into hairy
fringes and the channel's width varies widely along it, so it runs over the
same draws ``R`` with the gentler exponent ``glow_alpha`` (the constructive
paper's 0.3 makes "nearly straight" paths): the strokes keep a slightly
irregular edge and the channel a nearly constant width. A stroke thinner than
:data:`FULL` pixels lights its nodes in proportion to its width, as a channel
narrower than a pixel would, so branch tips fade out.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from . import _checks
from . import endpoints as _ep
from . import render as _r
from . import weights as _w
from .dendrite import Dendrite, trace
from .growth import _dendrite_edges, _path_costs
from .lattice import Lattice
from .sssp import _cost_per_node, shortest_paths

__all__ = ["LightningParams", "strike"]


def _width(name: str, value, along: tuple[str, ...]) -> None:
    if isinstance(value, _r.Taper):
        if value.along not in along:
            raise ValueError(f"Expected '{name}' to taper along one of {along}, but got along={value.along!r}")
    else:
        _checks.positive(name, value)


@dataclass(frozen=True)
class LightningParams:
    """The papers' lightning: two graphs of power weights, branches joined to the main channel, tapered widths.

    Widths, ``gap`` and the glow radius are pixels of a 600^2 picture (the papers' size) and
    scale with the picture's smaller side (by at least 0.5).
    """

    alpha: float = 3.0
    """Exponent of the power weights ``R^alpha``, R uniform in (1, 11) (3: the papers' erratic lightning)."""
    forks: int = 6
    """Side branches of the first graph (the main channel's), >= 0: each from an endpoint near the
    channel; fewer when not that many keep clear of the structure and descend without rising."""
    minor_forks: int = 18
    """Side branches of the second graph, >= 0, likewise (they may also leave the first graph's branches)."""
    descent: float = 0.7
    """Cost of the structure's edges per row they descend, relative to the graph's least path cost per
    node, in (0, 1): a branch meets a vertical channel at about asin(descent) from the horizontal
    (0.7: 45 degrees); lower values join sooner and more level."""
    gap: float = 9.0
    """A branch ends where it first comes this close to the structure (pixels) and joins it straight, >= 2."""
    main_width: _r.Taper = _r.Taper(4.0, 3.6, along="path")
    """Width T of the main channel: thick and nearly constant, tapered by eq. 2 from the top."""
    fork_width: _r.Taper = _r.Taper(2.2, 0.5, along="branch")
    """Width of the first graph's side branches, tapered along each branch (no wider than where it leaves)."""
    minor_width: _r.Taper = _r.Taper(1.6, 0.4, along="branch")
    """Width of the second graph's branches, tapered along each branch (no wider than where it leaves)."""
    minor_gain: float = 0.85
    """Brightness of the second graph relative to the first, in [0, 1]."""
    metric: Literal["path", "euclidean"] = "path"
    """What brightness falls off with: "path", the papers' path cost from the strokes over a lattice
    of the same draws R with exponent ``glow_alpha`` (widths scaled by its measured cost per node),
    or "euclidean", the distance in pixels (smooth strokes)."""
    glow_alpha: float = 0.3
    """Exponent of the weights ``R^glow_alpha`` the brightness search runs over, > 0 (with ``metric="path"``)."""
    glow_radius: float = 14.0
    """Blur radius of the halo (pixels), > 0."""
    glow_gain: float = 0.0
    """Strength of the halo, >= 0 (0: none, as the constructive paper's renderings, which it says lack it)."""

    def __post_init__(self):
        _checks.positive("alpha", self.alpha)
        if self.metric not in ("euclidean", "path"):
            raise ValueError(f"Expected 'metric' in ('euclidean', 'path'), but got {self.metric!r}")
        # the weights' own bound, in this preset's words: Power's default range (1, max), times the
        # longest edge a lattice may have (sqrt 3), below the supported largest weight
        top, limit = _w.Power().max, math.log(_w._MAX_WEIGHT / math.sqrt(3.0))
        for name in ("alpha", "glow_alpha"):
            if not _checks.positive(name, getattr(self, name)) * math.log(top) < limit:
                raise ValueError(f"'{name}' of the lightning's power weights must keep sqrt(3) * {top:g}**{name} below "
                                 f"{_w._MAX_WEIGHT:g} ({name} < {limit / math.log(top):.4g}), but got "
                                 f"{getattr(self, name)!r}")
        _checks.integer("forks", self.forks, low=0)
        _checks.integer("minor_forks", self.minor_forks, low=0)
        descent = _checks.positive("descent", self.descent)
        if descent >= 1:
            raise ValueError(f"Expected 'descent' in (0, 1) (the structure cheaper than the sky), but got {self.descent!r}")
        if _checks.positive("gap", self.gap) < 2:
            raise ValueError(f"Expected 'gap' >= 2 pixels, but got {self.gap!r}")
        _width("main_width", self.main_width, ("path", "branch", "dendrite"))
        _width("fork_width", self.fork_width, ("branch",))
        _width("minor_width", self.minor_width, ("branch",))
        gain = _checks.nonnegative("minor_gain", self.minor_gain, allow_none=False)
        if gain > 1:
            raise ValueError(f"Expected 'minor_gain' in [0, 1], but got {self.minor_gain!r}")
        _checks.positive("glow_radius", self.glow_radius)
        _checks.nonnegative("glow_gain", self.glow_gain, allow_none=False)


CLIMB = 3
"""Rows a branch may rise, followed outward, above the lowest point it has passed (lattice zigzags);
branches rising more are left out."""


FULL = 1.2
"""Width (pixels of a 600^2 picture) from which a stroke lights its nodes fully; thinner ones fade."""


def _scaled(width, s: float):
    if isinstance(width, _r.Taper):
        return dataclasses.replace(width, start=width.start * s, end=width.end * s)
    return float(width) * s


def _descent(lattice: Lattice, structure: Dendrite, per_row: float) -> Lattice:
    """``lattice`` whose edges along ``structure`` cost ``per_row`` per row they descend (a tenth of it level)."""
    dirs, lower = _dendrite_edges(lattice, structure)
    w = lattice.weights.copy()
    rows = np.maximum(np.abs(lattice.offsets[dirs, 0]), 0.1)
    w[(dirs,) + tuple(lower.T)] = (per_row * rows).astype(np.float32)
    return lattice.with_weights(w)


def _near(nodes: np.ndarray, shape, low: float, high: float, top: int) -> np.ndarray:
    """Nodes between ``low`` and ``high`` pixels from ``nodes``, below row ``top``."""
    from scipy import ndimage

    free = np.ones(shape, bool)
    free[tuple(nodes.T)] = False
    d = ndimage.distance_transform_edt(free)
    out = (d > low) & (d < high)
    out[:top] = False
    return out


CANDIDATES = 3
"""Endpoints drawn per branch asked for: the branches are kept in the order drawn, and some are left out."""


def _candidates(lattice: Lattice, name: str, count: int, region: np.ndarray, rng, spacing: float) -> np.ndarray:
    """:data:`CANDIDATES` times ``count`` endpoints in ``region``, denser low in the picture, or ``count``
    when fewer fit (a request that even so cannot be met names the parameter ``name``)."""
    def draw(m):
        return _ep.biased(lattice, m, seed=rng, power=1.5, axis=0, toward="end", within=region, min_spacing=spacing)

    try:
        return draw(CANDIDATES * count)
    except _ep.TooManyEndpoints:
        return _ep._requested(name, count, "near the main channel of", lattice.shape, lambda: draw(count))


def _disc(radius: float) -> np.ndarray:
    g = int(math.floor(radius))
    yy, xx = np.mgrid[-g: g + 1, -g: g + 1]
    keep = yy * yy + xx * xx <= radius * radius
    return np.stack([yy[keep], xx[keep]], axis=1)


def _keep_apart(traced: Dendrite, first: int, gap: float, count: int, floors=None):
    """Nodes and parents of ``traced``'s first ``first`` rows (the structure) and of the first ``count``
    branches its later endpoints keep (in their order), and each node's floor (the lowest row on its way out from the main channel;
    ``floors`` of the structure's rows, default their own rows). Each path, followed from its
    endpoint, ends at its first node within ``gap`` of what is kept so far and steps straight to the
    nearest kept node; a path whose endpoint lies that close, or that rises more than :data:`CLIMB`
    rows above its floor anywhere, is left out."""
    shape = traced.shape
    disc = _disc(gap)
    near = np.zeros(shape, bool)

    def mark(pts):
        q = (pts[:, None, :] + disc[None]).reshape(-1, 2)
        ok = np.all((q >= 0) & (q < np.asarray(shape)), axis=1)
        near[q[ok, 0], q[ok, 1]] = True

    parents = [traced.parent[:first]]
    acc = traced.nodes[:first]
    # the lowest row (largest index) on the way from the main channel to each kept node
    floor = floors if floors is not None else acc[:, 0].copy()
    mark(acc)
    kept = 0
    for e in traced.endpoints[traced.endpoints >= first]:
        if kept == count:
            break
        path = traced.path(int(e))
        pts = traced.nodes[path[: int(np.argmax(path < first)) + 1]]
        k = int(np.argmax(near[pts[:, 0], pts[:, 1]]))
        if k == 0:
            continue
        q = pts[k]
        j = int(np.argmin(((acc - q) ** 2).sum(axis=1)))
        n = int(np.abs(acc[j] - q).max())
        step = np.rint(q + (acc[j] - q) * (np.arange(1, n) / n)[:, None]).astype(np.int64)
        branch = np.concatenate([pts[: k + 1], step])
        # followed outward from the node it joins, the branch never rises CLIMB rows above its lowest point so far
        low = np.maximum.accumulate(np.concatenate([[floor[j]], branch[::-1, 0]]))
        if np.any(branch[::-1, 0] < low[:-1] - CLIMB):
            continue
        rows = len(acc) + np.arange(len(branch))
        parents.append(np.append(rows[1:], j))
        acc = np.concatenate([acc, branch])
        floor = np.concatenate([floor, low[1:][::-1]])
        mark(branch)
        kept += 1
    return acc, np.concatenate(parents), floor


def _structure(nodes, parent, graph, lattices, shape) -> Dendrite:
    """The joined tree, its costs path costs from the generator: each edge weighs what it does in
    the lattice of the graph its child node came from."""
    den = Dendrite.from_arrays(shape, nodes, parent, generation=graph)
    costs = [_path_costs(lat, den, "structure", None).astype(np.float64) for lat in lattices[: max(1, int(graph.max()))]]
    cost = costs[0].copy()
    if (graph == 2).any():
        # second-graph rows continue the cost of the first-graph node their branch leaves
        up = np.where((den.parent >= 0) & (graph == 2), den.parent, np.arange(len(den)))
        for _ in range(64):
            nxt = np.where(graph[up] == 2, up[up], up)
            if np.array_equal(nxt, up):
                break
            up = nxt
        two = graph == 2
        cost[two] = costs[0][up[two]] + costs[1][two] - costs[1][up[two]]
    return dataclasses.replace(den, cost=cost.astype(np.float32))


def _side_widths(den: Dendrite, rows: np.ndarray, width, out: np.ndarray) -> None:
    """Widths of the branches made of ``rows`` (each tapering from where it leaves the rest), at most the
    width of the node each leaves; written into ``out``."""
    if not len(rows):
        return
    index = np.full(len(den), -1, np.int64)
    index[rows] = np.arange(len(rows))
    par = den.parent[rows]
    sub_parent = np.where(par >= 0, index[np.maximum(par, 0)], -1)
    sub = Dendrite.from_arrays(den.shape, den.nodes[rows], sub_parent, cost=den.cost[rows])
    w = _r.node_widths(sub, width, side=width if isinstance(width, _r.Taper) else None).astype(np.float64)
    root = np.where(sub_parent >= 0, sub_parent, np.arange(len(rows)))
    for _ in range(64):  # each row's sub-root, by pointer jumping
        nxt = root[root]
        if np.array_equal(nxt, root):
            break
        root = nxt
    leaves = par[root]  # the node outside the rows each branch leaves
    out[rows] = np.minimum(w, out[leaves])


def strike(shape, params: LightningParams, seed) -> dict:
    """The lightning of :class:`LightningParams` on a ``shape`` (H, W) picture.

    Returns:
        A dict: ``"dendrite"`` the whole tree (``generation`` 0 on the main channel, 1 on the first
        graph's branches, 2 on the second's), ``"main"`` the main channel alone, ``"widths"`` every
        node's width (pixels), ``"value"`` the ``(H, W)`` brightness in [0, 1], ``"glow"`` the halo
        (zeros without one), ``"image"`` the ``(H, W, 3)`` picture, ``"lattices"`` the two graphs.

    Raises:
        ValueError: more ``forks`` or ``minor_forks`` than fit near the channel (naming the parameter).
    """
    rng = _checks.rng(seed)
    h, w = shape
    s = max(min(h, w) / 600.0, 0.5)  # the papers' widths are for 600^2 pictures; keep the look at other sizes
    gen = np.array([[2, int(w * rng.uniform(0.4, 0.6))]])
    seeds = [int(rng.integers(2**31)) for _ in range(2)]
    lats = [Lattice(shape, 8, weights=_w.Power(alpha=params.alpha, seed=k)) for k in seeds]
    cf = shortest_paths(lats[0], gen)
    main = trace(cf, [[h - 3, int(w * rng.uniform(0.3, 0.7))]])
    per_node = [_cost_per_node(lats[0], tuple(gen[0]), min(h, w) / 3, cf.dist), None]
    structure, graph, floor = main, np.zeros(len(main), np.int32), None
    plans = [("forks", params.forks, 0.3, h // 8, 0.08), ("minor_forks", params.minor_forks, 0.18, h // 6, 0.04)]
    for g, (name, count, reach, top, spacing) in enumerate(plans):
        if not count:
            continue
        lat = lats[g]
        if per_node[g] is None:
            per_node[g] = _cost_per_node(lat, tuple(gen[0]), min(h, w) / 3)
        region = _near(structure.nodes, shape, 0.03 * w, reach * w, top)
        ends = _candidates(lat, name, count, region, rng, spacing * min(h, w))
        walks = shortest_paths(_descent(lat, structure, params.descent * per_node[g]), gen)
        nodes, parent, floor = _keep_apart(trace(walks, ends, extend=structure), len(structure), params.gap * s,
                                           count, floor)
        graph = np.concatenate([graph, np.full(len(nodes) - len(structure), g + 1, np.int32)])
        structure = _structure(nodes, parent, graph, lats, shape)
    den = structure
    widths = np.zeros(len(den))
    widths[: len(main)] = _r.node_widths(main, _scaled(params.main_width, s))
    _side_widths(den, np.flatnonzero(graph == 1), _scaled(params.fork_width, s), widths)
    _side_widths(den, np.flatnonzero(graph == 2), _scaled(params.minor_width, s), widths)
    # a channel thinner than FULL pixels lights its pixels in proportion to its width
    peak = np.minimum(widths / (FULL * s), 1.0)
    layers, gains = [], []
    for g, rows, gain in ((0, np.flatnonzero(graph <= 1), 1.0), (1, np.flatnonzero(graph == 2), params.minor_gain)):
        if not len(rows):
            continue
        glow_lat, c = None, 1.0
        if params.metric == "path":
            glow_lat = Lattice(shape, 8, weights=_w.Power(alpha=params.glow_alpha, seed=seeds[g]))
            c = _cost_per_node(glow_lat, tuple(gen[0]), min(h, w) / 3)
        layers.append(_brightness(den, rows, widths * c, peak, params.metric, glow_lat))
        gains.append(gain)
    value = _r.composite(layers, mode="max", gains=gains)
    halo = (_r.glow(value, radius=params.glow_radius * s) * params.glow_gain if params.glow_gain > 0
            else np.zeros_like(value))
    image = _r.colorize(value, colormap="lightning", glow=halo, background=_sky(shape))
    return {"dendrite": den, "main": main, "widths": widths.astype(np.float32), "value": value, "glow": halo,
            "image": image, "lattices": tuple(lats)}


def _brightness(den: Dendrite, rows: np.ndarray, widths: np.ndarray, peak: np.ndarray, metric: str,
                lattice: Lattice | None) -> np.ndarray:
    """``peak * exp(-(d/T)^2)`` of the nearest of ``rows`` (``T`` and ``peak`` of that node), 0 beyond ``3 T``."""
    dist, label = _r.distance_field(den, limit=3.0 * float(widths[rows].max()), metric=metric, lattice=lattice,
                                    rows=rows)
    near = label >= 0
    t = widths[np.maximum(label, 0)]
    v = np.where(near & (dist <= 3.0 * t), peak[np.maximum(label, 0)] * np.exp(-np.square(dist / t)), 0.0)
    return v.astype(np.float32)


def _sky(shape) -> np.ndarray:
    y = np.linspace(0.0, 1.0, shape[0], dtype=np.float32)[:, None, None]
    top, bottom = np.array([0.05, 0.05, 0.12], np.float32), np.array([0.01, 0.01, 0.03], np.float32)
    return np.broadcast_to(top * (1 - y) + bottom * y, (*shape, 3)).copy()


from ._spec import document_fields as _document_fields  # noqa: E402  (the classes above are complete)

_document_fields(__name__)  # help() shows what each dataclass field means
