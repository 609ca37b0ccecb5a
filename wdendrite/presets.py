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

from . import _checks, _scenes
from . import endpoints as _ep
from . import figure as _fig
from . import lightning as _lightning
from . import geometry as _geo
from . import render as _r
from . import weights as _w
from .dendrite import Dendrite, trace
from .endpoints import _requested as _endpoints_in
from .growth import FractalParams, grow
from .lattice import Lattice
from .lightning import LightningParams
from .refine import _check_n_e, refine
from .skeleton import skeleton as _centre_lines
from .sssp import _cost_per_node, shortest_paths

__all__ = [
    "LightningParams",
    "Result",
    "cheap_paths",
    "competition",
    "dla_imitation",
    "elm_tree",
    "fractal_grid",
    "letters",
    "lichen_cluster",
    "lichen_on_rock",
    "lightning",
    "moss",
    "power_weights",
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
    """``den`` drawn in antialiased strokes ``width`` pixels wide, dark on white."""
    return _ink(_r.strokes(den, width))


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


def _reach(alpha: float, iterations: int) -> float:
    """``1 + 1/alpha + ... + 1/alpha^(n-1)``: how far a schedule's tips reach, in units of its first d."""
    a = float(alpha)
    return (1.0 - a ** -float(iterations)) / (1.0 - 1.0 / a)


def _schedule(d: float, alpha: float, beta: float, iterations: int, count: int) -> FractalParams:
    """First cost ``d``, and an epsilon between the last and the next d, so the schedule has exactly
    ``iterations`` steps."""
    try:
        eps = d / float(alpha) ** (iterations - 0.5)
    except OverflowError:
        eps = 0.0
    if not eps > 0:
        raise ValueError(f"'alpha' = {alpha!r} over 'iterations' = {iterations!r} shrinks the cost d below the "
                         "smallest float: lower either")
    return FractalParams(count=count, d=d, alpha=alpha, beta=beta, epsilon=eps)


def _fractal_params(half: int, per_node: float, alpha: float, beta: float, iterations: int,
                    count: int) -> FractalParams:
    """A schedule of ``iterations`` steps whose tips reach about :data:`_REACH` of ``half`` nodes,
    paths costing ``per_node`` per node (see :func:`_cost_per_node`)."""
    FractalParams(count=count, d=2.0, alpha=alpha, beta=beta, epsilon=1.0)  # alpha, beta and count first
    return _schedule(_REACH * half * per_node / _reach(alpha, iterations), alpha, beta, iterations, count)


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
    (thesis Fig. 3.13; the 2007 paper's Fig. 8 puts the alphas right to left): "α = 2, 1.5, 1.2",
    "β = 2, 3, 4", and "All dendrites were built with three iterations" (2007 paper, Fig. 8).
    Every panel grows from the same weights and starts from the same cost d, each iteration
    dividing d by alpha and multiplying the endpoint count by beta, so a smaller alpha places later
    endpoints farther out (a wider, denser dendrite) and a larger beta places more of them. d is
    set from the lattice's measured path cost per node so that the farthest-reaching schedule (the
    smallest alpha) reaches about 85 % of the way to the border. Panels are labelled with their
    alpha and beta. ``Result.dendrite`` (and the command's dendrite outputs) is the first panel's;
    ``parts["dendrites"]`` holds every panel's, keyed by ``(alpha, beta)``.

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
    for a in alphas:
        if not _checks.finite("alphas", a) > 1:
            raise ValueError(f"Expected every entry of 'alphas' > 1 (each iteration divides d by it), but got {a!r}")
    for b in betas:  # every panel's schedule checked before the first grows
        for a in alphas:
            _fractal_params(cell // 2, 1.0, a, b, iterations, count)
    widest = min(alphas)  # (every alpha > 1, checked above: the smallest reaches farthest)
    panels, labels, dens, d = [], [], {}, None
    for b in betas:
        for a in alphas:
            lat = Lattice((cell, cell), 8, weights=_w.Uniform(r=10, seed=seed))
            if d is None:  # every panel has the same weights
                per_node = _cost_per_node(lat, (cell // 2, cell // 2), cell // 2)
                d = _fractal_params(cell // 2, per_node, widest, b, iterations, count).d
            den = grow(lat, [[cell // 2, cell // 2]], _schedule(d, a, b, iterations, count), seed=seed)
            dens[(a, b)] = den
            panels.append(_drawing(den, 1.3))
            labels.append(f"alpha = {a:g}, beta = {b:g}")
    return Result(_tile(panels, len(alphas), labels), dens[(alphas[0], betas[0])],
                  parts={"dendrites": dens, "d": d, "labels": labels})


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


def _connectivity(connectivity) -> int:
    if _checks.integer("connectivity", connectivity) not in (4, 8):
        raise ValueError(f"Expected 'connectivity' 4 or 8, but got {connectivity!r}")
    return int(connectivity)


def power_weights(shape=(200, 200), *, alphas=(0.3, 1.0, 3.0), endpoints: int = 30, connectivity: int = 8,
                  seed: int = 0) -> Result:
    """The same endpoints under power weights ``e = R^alpha`` for each alpha (constructive path planning, eq. 1, Fig. 2).

    The paper draws R uniformly from (1, max) and shows "α = 0.3, α = 1.0, and α = 3.0": at 0.3
    "very direct branches, nearly straight lines", at 1.0 "a conventional model, with slight
    variation in the paths", at 3.0 paths "more erratic yet, willing to diverge considerably
    from the Euclidean shortest distance". As in its Fig. 1, the root sits at the bottom and the
    endpoints are scattered above it; every panel has the same draws R and the same endpoints.
    The paper gives neither max nor a lattice size: R spans (1, 11) here (:class:`~wdendrite.weights.Power`'s
    default) on 200 x 200 nodes. Its lattices are four-connected "to conserve memory" (2007
    paper, section 3), which notes that eight-connectivity reduces lattice artifacts: on four
    neighbours every path is a staircase of axis steps, so the default is 8 (diagonal edges
    weighted by their length); ``connectivity=4`` gives the paper's lattice.

    Args:
        shape: lattice shape (H, W) of each panel.
        alphas: exponents alpha of the weights, one panel each (each > 0).
        endpoints: endpoints, the same in every panel, in the upper 85 % of the lattice.
        connectivity: 8 (default) or 4 (the paper's).
        seed: seed of the draws R and of the endpoints.
    """
    shape, endpoints = _shape(shape, 2), _checks.integer("endpoints", endpoints, low=1)
    connectivity = _connectivity(connectivity)
    alphas = _entries("alphas", alphas, "exponents", lambda a: _checks.finite("alphas", a))
    for a in alphas:
        if not a > 0:
            raise ValueError(f"Expected every entry of 'alphas' > 0, but got {a!r}")
        _w.Power(alpha=a, seed=_checks.seed32(seed))  # (its bound on the largest weight)
    h, w = shape
    ends = _endpoints_in("endpoints", endpoints, "above the root of", shape, lambda: _ep.random(
        shape, endpoints, seed=seed, within=_ep.Box((1, 1), (int(0.85 * h), w - 2)),
        min_spacing=_spacing(shape, endpoints)))
    dens = {a: trace(shortest_paths(Lattice(shape, connectivity, weights=_w.Power(alpha=a, seed=seed)),
                                    [[h - 2, w // 2]]), ends) for a in alphas}
    labels = [f"alpha = {a:g}" for a in alphas]
    return Result(_tile([_drawing(d, 1.3) for d in dens.values()], len(alphas), labels), dens[alphas[0]],
                  parts={"dendrites": dens, "labels": labels})


def cheap_paths(shape=(200, 200), *, factors=(1.0, 0.8, 0.6, 0.3), former: int = 4, added: int = 24,
                connectivity: int = 8, seed: int = 0) -> Result:
    """Later paths attaching to former ones whose edges cost D times as much, for each D (thesis section 3.3.2, Fig. 3.14).

    The thesis multiplies the weights of the former dendrite's edges by a decreasing factor D ("the
    new edge weight W_new = W x D") and shows "paths obtained with D=1, 0.8, 0.6, 0.3": "when D
    decreases from 1 to 0.3, the added paths attach to the former structure more eagerly and the
    paths look more outspread". Here a generator at the centre first reaches ``former``
    endpoints at a path cost d (set so that they lie about 85 % of the way to the border), drawn
    in black; then ``added`` endpoints at cost d / 2 from that structure are traced, in colour,
    over the lattice whose former edges cost D times their weight (:func:`~wdendrite.grow`'s cheap
    former paths). Every panel has the same weights, former paths and added endpoints, and is
    labelled with its D. The thesis' weights are ``W = 1 + alpha R`` with alpha in 10-100 (10 here)
    on a four-connected lattice; the default is 8-connected, as :func:`power_weights` explains.

    Args:
        shape: lattice shape (H, W) of each panel.
        factors: weight factors D of the former edges, one panel each (each in (0, 1]).
        former: endpoints of the former paths.
        added: endpoints of the later paths (about as many; fewer where the band holds fewer).
        connectivity: 8 (default) or 4 (the thesis').
        seed: seed of the weights and the endpoints.
    """
    shape, connectivity = _shape(shape, 2), _connectivity(connectivity)
    former, added = _checks.integer("former", former, low=1), _checks.integer("added", added, low=1)
    factors = _entries("factors", factors, "weight factors D", lambda f: _checks.finite("factors", f))
    for f in factors:
        if not 0 < f <= 1:
            raise ValueError(f"Expected every entry of 'factors' in (0, 1], but got {f!r}")
        FractalParams(count=former, d=2.0, alpha=2.0, beta=added / former, epsilon=0.5, cheap=f)
    h, w = shape
    lat = Lattice(shape, connectivity, weights=_w.Uniform(r=10, seed=seed))
    centre = (h // 2, w // 2)
    d = _REACH * min(h, w) / 2 * _cost_per_node(lat, centre, min(h, w) / 2)
    dens, panels = {}, []
    for f in factors:
        den = grow(lat, [centre], FractalParams(count=former, d=d, alpha=2.0, beta=added / former, epsilon=d / 3,
                                                cheap=f), seed=seed)
        dens[f] = den
        new = (den.generation > 0).astype(np.float32)
        rust = np.array([0.2, 0.75, 0.9], np.float32)  # light each later stroke takes away (a rust red)
        img = 1.0 - _r.strokes(den, 2.2, ink=1.0 - new)[..., None] - _r.strokes(den, 1.3, ink=new)[..., None] * rust
        panels.append(np.clip(img, 0.0, 1.0))
    labels = [f"D = {f:g}" for f in factors]
    return Result(_tile(panels, 2, labels), dens[factors[0]], parts={"dendrites": dens, "labels": labels})


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
    connectivity = _connectivity(connectivity)
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
        if (den.label == k).any():
            img -= _r.strokes(den, 1.8, ink=(den.label == k).astype(np.float32))[..., None] * (1.0 - c)
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


def lightning(shape=(600, 600), *, params: LightningParams = LightningParams(), seed: int = 0) -> Result:
    """Forked lightning made of two graphs (constructive path planning, Figs. 3, 4, 9; thesis Fig. 4.11).

    The first graph (power weights, alpha = 3) holds the main channel, from a
    generator at the top to an endpoint at the bottom, thick and of nearly
    constant width, and a few side branches; the second, with other weights,
    holds only side branches, whose endpoints lie near the channel and low in
    the picture. Branches join the structure above their endpoints and never
    run alongside it (see :mod:`wdendrite.lightning`), so the bolt is one tree.
    Brightness is ``exp(-(d/T)^2)`` of the path cost ``d`` from the strokes
    (``params.metric = "euclidean"`` gives smooth strokes), ``T`` tapered by
    eq. 2; a blurred halo is optional (``glow_gain``). ``parts`` holds the main
    channel ``"main"``, the ``"graph"`` of every node (0 main channel, 1 the first
    graph's branches, 2 the second's), the ``"widths"``, the brightness
    ``"value"``, the halo ``"glow"`` and the ``"lattices"``.
    """
    shape = _shape(shape, 2)
    if not isinstance(params, LightningParams):
        raise TypeError(f"Expected LightningParams for 'params', but got {type(params).__name__}")
    made = _lightning.strike(shape, params, seed)
    den = made["dendrite"]
    return Result(made["image"], den, parts={"main": made["main"], "graph": den.generation, "widths": made["widths"],
                                             "value": made["value"], "glow": made["glow"],
                                             "lattices": made["lattices"]})


_STROKE_MAX = 2.0
"""Upper end of R in the figures of widths, whose weights are ``R^3``: see :func:`width_demo`."""


def _one_path(shape, weights) -> tuple[Dendrite, Lattice]:
    lat = Lattice(shape, 8, weights=weights)
    den = trace(shortest_paths(lat, [[4, shape[1] // 2]]), [[shape[0] - 5, shape[1] // 2]])
    return den, lat


def width_demo(shape=(200, 120), *, seed: int = 0) -> Result:
    """One stroke at the papers' widths, brightness by path cost (constructive path planning Fig. 3, thesis Fig. 4.9).

    Constructive path planning: "For a pixel at distance d, and a thickness factor T, we compute a
    brightness value V as V = exp(-(d/T)^2)", d "the path cost found by Dijkstra's algorithm";
    Fig. 3 shows "a wider one (T = 5.0) and a narrower one (T = 1.6)", the thicker with "a weak
    halo around it, obtained without additional computation", on its lightning's power weights
    ``R^alpha``, alpha = 3. The paper gives T in path cost units but not R's range; R spans (1, 2)
    here, so edges cost 1 to 8 and T = 5.0 spans a few pixels, with a ragged halo where cheap edges
    lead away (with R up to 11 both strokes would be one pixel wide). The thesis (Figs. 4.8-4.9):
    ``V = exp(-a (c(N) Ts)^2)`` with "α around 1/10000", width factors Ts = 0.6 and 0.2 (a smaller
    factor, a wider path), and "all the pixel intensities above 0.7 as 1", on weights
    ``W = 1 + alpha R`` with alpha = 100, over its own stroke. Panels, labelled: T = 5.0, T = 1.6,
    Ts = 0.6, Ts = 0.2.
    """
    shape = _shape(shape, 2)
    den, lat = _one_path(shape, _w.Power(alpha=3.0, max=_STROKE_MAX, seed=seed))
    thesis_den, thesis_lat = _one_path(shape, _w.Uniform(r=100.0, seed=seed))
    values = [_r.brightness(den, t, metric="path", lattice=lat) for t in (5.0, 1.6)]
    values += [_r.brightness(thesis_den, _r.thesis_width(k), metric="path", lattice=thesis_lat, clamp=0.7)
               for k in (0.6, 0.2)]
    panels = [_r.colorize(v, colormap="lightning") for v in values]
    labels = ["T = 5.0", "T = 1.6", "Ts = 0.6", "Ts = 0.2"]
    return Result(_tile(panels, 4, labels), den, parts={"values": values, "thesis_dendrite": thesis_den,
                                                        "lattices": (lat, thesis_lat), "labels": labels})


def taper_demo(shape=(200, 200), *, start: float = 5.0, end: float = 0.8, beta: float = 1.0, endpoints: int = 6,
               seed: int = 0) -> Result:
    """Constant width next to tapering by eq. 2 along each path and along each branch (constructive path planning Fig. 4).

    Eq. 2: ``T_i = Ts (1 - (d_i/d_max)^beta) + Tf (d_i/d_max)^beta`` with ``d_i`` the path cost at
    point i ("for the lightning, we used β = 1"). As :func:`width_demo`, brightness falls off with
    the path cost from the strokes over their own weights ``R^3``, R in (1, 2), so widths are in
    path cost units. Panels, labelled: constant T = ``start``; eq. 2 from the generator to each
    path's tip; eq. 2 along each branch (every side branch starts again at ``start``, as wide as
    where it leaves allows).

    Args:
        shape: lattice shape (H, W).
        start: width Ts where a path (or branch) starts; also the constant panel's width (path cost).
        end: width Tf at its farthest tip (path cost).
        beta: shape of the taper ``u^beta`` (> 0; 1: linear in path cost).
        endpoints: number of endpoints, drawn in the lower half.
        seed: seed of the weights and the endpoints.
    """
    shape, endpoints = _shape(shape, 2), _checks.integer("endpoints", endpoints, low=1)
    widths = [start, _r.Taper(start, end, beta, along="path"), _r.Taper(start, end, beta, along="branch")]
    lat = Lattice(shape, 8, weights=_w.Power(alpha=3.0, max=_STROKE_MAX, seed=seed))
    cf = shortest_paths(lat, [[3, shape[1] // 2]])
    ep = _endpoints_in("endpoints", endpoints, "in the lower half of", shape, lambda: _ep.biased(
        lat, endpoints, seed=seed, power=2.0, within=_ep.Box((shape[0] // 2, 2), (shape[0] - 3, shape[1] - 3))))
    den = trace(cf, ep)
    values = [_r.brightness(den, wd_, metric="path", lattice=lat) for wd_ in widths]
    panels = [_r.colorize(v, colormap="lightning") for v in values]
    labels = [f"T = {start:g}", "eq. 2 along each path", "eq. 2 along each branch"]
    return Result(_tile(panels, 3, labels), den, parts={"values": values, "lattice": lat, "labels": labels})


# --------------------------------------------------------------------------- 3D models


_GEOMETRIES = ("smooth", "spheres", "tubes", "isosurface")

_SIGMA = 2.0
"""Width (lattice nodes) of the Gaussian that smooths the 3D presets' centre lines: their turning
angle between samples one node apart stays below 25 degrees at the 95th percentile."""


# spheres this far apart (a body diagonal) touch when their radius is at least half of it
_MIN_SPHERE_RADIUS = 0.5 * 3**0.5


def _tree_mesh(den: Dendrite, radius, side, geometry: str, voxel: float):
    """The branches' mesh and, for ``"smooth"``, their centre lines (else None)."""
    if geometry == "smooth":
        return _scenes.smooth_body(den, radius, side=side, voxel=voxel, sigma=_SIGMA * den.spacing)
    if geometry == "spheres":
        return _geo.spheres(den, np.maximum(_r.node_widths(den, radius, side=side), _MIN_SPHERE_RADIUS)), None
    if geometry == "tubes":
        return _geo.tubes(den, radius, side=side), None
    if geometry == "isosurface":
        return _geo.isosurface(den, radius, side=side, smooth=5), None
    raise ValueError(f"Expected 'geometry' in {_GEOMETRIES}, but got {geometry!r}")


def elm_tree(shape=(80, 80, 80), *, endpoints: int = 17,
             geometry: Literal["smooth", "tubes", "spheres", "isosurface"] = "smooth", seed: int = 0) -> Result:
    """An elm-like tree: winding branches spreading from a root into a wide crown, tapered
    (constructive path planning Figs. 6-8: 80^3 lattice, 20 and 36 endpoints, taper beta 0.3 main / 0.2 small;
    17 endpoints as in thesis Table 5.1). The default, ``"smooth"``, meshes the branches' smooth
    centre lines (:mod:`wdendrite.skeleton`, the lattice only a guide) as one closed body
    (:func:`wdendrite.geometry.skeleton_mesh`), its twigs at least half a node (1/160 of the tree's
    height) thick; ``parts["skeleton"]`` holds the centre lines. The paper draws a sphere at each node
    (``"spheres"``, at least 0.87 nodes wide so that diagonal neighbours touch); ``"tubes"`` and
    ``"isosurface"`` (at least 0.6, :data:`wdendrite.geometry.MIN_ISO_RADIUS`) follow the lattice
    path too."""
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
    mesh, lines = _tree_mesh(den, radius, side, geometry, voxel=0.5 * scale)
    return Result(_geo.preview(mesh, color=_WOOD, elevation=10), den, mesh,
                  parts={"lattice": lat, "skeleton": lines})


def tropism_objects(shape=(60, 60, 60), *, toward=("axis", "away_from_axis", "top"), strength: float = 3.0,
                    endpoints: int = 24, seed: int = 0) -> Result:
    """3D objects from spatially varying weights (constructive path planning Fig. 5): the same endpoints, biased
    toward a vertical axis, away from it, or upward; weights depend on the horizontal distance ``sqrt(x^2 + y^2)``.
    Each object is one closed body around its smooth centre lines (as :func:`elm_tree`)."""
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
        mesh, _ = _scenes.smooth_body(den, _r.Taper(1.6 * d / 60, 0.4 * d / 60, along="path"), voxel=0.4 * d / 60,
                                      sigma=_SIGMA)
        dens[t], meshes[t] = den, mesh
        pics.append(_geo.preview(mesh, size=(320, 320), color=_WOOD, elevation=10))
    labels = [_toward_words(t) for t in toward]
    return Result(_tile(pics, len(pics), labels), dens[toward[0]], meshes[toward[0]], parts={"dendrites": dens,
                                                                                     "meshes": meshes,
                                                                                     "labels": labels})


def staghorn_coral(shape=(50, 50, 50), *, endpoints: int = 24, refine_n: int | None = 7, seed: int = 0) -> Result:
    """Staghorn coral: branches from a base to endpoints placed over a dome, refined for detail
    (2007 paper, Fig. 12 and Table 1: 50^3, 11 endpoints, or 24 with refinement), then meshed as one
    closed body around the refined dendrite's smooth centre lines (``parts["skeleton"]``; the paper
    puts a sphere at each node). ``refine_n`` = 7 is the thesis' smallest sublattice (section 4.4:
    7, 9 or 15, with ``e`` = 0.75 in its 0.5 < e < 1); 0 or None skips refinement.
    ``parts["coarse"]`` is the dendrite before refinement."""
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
        den, _ = refine(den, lat, n=refine_n, e=0.75, seed=seed)
    scale = d / 50.0
    # (the smoothing width in the coarse lattice's nodes: refinement adds detail below it)
    mesh, lines = _scenes.smooth_body(den, _r.Taper(1.6 * scale, 0.7 * scale, along="path"), voxel=0.4 * scale,
                                      sigma=_SIGMA)
    return Result(_geo.preview(mesh, color=_CORAL, elevation=15), den, mesh,
                  parts={"coarse": coarse, "lattice": lat, "skeleton": lines})


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


def lichen_cluster(shape=(256, 256), *, count: int = 8, bands=(2.5, 8.0), density=(0.9, 0.55),
                   seed: int = 0) -> Result:
    """A lichen cluster by cost bands (thesis section 5.4, Fig. 5.4 bottom, in 2D): a fractal dendrite
    grown from the centre; its nodes become generators, and the nodes whose path cost from it lies
    between two isocontours are one kind of lichen's particles, each kept with the band's density:
    orange close to the dendrite, grey-green embracing it. Particles are drawn as crusty, shaded
    patches on a stone. ``parts["kind"]`` holds the kind of every node (0: bare), ``parts["cost"]``
    the path costs from the dendrite.

    Args:
        shape: lattice shape (H, W).
        count: endpoints of the dendrite's first growth iteration (three iterations, alpha 1.5, beta 3).
        bands: outer edges of the bands, in lattice nodes of path cost (the lattice's median cost per
            node), increasing; the first band starts at the dendrite.
        density: share of each band's nodes that carry lichen, in (0, 1].
        seed: seed of the weights, the endpoints and the particles.
    """
    shape, count = _shape(shape, 2), _checks.integer("count", count, low=1)
    edges, dens = _scenes.check_bands(bands, density)
    _checks.seed32(seed)
    h, w = shape
    lat = Lattice(shape, 8, weights=_w.Uniform(r=10, seed=seed))
    centre = (h // 2, w // 2)
    per_node = _cost_per_node(lat, centre, min(shape) // 2)
    # the dendrite's tips stay clear of the border by the outer band
    half = max(int(min(shape) // 2 - edges[-1] - 2), 4)
    den = grow(lat, [centre], _fractal_params(half, per_node, 1.5, 3.0, 3, count), seed=seed)
    kind, cost = _scenes.cost_bands(lat, den.nodes, edges, per_node, dens, seed)
    img = _scenes.crust_picture(kind, _scenes.LICHEN_KINDS[: len(edges)], _ROCK, seed)
    return Result(img, den, parts={"kind": kind, "cost": cost, "lattice": lat})


lichen_cluster.units = {"bands": "nodes", "density": "fraction"}


def lichen_on_rock(shape=(128, 128, 128), *, neighbours: int = 14, count: int = 4, bands=(1.0, 3.5),
                   density=(0.9, 0.6), on_rock: bool = True, seed: int = 0) -> Result:
    """Lichen grown over a rock, as a cluster of crusty patches (2007 paper, Fig. 16 and Table 2:
    128^3; thesis section 5.4, Fig. 5.4 bottom, in 3D). A fractal dendrite grows over the rock's
    surface nodes (generator and endpoints on them); then the surface nodes whose path cost along
    the surface from the dendrite lies in a band become one kind of lichen's particles, each kept
    with the band's density (orange near the dendrite, grey-green around it). The rock (its region,
    smoothed), the dendrite's smooth ropes and a crust over the rock where the particles are (a
    layer 0.45 or 0.3 nodes thick at a patch's rim, thicker inside) are meshed as one closed body
    with vertex colours. ``parts``: ``"kind"`` per node (0: bare),
    ``"crust"`` the particles' nodes, ``"skeleton"`` the ropes' centre lines, ``"rock_field"`` the
    signed field whose zero level is the rock.

    Args:
        shape: lattice shape (D, H, W).
        neighbours: generators around the rock's that shape it.
        count: endpoints of the dendrite's first growth iteration (three iterations, alpha 1.5, beta 3).
        bands: outer edges of the bands, in lattice nodes of path cost along the surface, increasing.
        density: share of each band's surface nodes that carry lichen, in (0, 1].
        on_rock: keep the dendrite's paths on the surface nodes; False lets them leave the surface
            (never entering the rock) and come back, as in the 2007 paper's Fig. 16.
        seed: seed of the rock, the weights, the endpoints and the particles.
    """
    from scipy.ndimage import gaussian_filter

    shape, neighbours = _shape(shape, 3), _checks.integer("neighbours", neighbours, low=4)
    count = _checks.integer("count", count, low=1)
    edges, dens = _scenes.check_bands(bands, density)
    on_rock = _checks.flag("on_rock", on_rock)
    lat, cf = _rock_field(shape, neighbours, seed)
    inside = cf.label == 0
    surf = _geo.surface_nodes(inside)
    on_surface = np.zeros(shape, bool)
    on_surface[tuple(surf.T)] = True
    allowed = ~inside | on_surface
    weights = _w.Uniform(r=10, seed=(seed + 1) % 2**32)
    lichen_lat = Lattice(shape, 26, weights=weights, mask=on_surface if on_rock else allowed)
    top = surf[np.argmax(surf[:, 0] - 0.3 * np.abs(surf[:, 1:] - np.asarray(shape[1:]) / 2).sum(axis=1))]
    p = _fractal_params(int(0.22 * min(shape)), 6.0, 1.5, 3.0, 3, count)  # (paths over the rock's surface)
    den = grow(lichen_lat, [top], p, seed=seed, within=on_surface)
    # the bands: path costs along the surface only, from the dendrite's nodes on it
    skin = Lattice(shape, 26, weights=weights, mask=on_surface)
    on = den.nodes[on_surface[tuple(den.nodes.T)]]
    per_node = _cost_per_node(Lattice((17, 17, 17), 26, weights=weights), (8, 8, 8), 8)
    kind, _ = _scenes.cost_bands(skin, on, edges, per_node, dens, seed)
    crust = np.argwhere(kind > 0)
    scale = min(shape) / 128.0
    rope = _r.Taper(0.5 * scale + 0.35, 0.2 * scale + 0.3, along="path")
    lines = _centre_lines(den, rope, sigma=_SIGMA, min_radius=0.5)
    rock_field = gaussian_filter(_geo.signed_region_field(inside, band=3.0), 0.7)
    mesh, _ = _scenes.crust_body(rock_field, lines, crust, kind[tuple(crust.T)], _scenes.LICHEN_KINDS, _ROCK,
                                 grain=1.3, thickness=(0.45, 0.3), voxel=0.5, seed=seed)
    img = _geo.preview(mesh, elevation=35)
    return Result(img, den, mesh, parts={"kind": kind, "crust": crust, "skeleton": lines, "rock_field": rock_field,
                                         "costfield": cf, "lattice": lichen_lat})


lichen_on_rock.units = {"bands": "nodes", "density": "fraction"}


def moss(shape=(40, 96, 96), *, endpoints: int | None = None, image: np.ndarray | None = None,
         seed: int = 0) -> Result:
    """Moss: many strands grown up from a ground plane of generators (2007 paper, Fig. 15: "a mossy
    version of the peppers image"), each strand smooth and coloured from ``image`` at its root, on a
    ground that shows the same picture; strands and ground are one closed body with vertex colours.

    Args:
        shape: lattice shape (D, H, W).
        endpoints: number of endpoints (default: 800 at the default shape, a dense cushion, in
            proportion to the volume elsewhere).
        image: ``(h, w, 3)`` RGB picture (floats in [0, 1] or 8-bit), stretched over the ground
            (rows along the lattice's H axis); default: a procedural mossy picture of greens.
        seed: seed of the weights, the endpoints and the default picture.
    """
    shape = _shape(shape, 3)
    d, h, w = shape
    if endpoints is None:
        endpoints = max(1, round(800 * d * h * w / (40 * 96 * 96)))
    endpoints = _checks.integer("endpoints", endpoints, low=1)
    picture = _scenes.moss_image((h, w), _checks.seed32(seed)) if image is None else _scenes.image_rgb("image", image)
    lat = Lattice(shape, 26, weights=_w.Uniform(r=10, seed=seed))
    yy, xx = np.mgrid[:h, :w]
    plane = np.stack([np.zeros(h * w, np.int64), yy.ravel(), xx.ravel()], axis=1)
    band = _ep.Box((0.35 * d, 1, 1), (0.9 * d, h - 2, w - 2))
    ends = _endpoints_in("endpoints", endpoints, "in the band above the plane of", shape,
                         lambda: _ep.random(lat, endpoints, within=band, seed=seed, min_spacing=2.0))
    den = trace(shortest_paths(lat, plane), ends)
    mesh, lines = _scenes.moss_body(den, _r.Taper(0.55, 0.3, along="path"), picture, voxel=0.4, sigma=_SIGMA)
    return Result(_geo.preview(mesh, elevation=40), den, mesh, parts={"lattice": lat, "skeleton": lines,
                                                                       "image": picture})


from ._spec import document_fields as _document_fields  # noqa: E402  (the classes above are complete)

_document_fields(__name__)  # help() shows what each dataclass field means
