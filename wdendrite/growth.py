"""Fractal growth of dendrites (Xu thesis section 3.3.2, Fig 3.12) and competition."""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import _checks
from . import endpoints as _endpoints
from .dendrite import Dendrite, _trace
from .lattice import Lattice
from .sssp import CostField, _search, load_state, read_states, shortest_paths

__all__ = ["FractalParams", "grow", "lower_dendrite_weights"]


@dataclass(frozen=True)
class FractalParams:
    """Parameters of fractal growth (thesis Fig 3.12).

    Each iteration places ``count`` endpoints whose path cost from the
    current dendrite lies in ``(d - r, d + r)`` and traces them to it; then
    ``count *= beta`` and ``d /= alpha``, while ``d > epsilon``. The band
    never reaches below cost 0 (``(max(d - r, 0), d + r)``, once ``d < r``)
    and never offers the dendrite's own nodes.
    """

    count: int = 8
    """m: endpoints in the first iteration, >= 1."""
    d: float = 400.0
    """Path cost (weight units) of the first iteration's endpoints, > 0. It is absolute: scale it to
    the lattice. The first tips lie about ``d / c`` nodes from the generators, with ``c`` the least
    path cost per node (below the mean edge weight, since least paths pick cheap edges: about 3.1
    on 8-connected and 4.8 on 4-connected ``Uniform(r=10)`` lattices, whose mean weight is 6). So
    the default reaches about 130 nodes out on the former. A ``d`` near or beyond the lattice's
    largest costs fills it with branches; where no band meets a node, :func:`grow`'s error gives
    the costs there are. The ``fractal`` preset measures ``c`` and sets ``d`` from the lattice's size."""
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
    first generators and multiplies the dendrite's edges by D ("cheap former
    paths"): endpoints are still drawn by their cost from the dendrite, and their
    paths lead to the first generators, joining the dendrite where it is cheap
    enough to follow. Every dendrite edge costs D times its own weight, whatever
    iteration made it (the thesis' "iteratively decreasing" could also be read as
    D^k for edges k iterations old)."""
    min_spacing: float | None = None
    """Least distance between endpoints drawn in one iteration (nodes), or None. An
    iteration whose band cannot hold ``count`` endpoints that far apart takes as many as
    fit (candidates tried once each, in random order)."""

    MAX_ITERATIONS = 1000
    """Schedules longer than this are refused: they come from an ``alpha`` so close to 1
    that ``d`` barely shrinks, not from any growth a lattice could hold."""

    def __post_init__(self):
        # every field is checked, then stored as a plain Python value (so the parameters hash,
        # compare and print as written, and go into JSON records, whatever NumPy scalars they were)
        put = functools.partial(object.__setattr__, self)
        if isinstance(self.count, bool) or not isinstance(self.count, (int, np.integer)) or self.count < 1:
            raise ValueError(f"Expected an integer 'count' >= 1, but got {self.count!r}")
        put("count", int(self.count))
        put("d", _checks.positive("d", self.d))
        alpha = _checks.positive("alpha", self.alpha)
        if alpha <= 1:
            raise ValueError(f"'alpha' must be > 1 so that d shrinks and growth ends, but got {self.alpha!r}")
        put("alpha", alpha)
        if _checks.nonnegative("beta", self.beta, allow_none=False) < 1:
            raise ValueError(f"'beta' must be >= 1 (the endpoint count never shrinks), but got {self.beta!r}")
        put("beta", float(self.beta))
        put("epsilon", _checks.positive("epsilon", self.epsilon))
        if self.r is not None:
            put("r", _checks.positive("r", self.r))
        if self.min_spacing is not None:
            put("min_spacing", _checks.positive("min_spacing", self.min_spacing))
        cheap = _checks.nonnegative("cheap", self.cheap, allow_none=False)
        if cheap > 1:
            raise ValueError(f"Expected 'cheap' (D) in [0, 1], but got {self.cheap!r}")
        _check_factor("cheap", cheap, "use 0 for new generators, or a larger D")
        put("cheap", cheap)
        if not float(self.d) > float(self.epsilon):
            raise ValueError(
                f"'d' ({self.d!r}) must exceed 'epsilon' ({self.epsilon!r}): growth runs while d > epsilon, "
                "so this schedule has no iteration"
            )
        # the schedule's own loop, stopped as soon as it runs too long or asks for too much
        # (the length is checked first: an alpha near 1 is the cause even when counts overflow sooner)
        about = (math.log(float(self.d)) - math.log(float(self.epsilon))) / math.log(alpha)
        m, d, iterations = float(self.count), float(self.d), 0
        while d > self.epsilon:
            iterations += 1
            if iterations > self.MAX_ITERATIONS or about > self.MAX_ITERATIONS + 1:
                raise ValueError(
                    f"'alpha' = {self.alpha!r} shrinks 'd' from {self.d!r} to 'epsilon' = {self.epsilon!r} in about "
                    f"{about:.0f} iterations (at most {self.MAX_ITERATIONS}); use a larger 'alpha' (the thesis shows "
                    "1.2-2)"
                )
            if m > 1e15:
                raise ValueError(
                    f"'count' = {self.count!r} times 'beta' = {self.beta!r} to the power {iterations - 1} asks for "
                    f"{m:.3g} endpoints in iteration {iterations} of about {about:.0f} (from 'd' = {self.d!r} down "
                    f"to 'epsilon' = {self.epsilon!r}); lower 'beta' or 'count', or 'd' (or raise 'epsilon')"
                )
            m, d = m * self.beta, d / alpha

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


def _check_factor(name: str, factor: float, hint: str) -> None:
    """Refuse a weight factor so small that float32 weights times it would round to 0."""
    tiny = float(np.finfo(np.float32).tiny)
    if 0 < factor < tiny:
        raise ValueError(f"'{name}' = {factor!r} is below float32's smallest normal number ({tiny:.3g}): the "
                         f"lowered weights would round to 0; {hint}")


def lower_dendrite_weights(lattice: Lattice, dendrite: Dendrite, factor: float, rows=None) -> Lattice:
    """A lattice whose edges along ``dendrite`` (node to parent) cost ``factor`` times as much.

    Args:
        lattice: the lattice the dendrite lives on (stored weights are copied).
        dendrite: its edges are the pairs (row, parent[row]).
        factor: multiplier in (0, 1] (D of the thesis: weights stay positive and never rise).
        rows: only the edges leaving these rows (default: all).

    Returns:
        A new :class:`Lattice` with the same shape, connectivity and mask.

    Raises:
        ValueError: ``factor`` outside (0, 1] or below float32's smallest normal number, a
            dendrite of another lattice shape, or one with a step that is no lattice edge.
    """
    factor = _checks.positive("factor", factor)
    if factor > 1:
        raise ValueError(f"Expected 'factor' in (0, 1], but got {factor!r}: former paths only get cheaper")
    _check_factor("factor", factor, "use a larger factor")
    if tuple(dendrite.shape) != lattice.shape:
        raise ValueError(f"'dendrite' has shape {tuple(dendrite.shape)}, but 'lattice' has shape {lattice.shape}")
    dirs, lower = _dendrite_edges(lattice, dendrite, rows)
    w = lattice.weights.copy()
    idx = (dirs,) + tuple(lower.T)
    w[idx] = w[idx] * np.float32(factor)
    return lattice.with_weights(w)


def _dendrite_edges(lattice: Lattice, dendrite: Dendrite, rows=None, name: str = "dendrite"
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The edges from ``rows`` (default: all) to their parents, row by row (roots left out),
    as ``(dirs, lower)``: the direction of each and the coordinates of its lower end, where
    its weight is stored. A step that is no edge of the lattice is refused, naming ``name``."""
    rows = np.arange(len(dendrite)) if rows is None else np.asarray(rows, dtype=np.int64)
    rows = rows[dendrite.parent[rows] >= 0]
    a, b = dendrite.nodes[rows], dendrite.nodes[dendrite.parent[rows]]
    step = b - a
    dirs = np.full(len(rows), -1, dtype=np.int64)
    lower = a.copy()
    for k, off in enumerate(lattice.offsets):
        dirs[np.all(step == off, axis=1)] = k
        bwd = np.all(step == -off, axis=1)
        dirs[bwd] = k
        lower[bwd] = b[bwd]
    if (dirs < 0).any():
        row = int(rows[np.argmax(dirs < 0)])
        raise ValueError(
            f"'{name}' row {row} = {tuple(dendrite.nodes[row].tolist())} steps to its parent by "
            f"{tuple(step[np.argmax(dirs < 0)].tolist())}, which is no edge of the {lattice.connectivity}-connected "
            "lattice")
    return dirs, lower


