"""Rendering and meshes: wdendrite against the same pictures and meshes made with SciPy, scikit-image and trimesh.

Workloads (the papers' Table 2 sizes):

- ``lightning 2048^2``: brightness ``exp(-(d/T)^2)`` of the two-graph lightning
  (main stroke with forks, plus minor forks) with per-node tapered widths,
  composited. Euclidean: ``scipy.ndimage.distance_transform_edt`` (with
  indices, for the nearest node's T) + NumPy exp. Path (octile, the papers'
  path cost on a unit lattice): ``scipy.sparse.csgraph.dijkstra`` from the
  dendrite with the same limit.
- ``glow 2048^2``: three box blurs per axis against ``scipy.ndimage.uniform_filter``.
- ``rock 128^3``: the signed distance to a segmented region's boundary and
  marching cubes (scikit-image on the CPU for both; the field from SciPy's
  EDT for the baseline).
- ``rock + lichen 128^3``: the rock, plus the lichen's isosurface (tapered
  spheres blended by the nearest-node distance field).
- ``lichen tubes``: capped tubes along every edge, against a loop of
  ``trimesh.creation.cylinder`` + ``trimesh.util.concatenate``.
- ``elm body 80^3``: the elm preset's mesh (smooth centre lines, the tube field
  by a Warp kernel, marching cubes, one closed body) against SciPy's EDT of the
  marked samples and scikit-image's marching cubes (``bench_dendrites.scipy_body``);
  beside it, the parts of our time and the time of scikit-image's
  ``marching_cubes`` alone on our field (every cube, as a user calls it) and of
  trimesh's ``matrix_to_marching_cubes`` on its inside voxels.

Setup (growing the dendrites, segmenting the rock) is not timed. Each case
runs once to compile, then ``--repeat`` times (default 5), ours and the
baseline in turns; the median and the range of each are printed, and the ratio
of the medians. Outputs are compared: images by their largest difference,
meshes by vertex count and volume.

Run: ``python benchmarks/bench_render.py`` (``--quick`` for a smoke test, as the other benchmarks).
"""

from __future__ import annotations

import argparse
import logging
import time

import numpy as np
import warp as wp

from _measure import cpu_model, interleaved, now, shown, spread

wp.config.quiet = True
wp.config.log_level = logging.WARNING  # no start-up banner


def pair(ours, base, repeat: int):
    """Seconds of ``repeat`` runs of each, in turns after one untimed run each, and their last results."""
    runs = interleaved({"ours": ours, "base": base}, repeat, warm=True)
    return runs["ours"][0], runs["ours"][1], runs["base"][0], runs["base"][1]


# --------------------------------------------------------------------------- 2D


def lightning_setup(size: int, seed: int):
    """The preset's two layers, each as its own dendrite with the preset's tapered widths (pixels)."""
    from wdendrite import presets
    from wdendrite.dendrite import Dendrite

    res = presets.lightning((size, size), seed=seed)
    den, graph, widths = res.dendrite, res.parts["graph"], res.parts["widths"]
    layers = []
    for rows in (np.flatnonzero(graph <= 1), np.flatnonzero(graph == 2)):
        index = np.full(len(den), -1)
        index[rows] = np.arange(len(rows))
        parent = np.where(den.parent[rows] >= 0, index[np.maximum(den.parent[rows], 0)], -1)
        layers.append((Dendrite.from_arrays(den.shape, den.nodes[rows], parent, cost=den.cost[rows]), widths[rows]))
    return layers, presets.LightningParams().minor_gain


def ours_brightness(layers, gain, metric):
    from wdendrite import render

    vs = [render.brightness(den, w, metric=metric, reach=3.0) for den, w in layers]
    return render.composite(vs, gains=[1.0, gain])


def _rowmap(den):
    rows = np.full(den.shape, -1, np.int64)
    rows[tuple(den.nodes.T)] = np.arange(len(den))
    return rows


