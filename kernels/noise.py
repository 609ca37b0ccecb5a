"""Control functions and noise fields for Dendry, evaluated inside kernels.

A control function is a :class:`Control` struct: a ``kind`` id, a few numeric
parameters, the rectangle ``lo``-``hi`` it is defined on, its minimum and
maximum, and (for images) the sampled array. ``control_value`` evaluates it at
a point given in its own coordinates.

The noise kinds use our own 2D Perlin gradient noise: a seeded permutation
table P of 256 entries (stored twice, so sums of two entries index it without
wrapping) hashes each lattice corner to one of 8 gradients (the diagonals and
the axes), and a quintic fade blends the four corner ramps. The tables are laid
out for the lookups a sample makes: ``cols[i] = (P[i], P[i + 1])`` and
``grads[k]`` = the gradients of entries k and k + 1, so a sample costs three
loads. It is cheaper than
``wp.noise`` (no square roots, no per-corner random generator) and is zero at
every lattice point.
"""

import warp as wp

from . import OPTIONS
from .indexing import nonneg

wp.set_module_options(OPTIONS)

KIND_PLANE = wp.constant(0)
KIND_RADIAL = wp.constant(1)
KIND_FBM = wp.constant(2)
KIND_LICHTENBERG = wp.constant(3)
KIND_IMAGE = wp.constant(4)
KIND_RIDGED = wp.constant(5)



@wp.struct
class Control:
    """A control function c(x, y) in its own coordinates (see wdendrite.control)."""

    kind: int
    # plane: (c0, gx, gy, -); radial: (cx, cy, radius, -); noise: (frequency, gain, lacunarity, offset)
    a: wp.vec4
    octaves: int
    lo: wp.vec2
    hi: wp.vec2
    vmin: float
    vmax: float
    # 1: points outside lo-hi are outside the function's domain (their segments are dropped)
    bounded: int
    image: wp.array2d(dtype=float)
    cols: wp.array(dtype=wp.vec2i)  # noise kinds: (P[i], P[i + 1]) for i in 0..255 (P the permutation)
    grads: wp.array(dtype=wp.vec4)  # noise kinds: gradients of entries k and k + 1 of P, k in 0..510


@wp.func
def _fade(t: float) -> float:
    """Perlin's quintic fade 6t^5 - 15t^4 + 10t^3 (zero first and second derivatives at 0 and 1)."""
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


@wp.func
def perlin(cols: wp.array(dtype=wp.vec2i), grads: wp.array(dtype=wp.vec4), p: wp.vec2) -> float:
    """2D Perlin gradient noise at ``p``, in about [-1, 1], zero at integer points.

    Corner (i, j) takes the gradient of entry ``P[i & 255] + (j & 255)`` of the permutation
    P; one load of ``cols`` gives both columns' entries, one load of ``grads`` per column
    the gradients of rows j and j + 1.
    """
    fx = wp.floor(p[0])
    fy = wp.floor(p[1])
    x = p[0] - fx
    y = p[1] - fy
    ix = int(fx) & 255
    iy = int(fy) & 255
    col = cols[nonneg(ix)]
    ga = grads[nonneg(col[0] + iy)]
    gb = grads[nonneg(col[1] + iy)]
    n00 = ga[0] * x + ga[1] * y
    n10 = gb[0] * (x - 1.0) + gb[1] * y
    n01 = ga[2] * x + ga[3] * (y - 1.0)
    n11 = gb[2] * (x - 1.0) + gb[3] * (y - 1.0)
    u = _fade(x)
    v = _fade(y)
    low = n00 + u * (n10 - n00)
    high = n01 + u * (n11 - n01)
    return low + v * (high - low)


@wp.func
def _octave_shift(o: int) -> wp.vec2:
    """An irrational offset per octave, so the octaves' zero lattices do not line up."""
    return wp.vec2(float(o) * 0.6180339887, float(o) * 0.4142135624) * 7.0


@wp.func
def fbm(cols: wp.array(dtype=wp.vec2i), grads: wp.array(dtype=wp.vec4), p: wp.vec2, octaves: int, gain: float, lacunarity: float) -> float:
    """Fractal sum of Perlin noise, normalised to about [-1, 1]."""
    total = float(0.0)
    norm = float(0.0)
    amp = float(1.0)
    q = p
    for o in range(octaves):
        total += amp * perlin(cols, grads, q + _octave_shift(o))
        norm += amp
        amp *= gain
        q = q * lacunarity
    return total / norm


@wp.func
def ridged(cols: wp.array(dtype=wp.vec2i), grads: wp.array(dtype=wp.vec4), p: wp.vec2, octaves: int, gain: float, lacunarity: float, offset: float) -> float:
    """Ridged multifractal (Musgrave): octaves of (offset - |noise|)^2 weighted by the previous one."""
    total = float(0.0)
    norm = float(0.0)
    amp = float(1.0)
    weight = float(1.0)
    q = p
    for o in range(octaves):
        s = offset - wp.abs(perlin(cols, grads, q + _octave_shift(o)))
        s = s * s * weight
        weight = wp.clamp(s * 2.0, 0.0, 1.0)
        total += amp * s
        norm += amp
        amp *= gain
        q = q * lacunarity
    return total / norm


