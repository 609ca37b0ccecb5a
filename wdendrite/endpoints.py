"""Endpoint placement: where the paths of a dendrite start (thesis section 3.3.1).

Every strategy returns ``(M, ndim)`` int64 node coordinates (``(y, x)`` in 2D,
``(z, y, x)`` in 3D) of distinct, usable lattice nodes, drawn in a random order:

- :func:`random`: uniformly among the usable nodes, optionally restricted to a
  region (``within=``: a bool mask or a :class:`Disc`, :class:`Box`,
  :class:`Triangle`, :class:`Polygon` or :class:`Image`), weighted by a
  ``density``, and at least ``min_spacing`` apart (rejection sampling).
- :func:`biased`: denser toward one end of an axis (lightning: lower in the image).
- :func:`in_band`: nodes whose path cost lies in ``(d - r, d + r)``.
- :func:`manual`: a validated list.

Randomness comes only from ``seed`` (an int or a ``np.random.Generator``).
A request that cannot be met (no candidate node, more endpoints than
candidates, a spacing that leaves too few) raises ``ValueError`` at once; the
spacing search tries each candidate at most once, so it always ends.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from . import _checks
from . import sssp as _sssp
from .lattice import Lattice

__all__ = ["Box", "Disc", "Image", "Polygon", "Region", "TooManyEndpoints", "Triangle", "biased", "in_band", "manual",
           "random"]


# ---------------------------------------------------------------------------
# regions


class TooManyEndpoints(ValueError):
    """A request for more endpoints than the candidate nodes (or their spacing) allow."""


class Region:
    """A set of lattice nodes; subclasses define :meth:`mask`."""

    def mask(self, shape: tuple[int, ...]) -> np.ndarray:
        """Bool array of ``shape``: True for nodes inside the region."""
        raise NotImplementedError


_finite = _checks.finite


def _point(name: str, value, ndim: int | tuple[int, ...]) -> np.ndarray:
    """``value`` as float64 node coordinates, finite: ``ndim`` of them, or (a tuple) any count it holds."""
    try:
        p = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        p = np.array([np.nan])
    if p.shape not in [(n,) for n in np.atleast_1d(ndim)] or not np.isfinite(p).all():
        what = f"{ndim} finite" if isinstance(ndim, int) else "finite (y, x) or (z, y, x)"
        raise ValueError(f"Expected '{name}' as {what} node coordinates, but got {value!r}")
    return p


def _keep_point(region, name: str) -> tuple[float, ...]:
    """Check ``region``'s field ``name`` as finite ``(y, x)`` or ``(z, y, x)`` coordinates when the
    region is made (:meth:`Region.mask` checks them against the lattice's dimension) and store
    them as a tuple of floats, so that the region hashes, compares and prints as written."""
    kept = tuple(_point(name, getattr(region, name), (2, 3)).tolist())
    object.__setattr__(region, name, kept)
    return kept


def _grid(shape):
    return np.ogrid[tuple(slice(0, n) for n in shape)]


@dataclass(frozen=True)
class Disc(Region):
    """Nodes within ``radius`` of ``center`` (a disc in 2D, a ball in 3D), boundary included."""

    center: tuple[float, ...]
    """``(y, x)`` or ``(z, y, x)`` in node units."""
    radius: float
    """Radius in node units, > 0."""

    def __post_init__(self):
        _keep_point(self, "center")
        object.__setattr__(self, "radius", _checks.positive("radius", self.radius))

    def mask(self, shape):
        c = _point("center", self.center, len(shape))
        d2 = sum((g - ci) ** 2 for g, ci in zip(_grid(shape), c))
        return np.broadcast_to(d2 <= float(self.radius) ** 2 + 1e-9, shape).copy()


@dataclass(frozen=True)
class Box(Region):
    """Nodes with ``lo <= coords <= hi`` on every axis (both corners included)."""

    lo: tuple[float, ...]
    """Lower corner, ``(y, x)`` or ``(z, y, x)``."""
    hi: tuple[float, ...]
    """Upper corner; must be >= ``lo`` on every axis."""

    def __post_init__(self):
        lo, hi = _keep_point(self, "lo"), _keep_point(self, "hi")
        if len(lo) != len(hi):
            raise ValueError(f"Expected 'lo' and 'hi' with as many coordinates, but got lo={self.lo!r}, hi={self.hi!r}")
        if any(b < a for a, b in zip(lo, hi)):
            raise ValueError(f"Expected 'hi' >= 'lo' on every axis, but got lo={self.lo!r}, hi={self.hi!r}")

    def mask(self, shape):
        lo, hi = _point("lo", self.lo, len(shape)), _point("hi", self.hi, len(shape))
        if (hi < lo).any():
            raise ValueError(f"Expected 'hi' >= 'lo' on every axis, but got lo={self.lo!r}, hi={self.hi!r}")
        out = np.ones(shape, bool)
        for g, a, b in zip(_grid(shape), lo, hi):
            out &= (g >= a) & (g <= b)
        return out


def _vertices(name: str, value, minimum: int) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if v.ndim != 2 or v.shape[1] != 2 or len(v) < minimum or not np.isfinite(v).all():
        raise ValueError(f"Expected '{name}' as (V >= {minimum}, 2) finite (y, x) points, but got {value!r}")
    return v


def _need_2d(shape, what):
    if len(shape) != 2:
        raise ValueError(f"{what} needs a 2D lattice, but the lattice has shape {shape}")


@dataclass(frozen=True)
class Triangle(Region):
    """Nodes inside the triangle ``a, b, c`` (2D, ``(y, x)`` points), boundary included."""

    a: tuple[float, float]
    """First corner ``(y, x)``."""
    b: tuple[float, float]
    """Second corner."""
    c: tuple[float, float]
    """Third corner."""

    def __post_init__(self):
        v = _vertices("triangle", [self.a, self.b, self.c], 3)
        for name, corner in zip("abc", v):
            object.__setattr__(self, name, tuple(corner.tolist()))
        (ay, ax), (by, bx) = v[1] - v[0], v[2] - v[0]
        if abs(ay * bx - ax * by) < 1e-12:
            raise ValueError(f"Triangle corners {self.a!r}, {self.b!r}, {self.c!r} are collinear (zero area)")

    def mask(self, shape):
        _need_2d(shape, "Triangle")
        y, x = _grid(shape)
        v = _vertices("triangle", [self.a, self.b, self.c], 3)
        sides = []
        for p, q in ((v[0], v[1]), (v[1], v[2]), (v[2], v[0])):
            # z of (q - p) x (node - p); the sign says which side of the edge the node is on
            sides.append((q[0] - p[0]) * (x - p[1]) - (q[1] - p[1]) * (y - p[0]))
        eps = 1e-9
        pos = (sides[0] >= -eps) & (sides[1] >= -eps) & (sides[2] >= -eps)
        neg = (sides[0] <= eps) & (sides[1] <= eps) & (sides[2] <= eps)
        return np.broadcast_to(pos | neg, shape).copy()


@dataclass(frozen=True)
class Polygon(Region):
    """Nodes inside a simple or self-intersecting polygon (2D, even-odd rule).

    Nodes exactly on an edge may fall on either side.
    """

    vertices: tuple
    """``(V, 2)`` corners ``(y, x)`` in order, V >= 3; the last joins the first."""

    def __post_init__(self):
        object.__setattr__(self, "vertices", tuple(map(tuple, _vertices("vertices", self.vertices, 3).tolist())))

    def mask(self, shape):
        _need_2d(shape, "Polygon")
        v = _vertices("vertices", self.vertices, 3)
        y, x = _grid(shape)
        inside = np.zeros(shape, bool)
        for (y0, x0), (y1, x1) in zip(v, np.roll(v, -1, axis=0)):
            if y0 == y1:
                continue  # a horizontal edge never crosses the horizontal ray
            spans = (y0 > y) != (y1 > y)  # (H, 1)
            x_cross = x0 + (y - y0) * (x1 - x0) / (y1 - y0)  # (H, 1)
            inside ^= spans & (x < x_cross)
        return inside


@dataclass(frozen=True, eq=False)
class Image(Region):
    """Nodes where an image (array, file path or PIL image) is dark (or bright).

    The image has the lattice shape; row 0 is the top row. Brightness is
    read as in :class:`wdendrite.weights.Map` (0 black, 1 white).
    """

    image: object
    """``(H, W)`` / ``(D, H, W)`` array (bool, uint8, uint16 or float in [0, 1]), image file path, or PIL image."""
    threshold: float = 0.5
    """Brightness threshold in (0, 1]."""
    dark: bool = True
    """True: nodes with brightness < threshold; False: brightness >= threshold."""
    brightness: np.ndarray = field(init=False, repr=False)
    """The image as float32 brightness in [0, 1], read at construction."""

    def __post_init__(self):
        from .weights import _grayscale

        t = _checks.positive("threshold", self.threshold)
        if t > 1:
            raise ValueError(f"Expected 'threshold' in (0, 1], but got {self.threshold!r}")
        object.__setattr__(self, "dark", _checks.flag("dark", self.dark))
        object.__setattr__(self, "brightness", _grayscale("image", self.image))

    def mask(self, shape):
        if self.brightness.shape != tuple(shape):
            raise ValueError(f"Expected 'image' of the lattice shape {tuple(shape)}, but got shape {self.brightness.shape}")
        b = self.brightness
        return (b < self.threshold) if self.dark else (b >= self.threshold)


# ---------------------------------------------------------------------------
# sampling


_rng = _checks.rng


def _count(count) -> int:
    if isinstance(count, (bool, np.bool_)) or not isinstance(count, (int, np.integer)):
        raise TypeError(f"Expected an integer 'count', but got {count!r}")
    if count < 1:
        raise ValueError(f"Expected a positive 'count', but got {count!r}")
    return int(count)


def _space(lattice) -> tuple[tuple[int, ...], np.ndarray | None]:
    """Shape and node mask of a Lattice, or of a bare shape tuple."""
    if isinstance(lattice, Lattice):
        return lattice.shape, lattice.mask
    return _checks.lattice_shape(lattice), None


def _within(within, shape) -> np.ndarray:
    if isinstance(within, Region):
        return within.mask(shape)
    return _checks.bool_array("within", within, shape)


def _footprint(shape, spacing: float) -> np.ndarray:
    """Offsets ``o`` with ``|o| < spacing`` that can join two nodes of a lattice of ``shape``,
    shape (F, ndim). No offset reaches past a lattice's side, so a spacing wider than the
    lattice costs no more than one as wide as it."""
    reach = min(float(spacing), float(sum(shape)))  # every offset inside is shorter than the sum of the sides
    r = math.ceil(reach)
    axes = np.meshgrid(*[np.arange(-min(r, n - 1), min(r, n - 1) + 1) for n in shape], indexing="ij")
    off = np.stack([a.ravel() for a in axes], axis=1)
    # distances compared, not their squares: sqrt(2)**2 rounds above 2, which had refused a pair
    # exactly 'spacing' = sqrt(2) apart
    return off[np.sqrt((off.astype(np.float64) ** 2).sum(axis=1)) < reach]


_FOOTPRINT_MAX = 1 << 22
"""Largest footprint (offsets, about 100 MB of them in 3D) :func:`_spaced` marks per kept point;
wider spacings keep few points, which are compared with the candidates directly."""


def _footprint_size(shape, spacing: float) -> int:
    """Offsets in the box :func:`_footprint` would scan (an upper bound of its size)."""
    r = math.ceil(min(float(spacing), float(sum(shape))))
    return math.prod(2 * min(r, n - 1) + 1 for n in shape)


def _in_key_order(cand: np.ndarray, keys: np.ndarray, first: int):
    """Yield ``cand`` in increasing ``keys`` order, in blocks of growing size, sorting only what is read."""
    rest = np.arange(len(keys))
    size = max(1, first)
    while len(rest):
        if size < len(rest):
            part = np.argpartition(keys[rest], size - 1)
            head, rest = rest[part[:size]], rest[part[size:]]
        else:
            head, rest = rest, rest[:0]
        yield cand[head[np.argsort(keys[head], kind="stable")]]
        size *= 4


def _spaced(cand: np.ndarray, keys: np.ndarray, shape, count: int, spacing: float,
            partial: bool = False) -> np.ndarray:
    """Candidates in key order, each kept only if no kept one lies closer than ``spacing``;
    ``count`` of them, or with ``partial`` as many as fit, up to ``count``."""
    if _footprint_size(shape, spacing) > _FOOTPRINT_MAX:
        if count >= 2 and len(cand):
            # no two candidates that far apart: say so at once (the search would scan them all)
            span = np.array([int(p.max()) - int(p.min()) for p in np.unravel_index(cand, shape)], np.float64)
            if math.sqrt(float((span**2).sum())) < spacing:
                if partial:  # one fits: the first in key order
                    return np.asarray(next(_in_key_order(cand, keys, 1))[:1], dtype=np.int64)
                raise TooManyEndpoints(
                    f"No two of the {len(cand)} candidate nodes are 'min_spacing' = {spacing:g} apart (they span "
                    f"{tuple(int(v) for v in span)} nodes), but 'count' = {count} endpoints were asked for; lower "
                    "'min_spacing' or widen the region")
        kept = _spaced_far(cand, keys, shape, count, spacing)
    else:
        kept = _spaced_near(cand, keys, shape, count, spacing)
    if len(kept) < count and not partial:
        _spaced_error(kept, count, spacing, len(cand))
    return np.asarray(kept, dtype=np.int64)


def _spaced_error(kept, count: int, spacing: float, candidates: int):
    raise TooManyEndpoints(
        f"Could place only {len(kept)} of {count} endpoints at least 'min_spacing' = {spacing:g} apart "
        f"among {candidates} candidate nodes (each tried once, in random order); "
        "lower 'count' or 'min_spacing', or widen the region"
    )


def _spaced_far(cand: np.ndarray, keys: np.ndarray, shape, count: int, spacing: float) -> list[int]:
    """:func:`_spaced` for spacings whose footprint is large: few points fit, so each block of
    candidates is compared with the kept points directly (no per-node table)."""
    kept: list[int] = []
    at = np.empty((0, len(shape)), np.int64)
    # squared distances are integers: "at least spacing" is d2 >= the least integer whose root
    # reaches spacing (found exactly, so a pair exactly 'spacing' apart counts as far enough)
    need = math.ceil(spacing * spacing)
    while need > 0 and math.sqrt(need - 1) >= spacing:
        need -= 1
    while math.sqrt(need) < spacing:
        need += 1
    for order in _in_key_order(cand, keys, 4 * count + 1024):
        for start in range(0, len(order), 1 << 16):
            seg = order[start:start + (1 << 16)]
            pos = np.stack(np.unravel_index(seg, shape), axis=1).astype(np.int64)
            free = np.ones(len(seg), bool)
            for p in at:  # few: each keeps a wide region free of others
                free &= ((pos - p) ** 2).sum(-1) >= need
            while len(kept) < count and free.any():
                j = int(np.argmax(free))
                kept.append(int(seg[j]))
                at = np.vstack([at, pos[j]])
                free &= ((pos - pos[j]) ** 2).sum(-1) >= need
            if len(kept) == count:
                return kept
    return kept


def _spaced_near(cand: np.ndarray, keys: np.ndarray, shape, count: int, spacing: float) -> list[int]:
    """:func:`_spaced` marking each kept point's footprint in a per-node table."""
    foot = _footprint(shape, spacing)
    dims = np.asarray(shape)
    blocked = np.zeros(math.prod(shape), bool)
    kept: list[int] = []
    for order in _in_key_order(cand, keys, 4 * count + 1024):
        ptr, chunk = 0, 64
        # one Python step per kept point (plus a few per long run of rejected candidates)
        while len(kept) < count and ptr < len(order):
            seg = order[ptr : ptr + chunk]
            free = ~blocked[seg]
            if not free.any():
                ptr += len(seg)
                chunk = min(chunk * 2, 1 << 16)
                continue
            j = int(np.argmax(free))
            node = int(seg[j])
            kept.append(node)
            ptr += j + 1
            chunk = 64
            near = np.asarray(np.unravel_index(node, shape)) + foot
            near = near[np.all((near >= 0) & (near < dims), axis=1)]
            blocked[np.ravel_multi_index(tuple(near.T), shape)] = True
        if len(kept) == count:
            break
    return kept


def _plain_costs(cost) -> np.ndarray:
    """A plain ``cost`` array (not a CostField) as path costs: float, >= 0, inf where unreachable."""
    _checks.unmasked("cost", cost)
    dist = np.asarray(cost)
    if dist.dtype.kind != "f":
        raise TypeError(f"Expected a CostField or a float array for 'cost', but got {type(cost).__name__} {dist.dtype}")
    bad = np.isnan(dist) | (dist < 0)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(f"'cost' holds path costs (>= 0, inf where unreachable), but has {int(bad.sum())} NaN or "
                         f"negative entries (first at {where}: {float(dist[where])!r})")
    return dist


def _density(density, shape) -> np.ndarray:
    """``density`` as a flat float64 array (kept in float64 so that steep profiles do not underflow)."""
    _checks.unmasked("density", density)
    arr = np.asarray(density)
    if arr.dtype.kind not in "fiu" or arr.dtype == np.bool_:
        raise TypeError(f"Expected a real-valued array for 'density', but got dtype {arr.dtype}")
    if arr.shape != tuple(shape):
        raise ValueError(f"Expected 'density' of shape {tuple(shape)}, but got shape {arr.shape}")
    arr = arr.astype(np.float64).reshape(-1)
    bad = ~np.isfinite(arr)
    if bad.any():
        raise ValueError(f"'density' must be finite, but has {int(bad.sum())} NaN/inf entries")
    if (arr < 0).any():
        raise ValueError(f"'density' must be non-negative, but its minimum is {arr.min()}")
    return arr


def _sample(shape, cand: np.ndarray, count: int, rng, density, min_spacing, why: list,
            log_density=None, partial: bool = False) -> np.ndarray:
    """Draw ``count`` distinct nodes among the candidates ``cand`` (ascending flat indices);
    with ``partial``, as many as ``min_spacing`` lets fit when that is fewer.

    ``why`` holds zero-argument callables describing the filters, called only
    to word an error (counting candidates for a message is a pass over the lattice).
    ``log_density`` (see :func:`_random`) replaces ``density`` when given.
    """
    log_dens = None
    if density is not None:
        dens = _density(density, shape)
        cand = cand[dens[cand] > 0]
        why.append(lambda n=len(cand): f"{n} with positive 'density'")
        with np.errstate(divide="ignore"):
            log_dens = np.log(dens[cand])
    elif log_density is not None:
        log_dens = np.asarray(log_density, np.float64).reshape(-1)[cand]
    if len(cand) == 0:
        raise TooManyEndpoints("No candidate nodes for endpoints: " + _describe(why))
    if count > len(cand):
        raise TooManyEndpoints(f"Asked for 'count' = {count} endpoints, but there are only {len(cand)} candidate nodes: "
                         + _describe(why))
    if log_dens is None and min_spacing is None:
        # a uniform draw without replacement, in random order: no key per candidate needed
        flat = cand[rng.choice(len(cand), size=count, replace=False)]
    else:
        if log_dens is None:
            keys = rng.random(len(cand))
        else:
            # exponential keys scaled by 1/density: sorting them is weighted sampling without
            # replacement. Compared as logarithms, so that no density is too small (subnormal) or
            # too large for the quotient to hold
            keys = np.log(rng.exponential(size=len(cand))) - log_dens
        if min_spacing is None:
            flat = next(_in_key_order(cand, keys, count))
        else:
            flat = _spaced(cand, keys, shape, count, min_spacing, partial)
    return np.stack(np.unravel_index(flat, shape), axis=1).astype(np.int64)


def _requested(name: str, count: int, where: str, shape, draw) -> np.ndarray:
    """``draw()``'s endpoints; a request that cannot be met is reported against the caller's parameter
    ``name`` (``count`` endpoints asked for, ``where`` on the lattice of ``shape``)."""
    try:
        return draw()
    except TooManyEndpoints as exc:
        size = " x ".join(map(str, shape))
        raise ValueError(f"'{name}' = {count} is more than fit {where} the {size} lattice: {exc}") from None


def _describe(why: list) -> str:
    return ", ".join(w() for w in why)


def _usable_count(shape, mask):
    """Describer (for :func:`_sample`'s errors) of how many lattice nodes are usable."""
    return lambda: f"{math.prod(shape) if mask is None else int(np.count_nonzero(mask))} usable lattice nodes"


def _candidates(shape, mask, within) -> tuple[np.ndarray, list]:
    """Flat bool array of the usable nodes (inside ``within``), and the describers of :func:`_sample`."""
    base = np.ones(math.prod(shape), bool) if mask is None else mask.reshape(-1)
    why = [_usable_count(shape, mask)]
    usable = base
    if within is not None:
        usable = base & _within(within, shape).reshape(-1)
        why.append(lambda: f"{int(usable.sum())} of them inside 'within'")
    return usable, why


def _band_candidates(cost, shape, mask, low: float, high: float, within) -> tuple[np.ndarray, list]:
    """Ascending flat indices of the usable nodes (inside ``within``) whose cost lies in
    ``(low, high)``, and the describers of :func:`_sample`.

    ``cost`` is a :class:`~wdendrite.CostField`, whose band is read from the
    lattice's records without making its ``dist`` array, or a flat float array.
    """
    if isinstance(cost, np.ndarray):
        usable, why = _candidates(shape, mask, within)
        cand = np.flatnonzero(usable & (cost > low) & (cost < high))
        costs = lambda: cost  # noqa: E731
    else:
        cand = _sssp.band_nodes(cost, low, high)  # usable nodes only
        if within is None:
            # the band lists usable nodes only: the usable-node flags are needed for an error message only
            why = [_usable_count(shape, mask)]
        else:
            usable, why = _candidates(shape, mask, within)
            cand = cand[usable[cand]]
        costs = lambda: cost.dist.reshape(-1)  # noqa: E731

    def told() -> str:
        c = costs()
        finite = c[np.isfinite(c)]
        span = f"finite costs range over [{finite.min():g}, {finite.max():g}]" if finite.size else "no finite costs"
        return f"{len(cand)} with cost in ({low:g}, {high:g}) ({span})"

    why.append(told)
    return cand, why


def _spacing(min_spacing):
    return None if min_spacing is None else _checks.positive("min_spacing", min_spacing)


def random(
    lattice,
    count: int,
    *,
    seed: int | np.random.Generator = 0,
    within=None,
    density=None,
    min_spacing: float | None = None,
) -> np.ndarray:
    """Endpoints drawn at random among the usable nodes.

    Args:
        lattice: a :class:`~wdendrite.Lattice` (its mask is respected) or a shape ``(H, W)`` / ``(D, H, W)``.
        count: number of endpoints M, >= 1.
        seed: int seed or ``np.random.Generator``.
        within: restrict to a region: a bool array of the lattice shape or a
            :class:`Region` (:class:`Disc`, :class:`Box`, :class:`Triangle`, :class:`Polygon`, :class:`Image`).
        density: non-negative float array of the lattice shape; nodes are drawn
            with probability proportional to it (sequentially, without
            replacement). Nodes of zero density are never drawn.
        min_spacing: if given, every two endpoints are at least this far apart
            (Euclidean, node units): candidates are tried once each, in random
            order, and rejected when closer than ``min_spacing`` to one kept before.

    Returns:
        ``(M, ndim)`` int64 node coordinates, distinct, in the order drawn.

    Raises:
        ValueError: no candidate node, fewer candidates than ``count``, or a
            spacing that leaves fewer than ``count``; bad argument values.
        TypeError: bad argument types.
    """
    return _random(lattice, count, seed, within, density, None, min_spacing)


def _random(lattice, count, seed, within, density, log_density, min_spacing) -> np.ndarray:
    """:func:`random`, with the density optionally given by its logarithm (``log_density``:
    float64 of the lattice shape, -inf where it is 0), which no steep profile underflows."""
    shape, mask = _space(lattice)
    count, rng, spacing = _count(count), _rng(seed), _spacing(min_spacing)
    usable, why = _candidates(shape, mask, within)
    return _sample(shape, np.flatnonzero(usable), count, rng, density, spacing, why, log_density)


def biased(
    lattice,
    count: int,
    *,
    seed: int | np.random.Generator = 0,
    power: float = 2.0,
    axis: int = 0,
    toward: Literal["start", "end"] = "end",
    within=None,
    min_spacing: float | None = None,
) -> np.ndarray:
    """Endpoints denser toward one end of an axis, e.g. lower in the image for lightning.

    The probability of a node at index ``i`` along ``axis`` (of length n) is
    proportional to ``((i + 1) / n) ** power`` for ``toward="end"`` and
    ``((n - i) / n) ** power`` for ``toward="start"``. In a 2D image (axis 0 =
    rows, row 0 at the top), the default puts endpoints mostly low in the image.

    Args:
        lattice, count, seed, within, min_spacing: as for :func:`random`.
        power: >= 0; 0 is uniform, larger values concentrate toward the end.
        axis: lattice axis of the bias.
        toward: which end of ``axis`` is denser.

    Returns:
        ``(M, ndim)`` int64 node coordinates, distinct, in the order drawn.

    Raises:
        ValueError, TypeError: as for :func:`random`, and a bad ``power``, ``axis`` or ``toward``.
    """
    shape, mask = _space(lattice)
    power = _checks.nonnegative("power", power, allow_none=False)
    if isinstance(axis, (bool, np.bool_)) or not isinstance(axis, (int, np.integer)) or not -len(shape) <= axis < len(shape):
        raise ValueError(f"Expected 'axis' in [{-len(shape)}, {len(shape)}) for a lattice of shape {shape}, but got {axis!r}")
    if toward not in ("start", "end"):
        raise ValueError(f"Expected 'toward' in ('start', 'end'), but got {toward!r}")
    n = shape[axis]
    i = np.arange(n, dtype=np.float64)
    # the profile's logarithm: ((i + 1) / n) ** power underflows to 0 for steep powers, which
    # would have made such nodes undrawable (0 * log 0 is 0 at power 0: uniform)
    log_profile = power * np.log(((i + 1) / n) if toward == "end" else ((n - i) / n))
    view = [1] * len(shape)
    view[axis] = n
    log_density = np.broadcast_to(log_profile.reshape(view), shape)
    return _random(lattice, count, seed, within, None, log_density, min_spacing)


def in_band(
    cost,
    count: int,
    d: float,
    r: float,
    *,
    seed: int | np.random.Generator = 0,
    within=None,
    density=None,
    min_spacing: float | None = None,
) -> np.ndarray:
    """Endpoints whose path cost ``c`` satisfies ``d - r < c < d + r`` (thesis section 3.3.1, Fig 3.12).

    Args:
        cost: a :class:`~wdendrite.CostField` (its lattice mask is respected),
            or a float array ``dist`` of the lattice shape (inf where unreachable).
        count: number of endpoints, >= 1.
        d: centre of the band (path cost units), finite.
        r: half-width of the band, > 0.
        seed, within, density, min_spacing: as for :func:`random`.

    Returns:
        ``(M, ndim)`` int64 node coordinates, distinct, in the order drawn.

    Raises:
        ValueError: a band holding fewer candidates than asked for, a band reaching
            above a :class:`~wdendrite.CostField`'s ``limit``, a non-finite ``d``,
            ``r`` <= 0, or as for :func:`random`.
        TypeError: ``cost`` neither a CostField nor a float array, or as for :func:`random`.
    """
    if isinstance(cost, _sssp.CostField):
        shape, mask = _space(cost.lattice)
    else:
        dist = _plain_costs(cost)
        if dist.ndim not in (2, 3) or dist.size == 0:  # (the lattice check would name a 'shape' never given)
            raise ValueError(f"Expected 'cost' as a non-empty 2D (H, W) or 3D (D, H, W) array, but got shape "
                             f"{dist.shape}")
        shape, mask = _space(dist.shape)
        cost = dist.reshape(-1)
    d = _finite("d", d)
    r = _checks.positive("r", r)
    if d + r <= 0:
        raise ValueError(f"The band (d - r, d + r) = ({d - r:g}, {d + r:g}) lies below cost 0, where no node is: "
                         f"raise 'd' (got {d:g}) or 'r' (got {r:g})")
    count, rng, spacing = _count(count), _rng(seed), _spacing(min_spacing)
    if isinstance(cost, _sssp.CostField) and d + r > cost.limit:
        raise ValueError(
            f"The band's top 'd' + 'r' = {d + r:g} lies above the cost field's 'limit' {cost.limit:g}: costs there "
            "were not searched, so the band would be cut short; search with a limit of at least d + r"
        )
    cand, why = _band_candidates(cost, shape, mask, d - r, d + r, within)
    return _sample(shape, cand, count, rng, density, spacing, why)


def manual(lattice, points, *, cost=None) -> np.ndarray:
    """A hand-placed list of endpoints, validated.

    Args:
        lattice: a :class:`~wdendrite.Lattice` (its mask is respected) or a shape.
        points: ``(M, ndim)`` integer node coordinates.
        cost: optional :class:`~wdendrite.CostField` or ``dist`` array; points
            with infinite cost (unreachable from every generator) are rejected.

    Returns:
        ``(M, ndim)`` int64 copy of ``points``.

    Raises:
        ValueError: a point outside the lattice, on a masked-out node,
            unreachable, or listed twice (the message gives its rows and coordinates).
        TypeError: non-integer coordinates.
    """
    shape, mask = _space(lattice)
    pts = _checks.node_coordinates("points", points, shape, mask)
    flat = np.ravel_multi_index(tuple(pts.T), shape)
    _, first, seen = np.unique(flat, return_index=True, return_counts=True)
    if np.any(seen > 1):
        row = int(np.sort(first[seen > 1])[0])
        again = int(np.flatnonzero(flat == flat[row])[1])
        raise ValueError(f"'points' rows {row} and {again} are the same node {tuple(pts[row].tolist())}; "
                         "endpoints must be distinct")
    if cost is not None:
        dist = np.asarray(cost.dist) if hasattr(cost, "dist") else _plain_costs(cost)
        if dist.shape != shape:
            raise ValueError(f"Expected 'cost' of shape {shape}, but got shape {dist.shape}")
        bad = ~np.isfinite(dist[tuple(pts.T)])
        if bad.any():
            row = int(np.argmax(bad))
            raise ValueError(
                f"'points' row {row} = {tuple(pts[row].tolist())} is unreachable from every generator "
                f"({int(bad.sum())} unreachable points in all)"
            )
    return pts.copy()