def scipy_brightness_edt(layers, gain):
    from scipy import ndimage

    out = []
    for den, w in layers:
        free = np.ones(den.shape, bool)
        free[tuple(den.nodes.T)] = False
        d, idx = ndimage.distance_transform_edt(free, return_indices=True)
        t = w[_rowmap(den)[idx[0], idx[1]]]
        out.append(np.where(d <= 3.0 * t, np.exp(-((d / t) ** 2)), 0.0).astype(np.float32))
    return np.maximum(out[0], np.clip(out[1] * gain, 0, 1))


def scipy_brightness_dijkstra(layers, gain, graphs):
    from scipy.sparse.csgraph import dijkstra

    out = []
    for (den, w), g in zip(layers, graphs):
        src = np.ravel_multi_index(tuple(den.nodes.T), den.shape)
        d, _, near = dijkstra(g, indices=src, min_only=True, limit=3.0 * float(w.max()), return_predecessors=True)
        d = d.reshape(den.shape)
        rows = _rowmap(den).ravel()
        t = np.where(near >= 0, w[rows[np.maximum(near, 0)]], 1.0).reshape(den.shape)
        out.append(np.where(d <= 3.0 * t, np.exp(-((d / t) ** 2)), 0.0).astype(np.float32))
    return np.maximum(out[0], np.clip(out[1] * gain, 0, 1))


def image_diff(a, b) -> str:
    diff = np.abs(a.astype(np.float64) - b)
    return f"max |diff| {diff.max():.1e}, {100 * (diff > 1e-3).mean():.3f}% px > 1e-3"


# --------------------------------------------------------------------------- 3D


def rock_setup(size: int, seed: int):
    from wdendrite import presets, render

    res = presets.lichen_on_rock((size,) * 3, seed=seed)
    lichen = res.dendrite
    r = render.node_widths(lichen, render.Taper(1.4, 0.7, along="path"))
    return res.parts["costfield"].label.copy(), lichen, r


def ours_rock(labels):
    from wdendrite import geometry

    return geometry.region_mesh(labels, 0)


def scipy_rock(labels):
    from scipy import ndimage
    from skimage.measure import marching_cubes

    inside = labels == 0
    cross = np.zeros(inside.shape, bool)
    p = np.pad(inside, 1, constant_values=False)
    for axis in range(3):
        for step in (-1, 1):
            cross |= np.roll(p, step, axis=axis)[1:-1, 1:-1, 1:-1] != inside
    seeds = (inside & ~ndimage.binary_erosion(inside, border_value=0)) | cross
    d = np.minimum(ndimage.distance_transform_edt(~seeds), 2.0) + 0.5
    field = np.pad(np.where(inside, -d, d).astype(np.float32), 1, constant_values=1.5)
    v, f, _, _ = marching_cubes(field, 0.0)
    return v - 1.0, f


def ours_lichen_iso(lichen, r):
    from wdendrite import geometry

    return geometry.isosurface(lichen, r)


def scipy_lichen_iso(lichen, r):
    from scipy import ndimage
    from skimage.measure import marching_cubes

    free = np.ones(lichen.shape, bool)
    free[tuple(lichen.nodes.T)] = False
    d, idx = ndimage.distance_transform_edt(free, return_indices=True)
    field = d - r[_rowmap(lichen)[idx[0], idx[1], idx[2]]]
    field = np.pad(field.astype(np.float32), 1, constant_values=float(r.max()) + 2.0 - 0.01)
    v, f, _, _ = marching_cubes(field, 0.0)
    return v - 1.0, f


def ours_tubes(lichen, r):
    from wdendrite import geometry

    return geometry.tubes(lichen, r, sides=8, joints=False)


def trimesh_tubes(lichen, r):
    import trimesh

    pos = lichen.positions[:, ::-1]
    parts = []
    for i in np.flatnonzero(lichen.parent >= 0):
        a, b = pos[i], pos[lichen.parent[i]]
        parts.append(trimesh.creation.cylinder(radius=float(r[i]), segment=np.stack([a, b]), sections=8))
    return trimesh.util.concatenate(parts)


