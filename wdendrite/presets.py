"""The papers' models, one call each (Xu & Mould 2007, constructive path planning, Xu 2008 thesis).

Every preset is seeded, uses the papers' parameters by default (lattice
sizes included), takes smaller sizes for quick runs, and returns a
:class:`Result` holding the data and a picture::

    res = wd.presets.lightning(seed=3)
    wd.io.save_png("lightning.png", res.image)
    res = wd.presets.elm_tree(shape=(40, 40, 40))
    wd.io.save_mesh("elm.glb", res.mesh)

Pictures of 2D models are ``(H, W, 3)`` float images (ink on paper, or
light on a night sky); pictures of 3D models are ray-cast previews.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from . import _checks
from . import endpoints as _ep
from . import figure as _fig
from . import geometry as _geo
from . import render as _r
from . import weights as _w
from .dendrite import Dendrite, trace
from .growth import FractalParams, grow
from .lattice import Lattice
from .refine import _check_n_e, refine
from .sssp import shortest_paths

__all__ = [
    "LightningParams",
    "Result",
    "competition",
    "dla_imitation",
    "elm_tree",
    "fractal_grid",
    "letters",
    "lichen_on_rock",
    "lightning",
    "moss",
    "rock",
    "simple_dendrite",
    "staghorn_coral",
    "taper_demo",
    "tropism_objects",
    "tropisms",
    "weight_distributions",
    "width_demo",
]

_PAPER = (1.0, 1.0, 1.0)
_ROCK = (0.62, 0.6, 0.57)
_LICHEN = (0.78, 0.74, 0.32)
_MOSS = (0.35, 0.55, 0.18)
_WOOD = (0.55, 0.45, 0.33)
_CORAL = (0.93, 0.72, 0.6)


@dataclass(frozen=True, eq=False)
class Result:
    """What a preset made: the picture and the data behind it."""

    image: np.ndarray
    """``(H, W, 3)`` float32 picture in [0, 1]."""
    dendrite: Dendrite | None = None
    """The main dendrite (None when the model has none, e.g. a rock)."""
    mesh: object = None
    """A :class:`trimesh.Trimesh` for 3D models, else None."""
    parts: dict = field(default_factory=dict)
    """Everything else worth keeping (further dendrites, lattices, cost fields, per-panel data)."""

    def __repr__(self) -> str:
        mesh = "None" if self.mesh is None else f"<{len(self.mesh.vertices)} vertices, {len(self.mesh.faces)} faces>"
        return (f"Result(image={self.image.shape} {self.image.dtype}, dendrite={self.dendrite!r}, mesh={mesh}, "
                f"parts={sorted(self.parts)})")


def _shape(shape, ndim: int) -> tuple[int, ...]:
    s = _checks.lattice_shape(shape)
    if len(s) != ndim:
        raise ValueError(f"Expected a {ndim}D 'shape', but got {shape!r}")
    if min(s) < 8:
        raise ValueError(f"Expected at least 8 nodes per axis in 'shape', but got {shape!r}")
    return s


def _ink(value: np.ndarray) -> np.ndarray:
    """Dark strokes on white paper."""
    v = np.clip(np.asarray(value, np.float32), 0.0, 1.0)
    return np.repeat((1.0 - v)[..., None], 3, axis=2)


def _drawing(den: Dendrite, width=1.6) -> np.ndarray:
    return _ink(_r.brightness(den, width, metric="euclidean"))


def _tile(panels: list[np.ndarray], columns: int, labels: list[str]) -> np.ndarray:
    """Panels of one size in a grid with white gaps, each over its label (see :func:`wdendrite.figure.panels`);
    a multi-panel preset keeps the labels in ``parts["labels"]``, in the panels' order."""
    return _fig.panels(panels, columns=columns, labels=labels)


def _entries(name: str, values, what: str, check=lambda v: v, *, distinct: bool = True) -> list:
    """``values``, one entry per panel, as a list of ``check(entry)``: a non-empty list, tuple or 1D
    array, without repeats when ``distinct`` (each entry keys its panel's dendrite in ``parts["dendrites"]``)."""
    if isinstance(values, (str, bytes)):
        raise ValueError(f"Expected '{name}' as a non-empty list of {what}, but got the string {values!r}: a "
                         "sequence of them is expected, not one string")
    if not isinstance(values, (list, tuple, np.ndarray)):
        raise TypeError(f"Expected '{name}' as a non-empty list of {what}, but got {values!r}")
    if len(values) == 0 or (isinstance(values, np.ndarray) and values.ndim != 1):
        raise ValueError(f"Expected '{name}' as a non-empty list of {what}, but got {values!r}")
    out = [check(v) for v in (values.tolist() if isinstance(values, np.ndarray) else values)]
    for i, v in enumerate(out if distinct else []):
        if v in out[:i]:
            raise ValueError(f"'{name}' lists {values[i]!r} twice; each entry is one panel, keyed by it in "
                             "parts['dendrites']")
    return out


_REACH = 0.85
"""Fraction of its half-width (in path cost) a fractal preset's schedule reaches: the first
endpoints lie at cost d from the generator and each later iteration's d / alpha^k beyond the
dendrite, so its tips reach about d (1 + 1/alpha + ... + 1/alpha^(n-1)) from the centre."""


def _cost_per_node(lat: Lattice, centre, radius: float, dist=None) -> float:
    """Least path cost per node of straight-line distance from ``centre``: the median over the
    nodes between 0.8 and 1 times ``radius`` away (it is well below the mean weight, since least
    paths pick cheap edges). ``dist``: the costs from ``centre`` when already searched."""
    if dist is None:
        dist = shortest_paths(lat, [centre]).dist
    grid = np.indices(lat.shape, dtype=np.float64)
    r = np.sqrt(sum((g - c) ** 2 for g, c in zip(grid, centre)))
    ring = (r >= 0.8 * radius) & (r <= radius) & np.isfinite(dist)
    return float(np.median(dist[ring] / r[ring])) if ring.any() else float(lat.weights[0].mean())


