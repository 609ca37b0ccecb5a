"""Distance-field brightness kernels: Euclidean splats, brightness ``exp(-(d/T)^2)``, box blurs, colour maps;
and the shaded relief of terrains.

Fields are handled as 3D inside kernels (a 2D image is ``(1, H, W)``) with
flat C-order indices, like :mod:`wdendrite.kernels.lattice`. The nearest
node of a pixel is kept as one ``uint64`` word per pixel: the float32 bits
of the distance in the high half and the node row in the low half (the same
packing as the shortest-path kernels), so ``atomic_min`` settles distance
and label together, and among equal distances the lowest row, whatever the
order in which threads arrive.
"""

import warp as wp

from . import OPTIONS
from .indexing import nonneg
from .sssp import UNREACHED, pack_cost, packed_cost, packed_label

wp.set_module_options(OPTIONS)


METRIC_EUCLIDEAN = wp.constant(0)
METRIC_LATTICE = wp.constant(1)


@wp.func
def lattice_distance(a: float, b: float, c: float) -> float:
    """Shortest path length on the unit 8- (2D) or 26-connected (3D) lattice between nodes
    ``(a, b, c)`` apart (absolute offsets): straight, then face-diagonal, then space-diagonal steps."""
    hi = wp.max(a, wp.max(b, c))
    lo = wp.min(a, wp.min(b, c))
    mid = a + b + c - hi - lo
    return (hi - mid) + 1.41421356 * (mid - lo) + 1.73205081 * lo


@wp.kernel
def splat_distance_kernel(
    nodes_in: wp.array(dtype=wp.vec3i),
    shape: wp.vec3i,
    radius: float,
    metric: int,
    packed_out: wp.array(dtype=wp.uint64),
):
    """Each node writes ``pack(distance, row)`` into every cell within ``radius`` of it (atomic minimum).

    ``metric``: METRIC_EUCLIDEAN, or METRIC_LATTICE for the path length on a unit-weight
    8/26-connected lattice without obstacles (never shorter than the Euclidean one, so the
    same disc holds every cell in reach).
    """
    row = wp.tid()
    c = nodes_in[row]
    # no cell of the image lies farther than the sum of its sides under either metric: a
    # larger radius reaches every cell, and the loops stay within the image (and int32)
    reach = wp.min(radius, float(shape[0] + shape[1] + shape[2]))
    r = int(wp.floor(reach))
    r2 = wp.float64(reach) * wp.float64(reach)  # exact, as are the integer squares taken from it
    z0 = wp.max(c[0] - r, 0)
    z1 = wp.min(c[0] + r, shape[0] - 1)
    # (while loops and nonneg indices: see kernels/indexing.py; 0.4x the time of range() loops)
    z = int(z0)
    while z <= z1:
        dz = float(z - c[0])
        dy_i = wp.max(-r, -c[1])
        dy_last = wp.min(r, shape[1] - 1 - c[1])
        while dy_i <= dy_last:
            y = c[1] + dy_i
            dy = float(dy_i)
            rest = r2 - wp.float64(dz) * wp.float64(dz) - wp.float64(dy) * wp.float64(dy)
            # the test below compares float32 distances, which may round onto the radius from
            # just outside it: cells within a millionth of r^2 beyond the disc are scanned too
            tol = r2 * wp.float64(1.0e-6)
            if rest >= -tol:
                # only the columns inside the disc of this row (and such a cell beyond it)
                half = int(wp.floor(wp.sqrt(wp.max(rest, wp.float64(0.0)))))
                if wp.float64(half + 1) * wp.float64(half + 1) - rest <= tol:
                    half += 1
                x0 = wp.max(c[2] - half, 0)
                x1 = wp.min(c[2] + half, shape[2] - 1)
                base = (z * shape[1] + y) * shape[2]
                x = int(x0)
                while x <= x1:
                    dx = float(x - c[2])
                    d = float(0.0)
                    if metric == METRIC_EUCLIDEAN:
                        d = wp.sqrt(dz * dz + dy * dy + dx * dx)
                    else:
                        d = lattice_distance(wp.abs(dz), wp.abs(dy), wp.abs(dx))
                    if d <= radius:
                        wp.atomic_min(packed_out, nonneg(base + x), pack_cost(d, row))
                    x += 1
            dy_i += 1
        z += 1