def elm_setup(size: int, seed: int):
    from wdendrite import presets, render, skeleton

    res = presets.elm_tree((size,) * 3, seed=seed)
    scale = size / 80.0
    voxel = 0.5 * scale
    lines = skeleton.skeleton(res.dendrite, render.Taper(2.4 * scale, 0.6 * scale, beta=0.3, along="path"),
                              side=render.Taper(1.5 * scale, 0.35 * scale, beta=0.2, along="branch"),
                              min_radius=voxel)
    return lines, voxel


def ours_body(lines, voxel):
    from wdendrite import geometry

    return geometry.skeleton_mesh(lines, voxel=voxel)


def body_parts(lines, voxel, repeat):
    """Seconds of our tube field alone, of scikit-image's marching cubes on it (every cube) and of
    trimesh's marching cubes of its inside voxels."""
    import trimesh
    from skimage.measure import marching_cubes

    from wdendrite import geometry

    grown = geometry.meshable(lines, voxel)
    reach = float(grown.radius.max()) + 3.0 * voxel
    lo, hi = lines.points.min(axis=0) - reach, lines.points.max(axis=0) + reach
    field = geometry._tube_field(grown, voxel, lo, hi, "cpu")[0]
    runs = interleaved({"field": lambda: geometry._tube_field(grown, voxel, lo, hi, "cpu"),
                        "mc": lambda: marching_cubes(field, 0.0),
                        "tri": lambda: trimesh.voxel.ops.matrix_to_marching_cubes(field < 0, pitch=voxel)},
                       repeat, warm=True)
    return runs["field"][0], runs["mc"][0], runs["tri"][0], field.shape


