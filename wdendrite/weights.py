"""Edge-weight distributions and spatial bias fields (seeded and reproducible).

A distribution turns a lattice's shape and edge directions into the
``(K, *shape)`` float32 weight array of :class:`wdendrite.Lattice`. Every
weight is a function of ``(seed, node, direction)`` through a counter-based
hash, so the same seed gives the same weights every time, and a kernel can
recompute any single weight without a stored array (see
:meth:`Distribution.kernel_params` and ``wdendrite.kernels.weights.edge_weight``).
``node`` is the node's flat (row-major) index: a taller or deeper lattice keeps
the weights of the rows it shares with a smaller one, but a lattice of another
width gets other weights almost everywhere.

The papers' distributions, each multiplied by the edge's Euclidean length
(1, sqrt(2), sqrt(3)) so that diagonal moves cost what their length says:

- :class:`Uniform`: ``1 + r * R``, R uniform in (0, 1).
- :class:`Power`: ``R ** alpha``, R uniform in (1, max).
- :class:`Polynomial`: ``1 + v ** n``, v uniform in (0, 100).
- :class:`Constant`: ``value`` (no randomness; plain lattice distances).

Spatial bias (tropism) composes with a distribution through ``*`` and ``+``::

    w = wd.weights.Uniform(r=10, seed=1) * wd.weights.Tropism("left", strength=2)
    w = wd.weights.Power(alpha=3) + wd.weights.Map("sketch.png", strength=50, dark="cheaper")

A field ``g`` in [0, 1] (0 where edges are cheapest) gives a term
``strength * g ** exponent``. ``dist * field`` scales the weight by
``1 + term``; ``dist + field`` adds ``length * term``, as the papers add
structured values to the random ones. The result is a :class:`Biased`
distribution whose weight is ``length * (base + sum(added)) * prod(1 + scaled)``.
Fields are evaluated at the edge's midpoint (:class:`Tropism`) or as the mean of
the values at the edge's two end nodes (:class:`Map`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import warp as wp

from . import _checks
from .kernels import weights as _kw

__all__ = ["Biased", "Constant", "Distribution", "Map", "Polynomial", "Power", "Tropism", "Uniform"]

_MAX_WEIGHT = 1e30
"""Largest edge weight allowed, so that path sums of millions of edges stay finite in float32."""

_CONNECTIVITY = {(2, 2): 4, (2, 4): 8, (3, 3): 6, (3, 13): 26}
"""(ndim, number of half-offsets) -> connectivity."""


def _keep(obj, name: str, value):
    """Store the checked ``value`` as field ``name`` of the frozen ``obj`` (a plain Python value, so
    that the object hashes, compares and prints as written, whatever NumPy scalar it was given)."""
    object.__setattr__(obj, name, value)
    return value


def _number(name: str, value, *, low: float | None = None, low_open: bool = False) -> float:
    """``value`` as a finite float, checked against a lower bound (closed or open)."""
    x = _checks.finite(name, value)
    if low is not None and (x <= low if low_open else x < low):
        raise ValueError(f"Expected '{name}' {'>' if low_open else '>='} {low:g}, but got {value!r}")
    return x


def _offsets_for(shape: tuple[int, ...], lengths: np.ndarray, offsets) -> np.ndarray:
    """The ``(K, ndim)`` half-offsets matching ``lengths``: given, or the lattice's standard ones."""
    from .lattice import half_offsets

    ndim = len(shape)
    if offsets is None:
        conn = _CONNECTIVITY.get((ndim, len(lengths)))
        if conn is None:
            raise ValueError(
                f"Expected 'lengths' of {sorted(k for d, k in _CONNECTIVITY if d == ndim)} directions "
                f"for a {ndim}D lattice, but got {len(lengths)}; pass 'offsets' for other neighbourhoods"
            )
        offsets = half_offsets(ndim, conn)
    off = np.asarray(offsets)
    if off.dtype.kind not in "iu" or off.shape != (len(lengths), ndim):
        raise ValueError(f"Expected integer 'offsets' of shape ({len(lengths)}, {ndim}), but got {off.dtype} {off.shape}")
    return off.astype(np.int64)


def _as_shape3(shape: tuple[int, ...]) -> tuple[int, int, int]:
    return (1,) * (3 - len(shape)) + tuple(shape)


