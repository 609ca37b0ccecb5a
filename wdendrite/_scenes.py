"""Building blocks of the 3D presets and the lichen clusters: smooth bodies, a mossy ground, lichen crusts.

- :func:`smooth_body`: a dendrite's smooth centre lines meshed as one closed body.
- :func:`moss_body`: strands up from a ground slab, one body, coloured from an image
  (2007 paper, Fig. 15: "a mossy version of the peppers image").
- :func:`cost_bands`: the thesis' lichen cluster (section 5.4, Fig. 5.4): nodes chosen between
  isocontours of the path cost from a dendrite, one kind of lichen per band.
- :func:`crust_body`: a rock, the lichen's ropes and its crust of chosen surface nodes, one body.
- :func:`crust_picture`: the 2D cluster as crusty, shaded patches.
"""

from __future__ import annotations

import numpy as np

from . import _checks
from . import geometry as _geo
from .dendrite import Dendrite
from .lattice import Lattice
from .render import Width
from .skeleton import Skeleton, skeleton
from .sssp import shortest_paths

GROUND = -2
"""Segment label of the ground or the rock in a combined field."""


def smooth_body(den: Dendrite, radius: Width, *, side: Width | None = None, voxel: float, sigma: float | None = None):
    """The dendrite's smooth centre lines (radii at least ``voxel``) and their closed body."""
    lines = skeleton(den, radius, side=side, sigma=sigma, min_radius=voxel)
    return _geo.skeleton_mesh(lines, voxel=voxel), lines


def roots_of(den: Dendrite) -> np.ndarray:
    """``(N,)`` int64 row of each node's root (pointer jumping, as :attr:`Dendrite.depth`)."""
    up = np.where(den.parent >= 0, den.parent, np.arange(len(den)))
    for _ in range(2 + int(np.log2(max(len(den), 1)))):
        nxt = up[up]
        if np.array_equal(nxt, up):
            break
        up = nxt
    return up


# --------------------------------------------------------------------------- moss


def image_rgb(name: str, image) -> np.ndarray:
    """``image`` as ``(H, W, 3)`` float64 RGB in [0, 1]: floats in [0, 1] or 8-bit integers; grey
    ``(H, W)`` is repeated, an alpha channel dropped."""
    arr = np.asarray(image)
    if arr.dtype.kind not in "fiu" or arr.dtype == np.bool_:
        raise TypeError(f"Expected a real-valued array for '{name}', but got dtype {arr.dtype}")
    if arr.ndim == 2:
        arr = np.repeat(arr[..., None], 3, axis=2)
    if arr.ndim != 3 or arr.shape[2] not in (3, 4) or min(arr.shape[:2]) < 1:
        raise ValueError(f"Expected '{name}' of shape (H, W), (H, W, 3) or (H, W, 4), but got shape {arr.shape}")
    arr = arr[..., :3]
    if arr.dtype.kind in "iu":
        if arr.min() < 0 or arr.max() > 255:
            raise ValueError(f"Expected 8-bit values in [0, 255] for the integer '{name}', but got "
                             f"[{arr.min()}, {arr.max()}]")
        return arr.astype(np.float64) / 255.0
    out = arr.astype(np.float64)
    bad = ~np.isfinite(out)
    if bad.any():
        raise ValueError(f"Expected finite '{name}' values in [0, 1], but it has {int(bad.sum())} NaN/inf entries")
    if out.min() < 0 or out.max() > 1:
        raise ValueError(f"Expected '{name}' values in [0, 1] (floats) or [0, 255] (integers), but got "
                         f"[{out.min()}, {out.max()}]")
    return out


def moss_image(size: tuple[int, int], seed: int) -> np.ndarray:
    """A procedural "mossy" picture: ``(H, W, 3)`` blotches of dark, bright and yellow-green moss
    from three octaves of smooth value noise (the default colours of :func:`moss_body`)."""
    from scipy.ndimage import zoom

    rng = _checks.rng(seed)
    h, w = size
    noise = np.zeros((h, w))
    for cells, gain in ((4, 1.0), (9, 0.5), (20, 0.25)):
        grid = rng.random((cells + 1, cells + 1))
        noise += gain * zoom(grid, (h / (cells + 1), w / (cells + 1)), order=3, grid_mode=True, mode="nearest")[:h, :w]
    t = (noise - noise.min()) / max(float(np.ptp(noise)), 1e-12)
    palette = np.array([[0.16, 0.30, 0.08], [0.30, 0.50, 0.12], [0.52, 0.62, 0.18], [0.70, 0.66, 0.30]])
    x = t * (len(palette) - 1)
    i = np.minimum(x.astype(np.int64), len(palette) - 2)
    f = (x - i)[..., None]
    return palette[i] * (1.0 - f) + palette[i + 1] * f


