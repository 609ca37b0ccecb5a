"""Kernels for meshes: signed fields for isosurfaces (segmented regions, tapered tubes around centre lines).

Fields use flat C-order indices over ``(D, H, W)`` like :mod:`wdendrite.kernels.lattice`.
"""

import warp as wp

from . import OPTIONS
from .lattice import in_bounds, node_index
from .sssp import pack_cost

wp.set_module_options(OPTIONS)


@wp.kernel
def nonfinite_kernel(field_in: wp.array3d(dtype=float), count_out: wp.array(dtype=int), first_out: wp.array(dtype=int)):
    """Count the NaN / inf entries of ``field_in`` and keep the least flat index among them
    (``first_out`` starts at the field's size): a check that reads a device field in place."""
    i, j, k = wp.tid()
    v = field_in[i, j, k]
    if not wp.isfinite(v):
        wp.atomic_add(count_out, 0, 1)
        wp.atomic_min(first_out, 0, (i * field_in.shape[1] + j) * field_in.shape[2] + k)


@wp.kernel
def nearest_value_kernel(
    dist_in: wp.array(dtype=float),
    label_in: wp.array(dtype=wp.int32),
    values_in: wp.array(dtype=float),
    outside: float,
    field_out: wp.array(dtype=float),
):
    """``d - values[row]`` of the nearest node (a signed distance to tapered spheres); ``outside`` where unreached."""
    i = wp.tid()
    row = label_in[i]
    if row >= 0:
        field_out[i] = dist_in[i] - values_in[row]
    else:
        field_out[i] = outside


@wp.kernel
def lift_level_kernel(field_in: wp.array3d(dtype=float), level: float, above: float,
                      field_out: wp.array3d(dtype=float)):
    """A copy of the field whose values equal to ``level`` move just above it.

    Such a node moves up by a thousandth of its least nonzero difference from
    a 6-neighbour (at least to ``above``, the next float up), so that marching
    cubes puts no vertex on it, nor one nearer than that to it.
    """
    i, j, k = wp.tid()
    v = field_in[i, j, k]
    if v == level:
        step = float(0.0)
        for axis in range(3):
            for side in range(2):
                n = wp.vec3i(i, j, k)
                n[axis] = n[axis] + 2 * side - 1
                if n[axis] >= 0 and n[axis] < field_in.shape[axis]:
                    d = wp.abs(field_in[n[0], n[1], n[2]] - level)
                    if d > 0.0 and (step == 0.0 or d < step):
                        step = d
        v = wp.max(level + 0.001 * step, above)
    field_out[i, j, k] = v


@wp.kernel
def boundary_seeds_kernel(
    inside_in: wp.array(dtype=wp.uint8),
    shape: wp.vec3i,
    seeds_out: wp.array(dtype=wp.vec3i),
    count_out: wp.array(dtype=wp.int32),
):
    """List the cells that have a 6-neighbour (or the volume's edge) on the other side of ``inside``."""
    i = wp.tid()
    plane = shape[1] * shape[2]
    z = i / plane
    y = (i - z * plane) / shape[2]
    x = i - z * plane - y * shape[2]
    c = wp.vec3i(z, y, x)
    here = inside_in[i]
    edge = bool(False)
    for axis in range(3):
        for side in range(2):
            n = c
            n[axis] = c[axis] + 2 * side - 1
            if in_bounds(n, shape):
                if inside_in[node_index(n, shape)] != here:
                    edge = True
            elif here != wp.uint8(0):
                # the volume's edge closes a region that touches it
                edge = True
    if edge:
        slot = wp.atomic_add(count_out, 0, 1)
        seeds_out[slot] = c


@wp.kernel
def signed_region_kernel(
    dist_in: wp.array(dtype=float),
    inside_in: wp.array(dtype=wp.uint8),
    band: float,
    field_out: wp.array(dtype=float),
):
    """Signed distance to a region's boundary: ``-(d + 1/2)`` inside, ``d + 1/2`` outside, clipped to the band."""
    i = wp.tid()
    d = wp.min(dist_in[i], band) + 0.5
    if inside_in[i] != wp.uint8(0):
        field_out[i] = -d
    else:
        field_out[i] = d


@wp.kernel
def tube_field_kernel(
    # Skeleton:
    points_in: wp.array(dtype=wp.vec3),
    radius_in: wp.array(dtype=float),
    segments_in: wp.array(dtype=wp.vec2i),
    # Grid: world position of node (0, 0, 0), node spacing, node counts (z, y, x), clip value, key offset
    origin: wp.vec3,
    voxel: float,
    shape: wp.vec3i,
    band: float,
    offset: float,
    # Field out: pack(value + offset, segment) per node, flat over (z, y, x)
    packed_out: wp.array(dtype=wp.uint64),
):
    """Each segment (a tapered capsule: distance to the segment minus the radius interpolated at the
    nearest point) writes ``pack(value + offset, segment)`` into every node of its box where the value
    is below ``band`` (atomic minimum: the least value and, among equal values, the lowest segment;
    :func:`wdendrite.kernels.render.unpack_nearest_kernel` splits the words)."""
    s = wp.tid()
    seg = segments_in[s]
    a = points_in[seg[0]]
    b = points_in[seg[1]]
    ra = radius_in[seg[0]]
    rb = radius_in[seg[1]]
    ab = b - a
    len2 = wp.dot(ab, ab)
    reach = wp.max(ra, rb) + band
    lo = wp.min(a, b) - wp.vec3(reach, reach, reach) - origin
    hi = wp.max(a, b) + wp.vec3(reach, reach, reach) - origin
    x0 = wp.max(int(wp.ceil(lo[0] / voxel)), 0)
    x1 = wp.min(int(wp.floor(hi[0] / voxel)), shape[2] - 1)
    y0 = wp.max(int(wp.ceil(lo[1] / voxel)), 0)
    y1 = wp.min(int(wp.floor(hi[1] / voxel)), shape[1] - 1)
    z0 = wp.max(int(wp.ceil(lo[2] / voxel)), 0)
    z1 = wp.min(int(wp.floor(hi[2] / voxel)), shape[0] - 1)
    z = int(z0)
    while z <= z1:
        y = int(y0)
        while y <= y1:
            x = int(x0)
            while x <= x1:
                p = origin + wp.vec3(float(x), float(y), float(z)) * voxel
                t = float(0.0)
                if len2 > 0.0:
                    t = wp.clamp(wp.dot(p - a, ab) / len2, 0.0, 1.0)
                value = wp.length(p - (a + ab * t)) - (ra + (rb - ra) * t)
                if value < band:
                    i = (z * shape[1] + y) * shape[2] + x
                    wp.atomic_min(packed_out, i, pack_cost(value + offset, s))
                x += 1
            y += 1
        z += 1