class Distribution:
    """Base of the weight distributions: sampling, per-edge evaluation, kernel parameters, composition.

    Subclasses are frozen dataclasses that define ``_base()`` (kind, a, b, seed)
    and ``_bound()`` (largest base value).
    """

    def _base(self) -> tuple[int, float, float, int]:
        raise NotImplementedError

    def _bound(self) -> float:
        raise NotImplementedError

    def _terms(self) -> tuple[tuple[object, int], ...]:
        """``(field, op)`` pairs applied after the base, in order."""
        return ()

    # composition -------------------------------------------------------------
    def __mul__(self, other):
        if not isinstance(other, _Field):
            return NotImplemented
        return Biased(self, ((other, _kw.MULTIPLY),))

    __rmul__ = __mul__

    def __add__(self, other):
        if not isinstance(other, _Field):
            return NotImplemented
        return Biased(self, ((other, _kw.ADD),))

    __radd__ = __add__

    # evaluation --------------------------------------------------------------
    def kernel_params(self, shape: tuple[int, ...], device=None) -> _kw.WeightParams:
        """The :class:`~wdendrite.kernels.weights.WeightParams` struct for ``edge_weight`` on ``device``.

        Args:
            shape: lattice shape ``(H, W)`` or ``(D, H, W)``.
            device: Warp device for the struct's arrays (default: Warp's default device).

        Returns:
            A struct to pass to a kernel; keep it alive while kernels use it.

        Raises:
            ValueError: when a :class:`Map` does not match ``shape``, or the
                largest possible weight exceeds 1e30.
        """
        shape = _checks.lattice_shape(shape)
        device = _checks.device(device)
        kind, a, b, seed = self._base()
        terms, maps = [], []
        start = 0
        for fld, op in self._terms():
            term, values = fld._term(shape, op)
            if values is not None:
                term.map_start = start
                start += values.size
                maps.append(values.ravel())
            terms.append(term)
        upper = self._bound() + sum(f.strength for f, op in self._terms() if op == _kw.ADD)
        upper *= math.prod(1.0 + f.strength for f, op in self._terms() if op == _kw.MULTIPLY) * math.sqrt(3.0)
        if not upper < _MAX_WEIGHT:
            raise ValueError(f"{self!r} gives weights up to about {upper:.3g}, above the supported {_MAX_WEIGHT:g}")
        params = _kw.WeightParams()
        params.kind = int(kind)
        params.seed = wp.uint32(seed)
        params.a = float(a)
        params.b = float(b)
        params.num_terms = len(terms)
        params.terms = wp.array(terms or [_kw.BiasTerm()], dtype=_kw.BiasTerm, device=device)
        flat = np.concatenate(maps) if maps else np.zeros(1, np.float32)
        params.maps = wp.array(flat.astype(np.float32), dtype=float, device=device)
        params.links = wp.zeros(1, dtype=int, device=device)
        return params

    def _launch_args(self, shape, lengths, offsets, device):
        shape = _checks.lattice_shape(shape)
        lengths = np.asarray(lengths, dtype=np.float32).reshape(-1)
        off = _offsets_for(shape, lengths, offsets)
        off3 = np.zeros((len(off), 3), np.int32)
        off3[:, 3 - len(shape) :] = off
        params = self.kernel_params(shape, device)
        return (
            shape,
            params,
            wp.vec3i(*_as_shape3(shape)),
            wp.array(off3, dtype=wp.vec3i, device=device),
            wp.array(lengths, dtype=float, device=device),
        )

    def sample(self, shape: tuple[int, ...], lengths: np.ndarray, *, offsets=None, device=None) -> np.ndarray:
        """Every edge weight of a lattice.

        Args:
            shape: lattice shape ``(H, W)`` or ``(D, H, W)``.
            lengths: ``(K,)`` Euclidean length of each edge direction.
            offsets: ``(K, ndim)`` int half-offsets; default: the standard
                half-offsets of :func:`wdendrite.lattice.half_offsets` for K directions.
            device: Warp device to compute on (default ``"cpu"``).

        Returns:
            ``(K, *shape)`` float32; entry ``[k][idx]`` is the edge ``idx <-> idx + offsets[k]``.

        Raises:
            ValueError: a bad ``shape``, ``lengths`` or ``offsets`` that do not match it,
                or a distribution whose weights could exceed 1e30 (see :meth:`kernel_params`).
        """
        device = _checks.device(device if device is not None else "cpu")
        shape, params, shape3, off, lens = self._launch_args(shape, lengths, offsets, device)
        n = math.prod(shape)
        out = wp.empty((len(lens), n), dtype=float, device=device)
        wp.launch(
            _kw.fill_weights_kernel, dim=(len(lens), n), inputs=[params, shape3, off, lens], outputs=[out], device=device
        )
        return out.numpy().reshape((len(lens), *shape))

    def evaluate(self, shape, lengths, nodes, directions, *, offsets=None, device=None) -> np.ndarray:
        """Weights of single edges, computed without the whole array.

        Args:
            shape, lengths, offsets, device: as for :meth:`sample`.
            nodes: ``(E,)`` flat node indices (C order) of the edges' first ends.
            directions: ``(E,)`` direction indices in ``[0, K)``.

        Returns:
            ``(E,)`` float32, equal to ``sample(...)[directions, nodes]`` (flattened).

        Raises:
            ValueError: as for :meth:`sample`; ``nodes`` and ``directions`` of different
                lengths or out of range.
        """
        device = _checks.device(device if device is not None else "cpu")
        shape, params, shape3, off, lens = self._launch_args(shape, lengths, offsets, device)
        nodes = np.asarray(nodes).reshape(-1)
        directions = np.asarray(directions).reshape(-1)
        if nodes.shape != directions.shape:
            raise ValueError(f"'nodes' and 'directions' differ in length: {nodes.shape} vs {directions.shape}")
        if nodes.size and (nodes.min() < 0 or nodes.max() >= math.prod(shape)):
            raise ValueError(f"'nodes' must lie in [0, {math.prod(shape)}), but range over [{nodes.min()}, {nodes.max()}]")
        if directions.size and (directions.min() < 0 or directions.max() >= len(lens)):
            raise ValueError(f"'directions' must lie in [0, {len(lens)}), but range over [{directions.min()}, {directions.max()}]")
        out = wp.empty(len(nodes), dtype=float, device=device)
        wp.launch(
            _kw.edge_weights_at_kernel,
            dim=len(nodes),
            inputs=[
                params,
                shape3,
                off,
                lens,
                wp.array(nodes.astype(np.int32), dtype=int, device=device),
                wp.array(directions.astype(np.int32), dtype=int, device=device),
            ],
            outputs=[out],
            device=device,
        )
        return out.numpy()