def _at(image: np.ndarray, y: np.ndarray, x: np.ndarray, height: float, width: float) -> np.ndarray:
    """Colours of ``image`` stretched over ``[0, height] x [0, width]`` at world ``(y, x)`` (nearest pixel)."""
    h, w = image.shape[:2]
    r = np.clip((y / max(height, 1e-12) * h).astype(np.int64), 0, h - 1)
    c = np.clip((x / max(width, 1e-12) * w).astype(np.int64), 0, w - 1)
    return image[r, c]


def _box_field(shape_zyx, origin_xyz, voxel, lo, hi) -> np.ndarray:
    """Signed distance (exact outside, the largest face distance inside) to the box ``[lo, hi]`` (world xyz)."""
    axes = [origin_xyz[k] + voxel * np.arange(shape_zyx[2 - k]) for k in range(3)]
    parts = [np.maximum(lo[k] - axes[k], axes[k] - hi[k]) for k in range(3)]  # per axis, < 0 inside
    dx, dy, dz = (p.reshape([-1 if j == 2 - k else 1 for j in range(3)]) for k, p in enumerate(parts))
    outside = np.sqrt(np.maximum(dx, 0) ** 2 + np.maximum(dy, 0) ** 2 + np.maximum(dz, 0) ** 2)
    inside = np.minimum(np.maximum(np.maximum(dx, dy), dz), 0.0)
    return (outside + inside).astype(np.float32)


def moss_body(den: Dendrite, radius: Width, image: np.ndarray, *, voxel: float, sigma: float | None = None):
    """Moss strands (the dendrite's smooth centre lines) standing on a ground slab, one closed body.

    Each strand takes the colour of ``image`` (stretched over the lattice's ``(y, x)`` extent) at its
    root, darker toward the ground (light reaches the tips); the ground shows the same picture, darker
    and browner. The slab's top is the plane the roots sit on (lattice row 0), 1.5 nodes thick.

    Returns:
        ``(mesh, lines)``: the mesh carries vertex colours.
    """
    lines = skeleton(den, radius, sigma=sigma, min_radius=voxel)
    s = float(den.spacing)
    org = np.asarray(den.origin, np.float64)[::-1]  # world (x, y, z) of node (0, 0, 0)
    d, h, w = den.shape
    extent_y, extent_x = (h - 1) * s, (w - 1) * s
    roots = roots_of(den)
    rp = den.positions[roots[lines.row]][:, ::-1]  # (x, y, z) of each sample's root
    base = _at(image, rp[:, 1] - org[1], rp[:, 0] - org[0], extent_y, extent_x)
    height = np.clip((lines.points[:, 2] - org[2]) / max(float(np.ptp(lines.points[:, 2])), 1e-12), 0.0, 1.0)
    colors = base * (0.55 + 0.45 * height)[:, None]
    top = org[2] + 0.25 * s
    g_lo = np.array([org[0] - 0.5 * s, org[1] - 0.5 * s, org[2] - 1.25 * s])
    g_hi = np.array([org[0] + extent_x + 0.5 * s, org[1] + extent_y + 0.5 * s, top])
    reach = float(np.maximum(lines.radius, voxel).max()) + 3.0 * voxel
    lo = np.minimum(lines.points.min(axis=0) - reach, g_lo - 3.0 * voxel)
    hi = np.maximum(lines.points.max(axis=0) + reach, g_hi + 3.0 * voxel)
    field, label, origin = _geo._tube_field(_geo.meshable(lines, voxel), voxel, lo, hi, _checks.device(None))
    ground = _box_field(field.shape, origin, voxel, g_lo, g_hi)
    label = np.where(ground < field, GROUND, label)
    field = np.minimum(field, ground)
    segs = lines.segments
    seg_colors = colors[segs[:, 0]]
    soil = np.array([0.30, 0.22, 0.13])

    def paint(v):
        lab = label[_geo._node_of(v, origin, voxel, field.shape)]
        out = seg_colors[np.maximum(lab, 0)]
        on = lab == GROUND
        out[on] = 0.7 * 0.75 * _at(image, v[on, 1] - org[1], v[on, 0] - org[0], extent_y, extent_x) + 0.3 * soil
        return out

    return _geo._closed_body(field, origin, voxel, paint), lines