def _path_costs(lattice: Lattice, dendrite: Dendrite, name: str, device) -> np.ndarray:
    """float32 path costs of every row from its root along the parents over the weights the
    kernels on ``device`` use, summed from the root outward as a search sums them (so a dendrite
    traced there gets its own costs back, bit for bit)."""
    cost = np.zeros(len(dendrite), np.float32)
    child = np.flatnonzero(dendrite.parent >= 0)
    if not len(child):
        return cost
    dirs, lower = _dendrite_edges(lattice, dendrite, child, name)
    w = lattice._edge_weights(dirs, np.ravel_multi_index(tuple(lower.T), lattice.shape), device=device)
    depth = dendrite.depth[child]
    order = np.argsort(depth, kind="stable")
    cuts = np.flatnonzero(np.diff(depth[order])) + 1
    for level in np.split(order, cuts):  # one step per level, parents first
        rows = child[level]
        cost[rows] = cost[dendrite.parent[rows]] + w[level]
    return cost


def _check_start(start, lattice: Lattice, n_gens: int, device, iterations: int) -> Dendrite:
    """``start`` checked, with its costs recomputed as path costs over ``lattice``."""
    if not isinstance(start, Dendrite):
        raise TypeError(f"Expected a wdendrite.Dendrite for 'start', but got {type(start).__name__}")
    if tuple(start.shape) != lattice.shape:
        raise ValueError(f"'start' has shape {tuple(start.shape)}, but 'lattice' has shape {lattice.shape}")
    if len(start):
        _checks.node_coordinates("start.nodes", start.nodes, lattice.shape, lattice.mask)
        if start.label.min() < 0 or start.label.max() >= n_gens:
            raise ValueError(
                f"'start' labels range over [{start.label.min()}, {start.label.max()}], but they must index the "
                f"{n_gens} 'generators'"
            )
        last = int(start.generation.max()) + iterations  # growth numbers its iterations after the start's
        if last > np.iinfo(np.int32).max:
            raise ValueError(f"'start' has generations up to {int(start.generation.max())}; the {iterations} "
                             f"iterations after them would pass int32's {np.iinfo(np.int32).max}")
    return dataclasses.replace(start, cost=_path_costs(lattice, start, "start", device))