@wp.func
def _cubic_weights(t: float) -> wp.vec4:
    """Catmull-Rom (a = -0.5) cubic convolution weights of the 4 taps around t in [0, 1)."""
    t2 = t * t
    t3 = t2 * t
    return wp.vec4(
        -0.5 * t3 + t2 - 0.5 * t,
        1.5 * t3 - 2.5 * t2 + 1.0,
        -1.5 * t3 + 2.0 * t2 + 0.5 * t,
        0.5 * t3 - 0.5 * t2,
    )


@wp.func
def sample_bicubic(image: wp.array2d(dtype=float), fx: float, fy: float) -> float:
    """Bicubic sample at pixel coordinates (fx along columns, fy along rows), edges clamped."""
    h = image.shape[0]
    w = image.shape[1]
    # beyond a tap's reach of the edge every tap reads the border: clamping there first keeps the
    # int32 cell index from overflowing for far points (which read the first pixel instead)
    fx = wp.clamp(fx, -2.0, float(w) + 1.0)
    fy = wp.clamp(fy, -2.0, float(h) + 1.0)
    x0 = int(wp.floor(fx))
    y0 = int(wp.floor(fy))
    wx = _cubic_weights(fx - float(x0))
    wy = _cubic_weights(fy - float(y0))
    total = float(0.0)
    for j in range(4):
        r = wp.clamp(y0 - 1 + j, 0, h - 1)
        row = float(0.0)
        for i in range(4):
            c = wp.clamp(x0 - 1 + i, 0, w - 1)
            row += wx[i] * image[nonneg(r), nonneg(c)]
        total += wy[j] * row
    return total


@wp.func
def control_inside(ctl: Control, p: wp.vec2) -> bool:
    """False where ``p`` lies outside a bounded control function's rectangle."""
    if ctl.bounded == 0:
        return True
    return p[0] >= ctl.lo[0] and p[0] <= ctl.hi[0] and p[1] >= ctl.lo[1] and p[1] <= ctl.hi[1]


@wp.func
def control_value(ctl: Control, p: wp.vec2) -> float:
    """The control function at ``p`` (in the control's own coordinates)."""
    k = ctl.kind
    if k == KIND_PLANE:
        return ctl.a[0] + ctl.a[1] * p[0] + ctl.a[2] * p[1]
    if k == KIND_RADIAL:
        return wp.length(p - wp.vec2(ctl.a[0], ctl.a[1])) / ctl.a[2]
    if k == KIND_FBM:
        if ctl.octaves == 1:
            return 0.5 + 0.5 * perlin(ctl.cols, ctl.grads, p * ctl.a[0])  # the common single octave, without the sum's loop
        return 0.5 + 0.5 * fbm(ctl.cols, ctl.grads, p * ctl.a[0], ctl.octaves, ctl.a[1], ctl.a[2])
    if k == KIND_RIDGED:
        return ridged(ctl.cols, ctl.grads, p * ctl.a[0], ctl.octaves, ctl.a[1], ctl.a[2], ctl.a[3])
    if k == KIND_LICHTENBERG:
        # a[0] scales the bowl (1: the paper's); a positive factor keeps every comparison of links
        if wp.abs(p[0]) > 1.0 or wp.abs(p[1]) > 1.0:
            return 16.0 * ctl.a[0]
        return ctl.a[0] * (p[0] * p[0] + (p[1] + 1.0) * (p[1] + 1.0))
    # image: pixel centres tile the rectangle lo-hi, row 0 at y = lo.y
    h = float(ctl.image.shape[0])
    w = float(ctl.image.shape[1])
    fx = (p[0] - ctl.lo[0]) / (ctl.hi[0] - ctl.lo[0]) * w - 0.5
    fy = (p[1] - ctl.lo[1]) / (ctl.hi[1] - ctl.lo[1]) * h - 0.5
    return wp.clamp(sample_bicubic(ctl.image, fx, fy), ctl.vmin, ctl.vmax)


@wp.kernel
def control_points_kernel(ctl: Control, points_in: wp.array(dtype=wp.vec2), values_out: wp.array(dtype=float)):
    """Evaluate the control function at each point."""
    t = wp.tid()
    values_out[t] = control_value(ctl, points_in[t])


@wp.kernel
def control_grid_kernel(
    ctl: Control, lo: wp.vec2, step: wp.vec2, values_out: wp.array2d(dtype=float)
):
    """Evaluate the control function at pixel centres ``lo + (col + 0.5, row + 0.5) * step``."""
    r, c = wp.tid()
    p = wp.vec2(lo[0] + (float(c) + 0.5) * step[0], lo[1] + (float(r) + 0.5) * step[1])
    values_out[r, c] = control_value(ctl, p)
