"""Brightness images of dendrites (Xu & Mould lightning), tapering, compositing and colour maps;
Dendry trees drawn as lines.

A pixel at distance ``d`` from the dendrite gets the brightness
``V = exp(-(d / T)^2)``, where ``T`` (pixels, or cost units on a weighted
lattice) is the width of the dendrite node nearest to the pixel. Widths can
be constant (the paper shows T = 5.0, with a faint halo, and 1.6), differ
between the main stroke and side branches, or taper along each path
(constructive path planning, eq. 2)::

    T_i = Ts * (1 - (d_i / d_max)^beta) + Tf * (d_i / d_max)^beta

The distance is either a path cost (``metric="path"``) or the Euclidean
distance to the nearest node (``metric="euclidean"``). Path costs over a
given lattice come from a shortest-path search with the dendrite's nodes as
generators, stopped ``reach * T`` away; on the dendrite's own random lattice
this gives the papers' ragged halo. Without a lattice the path cost is the
one of a unit-weight 8-connected (26 in 3D) lattice, whose closed form
(straight plus diagonal steps, the octile distance) every node writes into a
disc of radius ``reach * T``, as for the Euclidean metric: the same values
as the search, without one.

Typical use::

    v = brightness(den, Taper(start=5.0, end=1.0))
    rgb = colorize(v, glow=glow(v, radius=12))
    wd.io.save_png("lightning.png", rgb)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Literal, Sequence

import numpy as np
import warp as wp

from . import _checks, _parallel
from .dendrite import Dendrite
from .kernels import render as _k
from .lattice import Lattice
from .sssp import shortest_paths

__all__ = [
    "COLORMAPS",
    "DENDRY_WIDENING",
    "Taper",
    "branch_order",
    "brightness",
    "colorize",
    "composite",
    "coverage",
    "dendry_lines",
    "distance_field",
    "glow",
    "node_widths",
    "relief",
    "strokes",
    "thesis_width",
    "unit_range",
]

Metric = Literal["path", "euclidean"]
_METRICS = ("path", "euclidean")
TaperAlong = Literal["branch", "path", "dendrite"]
_ALONG = ("branch", "path", "dendrite")


def _choice(name: str, value, allowed: tuple[str, ...]) -> str:
    if value not in allowed:
        raise ValueError(f"Expected '{name}' in {allowed}, but got {value!r}")
    return value


def _check_metric(metric, lattice) -> None:
    """Refuse an unknown ``metric``, and a ``lattice`` with the Euclidean one (which would ignore it)."""
    _choice("metric", metric, _METRICS)
    if metric == "euclidean" and lattice is not None:
        raise ValueError("'lattice' is only used with metric='path', but metric is 'euclidean'")


@dataclass(frozen=True)
class Taper:
    """A width that changes along each path: ``T = Ts (1 - u^beta) + Tf u^beta`` with ``u = d / d_max``.

    ``d`` is the path cost from where the measured stretch starts and
    ``d_max`` its value at the farthest tip reached through the node (see
    ``along``), so ``T`` goes from ``start`` to ``end``.
    """

    start: float
    """Ts: width at the start of the stretch (pixels or cost units), > 0."""
    end: float
    """Tf: width at the farthest tip, > 0."""
    beta: float = 1.0
    """Shape of the taper, > 0 (1: linear in path cost, as for the papers' lightning)."""
    along: TaperAlong = "branch"
    """What ``d`` is measured along: ``"branch"`` from where a branch leaves its parent branch
    (every side branch tapers on its own, starting again at ``start``), ``"path"`` from the root
    (the whole path from root to each tip), ``"dendrite"`` from the root with ``d_max`` the
    dendrite's largest cost. The constructive path planning paper's eq. 2 takes ``d`` as the
    path cost from the root, i.e. ``"path"`` or ``"dendrite"``; the default ``"branch"`` is
    ours (side branches as bold as their start, for pictures with a separate ``side`` taper)."""

    def __post_init__(self):
        for name in ("start", "end"):
            _width_number(name, getattr(self, name), " for Taper")
        if isinstance(self.beta, bool):
            raise TypeError(f"Expected a number for 'beta', but got {self.beta!r}")
        _checks.positive("beta", self.beta)
        _choice("along", self.along, _ALONG)

    def widths(self, d: np.ndarray, d_max: np.ndarray) -> np.ndarray:
        """Eq. 2 for path costs ``d`` and ``d_max`` (arrays of one shape); ``u`` is clipped to [0, 1]."""
        d = np.asarray(d, np.float64)
        d_max = np.asarray(d_max, np.float64)
        u = np.divide(d, d_max, out=np.zeros(np.broadcast(d, d_max).shape), where=d_max > 0)
        ub = np.clip(u, 0.0, 1.0) ** self.beta
        return self.start * (1.0 - ub) + self.end * ub


Width = float | Taper | np.ndarray

_WIDEST = 1e30
"""Largest width: widths are float32 and their squares must stay finite in float64."""


def _width_number(name: str, value, what: str = "") -> float:
    """``value`` as a width: a number > 0 that stays above 0 in float32, at most 1e30."""
    if isinstance(value, bool):
        raise TypeError(f"Expected a number for '{name}', but got {value!r}")
    x = _checks.positive(name, value)
    if x > _WIDEST or np.float32(x) == 0:
        raise ValueError(f"Expected '{name}'{what} in (0, {_WIDEST:g}] as a float32 width, but got "
                         f"{value!r}{_checks.float32_note(x)}")
    return x


def thesis_width(factor: float, a: float = 1e-4) -> float:
    """The ``T`` that makes ``exp(-(d/T)^2)`` equal the thesis' ``exp(-a (d * factor)^2)`` (Fig 4.8).

    In the thesis a larger width factor gives a *narrower* path; ``a`` is about 1/10000.
    Combine with ``brightness(..., clamp=0.7)`` for the thesis' rule that values above 0.7 become 1.
    ``d`` is the thesis' path cost on the weighted graph, so the ``T`` returned (167 for factor
    0.6) is in the lattice's cost units: pass the lattice (``brightness(..., metric="path",
    lattice=lat)``); in pixel distances it would be a halo 167 pixels wide.
    """
    factor = _checks.positive("factor", factor)
    a = _checks.positive("a", a)
    return 1.0 / (factor * math.sqrt(a))


def _check_dendrite(dendrite, what: str = "dendrite") -> Dendrite:
    if not isinstance(dendrite, Dendrite):
        raise TypeError(f"Expected a wdendrite.Dendrite for '{what}', but got {type(dendrite).__name__}")
    if len(dendrite) == 0:
        raise ValueError(f"'{what}' is empty (no nodes): there is nothing to render")
    return dendrite


def _levels(dendrite: Dendrite) -> list[np.ndarray]:
    """Rows grouped by depth, roots first."""
    rows = dendrite.order
    depth = dendrite.depth[rows]
    return np.split(rows, np.flatnonzero(np.diff(depth)) + 1)


@dataclass(frozen=True, eq=False)
class Branches:
    """A dendrite cut into branches: each node continues into the child leading to the farthest tip."""

    order: np.ndarray
    """``(N,)`` int32: 0 on the main path of every root, k + 1 on branches leaving an order-k branch."""
    start: np.ndarray
    """``(N,)`` int64 row of the first node of the node's branch (a root for order 0)."""
    attach: np.ndarray
    """``(N,)`` int64 row where the node's branch leaves its parent branch (the root for order 0)."""
    tip_cost: np.ndarray
    """``(N,)`` float64 largest path cost of an endpoint (or node) reached through the node."""


def branch_order(dendrite: Dendrite) -> Branches:
    """Split ``dendrite`` into branches (a main path per root, then side branches) and order them."""
    den = _check_dendrite(dendrite)
    n = len(den)
    cost = den.cost.astype(np.float64)
    tip = cost.copy()
    levels = _levels(den)
    for level in levels[::-1]:
        p = den.parent[level]
        ok = p >= 0
        np.maximum.at(tip, p[ok], tip[level[ok]])
    # heir of a node: its child with the farthest tip (lowest row on ties)
    child = np.flatnonzero(den.parent >= 0)
    heir = np.full(n, -1, np.int64)
    if len(child):
        keys = np.lexsort((child, -tip[child], den.parent[child]))
        ordered = child[keys]
        first = np.ones(len(ordered), bool)
        first[1:] = den.parent[ordered[1:]] != den.parent[ordered[:-1]]
        heir[den.parent[ordered[first]]] = ordered[first]
    order = np.zeros(n, np.int32)
    attach = np.arange(n, dtype=np.int64)
    start = np.arange(n, dtype=np.int64)
    for level in levels[1:]:
        p = den.parent[level]
        starts = heir[p] != level
        order[level] = order[p] + starts.astype(np.int32)
        attach[level] = np.where(starts, p, attach[p])
        start[level] = np.where(starts, level, start[p])
    return Branches(order=order, start=start, attach=attach, tip_cost=tip)


def _taper_widths(den: Dendrite, br: Branches, taper: Taper) -> np.ndarray:
    cost = den.cost.astype(np.float64)
    if taper.along == "branch":
        base = cost[br.attach]
        d, d_max = cost - base, br.tip_cost - base
    elif taper.along == "path":
        base = cost[den.roots].min() if len(den.roots) else 0.0
        d, d_max = cost - base, br.tip_cost - base
    else:
        d, d_max = cost, np.full(len(den), cost.max())
    return taper.widths(d, d_max)


def _lerp(start: np.ndarray, taper: Taper, d: np.ndarray, d_max: np.ndarray) -> np.ndarray:
    u = np.divide(d, d_max, out=np.zeros(len(d)), where=d_max > 0)
    ub = np.clip(u, 0.0, 1.0) ** taper.beta
    return start * (1.0 - ub) + np.minimum(taper.end, start) * ub


def _width_values(name: str, width, den: Dendrite, br: Branches) -> np.ndarray:
    """Widths of all nodes from a float, a Taper or an (N,) array."""
    if isinstance(width, Taper):
        return _taper_widths(den, br, width)
    if np.ndim(width) == 0:
        return np.full(len(den), _width_number(name, width))
    values = _checks.float_array(name, width, (len(den),), positive=True).astype(np.float64)
    wide = np.flatnonzero(values > _WIDEST)
    if wide.size:
        raise ValueError(f"Expected every '{name}' in (0, {_WIDEST:g}] as a float32 width, but got "
                         f"{values[wide[0]]:g} at index {int(wide[0])} ({wide.size} above {_WIDEST:g})")
    return values


def node_widths(dendrite: Dendrite, width: Width = 5.0, *, side: Width | None = None, _name: str = "width") -> np.ndarray:
    """The width ``T`` of every node of ``dendrite``.

    Args:
        dendrite: a non-empty :class:`~wdendrite.Dendrite`.
        width: a constant ``T`` > 0, a :class:`Taper`, or an ``(N,)`` array of positive widths.
        side: optional width of the side branches (order >= 1 in :func:`branch_order`);
            ``width`` then applies to the main paths only. A side :class:`Taper` with
            ``along="branch"`` starts no wider than its parent branch where it leaves it.

    Returns:
        ``(N,)`` float32 widths, > 0.

    Raises:
        ValueError: a non-positive width, a bad Taper, an empty dendrite.
    """
    den = _check_dendrite(dendrite)
    needs_branches = side is not None or isinstance(width, Taper)
    br = branch_order(den) if needs_branches else None
    out = _width_values(_name, width, den, br)
    if side is None:
        return out.astype(np.float32)
    if not isinstance(side, Taper):
        side_w = _width_values("side", side, den, br)
        out = np.where(br.order > 0, side_w, out)
        return out.astype(np.float32)
    cost = den.cost.astype(np.float64)
    for k in range(1, int(br.order.max()) + 1):
        rows = np.flatnonzero(br.order == k)
        if side.along == "branch":
            # a side branch starts at most as wide as its parent branch where it leaves it
            start = np.minimum(side.start, out[br.attach[rows]])
            base = cost[br.attach[rows]]
            out[rows] = _lerp(start, side, cost[rows] - base, br.tip_cost[rows] - base)
        else:
            out[rows] = _taper_widths(den, br, side)[rows]
    return out.astype(np.float32)


def _splat(nodes: np.ndarray, shape: tuple, reach: float, device, metric: str = "euclidean") -> wp.array:
    """Packed ``(distance, source row)`` words of every cell within ``reach`` of a node (flat).

    ``metric="path"`` is the path length on a unit-weight lattice (8- or 26-connected, no
    mask), which has a closed form, so no search is needed.
    """
    device = _checks.device(device)
    n = int(np.prod(shape))
    nodes3 = np.zeros((len(nodes), 3), np.int32)
    nodes3[:, 3 - len(shape):] = nodes
    shape3 = (1,) * (3 - len(shape)) + tuple(shape)
    with wp.ScopedDevice(device):
        packed = wp.full(n, value=wp.uint64(0xFFFFFFFFFFFFFFFF), dtype=wp.uint64)
        wp.launch(_k.splat_distance_kernel, dim=len(nodes),
                  inputs=[wp.array(nodes3, dtype=wp.vec3i), wp.vec3i(*shape3), float(reach),
                          _k.METRIC_EUCLIDEAN if metric == "euclidean" else _k.METRIC_LATTICE],
                  outputs=[packed])
    return packed


def _path_costs(nodes: np.ndarray, shape: tuple, reach: float, lattice: Lattice, device):
    """Least path costs (flat) from ``nodes`` over ``lattice`` up to ``reach``, and the nearest source's index."""
    if not isinstance(lattice, Lattice):
        raise TypeError(f"Expected a wdendrite.Lattice for 'lattice', but got {type(lattice).__name__}")
    if lattice.shape != shape:
        raise ValueError(f"'lattice' has shape {lattice.shape}, but the dendrite has shape {shape}")
    cf = shortest_paths(lattice, nodes, limit=reach, device=device)
    return cf.dist_array.flatten(), cf.label_array.flatten()


def _nearest(dendrite: Dendrite, reach_cost: float, metric: str, lattice: Lattice | None, rows, device):
    """Distance to the nearest source node and the source's index (into ``rows``, or the dendrite) as flat arrays."""
    nodes = dendrite.nodes if rows is None else dendrite.nodes[rows]
    shape = tuple(dendrite.shape)
    if metric == "path" and lattice is not None:
        return _path_costs(nodes, shape, reach_cost, lattice, device)
    packed = _splat(nodes, shape, reach_cost, device, metric)
    n = packed.shape[0]
    with wp.ScopedDevice(packed.device):
        dist = wp.empty(n, dtype=float)
        label = wp.empty(n, dtype=wp.int32)
        wp.launch(_k.unpack_nearest_kernel, dim=n, inputs=[packed], outputs=[dist, label])
    return dist, label


def _check_rows(rows, n: int):
    if rows is None:
        return None
    r = np.asarray(rows)
    if r.size == 0:  # (an empty list is a float array)
        raise ValueError("'rows' is empty: at least one node must be rendered")
    if r.dtype == np.bool_:
        if r.shape != (n,):
            raise ValueError(f"Expected a bool 'rows' mask of shape ({n},), but got shape {r.shape}")
        r = np.flatnonzero(r)
    if r.dtype.kind not in "iu" or r.ndim != 1:
        raise TypeError(f"Expected 'rows' as a 1D integer array or bool mask, but got {r.dtype} {r.shape}")
    if len(r) == 0:
        raise ValueError("'rows' selects no node: at least one node must be rendered")
    if r.min() < 0 or r.max() >= n:
        raise ValueError(f"'rows' must index the dendrite's {n} nodes, but has values in [{r.min()}, {r.max()}]")
    return r.astype(np.int64)


def distance_field(
    dendrite: Dendrite,
    *,
    limit: float,
    metric: Metric = "euclidean",
    lattice: Lattice | None = None,
    rows=None,
    device=None,
) -> tuple[np.ndarray, np.ndarray]:
    """Distance from every lattice node to the nearest dendrite node, up to ``limit``.

    Args:
        dendrite: a non-empty dendrite (2D or 3D).
        limit: largest distance searched (lattice units or path cost), > 0.
        metric: ``"euclidean"`` (straight-line distance to the nearest node) or
            ``"path"`` (least path cost over ``lattice``).
        lattice: the lattice for ``metric="path"`` (default: unit weights, 8- or
            26-connected, without a search: the octile distance in closed form).
        rows: only these dendrite rows (int array or ``(N,)`` bool mask) act as sources.
        device: Warp device (default: Warp's default device).

    Returns:
        ``(dist, label)`` of the dendrite's shape: float32 distance (inf beyond
        ``limit``) and int32 row of the nearest node (-1 beyond ``limit``).
    """
    den = _check_dendrite(dendrite)
    limit = _checks.positive("limit", limit)
    _check_metric(metric, lattice)
    sel = _check_rows(rows, len(den))
    dist, label = _nearest(den, limit, metric, lattice, sel, device)
    lab = label.numpy().reshape(den.shape)
    if sel is not None:
        lab = np.where(lab >= 0, sel[np.maximum(lab, 0)], -1).astype(np.int32)
    return dist.numpy().reshape(den.shape), lab


def brightness(
    dendrite: Dendrite,
    width: Width = 5.0,
    *,
    side: Width | None = None,
    metric: Metric = "path",
    lattice: Lattice | None = None,
    reach: float = 3.0,
    clamp: float | None = None,
    rows=None,
    device=None,
    as_warp: bool = False,
) -> np.ndarray | wp.array:
    """The papers' lightning brightness ``V = exp(-(d/T)^2)`` of a 2D dendrite.

    Args:
        dendrite: a non-empty 2D dendrite.
        width: ``T`` of every node: a constant > 0 (the papers' 5.0 or 1.6), a
            :class:`Taper` or an ``(N,)`` array (see :func:`node_widths`).
        side: optional width of side branches (see :func:`node_widths`).
        metric: ``"path"`` (path cost from the dendrite over ``lattice``, as in the
            papers) or ``"euclidean"`` (straight-line distance to the nearest node).
        lattice: lattice of the path costs, searched with
            :func:`~wdendrite.shortest_paths` (default: unit weights, 8-connected,
            in closed form). Pass the dendrite's own weighted lattice for ragged
            halos; widths are then in its cost units.
        reach: the search stops at ``reach * max(T)`` and a pixel is dark beyond
            ``reach * T`` of its node (3: V < 1.3e-4 there), > 0.
        clamp: values above it become 1 (the thesis uses 0.7), in (0, 1]; None: no clamp.
        rows: render only these dendrite rows (int array or bool mask).
        device: Warp device (default: Warp's default device).
        as_warp: return the image as the ``wp.array`` on the device that the kernels wrote (no
            copy to the host: for pipelines that continue on a GPU).

    Returns:
        ``(H, W)`` float32 brightness in [0, 1]: a NumPy array, or with ``as_warp`` a
        ``wp.array2d(dtype=float)`` on the device.

    Raises:
        ValueError: an empty or 3D dendrite, a non-positive width or reach,
            ``clamp`` outside (0, 1], an unknown metric, a ``lattice`` with the Euclidean metric.
    """
    den = _check_dendrite(dendrite)
    if den.ndim != 2:
        raise ValueError(f"brightness() renders 2D dendrites, but the dendrite has shape {den.shape}; "
                         "use wdendrite.geometry for 3D")
    reach = _checks.positive("reach", reach)
    as_warp = _checks.flag("as_warp", as_warp)
    if clamp is None:
        clamp_f = 2.0
    else:
        clamp_f = _checks.positive("clamp", clamp)
        if clamp_f > 1:
            raise ValueError(f"Expected 'clamp' in (0, 1], but got {clamp!r}")
    _check_metric(metric, lattice)
    widths = node_widths(den, width, side=side)
    sel = _check_rows(rows, len(den))
    nodes, w = (den.nodes, widths) if sel is None else (den.nodes[sel], widths[sel])
    reach_cost = reach * float(w.max())
    if metric == "path" and lattice is not None:
        dist, label = _path_costs(nodes, tuple(den.shape), reach_cost, lattice, device)
        device = dist.device
        out = wp.empty(dist.shape[0], dtype=float, device=device)
        wp.launch(_k.brightness_kernel, dim=dist.shape[0],
                  inputs=[dist, label, wp.array(w, dtype=float, device=device), reach, clamp_f],
                  outputs=[out], device=device)
    else:
        packed = _splat(nodes, tuple(den.shape), reach_cost, device, metric)
        device = packed.device
        out = wp.empty(packed.shape[0], dtype=float, device=device)
        wp.launch(_k.brightness_packed_kernel, dim=packed.shape[0],
                  inputs=[packed, wp.array(w, dtype=float, device=device), reach, clamp_f],
                  outputs=[out], device=device)
    return out.reshape(den.shape) if as_warp else out.numpy().reshape(den.shape)


def strokes(dendrite: Dendrite, width: Width = 1.5, *, ink=None, device=None) -> np.ndarray:
    """An antialiased line drawing of a 2D dendrite: each edge (node to parent) a round-capped stroke.

    A pixel's value is the largest ``ink * coverage`` over the strokes, with :func:`coverage` of
    the distance from the pixel's centre to the edge and the width there: summed across a stroke
    it gives the stroke's width at any slope, so lines keep an even weight instead of the stair
    steps of lit lattice nodes; a stroke 1 pixel wide peaks at 0.73, one 2.5 wide at 0.995.

    Args:
        dendrite: a non-empty 2D dendrite; its nodes are pixel centres (row, column).
        width: full stroke width of every node, in pixels: a constant > 0, a :class:`Taper` or
            an ``(N,)`` array (see :func:`node_widths`); along an edge the width goes linearly from
            the node's to its parent's. A root alone draws a dot of its width.
        ink: optional ``(N,)`` values in [0, 1], the strength of each node's edge (default 1).
        device: Warp device (default: Warp's default device).

    Returns:
        ``(H, W)`` float32 in [0, 1].

    Raises:
        ValueError: an empty or 3D dendrite, a non-positive width, ``ink`` of another length or outside [0, 1].
    """
    den = _check_dendrite(dendrite)
    if den.ndim != 2:
        raise ValueError(f"strokes() draws 2D dendrites, but the dendrite has shape {den.shape}")
    radii = 0.5 * node_widths(den, width).astype(np.float64)
    if ink is None:
        ink_v = np.ones(len(den), np.float32)
    else:
        ink_v = _checks.float_array("ink", ink, (len(den),)).astype(np.float32)
        if ink_v.size and not (ink_v.min() >= 0.0 and ink_v.max() <= 1.0):
            raise ValueError(f"Expected every 'ink' value in [0, 1], but got values in [{ink_v.min():g}, "
                             f"{ink_v.max():g}]")
    # a stroke wider than the image's diagonal covers it all: wider ones draw the same
    radii = np.minimum(radii, float(np.hypot(*den.shape)) + 1.0)
    parent = np.where(den.parent >= 0, den.parent, np.arange(len(den)))
    start = den.nodes.astype(np.float32)
    device = _checks.device(device)
    h, w = den.shape
    with wp.ScopedDevice(device):
        out = wp.zeros(h * w, dtype=float)
        wp.launch(_k.stroke_kernel, dim=len(den),
                  inputs=[wp.array(start, dtype=wp.vec2), wp.array(start[parent], dtype=wp.vec2),
                          wp.array(np.stack([radii, radii[parent]], 1).astype(np.float32), dtype=wp.vec2),
                          wp.array(ink_v, dtype=float), STROKE_SIGMA, h, w],
                  outputs=[out])
        return out.numpy().reshape(h, w)


STROKE_SIGMA = 0.45
"""Standard deviation (pixels) of the Gaussian pixel filter :func:`strokes` and :func:`coverage` see strokes through."""


def coverage(distance, width: float) -> np.ndarray:
    """How much of each pixel a stroke ``width`` pixels wide covers, from the distance (pixels) of the
    pixel's centre to the stroke's centre line, seen through the Gaussian pixel filter of
    :func:`strokes`: ``(erf((r - d) / (s sqrt 2)) + erf((r + d) / (s sqrt 2))) / 2`` with ``r = width / 2``
    and ``s`` = :data:`STROKE_SIGMA`. Summed across a straight stroke it gives ``width`` at any slope.

    Args:
        distance: array of distances >= 0 in pixels (+inf: no stroke in reach, coverage 0).
        width: stroke width in pixels, > 0.

    Returns:
        float32 array of ``distance``'s shape, in [0, 1].

    Raises:
        ValueError, TypeError: a negative or NaN distance, a non-positive width.
    """
    from scipy.special import erf

    width = _width_number("width", width)
    d = np.asarray(distance, np.float64)
    if d.dtype.kind not in "f" or np.isnan(d).any() or (d < 0).any():
        raise ValueError("Expected 'distance' as distances >= 0 (inf for none in reach), without NaN")
    k = 1.0 / (STROKE_SIGMA * math.sqrt(2.0))
    r = 0.5 * width
    with np.errstate(invalid="ignore"):
        out = 0.5 * (erf((r - d) * k) + erf((r + d) * k))
    return np.where(np.isfinite(d), out, 0.0).astype(np.float32)


def _image(name: str, value) -> np.ndarray:
    return _checks.finite_array(name, value, "2D (H, W)", lambda s: len(s) == 2)


def _rgb_triple(name: str, value) -> np.ndarray:
    return _checks.finite_array(name, value, "RGB triple (3,)", lambda s: s == (3,))


Blend = Literal["max", "add", "screen"]
_BLENDS = ("max", "add", "screen")


def composite(layers: Sequence[np.ndarray], *, mode: Blend = "max", gains: Sequence[float] | None = None) -> np.ndarray:
    """Combine brightness images of several graphs (the papers' main stroke plus forks).

    Args:
        layers: ``(H, W)`` images of one shape, values in [0, 1] (each layer, times its gain, is clipped to it).
        mode: ``"max"`` (the brighter wins), ``"add"`` (sum, clipped to 1) or
            ``"screen"`` (``1 - prod(1 - v)``, light adding up without clipping).
        gains: a factor per layer (default 1 each), >= 0.

    Returns:
        ``(H, W)`` float32 in [0, 1].

    Raises:
        ValueError: no layers, an empty, non-finite or mismatched layer, a negative gain, an unknown mode.
    """
    _choice("mode", mode, _BLENDS)
    imgs = [_image(f"layers[{i}]", v) for i, v in enumerate(layers)]
    if not imgs:
        raise ValueError("'layers' is empty: at least one image is needed")
    for i, v in enumerate(imgs[1:], 1):
        if v.shape != imgs[0].shape:
            raise ValueError(f"'layers[{i}]' has shape {v.shape}, but 'layers[0]' has shape {imgs[0].shape}")
    if gains is not None and (isinstance(gains, (str, bytes)) or np.ndim(gains) != 1):
        raise TypeError(f"Expected 'gains' as a sequence of numbers, one per layer, but got {gains!r}")
    g = [1.0] * len(imgs) if gains is None else [_checks.nonnegative(f"gains[{i}]", x, allow_none=False)
                                                  for i, x in enumerate(gains)]
    if len(g) != len(imgs):
        raise ValueError(f"Expected {len(imgs)} 'gains', one per layer, but got {len(g)}")
    # the CPU device named on every array (a scope would change the default for every thread)
    # the first layer enters as a blend over black, so every layer is scaled and clipped alike
    acc = wp.zeros(imgs[0].size, dtype=float, device="cpu")
    for v, gi in zip(imgs, g):
        wp.launch(_k.blend_kernel, dim=acc.shape[0],
                  inputs=[acc, wp.array(v.ravel(), dtype=float, device="cpu"), float(gi), _BLENDS.index(mode)],
                  outputs=[acc], device="cpu")
    out = acc.numpy().reshape(imgs[0].shape)
    return out.astype(np.float32)


MAX_GLOW_PASSES = 64
"""Most box filters :func:`glow` runs per axis: three (the default) already come close to a
Gaussian, and each pass sweeps the whole image twice, so more only cost time."""


def glow(value: np.ndarray, *, radius: float = 12.0, passes: int = 3, device=None) -> np.ndarray:
    """A soft halo: ``value`` blurred by ``passes`` box filters (close to a Gaussian of sigma ~ ``radius``).

    Args:
        value: ``(H, W)`` brightness.
        radius: blur scale in pixels, > 0 (box half-width ``radius * sqrt(3 / passes)``); radii
            beyond four image diagonals (times ``sqrt(passes)``) blur as that one does, to a near-even glow.
        passes: box filters per axis, in [1, :data:`MAX_GLOW_PASSES`].
        device: Warp device (default: Warp's default device).

    Returns:
        ``(H, W)`` float32; the blur keeps the image's total (away from its edges).

    Raises:
        ValueError: an empty, non-2D or non-finite ``value``, a non-positive ``radius``, ``passes``
            outside [1, :data:`MAX_GLOW_PASSES`] (before any kernel runs).
        TypeError: a ``value`` that is not real-valued.
    """
    img = _image("value", value)
    radius = _checks.positive("radius", radius)
    if isinstance(passes, bool) or not isinstance(passes, (int, np.integer)) or passes < 1:
        raise ValueError(f"Expected an integer 'passes' >= 1, but got {passes!r}")
    if passes > MAX_GLOW_PASSES:  # each pass sweeps the whole image twice
        raise ValueError(f"Expected 'passes' <= {MAX_GLOW_PASSES}, but got {passes!r}")
    # a blur much wider than the image spreads it evenly: no wider box changes the result's look
    radius = min(radius, 4.0 * float(np.hypot(*img.shape)) * math.sqrt(passes))
    # a box of half-width h has variance h (h + 1) / 3; pick h so the passes add up to radius^2
    half = max(1, int(round(0.5 * (math.sqrt(1.0 + 12.0 * radius * radius / passes) - 1.0))))
    device = _checks.device(device)
    h, w = img.shape
    # kernels take rows four at a time and columns as vec4 groups: a buffer of whole groups
    # (padding zeros, never read into the image), its rows a few floats longer than the image
    # so that column sweeps over power-of-two strides do not keep evicting each other from the caches
    rows = -(-h // 4) * 4
    stride = -(-w // 4) * 4 + 8
    buf = np.zeros((rows, stride), np.float32)
    buf[:h, :w] = img
    with wp.ScopedDevice(device):
        a = wp.array(buf, dtype=float)
        b = wp.zeros_like(a)
        a4, b4 = (wp.array(ptr=x.ptr, dtype=wp.vec4, shape=(rows, stride // 4), device=device) for x in (a, b))
        for _ in range(passes):
            wp.launch(_k.box_blur_rows_kernel, dim=rows // 4, inputs=[a, w, half], outputs=[b])
            wp.launch(_k.box_blur_cols_kernel, dim=stride // 4, inputs=[b4, h, half], outputs=[a4])
        return np.ascontiguousarray(a.numpy()[:h, :w])


COLORMAPS: dict[str, tuple[tuple[float, float, float], ...]] = {
    "grey": ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)),
    "lightning": ((0.0, 0.0, 0.0), (0.28, 0.22, 0.62), (0.62, 0.62, 1.0), (1.0, 1.0, 1.0)),
    "fire": ((0.0, 0.0, 0.0), (0.6, 0.05, 0.0), (1.0, 0.55, 0.0), (1.0, 1.0, 0.75)),
    "ice": ((0.0, 0.0, 0.0), (0.05, 0.25, 0.45), (0.45, 0.8, 0.95), (1.0, 1.0, 1.0)),
    "moss": ((0.0, 0.0, 0.0), (0.1, 0.25, 0.05), (0.4, 0.6, 0.15), (0.85, 0.9, 0.45)),
    "lichen": ((0.0, 0.0, 0.0), (0.35, 0.4, 0.25), (0.7, 0.75, 0.5), (0.95, 0.95, 0.8)),
}
"""Colour maps from dark (V = 0) to bright (V = 1), as evenly spaced RGB stops in [0, 1]."""


_LUT_SIZE = 256  # colours sampled from a callable or a Matplotlib colormap, evenly spaced over [0, 1]


def _stops_lut(stops: np.ndarray, size: int = _LUT_SIZE) -> np.ndarray:
    x = np.linspace(0.0, 1.0, len(stops))
    t = np.linspace(0.0, 1.0, size)
    return np.stack([np.interp(t, x, stops[:, c]) for c in range(3)], axis=1).astype(np.float32)


def _colours(value, rows: int | None = None) -> np.ndarray:
    """``value`` (for ``colormap``) as an (n, 3) float32 array of colours in [0, 1]; ``rows``: the
    (rows, 3|4) colours a callable returned for as many values (their alpha dropped)."""
    shapes = f"({rows}, 3) or ({rows}, 4) (returned by the callable)" if rows else "(N, 3)"
    arr = _checks.finite_array("colormap", value, shapes, lambda s: len(s) == 2 and s[1] in ((3, 4) if rows else (3,))
                               and (rows is None or s[0] == rows))[:, :3]
    if arr.min() < 0 or arr.max() > 1:
        raise ValueError(f"Expected the colours of 'colormap' in [0, 1], but they span [{arr.min():.6g}, "
                         f"{arr.max():.6g}]")
    return np.ascontiguousarray(arr)


def _matplotlib_lut(name: str) -> np.ndarray:
    try:
        import matplotlib  # (optional, and slow to import: only for a name of its own)
    except ImportError:
        raise ValueError(f"Expected 'colormap' in {tuple(COLORMAPS)} (other names are Matplotlib's colormaps, and "
                         f"Matplotlib is not installed), but got {name!r}") from None
    try:
        cmap = matplotlib.colormaps[name]
    except KeyError:
        raise ValueError(f"Expected 'colormap' in {tuple(COLORMAPS)} or a Matplotlib colormap name, but got "
                         f"{name!r}") from None
    return _colours(cmap(np.linspace(0.0, 1.0, _LUT_SIZE)), _LUT_SIZE)


def _lut(colormap) -> np.ndarray:
    """The (n >= 2, 3) float32 colours at evenly spaced values from 0 to 1 that ``colormap`` names (see
    :func:`colorize`); raises before any work when it names none."""
    if isinstance(colormap, str):
        if colormap in COLORMAPS:
            return _stops_lut(np.asarray(COLORMAPS[colormap], np.float64))
        return _matplotlib_lut(colormap)
    if callable(colormap):
        t = np.linspace(0.0, 1.0, _LUT_SIZE)
        try:
            colours = colormap(t)
        except Exception as exc:  # (any failure of the user's function, named as the parameter's)
            raise ValueError(f"'colormap' {colormap!r} failed on {_LUT_SIZE} values from 0 to 1: {exc!r}") from exc
        return _colours(colours, _LUT_SIZE)
    if isinstance(colormap, (np.ndarray, list, tuple)):
        stops = _colours(colormap)
        return stops if len(stops) >= 2 else np.repeat(stops, 2, axis=0)  # (one colour: every value gets it)
    raise TypeError(f"Expected 'colormap' as a name (one of {tuple(COLORMAPS)} or a Matplotlib colormap's), a "
                    f"callable or an (N, 3) array of colours, but got {type(colormap).__name__}")


def _rgb(name: str, value, shape) -> np.ndarray:
    arr = _checks.finite_array(name, value, f"RGB triple (3,) or image {(*shape, 3)}", lambda s: s in ((3,), (*shape, 3)))
    return np.broadcast_to(arr, (*shape, 3)).copy() if arr.shape == (3,) else arr


def colorize(
    value: np.ndarray,
    *,
    colormap: str | Callable[[np.ndarray], np.ndarray] | np.ndarray = "lightning",
    glow: np.ndarray | None = None,
    glow_color: tuple[float, float, float] = (0.45, 0.4, 1.0),
    background=None,
    device=None,
) -> np.ndarray:
    """An RGB picture: ``background + colormap(value) + glow * glow_color``, clipped to [0, 1].

    Light adds up, as for lightning over a sky. The colour maps start from
    black, so with the default black background the picture is ``colormap(value)``.

    Args:
        value: ``(H, W)`` brightness in [0, 1] (others are clipped to it).
        colormap: a name of :data:`COLORMAPS`; any other name is a Matplotlib colormap's (when
            Matplotlib is installed; ``"viridis"``, ``"magma_r"``...); a callable taking an
            ``(n,)`` float64 array of values in [0, 1] and returning their ``(n, 3)`` or ``(n, 4)``
            colours in [0, 1] (a Matplotlib ``Colormap`` is one; alpha is ignored), sampled at
            256 evenly spaced values; or an ``(N, 3)`` array of colours in [0, 1] at evenly
            spaced values from 0 to 1. Colours between samples are interpolated linearly.
        glow: optional ``(H, W)`` halo (e.g. from :func:`glow`).
        glow_color: RGB of the halo in [0, 1].
        background: an RGB triple or an ``(H, W, 3)`` image in [0, 1] (default black).
        device: Warp device (default: Warp's default device).

    Returns:
        ``(H, W, 3)`` float32 in [0, 1].

    Raises:
        ValueError: an empty, non-2D or non-finite ``value`` or ``glow``, a bad colour, an unknown
            colormap name (or any name beyond :data:`COLORMAPS` without Matplotlib), a callable
            that fails or returns no ``(256, 3|4)`` colours in [0, 1], an array of colours that is
            not ``(N, 3)`` in [0, 1].
        TypeError: a ``colormap`` that is neither a name, a callable nor an array; colours that are
            not numbers.
    """
    img = _image("value", value)
    lut = _lut(colormap)
    halo = np.zeros_like(img) if glow is None else _image("glow", glow)
    if halo.shape != img.shape:
        raise ValueError(f"'glow' has shape {halo.shape}, but 'value' has shape {img.shape}")
    gc = _rgb_triple("glow_color", glow_color)
    bg = _rgb("background", (0.0, 0.0, 0.0) if background is None else background, img.shape)
    device = _checks.device(device)
    with wp.ScopedDevice(device):
        out = wp.empty(img.shape, dtype=wp.vec3)
        wp.launch(_k.colorize_kernel, dim=img.shape,
                  inputs=[wp.array(img, dtype=float), wp.array(halo, dtype=float),
                          wp.array(lut, dtype=wp.vec3), wp.vec3(*gc.tolist()),
                          wp.array(bg, dtype=wp.vec3)],
                  outputs=[out])
        return out.numpy()


def unit_range(a: np.ndarray) -> np.ndarray:
    """``a`` scaled from its finite minimum to its maximum onto [0, 1] (non-finite values: 0)."""
    a = np.asarray(a, np.float64)
    ok = np.isfinite(a)
    if not ok.any():
        return np.zeros(a.shape)
    lo, hi = a[ok].min(), a[ok].max()
    if hi / 2.0 - lo / 2.0 > np.finfo(np.float64).max / 2.0:  # a span float64 cannot hold: halve everything first
        a, lo, hi = a / 2.0, lo / 2.0, hi / 2.0
    return np.where(ok, (a - lo) / (hi - lo) if hi > lo else 0.0, 0.0)


def relief(z, spacing: float, area=None, *, device=None, workers: int | None = None) -> np.ndarray:
    """Hillshade (light from the north-west) over a green-brown-white elevation tint, rivers in blue.

    Slopes are central differences (one-sided on the border), as ``numpy.gradient``; the tint
    goes from green-brown at the lowest elevation through brown at 60 % of the range to white.

    Args:
        z: (H, W) finite elevation, H and W at least 2.
        spacing: pixel side in the elevation's units (domain units per pixel), > 0.
        area: optional (H, W) drainage area in cells
            (:func:`wdendrite.hydrology.flow_accumulation`): blue where more than 0.1 % of the
            image drains through a cell, full at 2 %.
        device: Warp device of the shading kernel (default: Warp's default device).
        workers: CPU threads that shade bands of rows at once (None: every core); on CUDA one
            launch. The picture does not depend on it.

    Returns:
        (H, W, 3) float32 picture in [0, 1].

    Raises:
        ValueError, TypeError: ``z`` not a finite 2D real array of at least 2 x 2, ``spacing``
            not positive, ``area`` not positive and finite or not of ``z``'s shape, an absent
            device, bad ``workers``.
    """
    z = _checks.finite_array("z", z, "2D (H >= 2, W >= 2)", lambda s: len(s) == 2 and min(s) >= 2, dtype=np.float64)
    spacing = _checks.positive("spacing", spacing)
    if area is not None:
        area = _checks.float_array("area", area, z.shape, positive=True)
    device = _checks.device(device)
    workers = _parallel.workers(workers)
    span = float(z.max() - z.min())
    t = unit_range(z).astype(np.float32)
    # slopes are gain x differences of t; beyond 1e18 the light sees vertical walls either way (and
    # float32 squares of such slopes stay finite)
    gain = min(span / spacing, 1e18)
    light = wp.vec3(*(np.array([-1.0, -1.0, 1.5]) / np.linalg.norm([-1.0, -1.0, 1.5])))
    h = z.shape[0]
    out = np.empty((*z.shape, 3), np.float32)

    def shade(band) -> None:  # rows band[0]..band[1] - 1, from them and one more row on either side
        lo, hi = max(band[0] - 1, 0), min(band[1] + 1, h)  # (central differences reach one row)
        rows = wp.empty((hi - lo, z.shape[1]), dtype=wp.vec3, device=device)
        wp.launch(_k.relief_kernel, dim=rows.shape,
                  inputs=[wp.array(t[lo:hi], dtype=float, device=device), gain, light,
                          wp.array(area[lo:hi] if area is not None else np.ones((0, 0), np.float32), dtype=float,
                                   device=device),
                          0.001 * z.size, wp.vec3(0.12, 0.3, 0.85)],
                  outputs=[rows], device=device)
        out[band[0] : band[1]] = rows.numpy()[band[0] - lo : band[1] - lo]

    bands = [(0, h)] if device.is_cuda else _parallel.image_bands(z.shape, workers)
    _parallel.each(shade, bands, workers)
    return out


DENDRY_WIDENING = 1.4
"""How much wider :func:`dendry_lines` draws each level of a Dendry tree than the next finer level."""


def _dendry_widths(params, pixel: float) -> list[float]:
    """Line widths (pixels) of levels 1..n at ``pixel`` domain units a pixel: the finest level an
    eighth of its cell wide, within [1, 1.5] pixels, each coarser one :data:`DENDRY_WIDENING` wider."""
    finest_cell = 1.0 / (params.resolution * 2.0 ** (params.levels - 1) * pixel)
    fine = float(np.clip(finest_cell / 8.0, 1.0, 1.5))
    return [fine * DENDRY_WIDENING ** (params.levels - k) for k in range(1, params.levels + 1)]


def dendry_lines(shape, *, domain, params, control=None, widths=None, distance=None, device=None,
                 workers: int | None = None) -> np.ndarray:
    """A Dendry tree drawn as antialiased lines, each level at its own width (a Lichtenberg figure, rivers).

    The tree grows level by level, each level adding branches to the coarser ones, so the distance
    to its levels 1..k is :func:`wdendrite.dendry`'s distance with ``params`` cut to k levels. A pixel
    takes the most that one level's lines cover of it: the :func:`coverage` of a stroke of that
    level's width at the pixel's distance to the level's tree (the pixel filter of :func:`strokes`).

    Args:
        shape, domain, params, control, device: as :func:`wdendrite.dendry` takes them (its
            ``output`` is the distance). The pixel's side is the domain's width over ``W``.
        widths: line width of each level, 1 to n, in pixels (default: the finest level an eighth of
            its cell wide, within [1, 1.5] pixels, each coarser level :data:`DENDRY_WIDENING` wider).
        distance: the ``(H, W)`` distance to the whole tree when it is already computed (saves one
            evaluation of the finest level).
        workers: CPU threads (None: every core), as :func:`wdendrite.dendry` takes them; the
            coverage is computed in bands of rows by as many threads. The values do not depend on it.

    Returns:
        ``(H, W)`` float32 coverage: 1 on a branch, 0 away from every branch (draw ink on paper
        as ``1 - value``, or light with :func:`colorize`).

    Raises:
        ValueError, TypeError: what :func:`wdendrite.dendry` refuses; ``widths`` not one positive width per
            level; a ``distance`` of another shape; bad ``workers`` (before any evaluation).
    """
    import dataclasses

    from .dendry import DendryParams, dendry

    if not isinstance(params, DendryParams):
        raise TypeError(f"Expected a DendryParams for 'params', but got {type(params).__name__}")
    (x0, _), (x1, _) = domain
    pixel = (float(x1) - float(x0)) / int(shape[1])
    if widths is None:
        widths = _dendry_widths(params, pixel)
    if np.ndim(widths) != 1 or len(widths) != params.levels:
        raise ValueError(f"Expected 'widths' as one width per level ({params.levels}), but got {widths!r}")
    widths = [_width_number(f"widths[{i}]", w) for i, w in enumerate(widths)]
    if distance is not None and np.shape(distance) != tuple(shape):
        raise ValueError(f"'distance' has shape {np.shape(distance)}, but 'shape' is {tuple(shape)}")
    workers = _parallel.workers(workers)
    cover = np.zeros(tuple(shape), np.float32)
    bands = _parallel.image_bands(cover.shape, workers)
    for k, width in enumerate(widths, 1):
        if k == params.levels and distance is not None:
            d = np.asarray(distance)
        else:  # the tree of levels 1..k (per-level tuples cut alike)
            cut = {n: getattr(params, n)[:k] for n in ("eps", "delta") if isinstance(getattr(params, n), tuple)}
            d = dendry(shape, domain=domain, params=dataclasses.replace(params, levels=k, **cut), control=control,
                       output="distance", device=device, workers=workers)

        def cover_band(band, d=d, width=width):  # (+inf: no branch in reach, no cover)
            rows = slice(*band)
            np.maximum(cover[rows], coverage(d[rows] / pixel, width), out=cover[rows])

        _parallel.each(cover_band, bands, workers)  # (NumPy's and SciPy's loops run without the interpreter lock)
    return cover


from ._spec import document_fields as _document_fields  # noqa: E402  (the classes above are complete)

_document_fields(__name__)  # help() shows what each dataclass field means
