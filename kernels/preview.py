"""Kernel of the ray-cast mesh preview: smooth shading, shadows, a ground, several rays per pixel."""

import warp as wp

from . import OPTIONS

wp.set_module_options(OPTIONS)


@wp.struct
class Camera:
    """An orthographic camera: rays leave the plane through ``center`` spanned by ``right`` and ``up``."""

    center: wp.vec3
    forward: wp.vec3
    right: wp.vec3
    up: wp.vec3
    half_extent: wp.vec2
    """Half the picture's width and height, world units."""
    depth: float
    """Distance from the image plane to the scene's centre (rays travel twice as far)."""


@wp.struct
class Lights:
    """A key light with soft shadows, a head light, a sky ambient term and an optional shadow-catching ground."""

    key: wp.vec3
    """Unit vector toward the key light."""
    key_u: wp.vec3
    key_v: wp.vec3
    """Unit vectors across ``key``: each ray of a pixel sees the light from a slightly different
    direction (spread over ``spread`` radians), which softens shadow edges."""
    spread: float
    ground: int
    """1: the plane ``z = ground_z`` catches the mesh's shadow (fading out ``ground_radius`` from
    ``ground_center``); elsewhere it shows the background."""
    ground_z: float
    ground_center: wp.vec2
    ground_radius: float
    background: wp.vec3
    offset: float
    """Distance a shadow ray starts off the surface (against hitting its own triangle)."""
    skip: float
    """Distance a shadow ray travels before it looks for blockers: about two triangles, so that where the
    light grazes a curved surface the ray does not meet the neighbouring flat faces of the same
    surface (specks along the terminator); blockers farther away cast their shadows."""


@wp.func
def key_dir(lights: Lights, state: wp.uint32, sx: int, sy: int, samples: int) -> wp.vec3:
    """The key light's direction for the ray ``(sx, sy)`` of a pixel's ``samples x samples``: one
    stratum of the light's square each, at a place within it drawn from the pixel's own random
    stream (``state``), so that neighbouring pixels do not repeat one pattern (stripes in the
    penumbra) but differ by grain."""
    inv = 1.0 / float(samples)
    a = ((float(sx) + wp.randf(state)) * inv - 0.5) * lights.spread
    b = ((float(sy) + wp.randf(state)) * inv - 0.5) * lights.spread
    return wp.normalize(lights.key + lights.key_u * a + lights.key_v * b)


@wp.func
def shadowed(mesh: wp.uint64, p: wp.vec3, key: wp.vec3, skip: float) -> float:
    """1 where the mesh blocks the key light from ``p`` beyond ``skip``, else 0."""
    q = wp.mesh_query_ray(mesh, p + key * skip, key, 1.0e30)
    if q.result:
        return 1.0
    return 0.0


@wp.func
def lit(mesh: wp.uint64, p: wp.vec3, n: wp.vec3, forward: wp.vec3, key: wp.vec3, toward: wp.vec3,
        offset: float, skip: float) -> float:
    """Light reaching point ``p`` of normal ``n``: ambient from the sky (brighter facing up), the key
    light (from ``key``) unless the mesh blocks the shadow ray toward ``toward`` (``key`` moved
    within the light's spread), and a little head light."""
    sky = 0.32 + 0.18 * n[2]
    k = wp.dot(n, key)
    if k > 0.0:
        k = k * (1.0 - shadowed(mesh, p + n * offset, toward, skip))
    else:
        k = 0.0
    head = wp.max(wp.dot(n, -forward), 0.0)
    return sky + 0.62 * k + 0.16 * head


@wp.func
def lifted(p: wp.vec3, corner: wp.vec3, n: wp.vec3) -> wp.vec3:
    """``p`` moved onto the plane through ``corner`` normal to ``n`` when it lies below that plane."""
    d = wp.dot(p - corner, n)
    if d < 0.0:
        return p - n * d
    return p


