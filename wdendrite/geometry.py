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
- :func:`preview`: a shaded PNG-ready picture of any mesh, ray cast with
  Warp without a display.

Meshes are :class:`trimesh.Trimesh` with vertices in world ``(x, y, z)``
order: the lattice axes ``(z, y, x)`` reversed, placed by the dendrite's
``origin`` and ``spacing``. Lattice axis 0 is "up" (``z``) in previews.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import warp as wp

from . import _checks
from .dendrite import Dendrite
from .kernels import geometry as _kg
from .kernels import render as _kr
from .lattice import Lattice
from .render import Metric, Width, _check_metric, _nearest, _rgb_triple, node_widths

__all__ = ["field_mesh", "isosurface", "preview", "region_mesh", "spheres", "surface_nodes", "tubes"]


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
    # scikit-image's (region_mesh takes "lorensen")
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
        mask = None if band is None else np.abs(host - level) < band
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


def _scene(mesh, color) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices, faces and per-face colours of one mesh or a list of meshes (one colour each)."""
    meshes = list(mesh) if isinstance(mesh, (list, tuple)) else [mesh]
    cols = np.asarray(color, np.float32)
    if cols.ndim == 1:
        cols = np.broadcast_to(cols, (len(meshes), cols.shape[0]))
    if cols.shape != (len(meshes), 3) or not np.isfinite(cols).all():
        raise ValueError(f"Expected 'color' as one RGB triple or one per mesh ({len(meshes)}), but got {color!r}")
    _unit_rgb("color", cols, color)
    vs, fs, cs, base = [], [], [], 0
    for i, (m, c) in enumerate(zip(meshes, cols)):
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
        vs.append(v)
        fs.append(f + base)
        cs.append(np.broadcast_to(c, (len(f), 3)))
        base += len(v)
    faces = np.concatenate(fs)
    if not len(faces):
        raise ValueError("'mesh' has no faces: there is nothing to show")
    return np.concatenate(vs), faces, np.concatenate(cs).astype(np.float32)


def _unit_rgb(name: str, values: np.ndarray, given) -> None:
    """Refuse colours (finite RGB values) outside [0, 1]."""
    if values.size and (values.min() < 0 or values.max() > 1):
        raise ValueError(f"Expected '{name}' RGB values in [0, 1], but got {given!r}")


def preview(
    mesh,
    *,
    size: tuple[int, int] = (480, 480),
    elevation: float = 25.0,
    azimuth: float = -60.0,
    color: Sequence = (0.82, 0.76, 0.66),
    background: Sequence[float] = (1.0, 1.0, 1.0),
    device=None,
) -> np.ndarray:
    """A shaded picture of a mesh without a display (orthographic Warp ray casting).

    Args:
        mesh: a :class:`trimesh.Trimesh` (anything with ``vertices`` and ``faces``), or a list of them.
        size: ``(H, W)`` pixels.
        elevation, azimuth: view direction in degrees (``z`` is up; azimuth from ``+x`` toward ``+y``).
        color: surface RGB in [0, 1], or one RGB per mesh of a list.
        background: RGB in [0, 1].
        device: Warp device (default: Warp's default device).

    Returns:
        ``(H, W, 3)`` float32 in [0, 1], ready for :func:`wdendrite.io.save_png`.

    Raises:
        ValueError: an empty list, a bad ``size``, colours that are not RGB in [0, 1], meshes
            whose faces are not ``(F, 3)`` or index no vertex (before any kernel runs).
        TypeError: faces that are not integers.
    """
    if isinstance(mesh, (list, tuple)) and not len(mesh):
        raise ValueError("'mesh' is an empty list: there is nothing to show")
    if not isinstance(size, (list, tuple)) or len(size) != 2 or any(
            isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s <= 0 for s in size):
        raise ValueError(f"Expected 'size' as (H, W) positive ints, but got {size!r}")
    verts, faces, face_colors = _scene(mesh, color)
    bg = _rgb_triple("background", background)
    _unit_rgb("background", bg, background)
    el = math.radians(_checks.finite("elevation", elevation))
    az = math.radians(_checks.finite("azimuth", azimuth))
    forward = -np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right = right / np.linalg.norm(right) if np.linalg.norm(right) > 1e-9 else np.array([1.0, 0.0, 0.0])
    up = np.cross(right, forward)
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    center = 0.5 * (lo + hi)
    rel = verts - center
    ext_x = np.abs(rel @ right).max() * 1.05 + 1e-6
    ext_y = np.abs(rel @ up).max() * 1.05 + 1e-6
    h, w = int(size[0]), int(size[1])
    # keep square pixels: widen whichever extent is short for the image's aspect
    ext_x, ext_y = max(ext_x, ext_y * w / h), max(ext_y, ext_x * h / w)
    depth = float(np.linalg.norm(hi - lo)) + 1.0
    light = forward + 0.6 * right - 0.8 * up
    light /= np.linalg.norm(light)
    device = _checks.device(device)
    with wp.ScopedDevice(device):
        wmesh = wp.Mesh(points=wp.array(verts.astype(np.float32), dtype=wp.vec3),
                        indices=wp.array(faces.astype(np.int32).ravel(), dtype=wp.int32))
        out = wp.empty((h, w), dtype=wp.vec3)
        wp.launch(_kg.preview_kernel, dim=(h, w),
                  inputs=[wmesh.id, wp.vec3(*center), wp.vec3(*forward), wp.vec3(*right), wp.vec3(*up),
                          wp.vec2(ext_x, ext_y), depth, wp.vec3(*light), wp.array(face_colors, dtype=wp.vec3),
                          wp.vec3(*bg.tolist())],
                  outputs=[out])
        return out.numpy()