def mesh_volume(v, f) -> float:
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return float(abs(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6.0)


# --------------------------------------------------------------------------- main


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size2d", type=int, default=2048)
    ap.add_argument("--size3d", type=int, default=128)
    ap.add_argument("--repeat", type=int, default=5, help="runs of each side per case, in turns (default 5)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", "--small", dest="small", action="store_true",
                    help="512^2 and 48^3, a smoke test (--small: the old name)")
    args = ap.parse_args()
    if args.repeat < 1:
        ap.error(f"--repeat must be at least 1, got {args.repeat}")
    if args.small:
        args.size2d, args.size3d = 512, 48
    wp.init()
    rows = []

    t0 = time.perf_counter()
    layers, gain = lightning_setup(args.size2d, args.seed)
    setup_2d = time.perf_counter() - t0
    n2 = f"{args.size2d}^2"
    nodes = sum(len(d) for d, _ in layers)
    t_ours, a, t_base, b = pair(lambda: ours_brightness(layers, gain, "euclidean"),
                                lambda: scipy_brightness_edt(layers, gain), args.repeat)
    rows.append((f"lightning {n2}, Euclidean ({nodes} nodes)", "scipy EDT + NumPy exp", t_ours, t_base,
                 image_diff(a, b)))
    from wdendrite import Lattice

    graphs = [Lattice(layers[0][0].shape, 8).to_csgraph()] * 2
    t_ours, a, t_base, b = pair(lambda: ours_brightness(layers, gain, "path"),
                                lambda: scipy_brightness_dijkstra(layers, gain, graphs), args.repeat)
    rows.append((f"lightning {n2}, path cost (octile)", "scipy dijkstra (limit) + NumPy exp", t_ours, t_base,
                 image_diff(a, b)))
    from scipy import ndimage

    from wdendrite import render

    value = a
    half = max(1, int(round(0.5 * (np.sqrt(1.0 + 12.0 * (14.0 * args.size2d / 600) ** 2 / 3) - 1.0))))
    radius = 14.0 * args.size2d / 600

    def scipy_glow():
        g = value
        for _ in range(3):
            g = ndimage.uniform_filter(g, size=2 * half + 1, mode="constant", cval=0.0)
        return g

    t_ours, a, t_base, b = pair(lambda: render.glow(value, radius=radius), scipy_glow, args.repeat)
    rows.append((f"glow {n2} (radius {radius:.0f})", "scipy uniform_filter x3", t_ours, t_base, image_diff(a, b)))

    t0 = time.perf_counter()
    labels, lichen, r = rock_setup(args.size3d, args.seed)
    setup_3d = time.perf_counter() - t0
    n3 = f"{args.size3d}^3"
    t_ours, m, t_base, (v, f) = pair(lambda: ours_rock(labels), lambda: scipy_rock(labels), args.repeat)
    rows.append((f"rock {n3}: signed field + marching cubes", "scipy EDT + skimage MC", t_ours, t_base,
                 f"verts {len(m.vertices)} vs {len(v)}, volume {m.volume:.0f} vs {mesh_volume(v, f):.0f}"))
    t_ours, mi, t_base, (_, (vl, fl)) = pair(lambda: (ours_rock(labels), ours_lichen_iso(lichen, r)),
                                             lambda: (scipy_rock(labels), scipy_lichen_iso(lichen, r)), args.repeat)
    rows.append((f"rock + lichen {n3} ({len(lichen)} lichen nodes)", "scipy EDT + skimage MC", t_ours, t_base,
                 f"lichen volume {mi[1].volume:.0f} vs {mesh_volume(vl, fl):.0f}"))
    t_ours, mt, t_base, bt = pair(lambda: ours_tubes(lichen, r), lambda: trimesh_tubes(lichen, r), args.repeat)
    rows.append((f"lichen tubes ({len(lichen) - len(lichen.roots)} edges)", "trimesh cylinder per edge",
                 t_ours, t_base, f"faces {len(mt.faces)} vs {len(bt.faces)}"))

    from bench_dendrites import scipy_body

    size_elm = 80 if args.size3d >= 80 else 40
    lines, voxel = elm_setup(size_elm, args.seed)
    t_ours, mb, t_base, (vb, fb) = pair(lambda: ours_body(lines, voxel), lambda: scipy_body(lines, voxel), args.repeat)
    rows.append((f"elm body {size_elm}^3 ({len(lines)} samples, voxel {voxel:g})", "scipy EDT + skimage MC", t_ours,
                 t_base, f"faces {len(mb.faces)} vs {len(fb)}, volume {mb.volume:.0f} vs {mesh_volume(vb, fb):.0f}, "
                         f"closed {mb.is_watertight}, bodies {len(mb.split(only_watertight=False))}"))
    t_field, t_mc, t_tri, grid = body_parts(lines, voxel, args.repeat)

    print(f"setup, untimed above (first run, kernel compiles included): presets.lightning({n2}) {setup_2d:.2f} s; "
          f"presets.lichen_on_rock({n3}) {setup_3d:.2f} s (rock segmentation, lichen growth, meshes, preview)")
    print(f"# bench_render  {now()}  {cpu_model()}  seconds: median (range) of {args.repeat} runs per side, in turns")
    print("| workload | baseline | ours s | baseline s | ratio | check |")
    print("| --- | --- | ---: | ---: | ---: | --- |")
    for name, base, to, tb, check in rows:
        print(f"| {name} | {base} | {shown(to)} | {shown(tb)} | {spread(tb)[0] / spread(to)[0]:.1f}x | {check} |")
    print(f"\nelm body {size_elm}^3, grid {grid}: ours {shown(t_ours)} s in all, of which the tube field {shown(t_field)} s; "
          f"on the same field scikit-image's marching_cubes alone (every cube) {shown(t_mc)} s, trimesh's "
          f"matrix_to_marching_cubes of its inside voxels {shown(t_tri)} s")


if __name__ == "__main__":
    main()