@dataclass(frozen=True)
class Constant(Distribution):
    """Weights ``length * value``: no randomness (with ``value = 1``, plain lattice distances)."""

    value: float = 1.0
    """Cost of a unit-length edge; must be > 0 (paths need positive steps), at least float32's
    smallest normal number (about 1.2e-38; smaller values would round to 0 in the lattice's
    float32 weights) and below 1e30."""

    def __post_init__(self):
        x = _keep(self, "value", _number("value", self.value, low=0.0, low_open=True))
        tiny = float(np.finfo(np.float32).tiny)
        if x < tiny:
            raise ValueError(f"Expected 'value' >= {tiny:.4g} (float32's smallest normal number; the lattice's "
                             f"float32 weights would round it to 0), but got {self.value!r}")
        if not x < _MAX_WEIGHT:
            raise ValueError(f"Expected 'value' < {_MAX_WEIGHT:g} (the largest supported weight), but got {self.value!r}")

    def _base(self):
        return _kw.CONSTANT, float(self.value), 0.0, 0

    def _bound(self):
        return float(self.value)


@dataclass(frozen=True)
class Uniform(Distribution):
    """Xu & Mould's uniform weights ``W = length * (1 + r * R)``, R uniform in (0, 1)."""

    r: float = 10.0
    """Spread of the random part (the papers use about 10; the thesis 10 to 100). Must be >= 0."""
    seed: int = 0
    """Seed of the hash, in [0, 2**32); the same seed gives the same weights every time."""

    def __post_init__(self):
        _keep(self, "r", _number("r", self.r, low=0.0))
        _keep(self, "seed", _checks.seed32(self.seed))

    def _base(self):
        return _kw.UNIFORM, float(self.r), 0.0, self.seed

    def _bound(self):
        return 1.0 + float(self.r)


