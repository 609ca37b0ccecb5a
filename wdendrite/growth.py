"""Fractal growth of dendrites (Xu thesis section 3.3.2, Fig 3.12) and competition."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import _checks
from . import endpoints as _endpoints
from .dendrite import Dendrite, trace
from .lattice import Lattice
from .sssp import CostField, shortest_paths

__all__ = ["FractalParams", "grow", "lower_dendrite_weights"]


@dataclass(frozen=True)
class FractalParams:
    """Parameters of fractal growth (thesis Fig 3.12).

    Each iteration places ``count`` endpoints whose path cost from the
    current dendrite lies in ``(d - r, d + r)`` and traces them to it; then
    ``count *= beta`` and ``d /= alpha``, while ``d > epsilon``.
    """

    count: int = 8
    """m: endpoints in the first iteration, >= 1."""
    d: float = 400.0
    """Path cost (weight units) of the first iteration's endpoints, > 0."""
    alpha: float = 1.5
    """Attenuation: ``d`` is divided by it each iteration, > 1 (the thesis shows 2, 1.5, 1.2)."""
    beta: float = 3.0
    """Branching: ``count`` is multiplied by it each iteration, >= 1 (the thesis shows 2, 3, 4)."""
    epsilon: float = 20.0
    """Growth stops once ``d <= epsilon``, > 0."""
    r: float | None = None
    """Half-width of the cost band in weight units, > 0 (default: ``d / 10``)."""
    cheap: float = 0.0
    """D, the weight factor of the dendrite's own edges, in [0, 1]. 0 makes the
    dendrite the new generator set ("new generators"); 0 < D <= 1 keeps the
    first generators and multiplies the dendrite's edges by D ("cheap former paths")."""
    min_spacing: float | None = None
    """Least distance between endpoints drawn in one iteration (nodes), or None."""

    def __post_init__(self):
        if isinstance(self.count, bool) or not isinstance(self.count, (int, np.integer)) or self.count < 1:
            raise ValueError(f"Expected an integer 'count' >= 1, but got {self.count!r}")
        _checks.positive("d", self.d)
        alpha = _checks.positive("alpha", self.alpha)
        if alpha <= 1:
            raise ValueError(f"'alpha' must be > 1 so that d shrinks and growth ends, but got {self.alpha!r}")
        if _checks.nonnegative("beta", self.beta, allow_none=False) < 1:
            raise ValueError(f"'beta' must be >= 1 (the endpoint count never shrinks), but got {self.beta!r}")
        _checks.positive("epsilon", self.epsilon)
        if self.r is not None:
            _checks.positive("r", self.r)
        if self.min_spacing is not None:
            _checks.positive("min_spacing", self.min_spacing)
        cheap = _checks.nonnegative("cheap", self.cheap, allow_none=False)
        if cheap > 1:
            raise ValueError(f"Expected 'cheap' (D) in [0, 1], but got {self.cheap!r}")

    @property
    def band(self) -> float:
        """The band half-width r in use."""
        return self.d / 10.0 if self.r is None else float(self.r)

    def schedule(self) -> list[tuple[int, float]]:
        """``(count, d)`` of every iteration, in order."""
        out, m, d = [], float(self.count), float(self.d)
        while d > self.epsilon:
            out.append((int(round(m)), d))
            m, d = m * self.beta, d / self.alpha
        return out


def lower_dendrite_weights(lattice: Lattice, dendrite: Dendrite, factor: float, rows=None) -> Lattice:
    """A lattice whose edges along ``dendrite`` (node to parent) cost ``factor`` times as much.

    Args:
        lattice: the lattice the dendrite lives on.
        dendrite: its edges are the pairs (row, parent[row]).
        factor: multiplier in (0, 1] (weights must stay positive).
        rows: only the edges leaving these rows (default: all).
    """
    factor = _checks.positive("factor", factor)
    rows = np.arange(len(dendrite)) if rows is None else np.asarray(rows, dtype=np.int64)
    rows = rows[dendrite.parent[rows] >= 0]
    a, b = dendrite.nodes[rows], dendrite.nodes[dendrite.parent[rows]]
    w = lattice.weights.copy()
    step = b - a
    for k, off in enumerate(lattice.offsets):
        fwd = np.all(step == off, axis=1)
        bwd = np.all(step == -off, axis=1)
        # the weight of an undirected edge is stored at its lower end
        lower = np.concatenate([a[fwd], b[bwd]])
        idx = (np.full(len(lower), k),) + tuple(lower.T)
        w[idx] = w[idx] * np.float32(factor)
    return lattice.with_weights(w)


def _relabel(den: Dendrite, first: int, n_gens: int) -> Dendrite:
    """Map labels that name dendrite rows (new-generators mode) back to the first generators.

    New rows (from ``first`` on) point at older rows, whose labels are already mapped.
    """
    label = den.label.copy()
    new = label[first:]
    via_node = new >= n_gens
    new[via_node] = den.label[new[via_node] - n_gens]
    label[first:] = new
    return dataclasses.replace(den, label=label)