# --------------------------------------------------------------------------- lichen


LICHEN_KINDS = ((0.88, 0.58, 0.16), (0.62, 0.7, 0.5))
"""Colours of the two kinds of lichen of the clusters: orange near the dendrite, grey-green around it."""


def check_bands(bands, density) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Band edges (increasing, > 0, in nodes), at most one per kind of lichen, and one density in (0, 1]
    per band."""
    def numbers(name, values, what):
        if isinstance(values, (str, bytes)) or not isinstance(values, (list, tuple, np.ndarray)) or len(values) == 0:
            raise ValueError(f"Expected '{name}' as a non-empty list of {what}, but got {values!r}")
        return [_checks.positive(name, v) for v in values]

    edges = numbers("bands", bands, "increasing distances")
    if any(b <= a for a, b in zip(edges, edges[1:])):
        raise ValueError(f"Expected 'bands' increasing, but got {bands!r}")
    if len(edges) > len(LICHEN_KINDS):
        raise ValueError(f"Expected at most {len(LICHEN_KINDS)} 'bands' (one per kind of lichen), but got {bands!r}")
    dens = numbers("density", density, "shares in (0, 1]")
    if len(dens) != len(edges) or any(v > 1 for v in dens):
        raise ValueError(f"Expected one 'density' in (0, 1] per band ({len(edges)}), but got {density!r}")
    return tuple(edges), tuple(dens)


def cost_bands(lattice: Lattice, sources: np.ndarray, edges, per_node: float, density, seed):
    """The thesis' lichen cluster (section 5.4): costs from ``sources`` (a dendrite's nodes) over
    ``lattice``, and per node the kind of lichen there: ``k`` (1, 2, ...) where the cost lies in band
    ``k - 1``, ``[edges[k - 2], edges[k - 1])`` nodes of ``per_node`` path cost each (the first band
    from 0), and a draw keeps the node with probability ``density[k - 1]``; 0 elsewhere.

    Returns:
        ``(kind, cost)``: ``(*shape)`` int8 kinds and float32 costs (inf beyond the last band's reach).
    """
    lows = (0.0,) + tuple(edges[:-1])
    cf = shortest_paths(lattice, sources, limit=edges[-1] * per_node)
    draw = _checks.rng(seed).random(lattice.shape)
    kind = np.zeros(lattice.shape, np.int8)
    for k, (low, high, p) in enumerate(zip(lows, edges, density), start=1):
        kind[(cf.dist >= low * per_node) & (cf.dist < high * per_node) & (draw < p) & (kind == 0)] = k
    return kind, cf.dist


def crust_picture(kind: np.ndarray, colors, rock, seed) -> np.ndarray:
    """The 2D cluster: every chosen node a crusty particle, blurred into patches and shaded as a relief
    lit from the upper left over a speckled rock. ``kind``: ``(H, W)`` from :func:`cost_bands`;
    ``colors``: one RGB per kind."""
    from scipy.ndimage import gaussian_filter

    rng = _checks.rng(seed)
    h, w = kind.shape
    cols = np.asarray(colors, np.float64)
    dens = np.stack([gaussian_filter((kind == k + 1).astype(np.float64), 0.9) for k in range(len(cols))])
    cover = np.clip(dens.sum(axis=0) * 1.8, 0.0, 1.0)
    mix = np.einsum("khw,kc->hwc", dens, cols) / np.maximum(dens.sum(axis=0), 1e-9)[..., None]
    grain = 1.0 + 0.08 * gaussian_filter(rng.standard_normal((h, w)), 0.7)
    stone = np.asarray(rock, np.float64)[None, None, :] * grain[..., None]
    relief = gaussian_filter(dens.sum(axis=0), 0.6) * 2.5 + 0.15 * gaussian_filter(rng.standard_normal((h, w)), 1.2)
    gy, gx = np.gradient(relief)
    n = np.stack([-gx, -gy, np.full_like(gx, 0.35)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    light = np.array([-0.6, -0.6, 0.55])
    shade = 0.55 + 0.6 * np.clip(n @ (light / np.linalg.norm(light)), 0.0, 1.0)
    img = (stone * (1.0 - cover[..., None]) + mix * cover[..., None]) * shade[..., None]
    return np.clip(img, 0.0, 1.0).astype(np.float32)


def crust_body(rock_field: np.ndarray, lines: Skeleton, crust: np.ndarray, crust_kind: np.ndarray, colors,
               rock_color, *, grain: float, thickness, voxel: float, seed: int):
    """A rock (the zero level of ``rock_field``, a signed field on the lattice's nodes), the lichen's ropes
    (``lines``) and its crust, meshed as one closed body.

    The crust is a layer over the rock where balls of radius ``grain`` around the ``crust`` nodes
    (``(M, 3)`` lattice ``(z, y, x)``, of kinds ``crust_kind``) reach: ``thickness[kind - 1]`` thick at
    its rim and up to half a node thicker inside a patch, so that patches rise as cushions with
    crusty bumps where their balls crowd. Vertices take the rock's colour, or their nearest ball's
    kind colour (``colors[kind - 1]``, slightly varied per ball); the ropes the first kind's, darker.

    Returns:
        ``(mesh, balls)``: ``balls`` is the crust as a :class:`Skeleton` of lone samples.
    """
    from scipy.ndimage import affine_transform

    rng = _checks.rng(seed)
    pts = crust[:, ::-1].astype(np.float64)
    balls = Skeleton(points=pts, radius=np.full(len(pts), float(grain)),
                     offsets=np.arange(len(pts) + 1, dtype=np.int64),
                     row=np.zeros(len(pts), np.int64), parent_branch=np.full(len(pts), -1, np.int64))
    inside = np.argwhere(rock_field < 0.5)
    reach = float(max(lines.radius.max(), grain)) + 3.0 * voxel
    lo = np.minimum(np.minimum(lines.points.min(axis=0), pts.min(axis=0) if len(pts) else np.inf),
                    inside.min(axis=0)[::-1] - 1.0) - reach
    hi = np.maximum(np.maximum(lines.points.max(axis=0), pts.max(axis=0) if len(pts) else -np.inf),
                    inside.max(axis=0)[::-1] + 1.0) + reach
    device = _checks.device(None)
    ropes, rope_seg, origin = _geo._tube_field(_geo.meshable(lines, voxel), voxel, lo, hi, device)
    # the rock's field (on lattice nodes, spacing 1) read trilinearly at the grid's nodes
    rock = affine_transform(rock_field.astype(np.float32), [voxel] * 3, offset=origin[::-1], output_shape=ropes.shape,
                            order=1, mode="nearest")
    field = np.minimum(ropes, rock)
    label = np.where(rock < ropes, GROUND, rope_seg)
    seg_colors = np.full((len(lines.segments), 3), 0.75) * np.asarray(colors, np.float64)[0]
    if len(pts):
        near, ball, _ = _geo._tube_field(balls, voxel, lo, hi, device)
        thick = np.asarray(thickness, np.float32)[crust_kind[np.maximum(ball, 0)] - 1]
        layer = np.maximum(rock - thick - 0.5 * np.clip(-near, 0.0, 1.0), near)
        label = np.where(layer < field, len(seg_colors) + ball, label)
        field = np.minimum(field, layer)
        jitter = 1.0 + 0.14 * (rng.random(len(pts)) - 0.5)
        seg_colors = np.concatenate([seg_colors, np.asarray(colors, np.float64)[crust_kind - 1] * jitter[:, None]])

    def paint(v):
        lab = label[_geo._node_of(v, origin, voxel, field.shape)]
        out = seg_colors[np.maximum(lab, 0)]
        out[lab == GROUND] = rock_color
        return out

    return _geo._closed_body(field, origin, voxel, paint), balls