@dataclass(frozen=True)
class Power(Distribution):
    """Power weights ``W = length * R ** alpha``, R uniform in (1, max) (constructive path planning, eq. 1).

    alpha 0.3 gives nearly straight paths, 1 the conventional model, 3
    erratic ones (used for lightning).
    """

    alpha: float = 3.0
    """Exponent; must be > 0. Larger values make cheap edges relatively cheaper and paths more tortuous."""
    max: float = 11.0
    """Upper end of R's range; must be > 1. The default matches ``Uniform(r=10)``'s range (1, 11)."""
    seed: int = 0
    """Seed of the hash, in [0, 2**32)."""

    def __post_init__(self):
        _keep(self, "alpha", _number("alpha", self.alpha, low=0.0, low_open=True))
        _keep(self, "max", _number("max", self.max, low=1.0, low_open=True))
        _keep(self, "seed", _checks.seed32(self.seed))
        self._check_bound()

    def _check_bound(self):
        top = self._bound()
        if not top < _MAX_WEIGHT:
            raise ValueError(
                f"Power(alpha={self.alpha!r}, max={self.max!r}) gives weights up to {top:.3g}, "
                f"above the supported {_MAX_WEIGHT:g}; lower 'alpha' or 'max'"
            )

    def _base(self):
        return _kw.POWER, float(self.alpha), float(self.max), self.seed

    def _bound(self):
        try:
            return float(self.max) ** float(self.alpha)
        except OverflowError:
            return math.inf


@dataclass(frozen=True)
class Polynomial(Distribution):
    """The thesis' weights ``W = length * (1 + v ** n)``, v uniform in (0, 100) (section 4.2).

    n = 0 gives constant weights (Manhattan paths), 1 the simple dendrite,
    3 to 4 erratic paths (lightning), 8 very erratic ones. Path costs are
    float32: from n = 5 on the weights span more than it resolves, so along a
    costly path the cheapest edges add nothing, and such stretches are crossed
    in the fewest steps rather than by their least cost
    (:func:`~wdendrite.presets.weight_distributions` caps v for n > 4 instead).
    """

    n: float = 1.0
    """Exponent; must be >= 0 (and at most 14, so weights stay below 1e30)."""
    seed: int = 0
    """Seed of the hash, in [0, 2**32)."""

    def __post_init__(self):
        _keep(self, "n", _number("n", self.n, low=0.0))
        _keep(self, "seed", _checks.seed32(self.seed))
        if not self._bound() < _MAX_WEIGHT:
            raise ValueError(f"Expected 'n' <= 14 (weights up to 1 + 100**n must stay below 1e30), but got {self.n!r}")

    def _base(self):
        return _kw.POLYNOMIAL, float(self.n), 0.0, self.seed

    def _bound(self):
        return 1.0 + 100.0 ** float(self.n) if float(self.n) < 20 else math.inf


class _Field:
    """A spatial bias field: ``g`` in [0, 1] per edge, 0 where edges are cheapest."""

    strength: float
    exponent: float

    def _term(self, shape: tuple[int, ...], op: int) -> tuple[_kw.BiasTerm, np.ndarray | None]:
        raise NotImplementedError

    def _new_term(self, kind: int, op: int) -> _kw.BiasTerm:
        t = _kw.BiasTerm()
        t.kind = int(kind)
        t.op = int(op)
        t.strength = float(self.strength)
        t.exponent = float(self.exponent)
        t.invert = 0
        t.direction = wp.vec3(0.0, 0.0, 0.0)
        t.offset = 0.0
        t.center = wp.vec3(0.0, 0.0, 0.0)
        t.horizontal = wp.vec3(0.0, 0.0, 0.0)
        t.inv_radius = 0.0
        t.map_start = 0
        return t


_TOWARD = ("left", "right", "top", "bottom", "axis", "away_from_axis")