@wp.kernel
def unpack_nearest_kernel(
    packed_in: wp.array(dtype=wp.uint64),
    dist_out: wp.array(dtype=float),
    label_out: wp.array(dtype=wp.int32),
):
    """Split packed words into distances (inf where no node reached) and node rows (-1)."""
    i = wp.tid()
    word = packed_in[i]
    if word == UNREACHED:
        dist_out[i] = wp.inf
        label_out[i] = -1
    else:
        dist_out[i] = packed_cost(word)
        label_out[i] = packed_label(word)


@wp.func
def brightness_of(d: float, t: float, reach: float, clamp: float) -> float:
    """``exp(-(d / t)^2)`` within ``reach * t``, else 0; values above ``clamp`` become 1."""
    v = float(0.0)
    if d <= reach * t:
        q = d / t
        v = wp.exp(-q * q)
        if v > clamp:
            v = 1.0
    return v


@wp.kernel
def brightness_kernel(
    dist_in: wp.array(dtype=float),
    label_in: wp.array(dtype=wp.int32),
    widths_in: wp.array(dtype=float),
    reach: float,
    clamp: float,
    value_out: wp.array(dtype=float),
):
    """``V = exp(-(d / T)^2)`` with ``T`` the width of the nearest node; 0 beyond ``reach * T``.

    With ``clamp < 1``, values above ``clamp`` become 1 (the thesis' variant).
    """
    i = wp.tid()
    row = label_in[i]
    v = float(0.0)
    if row >= 0:
        v = brightness_of(dist_in[i], widths_in[row], reach, clamp)
    value_out[i] = v


@wp.kernel
def brightness_packed_kernel(
    packed_in: wp.array(dtype=wp.uint64),
    widths_in: wp.array(dtype=float),
    reach: float,
    clamp: float,
    value_out: wp.array(dtype=float),
):
    """Brightness straight from packed ``(distance, source)`` words (one pass, no unpacking)."""
    i = wp.tid()
    word = packed_in[i]
    v = float(0.0)
    if word != UNREACHED:
        v = brightness_of(packed_cost(word), widths_in[packed_label(word)], reach, clamp)
    value_out[i] = v


@wp.kernel
def stroke_kernel(
    start_in: wp.array(dtype=wp.vec2),
    end_in: wp.array(dtype=wp.vec2),
    radius_in: wp.array(dtype=wp.vec2),
    ink_in: wp.array(dtype=float),
    sigma: float,
    height: int,
    width: int,
    value_out: wp.array(dtype=float),
):
    """Each segment draws a round-capped stroke, its radius going linearly from ``radius_in[i][0]``
    at ``start_in[i]`` to ``[1]`` at ``end_in[i]`` (pixels, (row, column) coordinates), into the
    image (atomic maximum of ``ink * coverage``). A pixel's coverage is the stroke seen through a
    Gaussian pixel filter of standard deviation ``sigma`` (pixels):
    ``(erf((r - d) / (sigma sqrt 2)) + erf((r + d) / (sigma sqrt 2))) / 2``, with ``d`` the distance
    from the pixel's centre to the segment and ``r`` the radius at the nearest point. Summed across
    a stroke it gives ``2 r`` whatever the stroke's slope (a box filter's ``clamp(r + 0.5 - d)``
    inks a thin diagonal through pixel centres 12 % more than a level one).
    """
    i = wp.tid()
    a = start_in[i]
    b = end_in[i]
    ra = radius_in[i][0]
    rb = radius_in[i][1]
    ink = ink_in[i]
    reach = wp.max(ra, rb) + 4.0 * sigma
    y0 = wp.max(int(wp.floor(wp.min(a[0], b[0]) - reach)), 0)
    y1 = wp.min(int(wp.ceil(wp.max(a[0], b[0]) + reach)), height - 1)
    x0 = wp.max(int(wp.floor(wp.min(a[1], b[1]) - reach)), 0)
    x1 = wp.min(int(wp.ceil(wp.max(a[1], b[1]) + reach)), width - 1)
    ab = b - a
    length2 = wp.dot(ab, ab)
    y = int(y0)
    while y <= y1:
        x = int(x0)
        while x <= x1:
            p = wp.vec2(float(y), float(x))
            t = float(0.0)
            if length2 > 0.0:
                t = wp.clamp(wp.dot(p - a, ab) / length2, 0.0, 1.0)
            d = wp.length(p - (a + t * ab))
            r = ra + t * (rb - ra)
            k = 1.0 / (sigma * 1.41421356)
            cover = 0.5 * (wp.erf((r - d) * k) + wp.erf((r + d) * k))
            if cover > 0.0:
                wp.atomic_max(value_out, nonneg(y * width + x), ink * cover)
            x += 1
        y += 1