# --------------------------------------------------------------------------- 2D dendrites


def simple_dendrite(shape=(600, 600), *, endpoints: int = 15, r: float = 10.0, seed: int = 0) -> Result:
    """A dendrite from one central generator to random endpoints (2007 paper, Table 1: 600^2, 15 endpoints),
    kept apart by rejection sampling as in the paper: a twelfth of the smaller side, or less when
    many endpoints are asked for (see :func:`_spacing`)."""
    shape, endpoints = _shape(shape, 2), _checks.integer("endpoints", endpoints, low=1)
    lat = Lattice(shape, 8, weights=_w.Uniform(r=r, seed=seed))
    gen = np.array([[shape[0] // 2, shape[1] // 2]])
    cf = shortest_paths(lat, gen)
    den = trace(cf, _endpoints_in("endpoints", endpoints, "in", shape,
                                  lambda: _ep.random(lat, endpoints, seed=seed, min_spacing=_spacing(shape, endpoints))))
    return Result(_drawing(den), den, parts={"lattice": lat})


def _spacing(shape, endpoints: int) -> float:
    """Least distance between random endpoints: a twelfth of the smaller side, or half the side
    of the square each endpoint would have to itself when many are asked for."""
    return min(min(shape) / 12, 0.5 * math.sqrt(shape[0] * shape[1] / endpoints))


def _fractal_params(half: int, per_node: float, alpha: float, beta: float, iterations: int,
                    count: int) -> FractalParams:
    """A schedule of ``iterations`` steps whose tips reach about :data:`_REACH` of ``half`` nodes,
    paths costing ``per_node`` per node (see :func:`_cost_per_node`)."""
    FractalParams(count=count, d=2.0, alpha=alpha, beta=beta, epsilon=1.0)  # alpha, beta and count first
    a = float(alpha)  # > 1, checked above
    reach = (1.0 - a ** -float(iterations)) / (1.0 - 1.0 / a)  # 1 + 1/a + ... + 1/a^(n-1)
    d = _REACH * half * per_node / reach
    # epsilon between the last and the next d, so the schedule has exactly `iterations` steps
    try:
        eps = d / float(alpha) ** (iterations - 0.5)
    except OverflowError:
        eps = 0.0
    if not eps > 0:
        raise ValueError(f"'alpha' = {alpha!r} over 'iterations' = {iterations!r} shrinks the cost d below the "
                         "smallest float: lower either")
    return FractalParams(count=count, d=d, alpha=alpha, beta=beta, epsilon=eps)


def fractal_grid(
    cell: int = 170,
    *,
    alphas=(2.0, 1.5, 1.2),
    betas=(2.0, 3.0, 4.0),
    iterations: int = 3,
    count: int = 4,
    seed: int = 0,
) -> Result:
    """Fractal dendrites for every attenuation alpha (columns, left to right) and branching beta (rows)
    (thesis Fig. 3.13; the 2007 paper's Fig. 8 puts the alphas right to left). Each panel's first
    cost d is set from the lattice's measured path cost per node so that its tips reach about 85 %
    of the way to the border. ``Result.dendrite`` (and the command's dendrite outputs) is the first panel's; ``parts["dendrites"]``
    holds every panel's, keyed by ``(alpha, beta)``.

    Args:
        cell: side of each panel's lattice in nodes (>= 16).
        alphas: attenuations, one column each: every iteration divides d by alpha (each > 1).
        betas: branchings, one row each: every iteration multiplies the endpoint count by beta (each >= 1).
        iterations: fractal growth iterations (>= 1).
        count: endpoints of the first iteration.
        seed: seed of the weights and the endpoints.
    """
    cell, iterations = _checks.integer("cell", cell, low=16), _checks.integer("iterations", iterations, low=1)
    alphas, betas = _entries("alphas", alphas, "attenuations"), _entries("betas", betas, "branching factors")
    for b in betas:  # every panel's schedule checked before the first grows
        for a in alphas:
            _fractal_params(cell // 2, 1.0, a, b, iterations, count)
    panels, dens, per_node, labels = [], {}, None, []
    for b in betas:
        for a in alphas:
            lat = Lattice((cell, cell), 8, weights=_w.Uniform(r=10, seed=seed))
            if per_node is None:  # every panel has the same weights
                per_node = _cost_per_node(lat, (cell // 2, cell // 2), cell // 2)
            p = _fractal_params(cell // 2, per_node, a, b, iterations, count)
            den = grow(lat, [[cell // 2, cell // 2]], p, seed=seed)
            dens[(a, b)] = den
            panels.append(_drawing(den, 1.2))
            labels.append(f"alpha {a:g}, beta {b:g}")
    return Result(_tile(panels, len(alphas), labels), dens[(alphas[0], betas[0])],
                  parts={"dendrites": dens, "labels": labels})


def dla_imitation(shape=(500, 500), *, iterations: int = 4, alpha: float = 2.0, beta: float = 4.0, count: int = 6,
                  seed: int = 0) -> Result:
    """A path-planned fractal that imitates diffusion-limited aggregation (2007 paper, Fig. 11: 4 iterations),
    its first cost d set from the lattice's measured path cost per node so that the cluster's tips
    reach about 85 % of the way to the border.

    Args:
        shape: lattice shape (H, W).
        iterations: fractal growth iterations (>= 1).
        alpha: each iteration divides d by it (> 1).
        beta: each iteration multiplies the endpoint count by it (>= 1).
        count: endpoints of the first iteration.
        seed: seed of the weights and the endpoints.
    """
    shape, iterations = _shape(shape, 2), _checks.integer("iterations", iterations, low=1)
    _fractal_params(min(shape) // 2, 1.0, alpha, beta, iterations, count)  # checked before the lattice is built
    lat = Lattice(shape, 8, weights=_w.Uniform(r=10, seed=seed))
    centre = (shape[0] // 2, shape[1] // 2)
    p = _fractal_params(min(shape) // 2, _cost_per_node(lat, centre, min(shape) // 2), alpha, beta, iterations, count)
    den = grow(lat, [centre], p, seed=seed)
    return Result(_drawing(den, 1.0), den, parts={"lattice": lat, "params": p})


def _panels_of_weights(shape, distributions, endpoints: int, seed: int, *, roots=None, connectivity: int = 8,
                       within=None, where: str = "in"):
    """One drawing per weight distribution, every panel with the same endpoints (drawn ``within`` a
    region, ``where`` saying which in errors); each grows from its own root of ``roots`` (default:
    the lattice's centre)."""
    ep = _endpoints_in("endpoints", endpoints, where, shape, lambda: _ep.random(
        shape, endpoints, seed=seed, within=within, min_spacing=_spacing(shape, endpoints)))
    roots = [(shape[0] // 2, shape[1] // 2)] * len(distributions) if roots is None else roots
    panels, dens = [], []
    for dist, root in zip(distributions, roots):
        lat = Lattice(shape, connectivity, weights=dist)
        den = trace(shortest_paths(lat, [root]), ep)
        dens.append(den)
        panels.append(_drawing(den, 1.2))
    return panels, dens


def _polynomial(shape, n: float, seed: int, connectivity: int):
    """``W = 1 + v^n`` (thesis section 4.2); for n > 4, v is drawn from (0, 100^(4/n)) instead of (0, 100).

    Float32 path costs cannot resolve weights spanning 1e16 (n = 8): cheap edges
    vanish in the sums and backtracking meets ties. Capping the largest weight
    at 1e8 (as for n = 4) keeps every edge visible and the paths just as erratic.
    """
    if n <= 4:
        return _w.Polynomial(n=n, seed=seed)
    lengths = Lattice((2, 2), connectivity).lengths
    v = _checks.rng(seed).uniform(0.0, 100.0 ** (4.0 / n), (len(lengths), *shape))
    return (lengths.reshape(-1, 1, 1) * (1.0 + v**n)).astype(np.float32)


def weight_distributions(shape=(200, 200), *, ns: tuple[float, ...] = (0, 1, 4, 8), endpoints: int = 20,
                         connectivity: int = 4, seed: int = 0) -> Result:
    """The same endpoints under ``W = 1 + v^n`` for each n (thesis section 4.2): Manhattan to very erratic.
    The thesis' lattice is 4-connected, where n = 0 makes Manhattan paths; on an 8-connected one
    (``connectivity=8``) they run straight and at 45 degrees instead. For n > 4, v is drawn from
    (0, 100^(4/n)) instead of (0, 100), so that the largest weight stays 1e8 and float32 path costs
    resolve every edge (with 1e16 cheap edges vanish from the sums).

    Args:
        shape: lattice shape (H, W).
        ns: exponents n of the weights W = 1 + v^n, one panel each (each >= 0).
        endpoints: number of endpoints, the same in every panel.
        connectivity: lattice connectivity, 4 (the thesis') or 8.
        seed: seed of the weights and the endpoints.
    """
    shape, endpoints = _shape(shape, 2), _checks.integer("endpoints", endpoints, low=1)
    if _checks.integer("connectivity", connectivity) not in (4, 8):
        raise ValueError(f"Expected 'connectivity' 4 or 8, but got {connectivity!r}")
    ns = _entries("ns", ns, "exponents", lambda n: _checks.finite("ns", n))
    if any(n < 0 for n in ns):
        raise ValueError(f"Expected every entry of 'ns' >= 0, but got {min(ns)!r}")
    _checks.seed32(seed)
    _checks.stop_if_checking()  # (a check of the preset stops before the weight arrays are drawn)
    panels, dens = _panels_of_weights(shape, [_polynomial(shape, n, seed, connectivity) for n in ns], endpoints,
                                      seed, connectivity=connectivity)
    labels = [f"n = {n:g}" for n in ns]
    return Result(_tile(panels, len(ns), labels), dens[1 if len(dens) > 1 else 0],
                  parts={"dendrites": dict(zip(ns, dens)), "labels": labels})


def _toward_words(toward: str) -> str:
    """A panel's label for a tropism name: ``"toward left"``, ``"away from axis"``."""
    return "away from axis" if toward == "away_from_axis" else f"toward {toward}"


_ROOTS = ("left", "center", "right")
"""Where a tropism panel's root sits on the bottom row: near the left corner, in the middle, near the right corner."""


def tropisms(shape=(200, 200), *,
             toward=("left", "left", "right", "right", "axis", "away_from_axis", "top", "bottom"),
             roots=("left", "right", "left", "right", "center", "center", "center", "center"),
             strength: float = 12.0, endpoints: int = 20, seed: int = 0) -> Result:
    """Spatially biased weights (thesis Fig. 4.5; constructive path planning, Fig. 5): the same random
    endpoints reached from a root on the bottom row over weights made cheaper toward one side, so each
    dendrite leans that way. The defaults are the thesis' eight panels, a to h: cheaper toward the
    left with the root at the bottom left (a) and right (b), the same toward the right (c, d), cheaper
    near the vertical centre line (e), dearer near it (f), cheaper toward the top (g) and toward the
    bottom (h). Four panels a row; each is labelled with its letter, tropism and root.
    ``parts["dendrites"]`` holds every panel's dendrite, keyed by ``(toward, root)``.

    Args:
        shape: each panel's lattice shape (H, W).
        toward: where each panel's weights are cheapest (left, right, top, bottom, axis:
            near the vertical centre line, away_from_axis: far from it), one panel each.
        roots: where each panel's root sits on the bottom row (left, center, right), one per
            entry of ``toward``, or one for every panel.
        strength: tropism strength: weights scale by 1 + strength * g, g from 0 on the cheap side to 1 (>= 0).
        endpoints: number of endpoints, the same in every panel, drawn in the upper three quarters.
        seed: seed of the weights and the endpoints.
    """
    shape = _shape(shape, 2)
    toward = _entries("toward", toward, f"tropism names from {_w._TOWARD}", distinct=False)
    roots = _entries("roots", roots, f"root places from {_ROOTS}", distinct=False)
    for r in roots:
        if r not in _ROOTS:
            raise ValueError(f"Expected every entry of 'roots' in {_ROOTS}, but got {r!r}")
    if len(roots) == 1:
        roots = roots * len(toward)
    if len(roots) != len(toward):
        raise ValueError(f"Expected one entry of 'roots' per entry of 'toward' ({len(toward)}), or one for all, "
                         f"but got {len(roots)}: roots={tuple(roots)!r}, toward={tuple(toward)!r}")
    _entries("toward", list(zip(toward, roots)), "(toward, root) pairs")  # each pair keys one panel
    dists = [_w.Uniform(r=10, seed=seed) * _w.Tropism(t, strength=strength) for t in toward]
    h, w = shape
    column = {"left": round(0.1 * (w - 1)), "center": w // 2, "right": round(0.9 * (w - 1))}
    upper = _ep.Box((2, 2), (0.75 * (h - 1), w - 3))
    panels, dens = _panels_of_weights(shape, dists, _checks.integer("endpoints", endpoints, low=1), seed,
                                      roots=[(h - 3, column[r]) for r in roots], within=upper,
                                      where="in the upper three quarters of")
    labels = [f"({chr(97 + i) if i < 26 else i + 1}) {_toward_words(t)}, root {r}"
              for i, (t, r) in enumerate(zip(toward, roots))]
    return Result(_tile(panels, min(4, len(panels)), labels), dens[0],
                  parts={"dendrites": dict(zip(zip(toward, roots), dens)), "labels": labels})


def competition(shape=(300, 300), *, count: int = 6, seed: int = 0) -> Result:
    """Two dendrites grown at once compete for space (2007 paper, Fig. 14; thesis Fig. 5.3).

    Each node belongs to one of them (``label`` 0 or 1) and they never share a node. They do not keep
    a gap: their nodes may lie side by side, and nothing keeps a diagonal edge of one from crossing
    one of the other inside a lattice cell (see :class:`~wdendrite.Dendrite`)."""
    shape, count = _shape(shape, 2), _checks.integer("count", count, low=2)
    lat = Lattice(shape, 8, weights=_w.Uniform(r=10, seed=seed))
    gens = np.array([[shape[0] // 2, shape[1] // 3], [shape[0] // 2, 2 * shape[1] // 3]])
    # each reaches about 0.3 of the side: to its own border, and past the middle toward the other
    half = int(0.35 * min(shape))
    p = _fractal_params(half, _cost_per_node(lat, tuple(gens[0]), min(shape) // 3), 1.5, 3.0, 3, count)
    den = grow(lat, gens, p, seed=seed)
    colours = [np.array([0.75, 0.3, 0.1]), np.array([0.1, 0.35, 0.7])]
    img = np.ones((*shape, 3), np.float32)
    for k, c in enumerate(colours):
        rows = np.flatnonzero(den.label == k)
        if len(rows):
            v = _r.brightness(den, 1.4, rows=rows, metric="euclidean")
            img -= v[..., None] * (1.0 - c)
    return Result(np.clip(img, 0, 1), den, parts={"lattice": lat})


def _text_mask(text: str, height: int) -> np.ndarray:
    from PIL import Image, ImageDraw

    try:  # (a size FreeType refuses, or an image Pillow will not make, is reported against 'height')
        font = _fig.font(max(8, int(height * 0.8)))  # (the bitmap font, where Pillow has no FreeType, scaled below)
        left, top, right, bottom = ImageDraw.Draw(Image.new("L", (1, 1))).textbbox((0, 0), text, font=font)
        img = Image.new("L", (right - left + 8, bottom - top + 8), 0)
        ImageDraw.Draw(img).text((4 - left, 4 - top), text, fill=255, font=font)
        scale = height / img.height
        img = img.resize((max(1, round(img.width * scale)), height), Image.BILINEAR)
    except (OSError, ValueError, MemoryError, Image.DecompressionBombError) as exc:
        raise ValueError(f"'height' = {height} is too large for Pillow to draw 'text' {text!r}: {exc}") from None
    return np.asarray(img) > 127


def letters(text: str = "Hello", *, height: int = 300, mask=None, paths_per_1000: float = 24.0, seed: int = 0) -> Result:
    """Dendritic letters: paths fill letter-shaped regions (2007 paper, Fig. 13; thesis Figs. 5.5-5.6).

    Args:
        text: the word to fill, drawn with Pillow's default font.
        height: lattice height in nodes (the thesis used 300^2 per letter).
        mask: optional ``(H, W)`` bool array of a shape to fill instead of ``text`` (from Python only).
        paths_per_1000: endpoints per 1000 nodes inside the letters. The thesis put 600 paths in
            each letter's 300^2 lattice; letters covering about 28 % of their lattice, as Pillow's
            default font draws them, that is about 24.
        seed: seed of the weights and the endpoints.
    """
    from scipy import ndimage

    per_1000 = _checks.positive("paths_per_1000", paths_per_1000)
    if mask is None and not isinstance(text, str):  # (str() of bytes or None would have drawn "b'A'" or "None")
        raise TypeError(f"Expected a str for 'text', but got {type(text).__name__} {text!r:.60}")
    region = _text_mask(text, _checks.integer("height", height, low=16)) if mask is None else _checks.bool_array(
        "mask", mask, np.shape(mask))
    if region.ndim != 2 or not region.any():
        raise ValueError("Expected a non-empty 2D letter region ('text' or 'mask')")
    lat = Lattice(region.shape, 8, weights=_w.Uniform(r=10, seed=seed), mask=region)
    parts, n = ndimage.label(region)
    gens = []
    for k in range(1, n + 1):
        pts = np.argwhere(parts == k)
        # each letter part grows from its node nearest to the part's centre
        gens.append(pts[np.argmin(((pts - pts.mean(axis=0)) ** 2).sum(axis=1))])
    cf = shortest_paths(lat, np.array(gens))
    usable = int(region.sum())
    m = max(1, int(usable * min(per_1000 / 1000.0, 1.0)))  # (at most every node)
    den = trace(cf, _ep.random(lat, m, seed=seed))
    return Result(_drawing(den, 1.0), den, parts={"mask": region, "lattice": lat})


# --------------------------------------------------------------------------- lightning and widths


@dataclass(frozen=True)
class LightningParams:
    """The papers' lightning: two 2D graphs with power weights, tapering, glow (constructive path planning, Fig. 9)."""

    alpha: float = 3.0
    """Exponent of the power weights ``R^alpha`` (3: erratic strokes)."""
    forks: int = 9
    """Endpoints of side branches in the first graph (besides the main stroke's), >= 0."""
    minor_forks: int = 14
    """Endpoints of the second graph, which holds only side branches, >= 0."""
    main_width: _r.Taper = _r.Taper(2.6, 1.8, along="path")
    """Width of the main stroke: thick and nearly constant. Widths and the glow radius are pixels of a
    600^2 picture and scale with the picture's smaller side (by at least 0.5)."""
    fork_width: _r.Taper = _r.Taper(1.9, 0.45, along="branch")
    """Width of the first graph's side branches: they taper visibly."""
    minor_width: _r.Taper = _r.Taper(1.3, 0.35, along="path")
    """Width of the second graph's branches."""
    minor_gain: float = 0.8
    """Brightness of the second graph relative to the first, in [0, 1]."""
    glow_radius: float = 14.0
    """Blur radius of the halo (pixels), > 0."""
    glow_gain: float = 1.4
    """Strength of the halo, >= 0."""
    metric: Literal["euclidean", "path"] = "euclidean"
    """What brightness falls off with: "euclidean", the distance in pixels (smooth strokes), or
    "path", the papers' path cost over each graph's own random lattice, the widths scaled by its
    measured cost per pixel (ragged strokes whose glow creeps along cheap edges)."""

    def __post_init__(self):
        _checks.positive("alpha", self.alpha)
        if self.metric not in ("euclidean", "path"):
            raise ValueError(f"Expected 'metric' in ('euclidean', 'path'), but got {self.metric!r}")
        # the weights' own bound, in this preset's words: Power's default range (1, max), times the
        # longest edge a lattice may have (sqrt 3), below the supported largest weight
        top, limit = _w.Power().max, math.log(_w._MAX_WEIGHT / math.sqrt(3.0))
        if not float(self.alpha) * math.log(top) < limit:
            raise ValueError(f"'alpha' of the lightning's power weights must keep sqrt(3) * {top:g}**alpha below "
                             f"{_w._MAX_WEIGHT:g} (alpha < {limit / math.log(top):.4g}), but got {self.alpha!r}")
        _checks.integer("forks", self.forks, low=0)
        _checks.integer("minor_forks", self.minor_forks, low=0)
        for name in ("main_width", "fork_width", "minor_width"):
            w = getattr(self, name)
            if not isinstance(w, _r.Taper):
                _checks.positive(name, w)
        gain = _checks.nonnegative("minor_gain", self.minor_gain, allow_none=False)
        if gain > 1:
            raise ValueError(f"Expected 'minor_gain' in [0, 1], but got {self.minor_gain!r}")
        _checks.positive("glow_radius", self.glow_radius)
        _checks.nonnegative("glow_gain", self.glow_gain, allow_none=False)


def _forks_near(lat: Lattice, stroke: Dendrite, count: int, seed, name: str) -> np.ndarray:
    """Endpoints near the main stroke, denser lower in the image (2007 paper, section 4); ``name``
    is the parameter that asked for ``count`` of them (errors name it)."""
    from scipy import ndimage

    h, w = lat.shape
    free = np.ones(lat.shape, bool)
    free[tuple(stroke.nodes.T)] = False
    near = ndimage.distance_transform_edt(free) < 0.22 * w
    near[: h // 5] = False
    return _endpoints_in(name, count, "near the main stroke of", lat.shape, lambda: _ep.biased(
        lat, count, seed=seed, power=1.5, axis=0, toward="end", within=near, min_spacing=0.04 * min(h, w)))


def _sky(shape) -> np.ndarray:
    y = np.linspace(0.0, 1.0, shape[0], dtype=np.float32)[:, None, None]
    top, bottom = np.array([0.05, 0.05, 0.12], np.float32), np.array([0.01, 0.01, 0.03], np.float32)
    return np.broadcast_to(top * (1 - y) + bottom * y, (*shape, 3)).copy()


def _scaled(width, s: float):
    if isinstance(width, _r.Taper):
        return _r.Taper(width.start * s, width.end * s, width.beta, width.along)
    return float(width) * s


def lightning(shape=(600, 600), *, params: LightningParams = LightningParams(), seed: int = 0) -> Result:
    """Forked lightning made of two graphs (constructive path planning, Figs. 3, 4, 9; 2007 paper, Fig. 14).

    The first graph holds the main stroke, from a generator at the top to an
    endpoint at the bottom, plus forks near it; the second graph, with other
    weights, holds only side branches, grown from the upper main stroke (the
    thesis starts both graphs at the same generator; growing the second from
    the stroke keeps its branches on it). Their brightness images are
    combined, given a halo and lit over a night sky. Two choices differ from
    the papers by default: brightness falls off with the distance in pixels,
    not the path cost over the random lattice (``params.metric = "path"``
    gives the papers' ragged look), and a blurred halo is added, which the
    constructive paper says its renderings largely lack (``glow_gain = 0``
    leaves it out). ``parts`` holds both dendrites, the core brightness
    ``"value"`` and the halo ``"glow"``.
    """
    shape = _shape(shape, 2)
    if not isinstance(params, LightningParams):
        raise TypeError(f"Expected LightningParams for 'params', but got {type(params).__name__}")
    rng = _checks.rng(seed)
    h, w = shape
    gen = np.array([[2, int(w * rng.uniform(0.4, 0.6))]])
    lat1 = Lattice(shape, 8, weights=_w.Power(alpha=params.alpha, seed=int(rng.integers(2**31))))
    cf1 = shortest_paths(lat1, gen)
    main = trace(cf1, [[h - 3, int(w * rng.uniform(0.3, 0.7))]])
    first = trace(cf1, _forks_near(lat1, main, params.forks, rng, "forks"), extend=main) if params.forks else main
    # the papers' widths are for 600^2 pictures; keep the look at other sizes
    s = max(min(h, w) / 600.0, 0.5)

    def value_of(den, lat, width, side=None, dist=None):
        if params.metric == "euclidean":
            return _r.brightness(den, _scaled(width, s), side=None if side is None else _scaled(side, s))
        # widths in path cost: pixels times what a least path costs per pixel on this lattice
        c = s * _cost_per_node(lat, tuple(den.nodes[den.parent < 0][0]), min(h, w) / 3, dist)
        return _r.brightness(den, _scaled(width, c), side=None if side is None else _scaled(side, c),
                             metric="path", lattice=lat)

    v1 = value_of(first, lat1, params.main_width, params.fork_width, cf1.dist)  # (first's root: the generator)
    layers, gains, second, lat2 = [v1], [1.0], None, None
    if params.minor_forks:
        lat2 = Lattice(shape, 8, weights=_w.Power(alpha=params.alpha, seed=int(rng.integers(2**31))))
        # the second graph's branches leave the upper main stroke (its nodes are the generators) and
        # travel down to endpoints lower in the picture, crossing the first graph's branches
        stem = main.nodes[(main.nodes[:, 0] > 0.06 * h) & (main.nodes[:, 0] < 0.4 * h)]
        second = trace(shortest_paths(lat2, stem), _forks_near(lat2, main, params.minor_forks, rng, "minor_forks"))
        layers.append(value_of(second, lat2, params.minor_width))
        gains.append(params.minor_gain)
    value = _r.composite(layers, mode="max", gains=gains)
    halo = _r.glow(value, radius=params.glow_radius * s) * params.glow_gain
    img = _r.colorize(value, colormap="lightning", glow=halo, background=_sky(shape))
    return Result(img, first, parts={"second": second, "value": value, "glow": halo, "lattices": (lat1, lat2)})


def _one_path(shape, r: float, seed: int) -> tuple[Dendrite, Lattice]:
    lat = Lattice(shape, 8, weights=_w.Uniform(r=r, seed=seed))
    den = trace(shortest_paths(lat, [[4, shape[1] // 2]]), [[shape[0] - 5, shape[1] // 2]])
    return den, lat


def width_demo(shape=(200, 120), *, seed: int = 0) -> Result:
    """One path at several widths: T = 5.0 (with a halo) and 1.6, and the thesis' factors 0.6 and 0.2
    with ``exp(-a (c Ts)^2)``, a = 1/10000, clamped above 0.7 (constructive path planning Fig. 3, thesis Fig. 4.9).
    The thesis' panels use their own path over rougher weights (``r`` = 100, within the thesis' 10-100),
    whose path costs set the widths; at factor 0.2 the glow fills the panel."""
    shape = _shape(shape, 2)
    den, _ = _one_path(shape, 10.0, seed)
    thesis_den, thesis_lat = _one_path(shape, 100.0, seed)
    values = [_r.brightness(den, 5.0), _r.brightness(den, 1.6)]
    values += [_r.brightness(thesis_den, _r.thesis_width(k), metric="path", lattice=thesis_lat, clamp=0.7)
               for k in (0.6, 0.2)]
    panels = [_r.colorize(v, colormap="lightning") for v in values]
    labels = ["T = 5.0", "T = 1.6", "thesis c = 0.6", "thesis c = 0.2"]
    return Result(_tile(panels, 4, labels), den, parts={"values": values, "thesis_dendrite": thesis_den,
                                                        "labels": labels})


def taper_demo(shape=(200, 200), *, start: float = 5.0, end: float = 0.8, beta: float = 1.0, endpoints: int = 6,
               seed: int = 0) -> Result:
    """Constant width next to tapering by eq. 2 along each path and along each branch (constructive path planning Fig. 4).

    Args:
        shape: lattice shape (H, W).
        start: width Ts where a path (or branch) starts; also the constant panel's width (pixels).
        end: width Tf at its farthest tip (pixels).
        beta: shape of the taper ``u^beta`` (> 0; 1: linear in path cost).
        endpoints: number of endpoints, drawn in the lower half.
        seed: seed of the weights and the endpoints.
    """
    shape, endpoints = _shape(shape, 2), _checks.integer("endpoints", endpoints, low=1)
    widths = [start, _r.Taper(start, end, beta, along="path"), _r.Taper(start, end, beta, along="branch")]
    lat = Lattice(shape, 8, weights=_w.Power(alpha=3.0, seed=seed))
    cf = shortest_paths(lat, [[3, shape[1] // 2]])
    ep = _endpoints_in("endpoints", endpoints, "in the lower half of", shape, lambda: _ep.biased(
        lat, endpoints, seed=seed, power=2.0, within=_ep.Box((shape[0] // 2, 2), (shape[0] - 3, shape[1] - 3))))
    den = trace(cf, ep)
    values = [_r.brightness(den, wd_) for wd_ in widths]
    panels = [_r.colorize(v, colormap="lightning") for v in values]
    labels = [f"T = {start:g}", f"T {start:g} to {end:g}, along paths", f"T {start:g} to {end:g}, along branches"]
    return Result(_tile(panels, 3, labels), den, parts={"values": values, "labels": labels})


# --------------------------------------------------------------------------- 3D models


_GEOMETRIES = ("spheres", "tubes", "isosurface")


def _endpoints_in(name: str, count: int, where: str, shape, draw) -> np.ndarray:
    """``draw()``'s endpoints; a request that cannot be met is reported against the preset's parameter ``name``."""
    try:
        return draw()
    except _ep.TooManyEndpoints as exc:
        size = " x ".join(map(str, shape))
        raise ValueError(f"'{name}' = {count} is more than fit {where} the {size} lattice: {exc}") from None


# spheres this far apart (a body diagonal) touch when their radius is at least half of it
_MIN_SPHERE_RADIUS = 0.5 * 3**0.5


def _tree_mesh(den: Dendrite, radius, side, geometry: str):
    if geometry == "spheres":
        return _geo.spheres(den, np.maximum(_r.node_widths(den, radius, side=side), _MIN_SPHERE_RADIUS))
    if geometry == "tubes":
        return _geo.tubes(den, radius, side=side)
    if geometry == "isosurface":
        return _geo.isosurface(den, radius, side=side, smooth=5)
    raise ValueError(f"Expected 'geometry' in {_GEOMETRIES}, but got {geometry!r}")


def elm_tree(shape=(80, 80, 80), *, endpoints: int = 17, geometry: Literal["tubes", "spheres", "isosurface"] = "tubes",
             seed: int = 0) -> Result:
    """An elm-like tree: winding branches spreading from a root into a wide crown, tapered spheres or tubes
    (constructive path planning Figs. 6-8: 80^3 lattice, 20 and 36 endpoints, taper beta 0.3 main / 0.2 small;
    17 endpoints as in thesis Table 5.1). The paper draws a sphere at each node; tubes, the default, give
    the same branches with far fewer faces.
    Spheres are at least 0.87 nodes wide (neighbours along a diagonal touch) and isosurfaces 0.6
    (:data:`wdendrite.geometry.MIN_ISO_RADIUS`), so thin twigs stay joined."""
    shape, endpoints = _shape(shape, 3), _checks.integer("endpoints", endpoints, low=1)
    if geometry not in _GEOMETRIES:
        raise ValueError(f"Expected 'geometry' in {_GEOMETRIES}, but got {geometry!r}")
    d, h, w = shape
    lat = Lattice(shape, 26, weights=_w.Uniform(r=10, seed=seed))
    crown = _ep.Disc((0.72 * d, h / 2, w / 2), 0.42 * min(h, w)).mask(shape)
    crown[: int(0.45 * d)] = False
    ends = _endpoints_in("endpoints", endpoints, "in the crown of", shape,
                         lambda: _ep.random(lat, endpoints, within=crown, seed=seed, min_spacing=0.08 * d))
    den = trace(shortest_paths(lat, [[1, h // 2, w // 2]]), ends)
    scale = d / 80.0
    radius = _r.Taper(2.4 * scale, 0.6 * scale, beta=0.3, along="path")
    side = _r.Taper(1.5 * scale, 0.35 * scale, beta=0.2, along="branch")
    mesh = _tree_mesh(den, radius, side, geometry)
    return Result(_geo.preview(mesh, color=_WOOD, elevation=10), den, mesh, parts={"lattice": lat})


def tropism_objects(shape=(60, 60, 60), *, toward=("axis", "away_from_axis", "top"), strength: float = 3.0,
                    endpoints: int = 24, seed: int = 0) -> Result:
    """3D objects from spatially varying weights (constructive path planning Fig. 5): the same endpoints, biased
    toward a vertical axis, away from it, or upward; weights depend on the horizontal distance ``sqrt(x^2 + y^2)``."""
    shape = _shape(shape, 3)
    toward = _entries("toward", toward, f"tropism names from {_w._TOWARD}")
    for t in toward:
        _w.Tropism(t, strength=strength)  # each kind and the strength checked before any search
    d, h, w = shape
    endpoints = _checks.integer("endpoints", endpoints, low=1)
    ep = _endpoints_in("endpoints", endpoints, "in the upper part of", shape, lambda: _ep.random(
        shape, endpoints, within=_ep.Box((0.4 * d, 2, 2), (d - 3, h - 3, w - 3)), seed=seed, min_spacing=0.08 * d))
    pics, meshes, dens = [], {}, {}
    for t in toward:
        lat = Lattice(shape, 26, weights=_w.Uniform(r=10, seed=seed) * _w.Tropism(t, strength=strength))
        den = trace(shortest_paths(lat, [[1, h // 2, w // 2]]), ep)
        mesh = _geo.tubes(den, _r.Taper(1.6 * d / 60, 0.4 * d / 60, along="path"), sides=6)
        dens[t], meshes[t] = den, mesh
        pics.append(_geo.preview(mesh, size=(320, 320), color=_WOOD, elevation=10))
    labels = [_toward_words(t) for t in toward]
    return Result(_tile(pics, len(pics), labels), dens[toward[0]], meshes[toward[0]], parts={"dendrites": dens,
                                                                                     "meshes": meshes,
                                                                                     "labels": labels})


def staghorn_coral(shape=(50, 50, 50), *, endpoints: int = 24, refine_n: int | None = 3, seed: int = 0) -> Result:
    """Staghorn coral: branches from a base to endpoints placed over a dome, refined for detail
    (2007 paper, Fig. 12 and Table 1: 50^3, 11 endpoints, or 24 with refinement). ``refine_n`` = 3
    keeps the default quick; the thesis refines with 7, 9 or 15 for more winding detail. The
    branches are tubes where the paper puts a sphere at each node."""
    shape, endpoints = _shape(shape, 3), _checks.integer("endpoints", endpoints, low=1)
    if refine_n:  # 0 or None: no refinement; checked before the coarse dendrite is grown
        _check_n_e(refine_n, 0.75, n_name="refine_n")
    d, h, w = shape
    lat = Lattice(shape, 26, weights=_w.Uniform(r=10, seed=seed))
    dome = _ep.Disc((0.1 * d, h / 2, w / 2), 0.85 * d).mask(shape) & ~_ep.Disc((0.1 * d, h / 2, w / 2), 0.55 * d).mask(shape)
    dome[: int(0.3 * d)] = False
    ends = _endpoints_in("endpoints", endpoints, "on the dome of", shape,
                         lambda: _ep.random(lat, endpoints, within=dome, seed=seed, min_spacing=0.12 * d))
    den = trace(shortest_paths(lat, [[1, h // 2, w // 2]]), ends)
    coarse = den
    if refine_n:
        den, _ = refine(den, lat, n=refine_n, seed=seed)
    scale = d / 50.0
    mesh = _geo.tubes(den, _r.Taper(1.6 * scale, 0.7 * scale, along="path"), sides=8)
    return Result(_geo.preview(mesh, color=_CORAL, elevation=15), den, mesh, parts={"coarse": coarse, "lattice": lat})


def _rock_field(shape, neighbours: int, seed: int):
    """Label segmentation with one generator in the middle and others around it (2007 paper, section 3.4)."""
    rng = _checks.rng(seed)
    lat = Lattice(shape, 6, weights=_w.Uniform(r=10, seed=seed))
    c = (np.asarray(shape) - 1) / 2.0
    # directions spread evenly over the sphere (a Fibonacci lattice), turned at random and jittered:
    # independent random directions left gaps through which the rock ran into the lattice's walls
    k = np.arange(neighbours) + 0.5
    polar, turn = np.arccos(1.0 - 2.0 * k / neighbours), np.pi * (1.0 + 5**0.5) * k
    dirs = np.stack([np.cos(polar), np.sin(polar) * np.cos(turn), np.sin(polar) * np.sin(turn)], axis=1)
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    dirs = dirs @ (q * np.sign(np.diag(r))).T + 0.15 * rng.normal(size=(neighbours, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    ring = np.clip(np.round(c + dirs * 0.42 * np.asarray(shape)), 0, np.asarray(shape) - 1).astype(np.int64)
    gens = np.concatenate([np.round(c).astype(np.int64)[None], ring])
    return lat, shortest_paths(lat, gens)


def rock(shape=(128, 128, 128), *, neighbours: int = 14, smooth: int = 6, seed: int = 0) -> Result:
    """A "rock": the region of the lattice nearest (in path cost) to a central generator, meshed
    (2007 paper, Fig. 10 and Table 2: 128^3)."""
    shape, neighbours = _shape(shape, 3), _checks.integer("neighbours", neighbours, low=4)
    smooth = _checks.integer("smooth", smooth, low=0, high=1000)  # (rocks look smooth by 10)
    lat, cf = _rock_field(shape, neighbours, seed)
    mesh = _geo.region_mesh(cf.label, 0, smooth=smooth)
    return Result(_geo.preview(mesh, color=_ROCK), None, mesh, parts={"costfield": cf, "lattice": lat})


rock.makes_dendrite = False  # (the command refuses dendrite formats before running it)


def lichen_on_rock(shape=(128, 128, 128), *, neighbours: int = 14, count: int = 8, seed: int = 0) -> Result:
    """Lichen grown over a rock: generator and endpoints on the rock's surface, its interior forbidden
    (2007 paper, Fig. 16 and Table 2: 128^3). The mesh holds the rock and the lichen."""
    import trimesh

    shape, neighbours = _shape(shape, 3), _checks.integer("neighbours", neighbours, low=4)
    count = _checks.integer("count", count, low=1)
    lat, cf = _rock_field(shape, neighbours, seed)
    inside = cf.label == 0
    surf = _geo.surface_nodes(inside)
    on_surface = np.zeros(shape, bool)
    on_surface[tuple(surf.T)] = True
    allowed = ~inside | on_surface
    lichen_lat = Lattice(shape, 26, weights=_w.Uniform(r=10, seed=(seed + 1) % 2**32), mask=allowed)
    top = surf[np.argmax(surf[:, 0] - 0.3 * np.abs(surf[:, 1:] - np.asarray(shape[1:]) / 2).sum(axis=1))]
    p = _fractal_params(int(0.3 * min(shape)), 6.0, 1.5, 3.0, 3, count)  # (paths over the rock's surface)
    den = grow(lichen_lat, [top], p, seed=seed, within=on_surface)
    rock_mesh = _geo.region_mesh(cf.label, 0, smooth=6)
    scale = min(shape) / 128.0
    lichen_mesh = _geo.tubes(den, _r.Taper(1.1 * scale + 0.3, 0.5 * scale + 0.2, along="path"), sides=6)
    img = _geo.preview([rock_mesh, lichen_mesh], color=[_ROCK, _LICHEN])
    mesh = trimesh.util.concatenate([rock_mesh, lichen_mesh])
    return Result(img, den, mesh, parts={"rock": rock_mesh, "lichen": lichen_mesh, "costfield": cf,
                                         "lattice": lichen_lat})


def moss(shape=(40, 96, 96), *, endpoints: int | None = None, seed: int = 0) -> Result:
    """Moss: many short paths grown up from a plane of generators (2007 paper, Fig. 15).

    Args:
        shape: lattice shape (D, H, W).
        endpoints: number of endpoints (default: 400 at the default shape, in proportion to the volume elsewhere).
        seed: seed of the weights and the endpoints.
    """
    shape = _shape(shape, 3)
    d, h, w = shape
    if endpoints is None:
        endpoints = max(1, round(400 * d * h * w / (40 * 96 * 96)))
    endpoints = _checks.integer("endpoints", endpoints, low=1)
    lat = Lattice(shape, 26, weights=_w.Uniform(r=10, seed=seed))
    yy, xx = np.mgrid[:h, :w]
    plane = np.stack([np.zeros(h * w, np.int64), yy.ravel(), xx.ravel()], axis=1)
    cf = shortest_paths(lat, plane)
    band = _ep.Box((0.35 * d, 1, 1), (0.9 * d, h - 2, w - 2))
    ends = _endpoints_in("endpoints", endpoints, "in the band above the plane of", shape,
                         lambda: _ep.random(lat, endpoints, within=band, seed=seed, min_spacing=2.0))
    den = trace(cf, ends)
    mesh = _geo.tubes(den, _r.Taper(0.55, 0.25, along="path"), sides=5)
    return Result(_geo.preview(mesh, color=_MOSS, elevation=35), den, mesh, parts={"lattice": lat})