@dataclass(frozen=True)
class Tropism(_Field):
    """A smooth bias making edges cheaper toward one side of the lattice (tropism).

    The vertical lattice axis is axis 0: rows ``y`` of a 2D ``(H, W)`` lattice,
    ``z`` of a 3D ``(D, H, W)`` one. The horizontal coordinates are ``x`` in 2D
    and ``(y, x)`` in 3D. With ``t`` the normalized position (0 on the cheap
    side, 1 on the far side), the field is ``g = t ** exponent``:

    - ``"left"`` / ``"right"``: ``t`` grows linearly in ``x`` away from
      column 0 / column W-1.
    - ``"top"`` / ``"bottom"``: ``t`` grows linearly along the vertical axis
      away from the top / the bottom (see ``top_at_zero``).
    - ``"axis"``: ``t = r / r_max``, with ``r`` the horizontal distance from a
      vertical axis through ``center`` (radius in 3D) and ``r_max`` its largest
      value on the lattice: edges are cheaper near the axis.
    - ``"away_from_axis"``: ``t = 1 - r / r_max``: edges are cheaper far from it.

    Fields are evaluated at each edge's midpoint. Combine with a distribution:
    ``Uniform() * Tropism("left", strength=2)`` scales weights by ``1 + 2 g``
    (up to 3x dearer on the right); ``Uniform() + Tropism(...)`` adds ``2 g``
    (times the edge length).
    """

    toward: Literal["left", "right", "top", "bottom", "axis", "away_from_axis"]
    """Where edges are cheapest."""
    strength: float = 1.0
    """Size of the bias, >= 0 (see the class docstring for how it combines)."""
    exponent: float = 1.0
    """Shape of the ramp ``g = t ** exponent``, > 0 (1: linear)."""
    center: tuple[float, ...] | None = None
    """Horizontal position of the vertical axis: ``(x,)`` in 2D, ``(y, x)`` in 3D, in node units.
    Default: the lattice centre. Only for ``"axis"`` and ``"away_from_axis"``."""
    top_at_zero: bool | None = None
    """Whether index 0 of the vertical axis is the top. Default: True in 2D
    (image rows run downward), False in 3D (z runs upward)."""

    def __post_init__(self):
        if self.toward not in _TOWARD:
            raise ValueError(f"Expected 'toward' in {_TOWARD}, but got {self.toward!r}")
        _keep(self, "strength", _number("strength", self.strength, low=0.0))
        _keep(self, "exponent", _number("exponent", self.exponent, low=0.0, low_open=True))
        if self.center is not None:
            c = np.atleast_1d(np.asarray(self.center, dtype=float))
            if c.ndim != 1 or c.size not in (1, 2) or not np.isfinite(c).all():
                raise ValueError(f"Expected 'center' as finite (x,) in 2D or (y, x) in 3D, but got {self.center!r}")
            _keep(self, "center", tuple(c.tolist()))
        if self.top_at_zero is not None:
            if not isinstance(self.top_at_zero, (bool, np.bool_)):
                raise TypeError(f"Expected a bool or None for 'top_at_zero', but got {self.top_at_zero!r}")
            _keep(self, "top_at_zero", bool(self.top_at_zero))

    def _term(self, shape, op):
        ndim = len(shape)
        s3 = _as_shape3(shape)
        vert = 3 - ndim  # index of the vertical axis in (z, y, x)
        if self.toward in ("axis", "away_from_axis"):
            t = self._new_term(_kw.RADIAL, op)
            hdims = list(range(vert + 1, 3))
            if self.center is None:
                c = [(s3[d] - 1) / 2.0 for d in hdims]
            else:
                c = list(np.atleast_1d(np.asarray(self.center, dtype=float)))
                if len(c) != len(hdims):
                    raise ValueError(
                        f"Expected 'center' of {len(hdims)} horizontal coordinate(s) for a {ndim}D lattice, but got {self.center!r}"
                    )
            center = [0.0, 0.0, 0.0]
            horizontal = [0.0, 0.0, 0.0]
            far = 0.0
            for d, cd in zip(hdims, c):
                center[d] = float(cd)
                horizontal[d] = 1.0
                far += max(abs(cd), abs(s3[d] - 1 - cd)) ** 2
            t.center = wp.vec3(*center)
            t.horizontal = wp.vec3(*horizontal)
            t.inv_radius = 1.0 / math.sqrt(far) if far > 0 else 0.0
            t.invert = int(self.toward == "away_from_axis")
            return t, None
        t = self._new_term(_kw.RAMP, op)
        if self.toward in ("left", "right"):
            d, from_zero = 2, self.toward == "left"
        else:
            top_at_zero = (ndim == 2) if self.top_at_zero is None else bool(self.top_at_zero)
            d, from_zero = vert, (self.toward == "top") == top_at_zero
        span = s3[d] - 1
        direction = [0.0, 0.0, 0.0]
        if span > 0:
            direction[d] = 1.0 / span if from_zero else -1.0 / span
            t.offset = 0.0 if from_zero else 1.0
        t.direction = wp.vec3(*direction)
        return t, None