def _band_endpoints(cf: CostField, m: int, d: float, r: float, rng, within, min_spacing):
    """Up to ``m`` endpoints in the cost band, fewer when the band (inside ``within``,
    ``min_spacing`` apart) cannot hold that many; None when it holds none."""
    lattice = cf.lattice
    cand, why = _endpoints._band_candidates(cf, lattice.shape, lattice.mask, d, r, within)
    n = min(m, len(cand))
    while n > 0:
        try:
            return _endpoints._sample(lattice.shape, cand, n, rng, None, min_spacing, why)
        except ValueError:
            if min_spacing is None:
                raise
            n //= 2  # the spacing leaves room for fewer: ask for half as many
    return None


def grow(
    lattice: Lattice,
    generators,
    params: FractalParams = FractalParams(),
    *,
    seed: int | np.random.Generator = 0,
    device=None,
    start: Dendrite | None = None,
    within=None,
    progress: bool | Callable[[int, int, Dendrite], None] = False,
) -> Dendrite:
    """Grow a fractal dendrite from ``generators`` (thesis Fig 3.12).

    Each iteration draws endpoints in a cost band around the current dendrite,
    traces them to it, and updates the cost field with a warm start: the
    dendrite's nodes become generators (``params.cheap == 0``) or its edges get
    cheaper (``0 < cheap <= 1``). Costs are searched only up to the
    iteration's ``d + r``.

    Several generators grow competing dendrites: every node's ``label`` names
    the generator whose dendrite it belongs to, and the dendrites never share
    a node.

    Args:
        lattice: the weighted lattice.
        generators: ``(G, ndim)`` integer generator coordinates.
        params: the growth schedule.
        seed: int or ``np.random.Generator`` for the endpoint draws.
        device: Warp device (default: Warp's default device).
        start: an initial dendrite on the same lattice (e.g. hand-placed main
            paths) to grow from; its labels must index ``generators``.
        within: optional region (bool mask or an :mod:`wdendrite.endpoints`
            shape) endpoints must lie in.
        progress: True shows a tqdm bar; a callable gets
            ``(iteration, iterations, dendrite)`` after each iteration.

    Returns:
        The grown :class:`Dendrite`; ``generation`` numbers the iterations.
    """
    if not isinstance(lattice, Lattice):
        raise TypeError(f"Expected a wdendrite.Lattice for 'lattice', but got {type(lattice).__name__}")
    if not isinstance(params, FractalParams):
        raise TypeError(f"Expected FractalParams for 'params', but got {type(params).__name__}")
    gens = _checks.node_coordinates("generators", generators, lattice.shape, lattice.mask)
    rng = np.random.default_rng(seed)
    plan = params.schedule()
    r = params.band
    new_generators = params.cheap == 0.0
    bar = None
    if progress is True:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(plan), desc="growing", unit="iteration")

    den = start
    # cheap former paths change stored weights, so a hashed lattice gets its array once
    base_lat = lattice if new_generators or lattice.stores_weights else lattice.with_weights(lattice.weights)
    lat = base_lat
    if start is not None and not new_generators:
        lat = lower_dendrite_weights(base_lat, start, params.cheap)
    cf: CostField | None = None
    for it, (m, d) in enumerate(plan):
        if cf is None:
            base = gens if not (new_generators and den is not None) else np.concatenate([gens, den.nodes])
            cf = shortest_paths(lat, base, limit=d + r, device=device)
        ep = _band_endpoints(cf, m, d, r, rng, within, params.min_spacing)
        if ep is not None:
            first = 0 if den is None else len(den)
            den = trace(cf, ep, extend=den, generation=it, _drawn=True)
            if new_generators:
                den = _relabel(den, first, len(gens))
            if it + 1 < len(plan):
                # the next band lies below the next limit: nothing beyond it is searched
                limit = plan[it + 1][1] + r
                # the last cost field is not read again: the search may reuse its memory
                if new_generators:
                    # the new generators are the rows this iteration's walks added
                    cf = shortest_paths(lat, np.concatenate([gens, den.nodes]), limit=limit, warm_start=cf,
                                        _consume_warm_start=True, _walked=den._padded[first:])
                else:
                    lat = lower_dendrite_weights(base_lat, den, params.cheap)
                    cf = shortest_paths(lat, gens, limit=limit, warm_start=cf, _consume_warm_start=True)
        if bar is not None:
            bar.update(1)
        elif callable(progress):
            progress(it + 1, len(plan), den)
    if bar is not None:
        bar.close()
    if den is None:
        raise ValueError(
            f"no node has a path cost in any band (d - r, d + r) of the schedule {plan} with r = {r:g}; "
            "lower 'd' or raise 'r'"
        )
    return den