def _field_costs(costs: CostField, padded: np.ndarray) -> np.ndarray:
    """float32 costs of padded nodes in ``costs``, read from the records that hold it."""
    arrays = costs.lattice.device_arrays(costs.device)
    with arrays.stamps.lock:
        load_state(costs, arrays)
        return read_states(arrays, padded, costs.limit)[0]


def _rebase_costs(den: Dendrite, first: int, field_cost_of) -> Dendrite:
    """Make the costs of rows ``first:`` path costs from their first generator.

    A trace stores each new node's cost in the iteration's own field: the cost
    to the dendrite as it was (new generators), or with its edges made cheap.
    Each new branch joins an older row ``a`` (or starts at a generator), so its
    nodes get ``cost[a] + (c - c_a)``, with ``c`` and ``c_a`` their field costs:
    costs then grow from every root outward through all generations, as they
    do along a single trace (rendering tapers by them).

    ``field_cost_of(rows)`` gives the field cost of older rows (0 for new generators).
    """
    parent = den.parent
    # every new row's first older ancestor (or -1 at a root), by pointer jumping over the new rows
    join = parent[first:].copy()
    for _ in range(64):
        inside = np.flatnonzero(join >= first)
        if not len(inside):
            break
        join[inside] = join[join[inside] - first]
    joined = join >= 0
    cost = den.cost.copy()
    new = cost[first:]
    a = join[joined]
    new[joined] = den.cost[a] + (new[joined] - field_cost_of(a))
    cost[first:] = new
    return dataclasses.replace(den, cost=cost)