def _grayscale(name: str, image) -> np.ndarray:
    """``image`` (array, file path or PIL image) as float32 brightness in [0, 1] (0 = black).

    uint8 arrays are divided by 255, uint16 by 65535, bool arrays map to 0/1
    and float arrays must already lie in [0, 1]. Files and PIL images are
    converted to 8-bit grayscale, except 16-bit grayscale (modes ``I;16`` and ``I``, as
    Pillow opens 16-bit PNGs; divided by 65535) and float images (mode ``F``, in [0, 1]);
    transparent parts of an image read as white paper.
    """
    if isinstance(image, (str, os.PathLike)):
        from PIL import Image, UnidentifiedImageError

        try:
            with Image.open(image) as img:
                return _grayscale(name, img)
        except (OSError, UnidentifiedImageError) as err:
            raise ValueError(f"Could not read '{name}' from {os.fspath(image)!r}: {err}") from None
    if hasattr(image, "mode") and hasattr(image, "convert"):  # a PIL image
        if image.mode.startswith("I;16") or image.mode == "I":
            arr = np.asarray(image, dtype=np.float64)
            if arr.size and (arr.min() < 0 or arr.max() > 65535):
                raise ValueError(f"Expected a 16-bit grayscale image for '{name}' (values 0-65535), but its "
                                 f"values span [{arr.min():g}, {arr.max():g}]")
            return (arr / 65535.0).astype(np.float32)
        if image.mode == "F":
            return _grayscale(name, np.asarray(image, dtype=np.float32))
        if image.mode in ("LA", "RGBA", "PA", "La", "RGBa") or "transparency" in image.info:
            from PIL import Image

            paper = Image.new("RGBA", image.size, (255, 255, 255, 255))
            image = Image.alpha_composite(paper, image.convert("RGBA"))
        return (np.asarray(image.convert("L"), dtype=np.float64) / 255.0).astype(np.float32)
    arr = np.asarray(image)
    if arr.dtype == np.bool_:
        return arr.astype(np.float32)
    if arr.dtype == np.uint8:
        return (arr / 255.0).astype(np.float32)
    if arr.dtype == np.uint16:
        return (arr / 65535.0).astype(np.float32)
    if arr.dtype.kind != "f":
        raise TypeError(
            f"Expected '{name}' as a bool, uint8, uint16 or float array, a file path or a PIL image, "
            f"but got {type(image).__name__} of dtype {arr.dtype}"
        )
    if arr.size and (not np.isfinite(arr).all() or arr.min() < 0 or arr.max() > 1):
        raise ValueError(
            f"Expected float '{name}' values in [0, 1], but got range [{np.nanmin(arr)}, {np.nanmax(arr)}]"
            + (" with NaN/inf" if not np.isfinite(arr).all() else "")
        )
    return arr.astype(np.float32)