BLEND_MAX = wp.constant(0)
BLEND_ADD = wp.constant(1)
BLEND_SCREEN = wp.constant(2)


@wp.kernel
def blend_kernel(
    base_in: wp.array(dtype=float),
    layer_in: wp.array(dtype=float),
    gain: float,
    mode: int,
    value_out: wp.array(dtype=float),
):
    """Combine a layer (times ``gain``, clipped to [0, 1]) into a base image: max, clipped sum or screen."""
    i = wp.tid()
    a = base_in[i]
    b = wp.clamp(layer_in[i] * gain, 0.0, 1.0)
    if mode == BLEND_MAX:
        value_out[i] = wp.max(a, b)
    elif mode == BLEND_ADD:
        value_out[i] = wp.min(a + b, 1.0)
    else:
        value_out[i] = 1.0 - (1.0 - a) * (1.0 - b)


@wp.kernel
def box_blur_rows_kernel(
    src_in: wp.array2d(dtype=float),
    width: int,
    radius: int,
    dst_out: wp.array2d(dtype=float),
):
    """Mean over ``2 radius + 1`` pixels along rows ``4 t .. 4 t + 3`` (their first ``width``
    entries; running sums, zero outside).

    Four rows per thread: their running sums are independent, so a CPU thread adds them side
    by side instead of waiting on one sum; each row's sums are the same additions in the same
    order as one row at a time.
    """
    y = 4 * wp.tid()
    scale = 1.0 / float(2 * radius + 1)
    acc = wp.vec4(0.0)
    # (while loops and nonneg indices: see kernels/indexing.py)
    stop = wp.min(radius, width)
    x = int(0)
    while x < stop:
        xi = nonneg(x)
        acc += wp.vec4(src_in[y, xi], src_in[y + 1, xi], src_in[y + 2, xi], src_in[y + 3, xi])
        x += 1
    x = int(0)
    while x < width:
        if x + radius < width:
            xa = nonneg(x + radius)
            acc += wp.vec4(src_in[y, xa], src_in[y + 1, xa], src_in[y + 2, xa], src_in[y + 3, xa])
        if x - radius - 1 >= 0:
            xs = nonneg(x - radius - 1)
            acc -= wp.vec4(src_in[y, xs], src_in[y + 1, xs], src_in[y + 2, xs], src_in[y + 3, xs])
        out = acc * scale
        xo = nonneg(x)
        dst_out[y, xo] = out[0]
        dst_out[y + 1, xo] = out[1]
        dst_out[y + 2, xo] = out[2]
        dst_out[y + 3, xo] = out[3]
        x += 1


