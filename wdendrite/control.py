"""Control functions for Dendry: noise, plane, radial ramp, Lichtenberg bowl, images.

A control function ``c(x, y)`` steers the coarsest Dendry branches towards its
low values and sets the terrain's base elevation. Each one is defined on its
own rectangle ``domain`` (its coordinates) and knows its minimum and maximum.
:func:`wdendrite.dendry.dendry` maps its query rectangle onto that domain.

Example::

    from wdendrite import control
    c = control.perlin(seed=3, domain=((-0.2, -0.4), (1.4, 0.7)))
    c.evaluate([[0.0, 0.0], [0.5, 0.1]])   # -> float32 array of 2 values
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field, replace

import numpy as np
import warp as wp

from ._checks import (
    device as _device, finite, finite_array, fits_in_memory, flag, integer, lattice_shape, nonnegative, positive,
    seed32,
)
from .kernels import noise as _kn

__all__ = ["Control", "drained", "flood", "image", "lichtenberg", "perlin", "plane", "radial", "ridged"]

Rect = tuple[tuple[float, float], tuple[float, float]]

_KINDS = {"plane": 0, "radial": 1, "perlin": 2, "lichtenberg": 3, "image": 4, "ridged": 5}


def _finite_numbers(name: str, value, numbers, what: str) -> tuple[float, ...]:
    """``numbers`` (unpacked from ``value``) as finite floats; an error names ``name`` and all of ``value``."""
    try:
        return tuple(finite(name, v) for v in numbers)
    except (TypeError, ValueError) as err:  # TypeError for text and bools, ValueError for NaN/inf
        raise type(err)(f"Expected {what} for '{name}', but got {value!r}") from None


def _pair(name: str, value) -> tuple[float, float]:
    """Return ``value`` as two finite floats."""
    try:
        a, b = value
    except (TypeError, ValueError):
        raise TypeError(f"Expected two numbers for '{name}', but got {value!r}") from None
    return _finite_numbers(name, value, (a, b), "two finite numbers")


def rectangle(name: str, value) -> Rect:
    """Return ``value`` as ``((x0, y0), (x1, y1))`` floats with x0 < x1 and y0 < y1, all finite."""
    try:
        (x0, y0), (x1, y1) = value
    except (TypeError, ValueError):
        raise TypeError(f"Expected a rectangle ((x0, y0), (x1, y1)) for '{name}', but got {value!r}") from None
    x0, y0, x1, y1 = _finite_numbers(name, value, (x0, y0, x1, y1), "a rectangle of finite corners")
    if not (x1 > x0 and y1 > y0):
        raise ValueError(f"Expected '{name}' with x0 < x1 and y0 < y1 (not empty, not inverted), but got {value!r}")
    return ((x0, y0), (x1, y1))


def _grid_shape(shape, device) -> tuple[int, int]:
    """Return ``shape`` as (H, W) positive ints whose float32 grid fits on ``device``."""
    dims = lattice_shape(shape, ranks=(2,))
    fits_in_memory(4 * dims[0] * dims[1], device, f"A grid of 'shape' {dims}")
    return dims


@dataclass(frozen=True, eq=False)
class Control:
    """A control function; build one with :func:`perlin`, :func:`plane`, :func:`radial`,
    :func:`lichtenberg`, :func:`image` or :func:`ridged`.

    The fields are checked when a control is made (also by :func:`dataclasses.replace`), but
    ``minimum`` and ``maximum`` are taken as given: they are measured by the functions above, so
    call one of them again rather than replacing ``seed``, ``params`` or ``domain``.
    """

    kind: str
    """One of ``"plane"``, ``"radial"``, ``"perlin"``, ``"lichtenberg"``, ``"image"``, ``"ridged"``."""
    domain: Rect
    """The rectangle ``((x0, y0), (x1, y1))`` of the function's own coordinates that Dendry's query maps onto."""
    minimum: float
    """Smallest value the function takes on ``domain`` (values outside ``domain`` are not counted)."""
    maximum: float
    """Largest value the function takes on ``domain``; with ``minimum`` it normalises the terrain's
    slopes (:class:`wdendrite.dendry.DendryParams` ``beta``, eq. 7)."""
    params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    """Kind-specific numbers (plane: offset, gx, gy; radial: cx, cy, radius; noise: frequency, gain, lacunarity, offset)."""
    seed: int = 0
    """Noise seed (noise kinds only)."""
    octaves: int = 1
    """Noise octaves (noise kinds only)."""
    bounded: bool = False
    """True when points outside ``domain`` are outside the function (Dendry drops their segments)."""
    values: np.ndarray | None = field(default=None, repr=False)
    """The (h, w) float32 samples of an image control; pixel centres tile ``domain``, row 0 at y0."""

    def __post_init__(self):
        # (the builders pass checked values; this guards controls made or replaced by hand)
        put = functools.partial(object.__setattr__, self)
        if self.kind not in _KINDS:
            raise ValueError(f"Expected 'kind' in {tuple(_KINDS)}, but got {self.kind!r}")
        put("domain", rectangle("domain", self.domain))
        for name in ("minimum", "maximum"):  # (NaN and inf pass: the builders refuse them with their own names)
            value = getattr(self, name)
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.number)):
                raise TypeError(f"Expected a number for '{name}', but got {value!r}")
            put(name, float(value))
        if not self.minimum <= self.maximum and not (math.isnan(self.minimum) or math.isnan(self.maximum)):
            raise ValueError(f"Expected 'minimum' <= 'maximum', but got {self.minimum!r} and {self.maximum!r}")
        params = np.asarray(self.params, dtype=object)
        if params.shape != (4,):
            raise ValueError(f"Expected 'params' as 4 numbers, but got {self.params!r}")
        put("params", tuple(finite(f"params[{i}]", v) for i, v in enumerate(self.params)))
        put("seed", seed32(self.seed))
        put("octaves", integer("octaves", self.octaves, low=1, high=16))
        put("bounded", flag("bounded", self.bounded))
        if self.kind == "image" and self.values is None:
            raise ValueError("An image control needs its 'values', but got none")
        if self.kind != "image" and self.values is not None:
            raise ValueError(f"Expected 'values' for an image control only, but got an array for kind {self.kind!r}")
        if self.values is not None:
            # a read-only copy: later writes to the caller's array would change the control while its
            # minimum and maximum stay
            values = np.array(finite_array("values", self.values, "2D (h, w)", lambda s: len(s) == 2))
            values.flags.writeable = False
            put("values", values)

    def __setstate__(self, state):
        # unpickled and deep-copied controls get fresh, writeable values: read-only again
        self.__dict__.update(state)
        if isinstance(self.values, np.ndarray):
            self.values.flags.writeable = False

    def struct(self, device=None) -> _kn.Control:
        """The kernel-side :class:`wdendrite.kernels.noise.Control` on ``device``."""
        s = _kn.Control()
        s.kind = _KINDS[self.kind]
        s.a = wp.vec4(*self.params)
        s.octaves = int(self.octaves)
        s.lo = wp.vec2(*self.domain[0])
        s.hi = wp.vec2(*self.domain[1])
        s.vmin = float(self.minimum)
        s.vmax = float(self.maximum)
        s.bounded = int(self.bounded)
        img = self.values if self.values is not None else np.zeros((1, 1), np.float32)
        s.image = wp.array(img, dtype=float, device=device)
        noisy = self.kind in ("perlin", "ridged")
        perm = _permutation(self.seed) if noisy else np.zeros(2, np.int32)
        grad = _GRADIENTS[perm & 7]
        s.cols = wp.array(np.stack([perm[:-1], perm[1:]], axis=1)[:256], dtype=wp.vec2i, device=device)
        s.grads = wp.array(np.concatenate([grad[:-1], grad[1:]], axis=1), dtype=wp.vec4, device=device)
        return s

    def check_reach(self, lo, hi, what: str, fix: str) -> None:
        """Refuse evaluating a noise control between the corners ``lo`` and ``hi`` (x, y in its own
        coordinates) where float32 cannot resolve its noise: lattice coordinates (point times
        frequency, and lacunarity per octave) beyond 2**22 turn it flat, then NaN. Other kinds
        pass. ``what`` names the points in the error, ``fix`` says what to change."""
        if self.kind not in ("perlin", "ridged"):
            return
        freq, lac = self.params[0], self.params[2]
        with np.errstate(over="ignore"):
            top = float(np.max(np.abs(np.asarray([lo, hi], np.float64))))
            reach = top * freq * max(1.0, np.float64(lac) ** (self.octaves - 1))
        if not reach <= _NOISE_REACH:
            octaves = f"{self.octaves} octave{'s' if self.octaves != 1 else ''}"
            raise ValueError(
                f"{what} reaches {top:.4g} in the {self.kind} control's coordinates, where its noise (frequency "
                f"{freq:g}, lacunarity {lac:g} over {octaves}) is sampled at up to {reach:.3g}, beyond the "
                f"2**22 = {_NOISE_REACH} that float32 resolves (the noise would be flat, then NaN); {fix}")

    def evaluate(self, points, *, device=None) -> np.ndarray:
        """The function at ``points`` ((N, 2) x, y in its own coordinates; an empty list: none) as (N,) float32."""
        try:
            none = np.shape(points) in ((0,), (0, 2))
        except ValueError:  # ragged: finite_array names it
            none = False
        if none:
            return np.zeros(0, np.float32)
        pts = finite_array("points", points, "(N, 2)", lambda shape: len(shape) == 2 and shape[1] == 2)
        self.check_reach(pts.min(axis=0), pts.max(axis=0), "'points'", "evaluate it nearer the origin")
        device = _device(device)
        out = wp.zeros(len(pts), dtype=float, device=device)
        wp.launch(
            _kn.control_points_kernel,
            dim=len(pts),
            inputs=[self.struct(device), wp.array(pts, dtype=wp.vec2, device=device)],
            outputs=[out],
            device=device,
        )
        return out.numpy()

    def grid(self, shape, *, device=None) -> np.ndarray:
        """The function at the pixel centres of an (H, W) grid over ``domain`` (row 0 at y0), float32.

        Raises:
            ValueError, TypeError: ``shape`` is not two positive ints.
            MemoryError: the grid does not fit in the device's free memory.
        """
        device = _device(device)
        h, w = _grid_shape(shape, device)
        (x0, y0), (x1, y1) = self.domain
        out = wp.zeros((h, w), dtype=float, device=device)
        wp.launch(
            _kn.control_grid_kernel,
            dim=(h, w),
            inputs=[self.struct(device), wp.vec2(x0, y0), wp.vec2((x1 - x0) / w, (y1 - y0) / h)],
            outputs=[out],
            device=device,
        )
        return out.numpy()


# the 8 gradients of the Perlin noise: the diagonals, then along x, then along y
_GRADIENTS = np.array([[1, 1], [-1, 1], [1, -1], [-1, -1], [1, 0], [-1, 0], [0, 1], [0, -1]], np.float32)


@functools.lru_cache(maxsize=64)
def _permutation(seed: int) -> np.ndarray:
    """The Perlin permutation table of ``seed``: a Fisher-Yates shuffle of 0..255 stored twice (512 int32).

    The shuffle draws from SplitMix64 seeded with ``seed``, so a seed gives the same field on every
    machine and NumPy version.
    """
    state = seed % 2**64
    mask = 2**64 - 1
    perm = list(range(256))
    for i in range(255, 0, -1):
        state = (state + 0x9E3779B97F4A7C15) & mask
        z = state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & mask
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & mask
        z ^= z >> 31
        j = z % (i + 1)
        perm[i], perm[j] = perm[j], perm[i]
    table = np.array(perm + perm, dtype=np.int32)
    table.setflags(write=False)
    return table


_FLOAT32_MAX = float(np.finfo(np.float32).max)
_NOISE_REACH = 2**22  # noise lattice coordinates float32 resolves (see Control.check_reach)


def _fits(control: Control, names: str) -> Control:
    """``control``, once its minimum and maximum on its domain are finite in float32 (the kernels
    evaluate it in float32); else a ValueError naming the parameters ``names`` that set its range."""
    lo, hi = control.minimum, control.maximum
    if not (math.isfinite(lo) and math.isfinite(hi) and max(abs(lo), abs(hi)) <= _FLOAT32_MAX):
        raise ValueError(
            f"The {control.kind} control's values on its domain {control.domain} do not fit float32 (minimum "
            f"{lo!r}, maximum {hi!r}; the kernels evaluate it in float32): choose {names}")
    return control


def _noise(kind: str, seed, frequency, octaves, gain, lacunarity, offset, domain) -> Control:
    seed = seed32(seed)
    octaves = integer("octaves", octaves, low=1, high=16)
    params = (positive("frequency", frequency), positive("gain", gain), positive("lacunarity", lacunarity),
              nonnegative("offset", offset, allow_none=False))
    dom = rectangle("domain", domain)
    probe = Control(kind, dom, 0.0, 1.0, params, seed, octaves)
    probe.check_reach(*dom, f"'domain' {dom} (with 'frequency' = {frequency!r})",
                      "lower 'frequency', 'lacunarity' or 'octaves', or a 'domain' nearer the origin")
    # ridged maxima sit on creases (where an octave's noise crosses 0), which a coarse grid
    # straddles: a finer grid and more starting points for the zoom find them
    lo, hi = _extremes(probe, samples=513, keep=32) if kind == "ridged" else _extremes(probe)
    # (a large gain over many octaves overflows the octaves' float32 sum, which then gives NaN)
    return _fits(Control(kind, dom, lo, hi, params, seed, octaves),
                 "a smaller 'gain' or fewer 'octaves'" + (", or a smaller 'offset'" if kind == "ridged" else ""))


def _extremes(probe: Control, samples: int = 257, keep: int = 4, rounds: int = 4) -> tuple[float, float]:
    """Minimum and maximum of a smooth field over its domain.

    A noise sum has no closed-form range: sample it on a ``samples``^2 grid, then zoom
    in around the ``keep`` best samples of each kind with finer 17 x 17 grids (each round
    8 times narrower, clipped to the domain), so the values found lie within rounding
    of the true extremes instead of a grid step away.
    """
    (x0, y0), (x1, y1) = probe.domain
    vals = probe.grid((samples, samples), device="cpu")
    step = np.array([(x1 - x0) / samples, (y1 - y0) / samples])
    found = []
    for sign in (1.0, -1.0):
        best = float((sign * vals).min())
        for k in np.argsort((sign * vals).ravel())[:keep]:
            r, c = divmod(int(k), samples)
            centre = np.array([x0 + (c + 0.5) * step[0], y0 + (r + 0.5) * step[1]])
            half = step.copy()
            for _ in range(rounds):
                t = np.linspace(-1.0, 1.0, 17)
                gx, gy = np.meshgrid(centre[0] + t * half[0], centre[1] + t * half[1])
                pts = np.stack([np.clip(gx.ravel(), x0, x1), np.clip(gy.ravel(), y0, y1)], 1)
                v = sign * probe.evaluate(pts, device="cpu")
                i = int(np.argmin(v))
                best = min(best, float(v[i]))
                centre, half = pts[i], half / 8.0
        found.append(sign * best)
    return found[0], found[1]


def perlin(*, seed: int = 0, frequency: float = 1.0, octaves: int = 1, gain: float = 0.5,
           lacunarity: float = 2.0, domain=((0.0, 0.0), (1.0, 1.0))) -> Control:
    """Perlin gradient noise (fBm when ``octaves`` > 1) mapped to about [0, 1]: ``0.5 + 0.5 * sum / norm``.

    The noise is our own 2D Perlin noise on a permutation table shuffled from ``seed``
    (see :mod:`wdendrite.kernels.noise`); with one octave it is 0.5 at every integer point of
    ``frequency * p`` (further octaves are shifted, so fBm is not).

    Args:
        seed: selects the noise field, in [0, 2**32).
        frequency: features per unit of the control coordinates.
        octaves: number of summed octaves, each ``lacunarity`` times finer and ``gain`` times weaker.
        gain: amplitude of each octave relative to the one before (> 0; 0.5 halves it).
        lacunarity: frequency of each octave relative to the one before (> 0; 2 doubles it).
        domain: the rectangle Dendry's query maps onto; minimum and maximum are found there
            by sampling a 257 x 257 grid and zooming in around the best samples.
    """
    return _noise("perlin", seed, frequency, octaves, gain, lacunarity, 0.0, domain)


def ridged(*, seed: int = 0, frequency: float = 1.0, octaves: int = 8, gain: float = 0.5,
           lacunarity: float = 2.0, offset: float = 1.0, domain=((0.0, 0.0), (1.0, 1.0))) -> Control:
    """Ridged multifractal noise (octaves of ``(offset - |noise|)^2``, each weighted by the previous one).

    Its maxima lie on sharp creases (where an octave's noise is 0): the ``maximum`` found by
    sampling and zooming may lie below the true one by about 1e-3 (the noise lies in about [-1, 1], so
    the values stay below about ``max(offset, 1 - offset)^2``).

    Args:
        seed: selects the noise field, in [0, 2**32).
        frequency: features per unit of the control coordinates (of the first octave).
        octaves: number of octaves, in [1, 16]; more than :func:`perlin`'s one by default, since
            the ridges' detail comes from the finer octaves.
        gain: weight of each octave relative to the one before (> 0).
        lacunarity: frequency of each octave relative to the one before (> 0).
        offset: ``offset - |noise|`` before squaring, >= 0: 1 puts the ridges at the noise's
            zeros, smaller values lower them.
        domain: the rectangle Dendry's query maps onto; minimum and maximum are found there by
            sampling a 513 x 513 grid and zooming in around the 32 best samples.
    """
    return _noise("ridged", seed, frequency, octaves, gain, lacunarity, offset, domain)


def plane(gradient=(0.0, 1.0), *, offset: float = 0.0, domain=((0.0, 0.0), (1.0, 1.0))) -> Control:
    """The plane ``offset + gx * x + gy * y``; its extremes are at the corners of ``domain``.

    Args:
        gradient: (gx, gy), the rise per unit of the control coordinates along x and y.
        offset: the value at (0, 0).
        domain: ((x0, y0), (x1, y1)), the rectangle of control coordinates Dendry's domain maps
            onto by default; the range (minimum, maximum) is the plane's over it.
    """
    gx, gy = _pair("gradient", gradient)
    off = finite("offset", offset)
    dom = rectangle("domain", domain)
    corners = [off + gx * x + gy * y for x in (dom[0][0], dom[1][0]) for y in (dom[0][1], dom[1][1])]
    return _fits(Control("plane", dom, min(corners), max(corners), (off, gx, gy, 0.0)), "a smaller 'gradient', 'offset' or 'domain'")


def radial(center=(0.5, 0.5), *, radius: float = 1.0, domain=((0.0, 0.0), (1.0, 1.0))) -> Control:
    """The radial ramp ``|p - center| / radius`` (low at ``center``).

    Args:
        center: (x, y) of the minimum, 0, in control coordinates.
        radius: the distance from ``center`` at which the ramp reaches 1 (> 0).
        domain: ((x0, y0), (x1, y1)), the rectangle of control coordinates Dendry's domain maps
            onto by default; the range is the ramp's over it (from the point nearest to
            ``center`` to the farthest corner).
    """
    cx, cy = _pair("center", center)
    r = positive("radius", radius)
    dom = rectangle("domain", domain)
    (x0, y0), (x1, y1) = dom
    near = math.hypot(min(max(cx, x0), x1) - cx, min(max(cy, y0), y1) - cy) / r
    far = max(math.hypot(x - cx, y - cy) for x in (x0, x1) for y in (y0, y1)) / r
    return _fits(Control("radial", dom, near, far, (cx, cy, r, 0.0)), "a larger 'radius', or a smaller 'domain'")


def lichtenberg(scale: float = 1.0) -> Control:
    """The Lichtenberg bowl ``scale * (x^2 + (y + 1)^2)`` on [-1, 1]^2 and ``16 * scale`` outside (bounded).

    Its minimum and maximum are those on the domain: 0 at (0, -1) and ``5 * scale`` at
    (+-1, 1). The value outside the square is not counted: points there are outside the
    function, so Dendry drops their segments. ``scale`` (> 0) keeps the order of the values
    (up to float32 rounding, which could make two nearly equal key points tie), so the tree is
    the paper's; terrains (``output="elevation"``) take controls in [0, 1], which ``scale=0.2``
    gives. Outside the square a terrain has no branches, and its primitives take the bowl's
    maximum, ``5 * scale``: the elevation rises to it within two primitive cells of the edge
    (the blend's radius) and stays there.
    """
    scale = positive("scale", scale)
    # (16 * scale, its value outside the square, must fit float32 too)
    _fits(Control("lichtenberg", ((-1.0, -1.0), (1.0, 1.0)), 0.0, 16.0 * scale), "a smaller 'scale'")
    return Control("lichtenberg", ((-1.0, -1.0), (1.0, 1.0)), 0.0, 5.0 * scale, (scale, 0.0, 0.0, 0.0), bounded=True)


def image(values, *, domain=((0.0, 0.0), (1.0, 1.0))) -> Control:
    """A 2D array (sketch, DEM) sampled bicubically; pixel centres tile ``domain``, row 0 at y0.

    Values are clamped to the array's own minimum and maximum, so the Catmull-Rom
    overshoot never leaves that range. Outside ``domain`` the border values continue. A masked
    array (a DEM's nodata cells) is refused: fill its masked cells first.

    Args:
        values: (h, w) finite real array (any unit; a terrain's control must lie in [0, 1],
            so scale a DEM in metres first, e.g. ``(dem - dem.min()) / np.ptp(dem)``).
        domain: ((x0, y0), (x1, y1)), the rectangle of control coordinates the array covers:
            column 0 at x0, row 0 at y0 (y grows down the rows, as in :func:`wdendrite.dendry`).
    """
    arr = finite_array("values", values, "2D (h, w)", lambda shape: len(shape) == 2)
    dom = rectangle("domain", domain)  # (the control keeps a read-only copy of the float32 values)
    return Control("image", dom, float(arr.min()), float(arr.max()), values=arr)


def flood(z0: np.ndarray, rise: np.float32, seeds: np.ndarray | None = None,
          blocked: np.ndarray | None = None) -> np.ndarray:
    """``z0`` ((H, W) float32) filled by a priority flood (Barnes et al. 2014) from the ``seeds``
    ((H, W) bool; default: the border cells), which keep their values: every other cell reached
    over 8-connected neighbours ends at least ``rise`` (or one float32 step, when ``rise`` > 0)
    above the cell it was reached from, so each has a strictly lower neighbour and a descending
    path to a seed (with ``rise`` 0, a path that never climbs). The flood never enters
    ``blocked`` cells ((H, W) bool, default none); they and cells no seed reaches keep their values."""
    import heapq

    z = np.array(z0, dtype=np.float32)
    h, w = z.shape
    if seeds is None:
        seeds = np.zeros((h, w), bool)
        seeds[[0, -1], :] = seeds[:, [0, -1]] = True
    up = np.float32(np.inf)
    done = np.array(seeds, dtype=bool)
    heap = [(z[r, c], r, c) for r, c in zip(*np.nonzero(done))]
    if blocked is not None:
        done |= blocked
    heapq.heapify(heap)
    while heap:
        v, r, c = heapq.heappop(heap)
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                rr, cc = r + dr, c + dc
                if 0 <= rr < h and 0 <= cc < w and not done[rr, cc]:
                    done[rr, cc] = True
                    # the lowest value it may keep: above the cell it drains into, by the rise or at
                    # least one float32 step (level with it when there is no rise)
                    floor = max(v + rise, np.nextafter(v, up)) if rise > 0 else v
                    if z[rr, cc] < floor:
                        z[rr, cc] = floor
                    heapq.heappush(heap, (z[rr, cc], rr, cc))
    return z


def drained(base: Control, *, samples: int = 129, slope: float = 1.0e-4) -> Control:
    """``base`` sampled on a grid and filled so that water on it runs to the border (an image control).

    A control function with an interior minimum makes the level-1 key points around it
    sinks, and the terrain gets a closed basin there (the paper asks for a control
    "without too low local minima"). This wrapper removes such minima: it samples
    ``base`` at ``samples`` x ``samples`` pixel centres over its domain and applies a
    priority-flood fill (Barnes et al. 2014) in which every filled cell rises by
    ``slope * (maximum - minimum)`` above the cell it drains into (at least by one float32 step,
    so that the rise survives the image's float32), so filled basins tilt towards their outlets
    instead of staying flat. With ``slope`` > 0 every interior sample then has a strictly lower
    neighbour. Between the samples the image's bicubic interpolation can still dip a little
    near steep walls (a few per cent of the range in rough noise at 33 samples); more samples
    shrink those dips.

    A drained control does not by itself drain the terrain: where a valley or a basin's spill
    point is narrower than a level-1 cell, a key point can lie below all 8 of its jittered
    neighbours (a level-1 sink), and the rivers around it end in a closed basin. This is
    common in DEM amplification (a map pixel per level-1 cell). Level-1 outlets
    (:attr:`wdendrite.DendryParams.outlets`) remove those sinks without tilting the map; a
    steeper ``slope`` removes them too, at some cost in likeness to the map
    (``benchmarks/dem_hydrology.py`` measures both).

    Args:
        base: any control function.
        samples: grid size (>= 3).
        slope: rise per filled cell, relative to the base's range (0 to 1; 0 leaves filled basins flat).

    Returns:
        An image :class:`Control` over ``base.domain``, bounded where ``base`` is, whose values
        stay within ``base``'s range: where a basin's rim holds the maximum, so that filling it
        would rise above, the samples are first scaled towards their minimum by just that much
        (a control in [0, 1] stays a terrain's control; a large ``slope`` can flatten the base
        that way, or, where the rises alone pass the range, is refused).

    Raises:
        ValueError: a ``base`` that takes one value at every sample, or a ``slope`` whose rises
            alone climb past the base's range.
    """
    if not isinstance(base, Control):
        raise TypeError(f"Expected a Control for 'base', but got {type(base).__name__}")
    samples = integer("samples", samples, low=3)
    slope = nonnegative("slope", slope, allow_none=False)
    if slope > 1.0:
        raise ValueError(f"Expected 'slope' in [0, 1] (a rise per filled cell, relative to the range), but got {slope!r}")
    rise = np.float32(slope * max(base.maximum - base.minimum, 1e-12))
    z0 = base.grid((samples, samples))  # (float32, the image's own values: every rise is one it keeps)
    if not z0.max() > z0.min():
        raise ValueError(f"'base' takes the one value {float(z0.min())!r} at all {samples} x {samples} samples: there is "
                         "no slope to drain along and no range for the fill's rises; use the base as it is")
    z = flood(z0, rise)
    # a basin whose rim holds the maximum fills above it, out of the base's range (a terrain's [0, 1]
    # then refused the result): scale the samples towards their minimum by the excess, keeping the
    # rises, and fill again (a scale that keeps the order: the same basins fill)
    lo, top = float(z0.min()), float(base.maximum)

    def scaled(k: float) -> np.ndarray:  # the samples scaled towards their minimum by k, filled
        return flood((lo + (z0.astype(np.float64) - lo) * k).astype(np.float32), rise)

    k = 1.0
    for _ in range(8):
        over = float(z.max()) - top
        if over <= 0.0:
            break
        k = max(k - 1.1 * over / (top - lo), 0.0)
        z = scaled(k)
    if float(z.max()) > top:
        fits, z = 0.0, scaled(0.0)
        if float(z.max()) > top:  # the rises alone climb past the range: no scale fits
            raise ValueError(
                f"'slope' = {slope!r} tilts the filled basins of this base beyond its range at {samples} samples "
                f"(the rises alone climb {float(z.max()) - lo:.3g} over a range of {top - lo:.3g}); lower 'slope' "
                "or 'samples'")
        for _ in range(24):  # (slow to converge from above: the largest scale that fits, by bisection)
            mid = 0.5 * (fits + k)
            zm = scaled(mid)
            if float(zm.max()) > top:
                k = mid
            else:
                fits, z = mid, zm
    return replace(image(z, domain=base.domain), bounded=base.bounded)