@dataclass(frozen=True, eq=False)
class Map(_Field):
    """A user map (array or grayscale image, e.g. a sketch) biasing edges where it is dark.

    The map has the lattice's shape (row 0 is the image's top row). Its
    brightness ``b`` in [0, 1] is read at each node, and an edge takes the mean
    of its two end nodes. With ``dark="cheaper"`` the field is ``g = b``
    (edges over dark areas are cheapest); with ``dark="dearer"`` it is
    ``g = 1 - b``. Then ``g ** exponent`` enters like a :class:`Tropism`.
    """

    image: object
    """A ``(H, W)`` / ``(D, H, W)`` array (bool, uint8, uint16 or float in [0, 1]), an image file path, or a PIL image."""
    strength: float = 1.0
    """Size of the bias, >= 0."""
    dark: Literal["cheaper", "dearer"] = "cheaper"
    """Whether dark areas make edges cheaper or dearer."""
    exponent: float = 1.0
    """Shape exponent on ``g``, > 0."""
    brightness: np.ndarray = field(init=False, repr=False)
    """The map as float32 brightness in [0, 1] (read once, at construction)."""

    def __post_init__(self):
        if self.dark not in ("cheaper", "dearer"):
            raise ValueError(f"Expected 'dark' in ('cheaper', 'dearer'), but got {self.dark!r}")
        _keep(self, "strength", _number("strength", self.strength, low=0.0))
        _keep(self, "exponent", _number("exponent", self.exponent, low=0.0, low_open=True))
        b = _grayscale("image", self.image)
        if b.ndim not in (2, 3) or b.size == 0:
            raise ValueError(f"Expected a non-empty 2D or 3D 'image' (one value per node), but got shape {b.shape}")
        b = np.ascontiguousarray(b)
        b.flags.writeable = False
        object.__setattr__(self, "brightness", b)

    def __repr__(self) -> str:
        return f"Map(shape={self.brightness.shape}, strength={self.strength!r}, dark={self.dark!r}, exponent={self.exponent!r})"

    def _term(self, shape, op):
        if self.brightness.shape != tuple(shape):
            raise ValueError(
                f"Expected 'image' of the lattice shape {tuple(shape)}, but got shape {self.brightness.shape}"
            )
        t = self._new_term(_kw.MAP, op)
        t.invert = int(self.dark == "dearer")
        return t, self.brightness


@dataclass(frozen=True, eq=False)
class Biased(Distribution):
    """A distribution with spatial bias terms: ``length * (base + sum(added)) * prod(1 + scaled)``.

    Built by ``distribution * field`` and ``distribution + field``; more fields
    chain (``Uniform() * Tropism("left") * Map(img)``). Added terms must come
    before scaled ones, so that the written expression is what is computed.
    """

    base: Distribution
    """The random part (not itself a :class:`Biased`)."""
    terms: tuple = ()
    """``(field, op)`` pairs, op being ``kernels.weights.ADD`` or ``MULTIPLY``, in order."""

    def __post_init__(self):
        if not isinstance(self.base, Distribution) or isinstance(self.base, Biased):
            raise TypeError(f"Expected a plain distribution for 'base', but got {self.base!r}")
        if not isinstance(self.terms, tuple) or any(not (isinstance(t, tuple) and len(t) == 2) for t in self.terms):
            raise TypeError(f"Expected 'terms' as a tuple of (field, op) pairs, but got {self.terms!r}")
        ops = [op for _, op in self.terms]
        if any(not isinstance(f, _Field) for f, _ in self.terms):
            raise TypeError(f"Expected Tropism or Map fields in 'terms', but got {self.terms!r}")
        bad = [op for op in ops if isinstance(op, bool) or op not in (_kw.ADD, _kw.MULTIPLY)]
        if bad:
            raise ValueError(f"Expected each op in 'terms' to be kernels.weights.ADD ({_kw.ADD}) or MULTIPLY "
                             f"({_kw.MULTIPLY}), but got {bad[0]!r}")
        if any(a == _kw.MULTIPLY and b == _kw.ADD for a, b in zip(ops, ops[1:])):
            raise ValueError(
                "A field cannot be added after one was multiplied in: write (dist + field_a) * field_b, "
                "which is computed as length * (base + a) * (1 + b)"
            )

    def _base(self):
        return self.base._base()

    def _bound(self):
        return self.base._bound()

    def _terms(self):
        return tuple(self.terms)

    def __mul__(self, other):
        if not isinstance(other, _Field):
            return NotImplemented
        return Biased(self.base, self.terms + ((other, _kw.MULTIPLY),))

    __rmul__ = __mul__

    def __add__(self, other):
        if not isinstance(other, _Field):
            return NotImplemented
        return Biased(self.base, self.terms + ((other, _kw.ADD),))

    __radd__ = __add__


from ._spec import document_fields as _document_fields  # noqa: E402  (the classes above are complete)

_document_fields(__name__)  # help() shows what each dataclass field means
