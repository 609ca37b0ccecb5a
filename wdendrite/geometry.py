"""Meshes from dendrites and segmented lattices (Xu & Mould 2007, sections 3.3 and 3.4).

- :func:`spheres` and :func:`tubes`: a sphere per node, or a capped tube per
  edge with a sphere at each joint, with radii from
  :func:`wdendrite.render.node_widths` (constant, per branch, or tapered).
- :func:`isosurface`: the surface of a distance field from the dendrite
  (every node a sphere of its own radius, blended into one surface).
- :func:`region_mesh`: the boundary of a region of a label segmentation (the
  papers' "rocks"); :func:`surface_nodes` lists a region's surface nodes, where
  lichen is grown.
- :func:`field_mesh`: marching cubes on any scalar field (scikit-image on the
  CPU, Warp's own marching cubes when the field is on a CUDA device).
- :func:`skeleton_mesh`: one closed body around smooth centre lines
  (:mod:`wdendrite.skeleton`): the isosurface of the distance to their
  tapered segments.
- :func:`preview`: a shaded PNG-ready picture of any mesh, ray cast with
  Warp without a display (see :mod:`wdendrite.preview`).

Meshes are :class:`trimesh.Trimesh` with vertices in world ``(x, y, z)``
order: the lattice axes ``(z, y, x)`` reversed, placed by the dendrite's
``origin`` and ``spacing``. Lattice axis 0 is "up" (``z``) in previews.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Sequence

import numpy as np
import warp as wp

from . import _checks
from .dendrite import Dendrite
from .kernels import geometry as _kg
from .kernels import render as _kr
from .lattice import Lattice
from .preview import _unit_rgb, preview, vertex_normals
from .render import Metric, Width, _check_metric, _nearest, node_widths

__all__ = ["field_mesh", "isosurface", "preview", "region_mesh", "skeleton_mesh", "spheres", "surface_nodes", "tubes"]


def _check_3d(dendrite, what: str) -> Dendrite:
    if not isinstance(dendrite, Dendrite):
        raise TypeError(f"Expected a wdendrite.Dendrite for 'dendrite', but got {type(dendrite).__name__}")
    if len(dendrite) == 0:
        raise ValueError("'dendrite' is empty (no nodes): there is no mesh to build")
    if dendrite.ndim != 3:
        raise ValueError(
            f"{what} needs a 3D dendrite, but the dendrite has shape {tuple(dendrite.shape)}; "
            "render 2D dendrites with wdendrite.render.brightness or save them with wdendrite.io.save_svg"
        )
    return dendrite


def _world(dendrite: Dendrite) -> np.ndarray:
    """``(N, 3)`` float64 node positions in ``(x, y, z)`` order."""
    return dendrite.positions[:, ::-1].copy()


def _radii(dendrite: Dendrite, radius: Width, side: Width | None) -> np.ndarray:
    return node_widths(dendrite, radius, side=side, _name="radius").astype(np.float64)


def _trimesh(vertices: np.ndarray, faces: np.ndarray):
    import trimesh

    return trimesh.Trimesh(vertices=np.asarray(vertices, np.float64), faces=np.asarray(faces, np.int64), process=False)


def _sphere_mesh(centers: np.ndarray, radii: np.ndarray, subdivisions: int):
    import trimesh

    unit = trimesh.creation.icosphere(subdivisions=subdivisions)
    v = unit.vertices[None, :, :] * radii[:, None, None] + centers[:, None, :]
    f = unit.faces[None, :, :] + (np.arange(len(centers)) * len(unit.vertices))[:, None, None]
    return v.reshape(-1, 3), f.reshape(-1, 3)


def _int_arg(name: str, value, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise ValueError(f"Expected an integer '{name}' >= {low}, but got {value!r}")
    return int(value)


MAX_SUBDIVISIONS = 8
"""Most icosphere subdivisions of :func:`spheres`: 20 * 4**8 (1.3 million) faces per sphere;
each more takes four times the memory."""


def spheres(dendrite: Dendrite, radius: Width = 1.0, *, side: Width | None = None, subdivisions: int = 1):
    """A sphere at every node of a 3D dendrite, merged into one mesh (the papers' elm trees and coral).

    Args:
        dendrite: a non-empty 3D dendrite.
        radius: sphere radius in world units: a constant > 0, a
            :class:`~wdendrite.render.Taper` or an ``(N,)`` array.
        side: optional radius of side branches (see :func:`~wdendrite.render.node_widths`).
        subdivisions: icosphere subdivisions (0: 20 faces per sphere, 1: 80, 2: 320), at most
            :data:`MAX_SUBDIVISIONS` (8).

    Returns:
        A :class:`trimesh.Trimesh` of ``N`` closed spheres (watertight, outward normals).

    Raises:
        ValueError: an empty or 2D dendrite, a bad radius, ``subdivisions`` not an integer in
            [0, 8] (before any work).
        MemoryError: the spheres' vertices and faces would not fit in free host memory.
    """
    den = _check_3d(dendrite, "spheres()")
    subdivisions = _int_arg("subdivisions", subdivisions, 0)
    if subdivisions > MAX_SUBDIVISIONS:
        raise ValueError(f"Expected 'subdivisions' <= {MAX_SUBDIVISIONS} ({20 * 4**MAX_SUBDIVISIONS} faces per "
                         f"sphere), but got {subdivisions!r}")
    # (10 * 4^s + 2) vertices and 20 * 4^s faces per sphere, 3 float64 or int64 values each
    _checks.fits_in_memory(24 * len(den) * (30 * 4**subdivisions + 2), "cpu",
                           f"spheres() of {len(den)} nodes with 'subdivisions' = {subdivisions}")
    v, f = _sphere_mesh(_world(den), _radii(den, radius, side), subdivisions)
    return _trimesh(v, f)


def _frame(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors ``u, v`` with ``u x v = d`` for unit rows ``d``."""
    helper = np.where(np.abs(d[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    u = np.cross(helper, d)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u, np.cross(d, u)


def _frustums(a: np.ndarray, b: np.ndarray, ra: np.ndarray, rb: np.ndarray, sides: int):
    """Closed, capped cones from ``a`` (radius ``ra``) to ``b`` (radius ``rb``), outward normals."""
    d = b - a
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    u, v = _frame(d)
    theta = 2.0 * np.pi * np.arange(sides) / sides
    ring = np.cos(theta)[None, :, None] * u[:, None, :] + np.sin(theta)[None, :, None] * v[:, None, :]
    ring_a = a[:, None, :] + ra[:, None, None] * ring
    ring_b = b[:, None, :] + rb[:, None, None] * ring
    verts = np.concatenate([ring_a, ring_b, a[:, None, :], b[:, None, :]], axis=1)  # (E, 2 sides + 2, 3)
    i = np.arange(sides)
    j = (i + 1) % sides
    ca, cb = 2 * sides, 2 * sides + 1
    faces = np.concatenate([
        np.stack([i, j, sides + i], axis=1),
        np.stack([j, sides + j, sides + i], axis=1),
        np.stack([np.full(sides, cb), sides + i, sides + j], axis=1),
        np.stack([np.full(sides, ca), j, i], axis=1),
    ])
    per = verts.shape[1]
    f = faces[None, :, :] + (np.arange(len(a)) * per)[:, None, None]
    return verts.reshape(-1, 3), f.reshape(-1, 3)


def tubes(
    dendrite: Dendrite,
    radius: Width = 1.0,
    *,
    side: Width | None = None,
    sides: int = 8,
    joints: bool = True,
):
    """A tube along every edge of a 3D dendrite with tapered radii, merged into one mesh.

    Each edge (node to parent) is a cone from the node's radius to the
    parent's; edges continuing in a straight line share their rings, so a
    straight run is one closed tube, and other edges are capped at both ends.
    With ``joints`` a low-resolution sphere fills each node so bends look round
    (the spheres and tubes overlap: closed pieces, not one solid). Caps of
    different edges meet at their node, and may share points there: a loader
    that welds vertices (STL always does) can find edges of more than two
    faces at bends and forks; straight runs weld cleanly.

    Args:
        dendrite: a non-empty 3D dendrite.
        radius: radius in world units: a constant > 0, a
            :class:`~wdendrite.render.Taper` or an ``(N,)`` array.
        side: optional radius of side branches.
        sides: polygon sides of each tube, >= 3.
        joints: add a sphere at every node.

    Returns:
        A :class:`trimesh.Trimesh` of closed pieces (watertight, outward normals).

    Raises:
        ValueError: an empty or 2D dendrite, a bad radius or side radius, ``sides`` not an integer >= 3
            (before any work).
        TypeError: a ``joints`` that is not a bool.
        MemoryError: the tubes' vertices and faces would not fit in free host memory (before any work).
    """
    den = _check_3d(dendrite, "tubes()")
    sides = _int_arg("sides", sides, 3)
    # per edge two rings of ``sides`` vertices and their caps' centres, 4 ``sides`` faces, 3 float64
    # or int64 values each, and about as much again while the runs are joined
    joints = _checks.flag("joints", joints)
    _checks.fits_in_memory(2 * 24 * len(den) * (6 * sides + 2), "cpu",
                           f"tubes() of {len(den)} nodes with 'sides' = {sides}")
    r = _radii(den, radius, side)
    pos = _world(den)
    child = np.flatnonzero(den.parent >= 0)
    parts_v, parts_f = [], []
    if len(child):
        v, f = _straight_runs_joined(den, child, *_frustums(pos[child], pos[den.parent[child]], r[child],
                                                            r[den.parent[child]], sides), sides)
        parts_v.append(v)
        parts_f.append(f)
    if joints or not len(child):
        v, f = _sphere_mesh(pos, r, 0)
        parts_f.append(f + sum(len(p) for p in parts_v))
        parts_v.append(v)
    return _trimesh(np.concatenate(parts_v), np.concatenate(parts_f))


def _straight_runs_joined(den: Dendrite, child: np.ndarray, verts: np.ndarray, faces: np.ndarray, sides: int):
    """Join the frustums of :func:`_frustums` (edge ``e`` from ``child[e]`` to its parent) where a node's
    edge continues a child's edge in the same direction: both caps there go, and the upper frustum
    takes the lower one's end ring (the same points: the same centre, radius and frame). A straight
    run is then one closed tube; caps met head on had made an edge of four faces once welded (STL)."""
    per = 2 * sides + 2
    step = den.nodes[den.parent[child]] - den.nodes[child]
    n_children = np.bincount(den.parent[child], minlength=len(den))
    edge_of = np.full(len(den), -1, np.int64)
    edge_of[child] = np.arange(len(child))
    # edge e -> the edge of its child below, where that child is its parent's only one
    below = np.full(len(child), -1, np.int64)
    # the child (if any) whose edge its parent's edge continues straight on, siblings or not: at most
    # one child lies straight below a node
    lined = child[edge_of[den.parent[child]] >= 0]  # children whose parent has an edge too (not a root)
    lined = lined[np.all(step[edge_of[lined]] == step[edge_of[den.parent[lined]]], axis=1)]
    below[edge_of[den.parent[lined]]] = edge_of[lined]
    straight = below >= 0
    # faces of each frustum: sides x 2 wall, then sides of the end cap, then sides of the start cap
    group = np.repeat(np.arange(4), sides)
    keep = np.ones((len(child), 4 * sides), bool)
    keep[straight] &= group != 3  # this edge's start cap
    keep[below[straight]] &= group != 2  # the end cap of the edge below
    # the start ring of a straight edge is the end ring of the edge below
    remap = np.arange(len(verts))
    upper = np.flatnonzero(straight)[:, None] * per + np.arange(sides)
    lower = below[straight][:, None] * per + sides + np.arange(sides)
    remap[upper.ravel()] = lower.ravel()
    faces = remap[faces.reshape(len(child), 4 * sides, 3)[keep]]
    used = np.zeros(len(verts), bool)
    used[faces] = True
    new_index = np.cumsum(used) - 1
    return verts[used], new_index[faces]


def _check_field(field) -> np.ndarray | wp.array:
    """A finite ``(D, H, W)`` float32 field with at least 2 nodes per axis.

    A Warp array is checked where it lives, by a kernel (nothing but two counters is copied).
    """
    if isinstance(field, wp.array):
        if field.ndim != 3 or field.dtype != wp.float32:
            raise ValueError(f"Expected a 3D float32 Warp array for 'field', but got {field.ndim}D {field.dtype}")
        if field.size:
            with wp.ScopedDevice(field.device):
                count, first = wp.zeros(1, dtype=int), wp.full(1, field.size, dtype=int)
                wp.launch(_kg.nonfinite_kernel, dim=field.shape, inputs=[field], outputs=[count, first])
                count, first = int(count.numpy()[0]), int(first.numpy()[0])
            if count:
                where = tuple(int(i) for i in np.unravel_index(first, field.shape))
                value = field[tuple(slice(i, i + 1) for i in where)].numpy().item()
                raise ValueError(f"'field' must be finite, but has {count} NaN/inf entries (first at {where}: "
                                 f"{value!r})")
        shape = field.shape
    else:
        field = _checks.finite_array("field", field, "3D (D, H, W)", lambda s: len(s) == 3)
        shape = field.shape
    if min(shape) < 2:
        raise ValueError(f"Expected at least 2 nodes on every axis of 'field', but got shape {tuple(shape)}")
    return field


def _check_level(host: np.ndarray, level: float) -> None:
    if not (host.min() < level < host.max()):
        raise ValueError(f"'level' {level} is outside the field's range [{host.min()}, {host.max()}]")


def field_mesh(
    field,
    level: float = 0.0,
    *,
    spacing: float = 1.0,
    origin: Sequence[float] = (0.0, 0.0, 0.0),
    smooth: int = 0,
    band: float | None = None,
    device=None,
    _backend: str = "auto",
    _method: str = "lewiner",
    _cubes: np.ndarray | None = None,
):
    """The isosurface ``field == level`` by marching cubes.

    Runs scikit-image's marching cubes on the CPU, and Warp's own
    (``warp.geometry.IsoSurfaceMarchingCubes``) when the field is on a CUDA
    device, so a GPU field stays on the GPU until the mesh is built.

    Args:
        field: ``(D, H, W)`` NumPy array or float32 Warp array; nodes below
            ``level`` are inside, nodes at it or above outside (a node exactly at
            the level is moved above it by a thousandth of its least difference
            from a neighbour, so that no vertex sits on a node and pinches the surface).
        level: iso value.
        spacing: world distance between field nodes, > 0.
        origin: world position ``(z, y, x)`` of node (0, 0, 0).
        smooth: Taubin smoothing iterations (0: none); keeps the volume
            nearly unchanged while removing the lattice's stair steps.
        band: skip the cubes whose first node lies ``band`` or more from the level
            (``|field - level| >= band``), > 0. Give it only when every cube the
            surface crosses has its first node within ``band`` (a distance field
            with steps <= 1 per node needs ``band`` > sqrt(3)); the mesh is then the
            same, found faster (CPU only). Default: every cube.
        device: Warp device for a NumPy field (default: the CPU); a Warp field is meshed on its own device.

    Returns:
        A :class:`trimesh.Trimesh` (vertices ``(x, y, z)``; faces point outward).

    Raises:
        ValueError: a field that is not 3D, has fewer than 2 nodes on an axis or holds NaN/inf
            (a Warp field is checked on its device), a non-finite ``level`` or one outside
            the field's range, a bad ``spacing``, ``origin``, ``smooth`` or ``band``.
        TypeError: a field that is not real-valued, a ``level`` that is not a number.
    """
    field = _check_field(field)
    spacing = _checks.positive("spacing", spacing)
    org = _checks.finite_array("origin", origin, "(3,) (z, y, x)", lambda s: s == (3,)).astype(np.float64)
    smooth = _int_arg("smooth", smooth, 0)
    level = _checks.finite("level", level)
    band = None if band is None else _checks.positive("band", band)
    dev = _checks.device(device if device is not None else field.device if isinstance(field, wp.array) else "cpu")
    if isinstance(field, wp.array) and dev != field.device:
        raise ValueError(f"'device' {device!r} is not the device of the Warp field ({field.device}); a Warp field "
                         "is meshed where it lies (leave 'device' out, or pass a NumPy field)")
    # _backend is a testing hook: "warp" runs Warp's marching cubes on any device; _method is
    # scikit-image's (region_mesh takes "lorensen"); _cubes marks the cubes to visit (by their last
    # node) in place of the band, on the CPU
    if (dev.is_cuda and _backend == "auto") or _backend == "warp":
        from warp.geometry import IsoSurfaceMarchingCubes

        arr = field if isinstance(field, wp.array) else wp.array(field, dtype=float, device=dev)
        verts, idx = IsoSurfaceMarchingCubes.extract(_lift_level(arr, level), level)
        v = verts.numpy().astype(np.float64)[:, ::-1]  # array axes (z, y, x) -> (x, y, z)
        f = idx.numpy().reshape(-1, 3).astype(np.int64)
        if not len(f):  # a level inside the range always crosses some cube: say why there is no surface
            _check_level(arr.numpy(), level)
    else:
        from skimage.measure import marching_cubes

        host = field.numpy() if isinstance(field, wp.array) else field
        _check_level(host, level)
        at = host == level
        if at.any():  # (only those nodes change: a float64 field keeps its other values)
            lifted = _lift_level(wp.array(host, dtype=float, device="cpu"), level).numpy()
            host = np.where(at, lifted.astype(host.dtype), host)
        mask = _cubes if _cubes is not None else None if band is None else np.abs(host - level) < band
        v, f, _, _ = marching_cubes(host, level, mask=mask, method=_method)
        v = v[:, ::-1]  # (z, y, x) -> (x, y, z)
    # both marching cubes, once their axes are reversed to (x, y, z), wind faces toward the low
    # values (the inside), closed surface or not: reversed, they point outward
    f = f[:, ::-1]
    mesh = _trimesh(v * spacing + org[::-1], f)
    if smooth:
        import trimesh

        trimesh.smoothing.filter_taubin(mesh, iterations=smooth)
    return mesh


def _lift_level(arr: wp.array, level: float) -> wp.array:
    """A float32 copy of ``arr`` where the nodes exactly at ``level`` lie just above it."""
    lifted = wp.empty_like(arr)
    level32 = np.float32(level)
    wp.launch(_kg.lift_level_kernel, dim=arr.shape,
              inputs=[arr, float(level32), float(np.nextafter(level32, np.float32(np.inf)))], outputs=[lifted],
              device=arr.device)
    return lifted


def _padded(field: np.ndarray, value: float) -> np.ndarray:
    return np.pad(field, 1, mode="constant", constant_values=value)


MIN_ISO_RADIUS = 0.6
"""Least radius (node units) of a Euclidean :func:`isosurface`: chains of nodes along any of the
26 directions stay one piece from it on (0.5 breaks diagonal chains apart)."""


def isosurface(
    dendrite: Dendrite,
    radius: Width = 1.5,
    *,
    side: Width | None = None,
    metric: Metric = "euclidean",
    lattice: Lattice | None = None,
    smooth: int = 0,
    device=None,
):
    """The surface around a 3D dendrite where the distance to the nearest node equals that node's radius.

    The distance field comes from the dendrite's nodes (the papers' section
    3.3: the dendrite as generators); each node's radius may taper. The paper
    measures it by a breadth-first search over the lattice (``metric="path"``
    with unit weights); the default, Euclidean distance, gives round branches
    where lattice steps give blocky ones.

    Args:
        dendrite: a non-empty 3D dendrite.
        radius: radius (constant > 0, Taper or ``(N,)`` array): in lattice node
            units with ``metric="euclidean"``, where radii below
            :data:`MIN_ISO_RADIUS` (0.6) are raised to it (marching cubes on the
            node grid breaks thinner branches into beads); in path-cost units
            with ``metric="path"``.
        side: optional radius of side branches.
        metric: ``"euclidean"`` or ``"path"`` (path cost over ``lattice``).
        lattice: lattice of the path costs, ``metric="path"`` only (default: unit
            weights, 26-connected).
        smooth: Taubin smoothing iterations after marching cubes.
        device: Warp device for the distance field.

    Returns:
        A closed :class:`trimesh.Trimesh` (the field is padded so the surface closes at the lattice's edge).

    Raises:
        ValueError: an empty or 2D dendrite, a bad radius, ``metric`` or ``smooth``,
            a ``lattice`` with the Euclidean metric (before any kernel runs).
    """
    den = _check_3d(dendrite, "isosurface()")
    _check_metric(metric, lattice)
    smooth = _int_arg("smooth", smooth, 0)  # checked again by field_mesh, but only after the kernels ran
    r = node_widths(den, radius, side=side, _name="radius")
    if metric == "euclidean":
        r = np.maximum(r, np.float32(MIN_ISO_RADIUS))
    # the limit, the border and the band in float32, as the field holds them (from about 2.6e5 on,
    # limit - 0.01 rounded up to the limit itself, whose cubes the band skips: the surface did not
    # close there); the limit stays above every radius, so that nodes inside stay within the band
    limit32 = max(np.float32(float(r.max()) + 2.0), np.nextafter(r.max(), np.float32(np.inf)))
    limit = float(limit32)
    dist, label = _nearest(den, limit, metric, lattice, None, device)
    out = wp.empty(dist.shape[0], dtype=float, device=dist.device)
    wp.launch(_kg.nearest_value_kernel, dim=dist.shape[0],
              inputs=[dist, label, wp.array(r, dtype=float, device=dist.device), limit], outputs=[out],
              device=dist.device)
    # a border just below the limit: outside the surface, but inside the cubes marching cubes visits
    border = min(np.float32(limit - 0.01), np.nextafter(limit32, np.float32(0)))
    field = _padded(out.numpy().reshape(den.shape), border)
    org = np.asarray(den.origin, np.float64) - den.spacing
    # cubes the surface crosses start within sqrt(3) of a node inside, i.e. below the limit (Euclidean
    # steps are <= 1 per node; path costs may step further, so every cube is visited there)
    band = float(limit32) if metric == "euclidean" else None
    # the field is on the host by now: scikit-image meshes it on every device. Warp's marching cubes
    # (what a CUDA device would pick) split ambiguous cubes the plain Lorensen way, breaking branches
    # one body diagonal apart into beads; scikit-image's Lewiner cubes keep them whole
    return field_mesh(field, 0.0, spacing=den.spacing, origin=org, smooth=smooth, band=band, device="cpu")


MAX_FIELD_NODES = 2**28
"""Most grid nodes of a :func:`skeleton_mesh` field (eight bytes each while it is built, and as
much again for the value and segment read from it)."""


def _rgb_rows(name: str, colors, n: int, what: str) -> np.ndarray:
    """``colors`` as ``(n, 3)`` float32 RGB in [0, 1]."""
    cols = _checks.finite_array(name, colors, f"({n}, 3), one RGB per {what}", lambda s: s == (n, 3))
    _unit_rgb(name, cols, f"values in [{cols.min()}, {cols.max()}]")
    return cols.astype(np.float32)


def _tube_field(lines, voxel: float, lo: np.ndarray, hi: np.ndarray, device):
    """The tapered capsules of ``lines``' segments as a field on a grid of spacing ``voxel`` covering the
    world box ``[lo, hi]`` (``(x, y, z)``): ``(D, H, W)`` float32 values (negative inside, clipped at
    ``2 voxel`` outside), ``(D, H, W)`` int32 segment rows (-1 beyond every capsule's reach) and the
    world ``(x, y, z)`` of node (0, 0, 0)."""
    band = 2.0 * voxel
    origin = lo.astype(np.float64)
    shape = tuple(int(v) for v in (np.ceil((hi - lo) / voxel).astype(np.int64) + 1)[::-1])  # (z, y, x)
    nodes = int(np.prod(shape, dtype=np.int64))
    if nodes > MAX_FIELD_NODES:
        raise ValueError(f"A voxel of {voxel:g} makes a field of {shape} nodes (more than {MAX_FIELD_NODES}); "
                         "choose a larger 'voxel'")
    _checks.fits_in_memory(16 * nodes, device, f"a tube field of {shape} nodes")
    segs = lines.segments
    offset = float(lines.radius.max()) + band
    with wp.ScopedDevice(device):
        packed = wp.full(nodes, value=wp.uint64(0xFFFFFFFFFFFFFFFF), dtype=wp.uint64)
        if len(segs):
            wp.launch(_kg.tube_field_kernel, dim=len(segs),
                      inputs=[wp.array(lines.points.astype(np.float32), dtype=wp.vec3),
                              wp.array(lines.radius.astype(np.float32), dtype=float),
                              wp.array(segs.astype(np.int32), dtype=wp.vec2i),
                              wp.vec3(*origin.tolist()), float(voxel), wp.vec3i(*shape), band, offset],
                      outputs=[packed])
        keyed = wp.empty(nodes, dtype=float)
        label = wp.empty(nodes, dtype=wp.int32)
        wp.launch(_kr.unpack_nearest_kernel, dim=nodes, inputs=[packed], outputs=[keyed, label])
        # (unreached nodes hold inf: the band, outside)
        field = np.minimum(keyed.numpy() - np.float32(offset), np.float32(band))
        return field.reshape(shape), label.numpy().reshape(shape), origin


def _closed_body(field: np.ndarray, origin_xyz: np.ndarray, voxel: float, vertex_rgb=None):
    """The closed surface ``field == 0`` (the field ends above 0 on its border) with smooth vertex
    normals; ``vertex_rgb(vertices)`` gives ``(V, 3)`` colours in [0, 1] when set."""
    # a node within a thousandth of a voxel of the level moves just outside it: marching cubes puts a
    # vertex that close to a node on the node itself (in float32), once per cube edge there, and the
    # surface splits at those coincident vertices
    eps = np.float32(1e-3 * voxel)
    field = np.where(np.abs(field) < eps, eps, field)
    mesh = _without_voids(field_mesh(field, 0.0, spacing=voxel, origin=tuple(origin_xyz[::-1]), device="cpu",
                                     _cubes=_crossed_cubes(field > 0)))
    if vertex_rgb is not None and len(mesh.vertices):
        rgb = np.clip(np.asarray(vertex_rgb(mesh.vertices), np.float64), 0.0, 1.0)
        alpha = np.full((len(rgb), 1), 255, np.uint8)
        mesh.visual.vertex_colors = np.concatenate([np.round(rgb * 255).astype(np.uint8), alpha], axis=1)
    mesh.vertex_normals = vertex_normals(mesh.vertices, mesh.faces)
    return mesh


def _crossed_cubes(outside: np.ndarray) -> np.ndarray:
    """Bool array of ``outside``'s shape: True at the last node (largest indices) of every cube whose eight
    nodes are not all on one side: the only cubes marching cubes needs to visit, whatever the field's
    slope (scikit-image's ``mask`` names a cube by that node)."""
    d, h, w = outside.shape
    corners = [outside[a: d - 1 + a, b: h - 1 + b, c: w - 1 + c] for a in (0, 1) for b in (0, 1) for c in (0, 1)]
    some, every = corners[0].copy(), corners[0].copy()
    for k in corners[1:]:
        some |= k
        every &= k
    out = np.zeros(outside.shape, bool)
    out[1:, 1:, 1:] = some & ~every
    return out


def _without_voids(mesh):
    """``mesh`` without its closed pieces of negative volume: hollows enclosed by the body (where
    tubes nearly touch around a pocket of outside nodes), whose faces point into the pocket."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    f = mesh.faces
    if not len(f):
        return mesh
    n = len(mesh.vertices)
    a = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    b = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    count, comp = connected_components(coo_matrix((np.ones(len(a), np.int8), (a, b)), shape=(n, n)), directed=False)
    if count == 1:
        return mesh
    v = mesh.vertices[f]
    # six times each piece's signed volume: the triple products of its faces' corners
    vol = np.bincount(comp[f[:, 0]], weights=np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])),
                      minlength=count)
    keep = vol[comp[f[:, 0]]] >= 0
    if keep.all():
        return mesh
    used = np.zeros(n, bool)
    used[f[keep]] = True
    new_index = np.cumsum(used) - 1
    return _trimesh(mesh.vertices[used], new_index[f[keep]])


def _node_of(vertices: np.ndarray, origin_xyz: np.ndarray, voxel: float, shape) -> tuple:
    """Index ``(z, y, x)`` of the grid node nearest each vertex."""
    ijk = np.rint((vertices - origin_xyz) / voxel).astype(np.int64)
    ijk = np.clip(ijk, 0, np.asarray(shape[::-1]) - 1)
    return ijk[:, 2], ijk[:, 1], ijk[:, 0]


SAGITTA = 0.1
"""Marching cubes cuts a tube of radius ``r`` on a grid of spacing ``h`` with flat faces between
vertices on its surface, losing volume: a helix of radius ``h`` kept 78 % of it, of ``2 h`` 95 %. The
radii of a body grow by ``SAGITTA * h**2 / r`` first (measured on helices of radius ``h`` to ``5 h``:
their meshes then hold 96-100 % of the tubes' volume)."""


def meshable(lines, voxel: float):
    """``lines`` with radii raised to ``voxel`` at least, then grown by :data:`SAGITTA` ``* voxel**2 / r``."""
    r = np.maximum(lines.radius, voxel)
    return dataclasses.replace(lines, radius=r + SAGITTA * voxel**2 / r)


def skeleton_mesh(lines, *, voxel: float | None = None, colors=None, device=None):
    """One closed body around smooth centre lines: the surface of their tapered capsules' union.

    The field is the least, over the skeleton's segments, of the distance to
    the segment minus the radius interpolated along it (the papers' section
    3.3 route: an isosurface of a distance field around the skeleton, here
    the smooth one of :func:`wdendrite.skeleton.skeleton`), computed by a Warp
    kernel on a grid of spacing ``voxel`` and meshed by marching cubes
    (scikit-image's, whose surfaces of a closed field are closed 2-manifolds).
    A connected skeleton gives one body: radii below ``voxel`` are raised to
    it, since a thinner tube could fall between the grid's nodes; all radii
    then grow a little (see :data:`SAGITTA`) so that the mesh holds the tubes'
    volume. Pockets the tubes enclose (where they nearly touch) are filled.

    Args:
        lines: a :class:`~wdendrite.skeleton.Skeleton`.
        voxel: grid spacing, world units, > 0 (default: the least radius, but no finer than
            1/400 of the skeleton's largest extent).
        colors: optional ``(P, 3)`` RGB in [0, 1] per sample: each vertex takes the colour of
            the segment nearest it (the mesh's ``visual.vertex_colors``).
        device: Warp device of the field (default: Warp's default device).

    Returns:
        A :class:`trimesh.Trimesh` (watertight, outward faces, vertex normals from the faces around
        each vertex).

    Raises:
        TypeError: ``lines`` is not a Skeleton.
        ValueError: a bad ``voxel`` or ``colors``, or a grid of more than :data:`MAX_FIELD_NODES`
            nodes (before any kernel runs).
        MemoryError: the field would not fit in free memory.
    """
    from .skeleton import Skeleton

    if not isinstance(lines, Skeleton):
        raise TypeError(f"Expected a wdendrite.skeleton.Skeleton for 'lines', but got {type(lines).__name__}")
    pts = lines.points
    extent = float((pts.max(axis=0) - pts.min(axis=0)).max()) + 2.0 * float(lines.radius.max())
    if voxel is None:
        voxel = max(float(lines.radius.min()), extent / 400.0)
    voxel = _checks.positive("voxel", voxel)
    cols = None if colors is None else _rgb_rows("colors", colors, len(lines), "sample")
    grown = meshable(lines, voxel)
    reach = float(grown.radius.max()) + 3.0 * voxel  # the border lies beyond every capsule's band
    lo, hi = pts.min(axis=0) - reach, pts.max(axis=0) + reach
    device = _checks.device(device)
    field, label, origin = _tube_field(grown, voxel, lo, hi, device)
    paint = None
    if cols is not None:
        seg_colors = cols[lines.segments[:, 0]] if len(lines.segments) else cols[:1]

        def paint(v):
            return seg_colors[np.maximum(label[_node_of(v, origin, voxel, field.shape)], 0)]

    return _closed_body(field, origin, voxel, paint)


def _region_mask(name: str, labels, region) -> np.ndarray:
    lab = np.asarray(labels)
    if lab.dtype.kind not in "iu":
        raise TypeError(f"Expected an integer label array for '{name}', but got dtype {lab.dtype}")
    if lab.ndim != 3:
        raise ValueError(f"Expected a 3D (D, H, W) label array for '{name}' (region meshes are 3D), "
                         f"but got shape {lab.shape}")
    ids = np.atleast_1d(np.asarray(region))
    if ids.dtype.kind not in "iu" or ids.ndim != 1 or not len(ids):
        raise ValueError(f"Expected 'region' as one or more integer labels, but got {region!r}")
    inside = np.isin(lab, ids)
    if not inside.any():
        raise ValueError(f"No node of '{name}' has a label in 'region' {ids.tolist()}")
    return inside


def surface_nodes(inside) -> np.ndarray:
    """``(M, 3)`` int64 coordinates of the region's surface: inside nodes with a 6-neighbour outside.

    Nodes on the lattice's edge count as surface. ``inside`` is a 3D bool array.
    """
    mask = np.asarray(inside)
    if mask.dtype != np.bool_ or mask.ndim != 3:
        raise ValueError(f"Expected a 3D bool array for 'inside', but got {mask.dtype} {mask.shape}")
    p = np.pad(mask, 1, constant_values=False)
    interior = p[1:-1, 1:-1, 1:-1].copy()
    for axis in range(3):
        for step in (-1, 1):
            interior &= np.roll(p, step, axis=axis)[1:-1, 1:-1, 1:-1]
    return np.argwhere(mask & ~interior).astype(np.int64)


def region_mesh(labels, region, *, band: float = 2.0, smooth: int = 0, spacing: float = 1.0, device=None):
    """The boundary surface of the nodes whose label is in ``region`` (the papers' rocks, section 3.4).

    A signed distance to the region's boundary (negative inside) is built
    with Warp (boundary nodes found in one pass, then a distance splat of
    width ``band``) and meshed at 0, halfway between the last node inside and
    the first outside.

    Args:
        labels: ``(D, H, W)`` int labels, e.g. ``CostField.label`` of a search
            from several generators.
        region: one label or a sequence of labels forming the solid.
        band: width of the signed distance kept on each side, > 1 (lattice units); 2 gives
            every corner of the cubes the surface crosses its true value.
        smooth: Taubin smoothing iterations (rocks look better with 5-10).
        spacing: world distance between nodes.
        device: Warp device (default: Warp's default device).

    Returns:
        A closed :class:`trimesh.Trimesh` with positive volume.
    """
    inside = _region_mask("labels", labels, region)
    band = _checks.positive("band", band)
    if band <= 1.0:
        raise ValueError(f"Expected 'band' > 1 so the surface lies inside it, but got {band!r}")
    # field_mesh checks these too, but only after the signed field's kernels ran
    smooth = _int_arg("smooth", smooth, 0)
    spacing = _checks.positive("spacing", spacing)
    field = signed_region_field(inside, band=band, device=device)
    # boundary nodes hold +-1/2 and their neighbours +-3/2: the crossed cubes start there
    cpu = _checks.device(device).is_cpu
    # the border outside the lattice acts as outside boundary nodes (+1/2): the surface lies halfway.
    # Lorensen's cases, as Warp's marching cubes: they split an ambiguous cube face alike in both
    # cubes that share it. Lewiner's face test ties on this field (+-1/2 across every face where
    # nodes touch along an edge only), and each cube then splits the face its own way: edges of
    # four faces, not a closed surface
    return field_mesh(_padded(field, 0.5), 0.0, spacing=spacing, origin=(-spacing,) * 3, smooth=smooth,
                      band=2.0 if cpu else None, device=device, _method="lorensen")


def signed_region_field(inside: np.ndarray, *, band: float = 3.0, device=None) -> np.ndarray:
    """``(D, H, W)`` float32 signed distance to the boundary of ``inside``: ``-(d + 1/2)`` inside, ``d + 1/2`` outside.

    ``d`` is the Euclidean distance to the nearest boundary node (a node
    with a 6-neighbour across the boundary), clipped to ``band``.
    """
    mask = np.asarray(inside)
    if mask.dtype != np.bool_ or mask.ndim != 3:
        raise ValueError(f"Expected a 3D bool array for 'inside', but got {mask.dtype} {mask.shape}")
    band = _checks.positive("band", band)
    device = _checks.device(device)
    shape = mask.shape
    n = mask.size
    with wp.ScopedDevice(device):
        flags = wp.array(mask.ravel().astype(np.uint8), dtype=wp.uint8)
        seeds = wp.empty(n, dtype=wp.vec3i)
        count = wp.zeros(1, dtype=wp.int32)
        wp.launch(_kg.boundary_seeds_kernel, dim=n, inputs=[flags, wp.vec3i(*shape)], outputs=[seeds, count])
        m = int(count.numpy()[0])
        packed = wp.full(n, value=wp.uint64(0xFFFFFFFFFFFFFFFF), dtype=wp.uint64)
        if m:
            wp.launch(_kr.splat_distance_kernel, dim=m,
                      inputs=[seeds, wp.vec3i(*shape), float(band), _kr.METRIC_EUCLIDEAN], outputs=[packed])
        dist = wp.empty(n, dtype=float)
        label = wp.empty(n, dtype=wp.int32)
        wp.launch(_kr.unpack_nearest_kernel, dim=n, inputs=[packed], outputs=[dist, label])
        out = wp.empty(n, dtype=float)
        wp.launch(_kg.signed_region_kernel, dim=n, inputs=[dist, flags, float(band)], outputs=[out])
        return out.numpy().reshape(shape)
