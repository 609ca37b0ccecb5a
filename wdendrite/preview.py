"""Shaded pictures of meshes without a display: orthographic ray casting with Warp.

Every pixel averages ``samples x samples`` rays (antialiasing). Surfaces are
shaded with normals interpolated from the vertex normals (smooth, no facets),
lit by a key light that casts soft shadows (on the mesh itself and on a
ground plane under it), a head light, and an ambient term brighter on faces
turned up, so that form reads. :func:`wdendrite.geometry.preview` is this module's
:func:`preview`.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import warp as wp

from . import _checks
from .kernels import preview as _kp
from .render import _rgb_triple

__all__ = ["preview"]

_STONE = (0.82, 0.76, 0.66)
"""Colour of meshes that bring none."""


def _unit_rgb(name: str, values: np.ndarray, given) -> None:
    """Refuse colours (finite RGB values) outside [0, 1]."""
    if values.size and (values.min() < 0 or values.max() > 1):
        raise ValueError(f"Expected '{name}' RGB values in [0, 1], but got {given!r}")


def _own_colors(m, n: int) -> np.ndarray | None:
    """``(n, 3)`` float32 vertex colours a trimesh carries (``visual.vertex_colors``), else None."""
    visual = getattr(m, "visual", None)
    if visual is None or getattr(visual, "kind", None) != "vertex":
        return None
    rgb = np.asarray(visual.vertex_colors)[:, :3]
    return (rgb.astype(np.float32) / 255.0) if rgb.shape == (n, 3) else None


def vertex_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``(V, 3)`` unit vertex normals: the area-weighted mean of the normals of the faces around each
    vertex (zero for a vertex no face uses)."""
    out = np.zeros((len(v), 3))
    if len(f):
        fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # (twice the area, outward)
        for k in range(3):
            for c in range(3):
                out[:, c] += np.bincount(f[:, k], weights=fn[:, c], minlength=len(v))
    norm = np.linalg.norm(out, axis=1, keepdims=True)
    return np.divide(out, norm, out=np.zeros_like(out), where=norm > 0)


def _scene(mesh, color):
    """Vertices, faces, vertex normals and vertex colours of one mesh or a list of meshes.

    ``color``: None (each mesh's own vertex colours, else a stone colour), one RGB, or one per mesh."""
    meshes = list(mesh) if isinstance(mesh, (list, tuple)) else [mesh]
    cols = None
    if color is not None:
        cols = np.asarray(color, np.float32)
        if cols.ndim == 1:
            cols = np.broadcast_to(cols, (len(meshes), cols.shape[0]))
        if cols.shape != (len(meshes), 3) or not np.isfinite(cols).all():
            raise ValueError(f"Expected 'color' as one RGB triple or one per mesh ({len(meshes)}), but got {color!r}")
        _unit_rgb("color", cols, color)
    vs, fs, ns, cs, base = [], [], [], [], 0
    for i, m in enumerate(meshes):
        v = np.asarray(getattr(m, "vertices", None), np.float64)
        f = np.asarray(getattr(m, "faces", None))
        if v.ndim != 2 or v.shape[1:] != (3,) or f.ndim != 2 or f.shape[1:] != (3,):
            raise ValueError("Expected triangle meshes with (V, 3) 'vertices' and (F, 3) 'faces' for 'mesh'")
        # wp.Mesh reads whatever the faces index: one beyond the vertices would read out of bounds;
        # its rays and bounds need finite float32 vertices
        which = "mesh" if m is mesh else f"mesh[{i}]"
        f = _checks.face_indices(f"{which}.faces", f, len(v))
        if len(v):
            _checks.finite_array(f"{which}.vertices", v, "(V, 3)", lambda s: len(s) == 2 and s[1] == 3)
        own = _own_colors(m, len(v)) if cols is None else None
        rgb = own if own is not None else np.broadcast_to(
            np.asarray(_STONE if cols is None else cols[i], np.float32), (len(v), 3))
        vs.append(v)
        fs.append(f + base)
        ns.append(vertex_normals(v, f))
        cs.append(rgb)
        base += len(v)
    faces = np.concatenate(fs)
    if not len(faces):
        raise ValueError("'mesh' has no faces: there is nothing to show")
    return np.concatenate(vs), faces, np.concatenate(ns), np.concatenate(cs).astype(np.float32)


def _camera(verts: np.ndarray, size: tuple[int, int], elevation: float, azimuth: float) -> tuple:
    """The orthographic camera framing ``verts`` (a 5 % margin, square pixels) and its unit vectors."""
    el, az = math.radians(elevation), math.radians(azimuth)
    forward = -np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right = right / np.linalg.norm(right) if np.linalg.norm(right) > 1e-9 else np.array([1.0, 0.0, 0.0])
    up = np.cross(right, forward)
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    center = 0.5 * (lo + hi)
    rel = verts - center
    ext_x = np.abs(rel @ right).max() * 1.05 + 1e-6
    ext_y = np.abs(rel @ up).max() * 1.05 + 1e-6
    h, w = size
    # keep square pixels: widen whichever extent is short for the image's aspect
    ext_x, ext_y = max(ext_x, ext_y * w / h), max(ext_y, ext_x * h / w)
    depth = float(np.linalg.norm(hi - lo)) + 1.0
    cam = _kp.Camera()
    cam.center, cam.forward, cam.right, cam.up = (wp.vec3(*a.tolist()) for a in (center, forward, right, up))
    cam.half_extent = wp.vec2(ext_x, ext_y)
    cam.depth = depth
    return cam, forward, right, lo, hi