def _band_endpoints(costs: CostField, m: int, d: float, r: float, rng, within, min_spacing):
    """Up to ``m`` endpoints in the cost band, fewer when the band (inside ``within``,
    ``min_spacing`` apart) cannot hold that many; None when it holds none.

    ``costs`` holds costs from the dendrite (its nodes cost 0). The band never reaches below
    cost 0, so it never offers the dendrite's own nodes: an endpoint there would add no path.
    """
    lattice = costs.lattice
    cand, why = _endpoints._band_candidates(costs, lattice.shape, lattice.mask, max(d - r, 0.0), d + r, within)
    if len(cand) == 0:
        return None
    # in random order, each candidate kept unless a kept one lies within min_spacing: as many as fit
    return _endpoints._sample(lattice.shape, cand, min(m, len(cand)), rng, None, min_spacing, why, partial=True)


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

    Each iteration draws endpoints whose path cost from the current dendrite
    lies in the band, traces them, and updates the cost fields with warm
    starts (only up to the next iteration's ``d + r`` for the costs from the
    dendrite). With new generators (``params.cheap == 0``) the walks descend
    the costs from the dendrite, so every new path ends on it. With cheap
    former paths (``0 < cheap <= 1``) they descend the costs from the first
    generators over the lattice whose dendrite edges cost ``cheap`` times as
    much: a new path joins the dendrite where that pays, more eagerly the
    smaller ``cheap`` (thesis section 3.3.2, Figs 3.14-3.15); this field is
    searched over the whole lattice. The band never reaches below cost 0 nor
    offers the dendrite's own nodes. Cheap former paths change stored
    weights: a lattice that stores none (``store_weights=False``) has its
    weights stored once for the growth, so it must fit in memory with them.

    Several generators grow competing dendrites: every node's ``label`` names
    the generator whose dendrite it belongs to, and the dendrites never share
    a node.

    Args:
        lattice: the weighted lattice.
        generators: ``(G, ndim)`` integer generator coordinates, (row, col) = (y, x) in 2D and
            (z, y, x) in 3D, as numpy indexes.
        params: the growth schedule; its ``d`` is a path cost, to scale to the lattice (see
            :attr:`FractalParams.d`).
        seed: int or ``np.random.Generator`` for the endpoint draws.
        device: Warp device (default: Warp's default device).
        start: an initial dendrite on the same lattice (e.g. hand-placed main
            paths) to grow from; its labels must index ``generators``, each of its
            steps must be a lattice edge, and its costs are recomputed as path
            costs over the lattice's weights from its roots (a traced dendrite
            keeps its own, bit for bit).
        within: optional region (bool mask or an :mod:`wdendrite.endpoints`
            shape) endpoints must lie in.
        progress: True shows a tqdm bar; a callable gets
            ``(iteration, iterations, dendrite)`` after each iteration (the
            dendrite so far: ``start``, or None until an iteration has found
            endpoints).

    Returns:
        The grown :class:`Dendrite`; ``generation`` numbers the iterations,
        after those of ``start`` (its rows keep theirs; the first iteration
        is one more than their largest).
        Its ``cost`` is the path cost from each node's generator along the
        dendrite: every new branch continues the cost of the node it joins
        (a single :func:`trace` gives the same: ``dist``).

    Raises:
        TypeError: ``lattice``, ``params``, ``start``, ``seed`` or ``progress`` of the wrong type.
        ValueError: bad ``generators`` (empty, out of bounds, on masked nodes), a ``start``
            from another lattice shape, with a step that is no lattice edge or whose labels
            do not index ``generators``, a ``within`` of another shape or without a usable node, a negative ``seed``, a schedule whose bands
            hold no node at all (none grows, with or without ``start``), or with cheap
            former paths a ``start`` node no generator reaches (searched before any draw).
    """
    if not isinstance(lattice, Lattice):
        raise TypeError(f"Expected a wdendrite.Lattice for 'lattice', but got {type(lattice).__name__}")
    if not isinstance(params, FractalParams):
        raise TypeError(f"Expected FractalParams for 'params', but got {type(params).__name__}")
    gens = _checks.node_coordinates("generators", generators, lattice.shape, lattice.mask)
    rng = _checks.rng(seed)
    if progress is None or isinstance(progress, (bool, np.bool_)):
        progress = bool(progress)
    elif not callable(progress):
        raise TypeError(f"Expected a bool or a callable for 'progress', but got {progress!r}")
    plan = params.schedule()
    device = _checks.device(device)  # (before a hashed lattice's weights are made, below)
    if start is not None:
        start = _check_start(start, lattice, len(gens), device, len(plan))
    if within is not None:
        within = _endpoints._within(within, lattice.shape)  # checked (and a region drawn) once, before any search
        if not (within if lattice.mask is None else within & lattice.mask).any():
            raise ValueError("'within' holds no usable node of the lattice: no endpoint could be drawn")
    # iterations continue the generations of ``start``
    first_generation = 0 if start is None or not len(start) else int(start.generation.max()) + 1
    r = params.band
    new_generators = params.cheap == 0.0
    den = start
    # cheap former paths change stored weights, so a hashed lattice gets its array once
    base_lat = lattice if new_generators or lattice.stores_weights else lattice.with_weights(lattice.weights)
    lat = base_lat
    if start is not None and not new_generators:
        lat = lower_dendrite_weights(base_lat, start, params.cheap)
    # walked_costs: the costs walks follow (from the dendrite with new generators; from the first generators
    # over the lattice with cheap former paths, searched whole: a walk may start far from them).
    # band_costs: with cheap former paths, the costs from the dendrite, where endpoints are drawn (thesis
    # Fig 3.15: "successively smaller path cost from the structure"); with new generators, walked_costs itself
    walked_costs: CostField | None = None
    band_costs: CostField | None = None
    grew = False
    bar = None
    if progress is True:  # (made just before the loop whose end closes it)
        from tqdm.auto import tqdm

        bar = tqdm(total=len(plan), desc="growing", unit="iteration")
    try:
        for it, (m, d) in enumerate(plan):
            if walked_costs is None:
                structure = gens if den is None else np.concatenate([gens, den.nodes])
                if new_generators:
                    walked_costs = band_costs = shortest_paths(lat, structure, limit=d + r, device=device)
                else:
                    walked_costs = shortest_paths(lat, gens, device=device)
                    if den is not None and len(den):
                        # walks lead to the generators: a start node they cannot reach would leave its
                        # surroundings' endpoints without a way down
                        far = ~np.isfinite(_field_costs(walked_costs, den._padded))
                        if far.any():
                            row = int(np.argmax(far))
                            raise ValueError(
                                f"'start' row {row} = {tuple(den.nodes[row].tolist())} cannot be reached from any of "
                                "the 'generators' on this lattice; cheap former paths trace every branch to them "
                                "(new generators, cheap = 0, grow from 'start' itself)")
                    band_costs = (walked_costs if den is None
                                  else shortest_paths(base_lat, structure, limit=d + r, device=device))
            ep = _band_endpoints(band_costs, m, d, r, rng, within, params.min_spacing)
            if ep is not None:
                grew = True
                first = 0 if den is None else len(den)
                # (new branches take the label of the node they join: the first generators' rows)
                den = _trace(walked_costs, ep, extend=den, generation=first_generation + it, drawn=True)
                if first:
                    # before the next search reuses the records that hold this field
                    den = _rebase_costs(den, first, (lambda rows: np.float32(0.0)) if new_generators
                                        else (lambda rows: _field_costs(walked_costs, den._padded[rows])))
                if it + 1 < len(plan):
                    # the next band lies below the next limit: nothing beyond it is searched
                    limit = plan[it + 1][1] + r
                    structure = np.concatenate([gens, den.nodes])
                    # the last cost fields are not read again: the searches may reuse their memory
                    if not new_generators:
                        # older dendrite edges are already cheap in lat: only this iteration's join them
                        new_rows = np.arange(first, len(den))
                        lowered = None
                        if lat is base_lat:
                            # growth's own copy, whose later edges are lowered in place
                            lat = lower_dendrite_weights(lat, den, params.cheap, rows=new_rows)
                        else:
                            dirs, lower = _dendrite_edges(lat, den, new_rows)  # (traced: all lattice edges)
                            lowered = lat._lower_in_place(dirs, lower, params.cheap, walked_costs.device)
                        walked_costs = _search(lat, gens, warm_start=walked_costs, lowered=lowered,
                                               consume_warm_start=band_costs is not walked_costs)
                    # the costs from the dendrite: its new nodes (the rows this iteration's walks added)
                    # join the generators
                    band_costs = _search(base_lat, structure, limit=limit, warm_start=band_costs,
                                         consume_warm_start=True, walked=den._padded[first:])
                    if new_generators:
                        walked_costs = band_costs
            if bar is not None:
                bar.update(1)
            elif callable(progress):
                progress(it + 1, len(plan), den)
    finally:  # (an interrupted growth closes its bar too)
        if bar is not None:
            bar.close()
    if not grew:
        advice = _band_advice(base_lat, gens if den is None else np.concatenate([gens, den.nodes]), plan, r, device,
                              within)
        raise ValueError(
            f"no node off the dendrite has a path cost in any band (max(d - r, 0), d + r) of the schedule {plan} "
            f"with r = {r:g}; {advice}"
        )
    return den


def _band_advice(lattice: Lattice, structure: np.ndarray, plan, r: float, device, within=None) -> str:
    """What to change when no band of ``plan`` held a node: the costs off ``structure`` (inside
    ``within``, where endpoints are drawn) are searched in full (on this failure only) and
    compared with the bands."""
    dist = shortest_paths(lattice, structure, device=device).dist
    drawn = np.isfinite(dist) & (dist > 0)
    where = "off the dendrite" if within is None else "off the dendrite inside 'within'"
    off = dist[drawn if within is None else drawn & within]
    if not off.size:
        return f"no node {where} can be reached from it on this lattice"
    low, high = float(off.min()), float(off.max())
    span = f"costs {where} span [{low:.4g}, {high:.4g}] on this lattice"
    if plan[0][1] + r <= low:
        return f"{span}, all above the first band: raise 'd' into that range"
    if max(plan[-1][1] - r, 0.0) >= high:
        return f"{span}, all below the last band: lower 'd' into that range (or grow on a larger lattice)"
    return f"{span}, between the bands: raise 'r' or choose 'd' so that a band meets them"


from ._spec import document_fields as _document_fields  # noqa: E402  (the classes above are complete)

_document_fields(__name__)  # help() shows what each dataclass field means
