"""Kernels for meshes: signed fields for isosurfaces and a ray-cast preview of a triangle mesh.

Fields use flat C-order indices over ``(D, H, W)`` like :mod:`wdendrite.kernels.lattice`.
"""

import warp as wp

from . import OPTIONS
from .lattice import in_bounds, node_index

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
def preview_kernel(
    mesh: wp.uint64,
    center: wp.vec3,
    forward: wp.vec3,
    right: wp.vec3,
    up: wp.vec3,
    half_extent: wp.vec2,
    depth: float,
    light: wp.vec3,
    face_colors_in: wp.array(dtype=wp.vec3),
    background: wp.vec3,
    rgb_out: wp.array2d(dtype=wp.vec3),
):
    """Orthographic ray cast of ``mesh``: Lambert shading with a head light and a key light, both faces lit."""
    y, x = wp.tid()
    h = rgb_out.shape[0]
    w = rgb_out.shape[1]
    sx = (2.0 * (float(x) + 0.5) / float(w) - 1.0) * half_extent[0]
    sy = (1.0 - 2.0 * (float(y) + 0.5) / float(h)) * half_extent[1]
    start = center + right * sx + up * sy - forward * depth
    q = wp.mesh_query_ray(mesh, start, forward, 2.0 * depth)
    if q.result:
        n = wp.normalize(q.normal)
        if wp.dot(n, forward) > 0.0:
            n = -n
        key = wp.max(wp.dot(n, -light), 0.0)
        head = wp.max(wp.dot(n, -forward), 0.0)
        shade = 0.15 + 0.6 * key + 0.3 * head
        color = face_colors_in[q.face]
        rgb_out[y, x] = wp.vec3(
            wp.min(color[0] * shade, 1.0), wp.min(color[1] * shade, 1.0), wp.min(color[2] * shade, 1.0)
        )
    else:
        rgb_out[y, x] = background