def preview(
    mesh,
    *,
    size: tuple[int, int] = (480, 480),
    elevation: float = 25.0,
    azimuth: float = -60.0,
    color: Sequence | None = None,
    background: Sequence[float] = (1.0, 1.0, 1.0),
    samples: int = 3,
    ground: bool = True,
    device=None,
) -> np.ndarray:
    """A shaded picture of a mesh without a display (orthographic Warp ray casting).

    Args:
        mesh: a :class:`trimesh.Trimesh` (anything with ``vertices`` and ``faces``), or a list of them.
            Its vertex normals are the area-weighted mean of the normals of the faces around each vertex.
        size: ``(H, W)`` pixels.
        elevation, azimuth: view direction in degrees (``z`` is up; azimuth from ``+x`` toward ``+y``).
        color: surface RGB in [0, 1], or one RGB per mesh of a list; default: each mesh's own vertex
            colours (``visual.vertex_colors``), else a light stone colour.
        background: RGB in [0, 1].
        samples: rays per pixel along each axis (``samples**2`` per pixel, averaged), 1 to 8.
        ground: a ground plane under the mesh (at its lowest ``z``) takes its shadow, fading out
            away from the mesh; the ground itself shows the background.
        device: Warp device (default: Warp's default device).

    Returns:
        ``(H, W, 3)`` float32 in [0, 1], ready for :func:`wdendrite.io.save_png`.

    Raises:
        ValueError: an empty list, a bad ``size`` or ``samples``, colours that are not RGB in [0, 1],
            meshes whose faces are not ``(F, 3)`` or index no vertex (before any kernel runs).
        TypeError: faces that are not integers, a ``ground`` that is not a bool.
    """
    if isinstance(mesh, (list, tuple)) and not len(mesh):
        raise ValueError("'mesh' is an empty list: there is nothing to show")
    if not isinstance(size, (list, tuple)) or len(size) != 2 or any(
            isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s <= 0 for s in size):
        raise ValueError(f"Expected 'size' as (H, W) positive ints, but got {size!r}")
    samples = _checks.integer("samples", samples, low=1, high=8)
    ground = _checks.flag("ground", ground)
    verts, faces, normals, colors = _scene(mesh, color)
    bg = _rgb_triple("background", background)
    _unit_rgb("background", bg, background)
    elevation = _checks.finite("elevation", elevation)
    azimuth = _checks.finite("azimuth", azimuth)
    h, w = int(size[0]), int(size[1])
    cam, forward, right, lo, hi = _camera(verts, (h, w), elevation, azimuth)
    # the key light from above, to the left of the viewer and a little behind: shadows fall back and right
    flat = np.array([forward[0], forward[1], 0.0])
    flat = flat / np.linalg.norm(flat) if np.linalg.norm(flat) > 1e-9 else np.array([0.0, 1.0, 0.0])
    key = np.array([0.0, 0.0, 1.0]) - 0.55 * right - 0.45 * flat
    lights = _kp.Lights()
    key = key / np.linalg.norm(key)
    key_u = np.cross(key, [0.0, 0.0, 1.0]) if abs(key[2]) < 0.99 else np.array([1.0, 0.0, 0.0])
    key_u /= np.linalg.norm(key_u)
    lights.key = wp.vec3(*key.tolist())
    lights.key_u, lights.key_v = wp.vec3(*key_u.tolist()), wp.vec3(*np.cross(key, key_u).tolist())
    lights.spread = 0.03
    lights.ground = int(ground)
    lights.ground_z = float(lo[2])
    lights.ground_center = wp.vec2(float(0.5 * (lo[0] + hi[0])), float(0.5 * (lo[1] + hi[1])))
    lights.ground_radius = float(max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) * 0.9 + 1e-6)
    lights.background = wp.vec3(*bg.tolist())
    lights.offset = float(1e-4 * (np.linalg.norm(hi - lo) + 1.0))
    edges = np.linalg.norm(verts[faces[:, 1]] - verts[faces[:, 0]], axis=1)
    lights.skip = float(2.0 * np.median(edges))
    device = _checks.device(device)
    with wp.ScopedDevice(device):
        flat_faces = wp.array(faces.astype(np.int32).ravel(), dtype=wp.int32)
        points = wp.array(verts.astype(np.float32), dtype=wp.vec3)
        wmesh = wp.Mesh(points=points, indices=flat_faces)
        out = wp.empty((h, w), dtype=wp.vec3)
        wp.launch(_kp.preview_kernel, dim=(h, w),
                  inputs=[wmesh.id, points, flat_faces, wp.array(normals.astype(np.float32), dtype=wp.vec3),
                          wp.array(colors, dtype=wp.vec3), cam, lights, samples],
                  outputs=[out])
        return np.clip(out.numpy(), 0.0, 1.0)