@wp.kernel
def preview_kernel(
    # Scene:
    mesh: wp.uint64,
    points_in: wp.array(dtype=wp.vec3),
    faces_in: wp.array(dtype=wp.int32),
    normals_in: wp.array(dtype=wp.vec3),
    colors_in: wp.array(dtype=wp.vec3),
    camera: Camera,
    lights: Lights,
    samples: int,
    # Picture out:
    rgb_out: wp.array2d(dtype=wp.vec3),
):
    """``samples x samples`` rays per pixel on a regular grid inside it, averaged. A ray that meets the
    mesh takes the colour there (per vertex, interpolated) times :func:`lit` with the normal
    interpolated from the vertex normals (turned toward the viewer on a back face); one that misses
    shows the background, darkened where the ground (if any) lies in the mesh's shadow."""
    y, x = wp.tid()
    h = rgb_out.shape[0]
    w = rgb_out.shape[1]
    acc = wp.vec3(0.0, 0.0, 0.0)
    inv = 1.0 / float(samples)
    state = wp.rand_init(7919, y * w + x)  # (a fixed seed: the same picture every time)
    for sy in range(samples):
        for sx in range(samples):
            px = (float(x) + (float(sx) + 0.5) * inv) / float(w)
            py = (float(y) + (float(sy) + 0.5) * inv) / float(h)
            ox = (2.0 * px - 1.0) * camera.half_extent[0]
            oy = (1.0 - 2.0 * py) * camera.half_extent[1]
            start = camera.center + camera.right * ox + camera.up * oy - camera.forward * camera.depth
            q = wp.mesh_query_ray(mesh, start, camera.forward, 2.0 * camera.depth)
            color = lights.background
            if q.result:
                f = q.face
                i0 = faces_in[3 * f]
                i1 = faces_in[3 * f + 1]
                i2 = faces_in[3 * f + 2]
                c = 1.0 - q.u - q.v
                n = wp.normalize(normals_in[i0] * q.u + normals_in[i1] * q.v + normals_in[i2] * c)
                g = wp.normalize(q.normal)
                if wp.dot(g, camera.forward) > 0.0:  # the back of an open surface
                    g = -g
                    n = -n
                if wp.dot(n, camera.forward) > 0.0:  # a normal bent away from the viewer
                    n = g
                p = start + camera.forward * q.t
                # shadow rays leave from the surface the normals describe, not the flat face: the hit
                # point lifted onto each corner's tangent plane it lies below, weighted as the normals
                # (a ray from the face itself could graze its neighbours where the light is low)
                s_ = lifted(p, points_in[i0], normals_in[i0]) * q.u + lifted(p, points_in[i1], normals_in[i1]) * q.v
                s_ = s_ + lifted(p, points_in[i2], normals_in[i2]) * c
                if wp.dot(g, n) < 0.0:  # (a normal turned toward the viewer above: keep the face's point)
                    s_ = p
                base = colors_in[i0] * q.u + colors_in[i1] * q.v + colors_in[i2] * c
                toward = key_dir(lights, state, sx, sy, samples)
                color = base * lit(mesh, s_ + g * lights.offset, n, camera.forward, lights.key, toward, lights.offset,
                                   lights.skip)
            elif lights.ground != 0 and camera.forward[2] < 0.0:
                t = (lights.ground_z - start[2]) / camera.forward[2]
                p = start + camera.forward * t
                dx = p[0] - lights.ground_center[0]
                dy = p[1] - lights.ground_center[1]
                fade = wp.exp(-(dx * dx + dy * dy) / (lights.ground_radius * lights.ground_radius))
                key = key_dir(lights, state, sx, sy, samples)
                dark = 0.42 * fade * shadowed(mesh, p + wp.vec3(0.0, 0.0, lights.offset), key, 0.0)
                color = lights.background * (1.0 - dark)
            acc = acc + wp.vec3(wp.min(color[0], 1.0), wp.min(color[1], 1.0), wp.min(color[2], 1.0))
    rgb_out[y, x] = acc * (inv * inv)