@wp.kernel
def box_blur_cols_kernel(
    src_in: wp.array2d(dtype=wp.vec4),
    height: int,
    radius: int,
    dst_out: wp.array2d(dtype=wp.vec4),
):
    """Mean over ``2 radius + 1`` pixels down columns ``4 t .. 4 t + 3`` (the image viewed as
    rows of ``vec4``; running sums over the first ``height`` rows, zero outside)."""
    x = wp.tid()
    scale = 1.0 / float(2 * radius + 1)
    acc = wp.vec4(0.0)
    stop = wp.min(radius, height)
    y = int(0)
    while y < stop:
        acc += src_in[nonneg(y), x]
        y += 1
    y = int(0)
    while y < height:
        if y + radius < height:
            acc += src_in[nonneg(y + radius), x]
        if y - radius - 1 >= 0:
            acc -= src_in[nonneg(y - radius - 1), x]
        dst_out[nonneg(y), x] = acc * scale
        y += 1


@wp.kernel
def colorize_kernel(
    value_in: wp.array2d(dtype=float),
    glow_in: wp.array2d(dtype=float),
    lut_in: wp.array(dtype=wp.vec3),
    glow_color: wp.vec3,
    background_in: wp.array2d(dtype=wp.vec3),
    rgb_out: wp.array2d(dtype=wp.vec3),
):
    """``background + lut(value) + glow * glow_color`` per pixel, clipped to [0, 1] (additive light)."""
    y, x = wp.tid()
    v = wp.clamp(value_in[y, x], 0.0, 1.0)
    n = lut_in.shape[0]
    f = v * float(n - 1)
    k = wp.min(int(f), n - 2)
    t = f - float(k)
    col = lut_in[k] * (1.0 - t) + lut_in[k + 1] * t
    c = background_in[y, x] + col + glow_color * glow_in[y, x]
    rgb_out[y, x] = wp.vec3(wp.clamp(c[0], 0.0, 1.0), wp.clamp(c[1], 0.0, 1.0), wp.clamp(c[2], 0.0, 1.0))


@wp.func
def slope_along(z: wp.array2d(dtype=float), r: int, c: int, dr: int, dc: int, n: int, i: int) -> float:
    """Elevation change per pixel at (r, c) along (dr, dc), whose index there is ``i`` of ``n``:
    central differences inside, one-sided ones on the first and last pixel (as numpy.gradient)."""
    lo = wp.max(i - 1, 0)
    hi = wp.min(i + 1, n - 1)
    a = z[nonneg(r - dr * (i - lo)), nonneg(c - dc * (i - lo))]
    b = z[nonneg(r + dr * (hi - i)), nonneg(c + dc * (hi - i))]
    return (b - a) / float(hi - lo)


@wp.kernel
def relief_kernel(
    t_in: wp.array2d(dtype=float), gain: float, light: wp.vec3,
    area_in: wp.array2d(dtype=float), wet_area: float, river: wp.vec3, image_out: wp.array2d(dtype=wp.vec3),
):
    """Hillshade lit from ``light`` (unit) over an elevation tint (green-brown to white), with
    rivers blended in where ``area_in`` (if it has cells) exceeds ``wet_area``: full at 20 times it.

    ``t_in`` is the elevation scaled onto [0, 1] and ``gain`` its range over the pixel side,
    so that slopes are ``gain`` times the differences of ``t_in``.
    """
    r, c = wp.tid()
    h = t_in.shape[0]
    w = t_in.shape[1]
    gx = slope_along(t_in, r, c, 0, 1, w, c) * gain
    gy = slope_along(t_in, r, c, 1, 0, h, r) * gain
    shade = wp.clamp(wp.dot(wp.normalize(wp.vec3(-gx, -gy, 1.0)), light), 0.0, 1.0)
    t = t_in[r, c]
    low = wp.vec3(0.3, 0.45, 0.25)
    mid = wp.vec3(0.55, 0.45, 0.3)
    high = wp.vec3(0.95, 0.95, 0.95)
    tint = mid + (high - mid) * ((t - 0.6) / 0.4)
    if t < 0.6:
        tint = low + (mid - low) * (t / 0.6)
    out = tint * (0.35 + 0.65 * shade)
    if area_in.shape[0] > 0:
        wet = wp.clamp(wp.log(area_in[r, c] / wet_area) / wp.log(20.0), 0.0, 1.0)
        out = out * (1.0 - 0.9 * wet) + river * (0.9 * wet)
    image_out[r, c] = out
