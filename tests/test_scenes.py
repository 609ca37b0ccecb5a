"""The 3D presets' bodies and the lichen clusters: smooth centre lines, one closed body each, cost bands
against SciPy, moss coloured from its picture, determinism and bad input."""

import numpy as np
import pytest
from scipy.sparse.csgraph import dijkstra

import wdendrite as wd
from wdendrite import cli, presets
from wdendrite.geometry import surface_nodes
from wdendrite.skeleton import turning_angles


def _one_body(mesh):
    return mesh.is_watertight and len(mesh.split(only_watertight=False)) == 1 and mesh.volume > 0


# the issue's goal, at the presets' own sizes: centre lines that turn less than 25 degrees between
# samples one lattice node apart (the lattice paths turn by 45-90 degrees at most nodes), and one body
@pytest.mark.parametrize("name, seed", [("elm_tree", 0), ("elm_tree", 1), ("staghorn_coral", 0),
                                        ("staghorn_coral", 1), ("moss", 0)])
def test_default_presets_have_smooth_centre_lines_and_one_closed_body(name, seed):
    res = getattr(presets, name)(seed=seed)
    lines = res.parts["skeleton"]
    angles = turning_angles(lines, 1.0)
    assert len(angles) > 500 and np.percentile(angles, 95) < 25.0
    # the dendrite the lines were drawn from turns sharply: the smoothing made the difference
    den = res.dendrite if name != "staghorn_coral" else res.parts["coarse"]
    raw = wd.skeleton.skeleton(den, 1.0, sigma=0.0, samples=1)
    assert np.percentile(turning_angles(raw, 1.0), 95) >= 45.0
    assert _one_body(res.mesh)


SMALL = {
    "elm_tree": lambda s: presets.elm_tree((24, 24, 24), endpoints=5, seed=s),
    "staghorn_coral": lambda s: presets.staghorn_coral((16, 16, 16), endpoints=4, refine_n=3, seed=s),
    "lichen_on_rock": lambda s: presets.lichen_on_rock((32, 32, 32), count=3, seed=s),
    "moss": lambda s: presets.moss((12, 24, 24), endpoints=20, seed=s),
    "rock": lambda s: presets.rock((24, 24, 24), seed=s),
}


@pytest.mark.parametrize("seed", [0, 2])
@pytest.mark.parametrize("name", sorted(SMALL))
def test_every_3d_preset_is_one_closed_body_at_small_sizes_too(name, seed):
    assert _one_body(SMALL[name](seed).mesh)


def test_tropism_objects_are_each_one_closed_body():
    res = presets.tropism_objects((20, 20, 20), endpoints=6, seed=3)
    assert len(res.parts["meshes"]) == 3 and all(_one_body(m) for m in res.parts["meshes"].values())


def test_coral_is_refined_with_the_thesis_sublattice_by_default():
    res = presets.staghorn_coral((20, 20, 20), endpoints=5, seed=0)
    assert res.dendrite.spacing == pytest.approx(1 / 7) and len(res.dendrite) > 3 * len(res.parts["coarse"])


def _costs_from(lat, sources):
    """SciPy's least path costs from the source nodes over the lattice (the reference)."""
    flat = np.ravel_multi_index(tuple(np.asarray(sources).T), lat.shape)
    return dijkstra(lat.to_csgraph(), directed=True, indices=flat, min_only=True).reshape(lat.shape)


def _per_node(lat, centre, radius):
    return presets._cost_per_node(lat, centre, radius)


def test_lichen_cluster_kinds_lie_in_their_cost_bands():
    res = presets.lichen_cluster((96, 96), count=4, bands=(2.0, 5.0), density=(0.9, 0.5), seed=2)
    kind, lat, den = res.parts["kind"], res.parts["lattice"], res.dendrite
    cost = _costs_from(lat, den.nodes)
    np.testing.assert_allclose(res.parts["cost"][np.isfinite(res.parts["cost"])],
                               cost[np.isfinite(res.parts["cost"])], rtol=1e-5)
    per = _per_node(lat, (48, 48), 48)
    inner, outer = cost < 2.0 * per, (cost >= 2.0 * per) & (cost < 5.0 * per)
    assert np.all(inner[kind == 1]) and np.all(outer[kind == 2]) and not kind[~(inner | outer)].any()
    # each band keeps about its density of nodes (binomial: within five standard deviations)
    for k, band, p in ((1, inner, 0.9), (2, outer, 0.5)):
        n = band.sum()
        assert abs((kind[band] == k).sum() - p * n) < 5 * np.sqrt(n * p * (1 - p))
    assert (kind == 1).sum() > 100 and (kind == 2).sum() > 100
    # orange near the dendrite, grey-green around it, stone elsewhere
    img = res.image
    green = img[..., 1] - img[..., 0]
    assert img[kind == 1][:, 0].mean() > img[kind == 1][:, 2].mean() + 0.2
    assert green[kind == 2].mean() > green[kind == 1].mean() + 0.1


def test_lichen_crust_lies_on_the_rock_surface_by_cost_along_it():
    res = presets.lichen_on_rock((32, 32, 32), count=3, bands=(1.5, 4.0), seed=0)
    inside = res.parts["costfield"].label == 0
    surf = np.zeros_like(inside)
    surf[tuple(surface_nodes(inside).T)] = True
    kind = res.parts["kind"]
    assert kind.any() and surf[kind > 0].all()
    # SciPy's costs over the surface nodes alone, from the dendrite's nodes
    weights = wd.weights.Uniform(r=10, seed=1)
    skin = wd.Lattice(inside.shape, 26, weights=weights, mask=surf)
    cost = _costs_from(skin, res.dendrite.nodes)
    per = _per_node(wd.Lattice((17, 17, 17), 26, weights=weights), (8, 8, 8), 8)
    assert np.all(cost[kind == 1] < 1.5 * per) and np.all((cost[kind == 2] >= 1.5 * per) & (cost[kind == 2] < 4 * per))
    # the crust's colours are on the mesh: orange and grey-green vertices beside the rock's grey
    rgb = res.mesh.visual.vertex_colors[:, :3].astype(float) / 255
    orange = (rgb[:, 0] > 0.6) & (rgb[:, 2] < 0.3)
    assert orange.sum() > 100 and (np.abs(rgb - presets._ROCK).max(axis=1) < 1e-2).sum() > 1000


def test_moss_takes_its_colours_from_the_picture():
    red_blue = np.zeros((8, 8, 3))
    red_blue[:, :4, 0] = 1.0  # left half red (x < W / 2), right half blue
    red_blue[:, 4:, 2] = 1.0
    res = presets.moss((12, 24, 24), endpoints=30, image=red_blue, seed=1)
    v, rgb = res.mesh.vertices, res.mesh.visual.vertex_colors[:, :3].astype(float)
    strands = v[:, 2] > 1.0  # above the ground slab
    left, right = strands & (v[:, 0] < 9), strands & (v[:, 0] > 14)
    assert left.sum() > 50 and right.sum() > 50
    # (strands wander, but rarely 2.5 nodes or more across the middle)
    assert np.mean(rgb[left, 0] > rgb[left, 2]) > 0.9 and np.mean(rgb[right, 2] > rgb[right, 0]) > 0.9
    ground = v[:, 2] < -1.0  # the slab's underside shows the picture too
    assert np.all(rgb[ground & (v[:, 0] < 5), 0] > rgb[ground & (v[:, 0] < 5), 2])
    # 8-bit pictures and grey ones are taken as well
    grey = presets.moss((12, 24, 24), endpoints=30, image=np.full((4, 4), 128, np.uint8), seed=1)
    g = grey.mesh.visual.vertex_colors[:, :3].astype(int)[grey.mesh.vertices[:, 2] > 1.0]
    assert len(g) and np.all(g[:, 0] == g[:, 1]) and _one_body(grey.mesh)


@pytest.mark.parametrize("call", [
    lambda: presets.lichen_cluster((64, 64), count=3, seed=5),
    lambda: presets.lichen_on_rock((24, 24, 24), count=2, seed=5),
    lambda: presets.moss((10, 16, 16), endpoints=10, image=np.random.default_rng(0).random((5, 7, 3)), seed=5),
])
def test_the_new_presets_are_reproducible(call):
    a, b = call(), call()
    np.testing.assert_array_equal(a.image, b.image)
    np.testing.assert_array_equal(a.dendrite.nodes, b.dendrite.nodes)
    if a.mesh is not None:
        np.testing.assert_array_equal(a.mesh.vertices, b.mesh.vertices)
        np.testing.assert_array_equal(a.mesh.visual.vertex_colors, b.mesh.visual.vertex_colors)


@pytest.mark.parametrize("func, kw, exc, match", [
    (presets.lichen_cluster, dict(shape=(32, 32), bands=(4.0, 2.0)), ValueError, "'bands' increasing"),
    (presets.lichen_cluster, dict(shape=(32, 32), bands=(2.0, 4.0, 6.0), density=(1, 1, 1)), ValueError, "at most 2"),
    (presets.lichen_cluster, dict(shape=(32, 32), bands=()), ValueError, "'bands' as a non-empty list"),
    (presets.lichen_cluster, dict(shape=(32, 32), bands=(-1.0, 2.0)), ValueError, "'bands'"),
    (presets.lichen_cluster, dict(shape=(32, 32), density=(0.5,)), ValueError, "one 'density'"),
    (presets.lichen_cluster, dict(shape=(32, 32), density=(0.5, 1.5)), ValueError, "'density' in \\(0, 1\\]"),
    (presets.lichen_cluster, dict(shape=(32, 32, 32)), ValueError, "2D"),
    (presets.lichen_cluster, dict(shape=(32, 32), count=0), ValueError, "'count'"),
    (presets.lichen_on_rock, dict(shape=(16, 16, 16), bands=(3.0, 1.0)), ValueError, "'bands' increasing"),
    (presets.lichen_on_rock, dict(shape=(16, 16, 16), density=(0.0, 0.5)), ValueError, "'density'"),
    (presets.lichen_on_rock, dict(shape=(16, 16, 16), on_rock="yes"), TypeError, "'on_rock'"),
    (presets.moss, dict(shape=(16, 16, 16), image=np.zeros((4, 4, 2))), ValueError, "'image'"),
    (presets.moss, dict(shape=(16, 16, 16), image=np.full((4, 4, 3), 1.5)), ValueError, "'image'"),
    (presets.moss, dict(shape=(16, 16, 16), image=np.full((4, 4, 3), np.nan)), ValueError, "'image'"),
    (presets.moss, dict(shape=(16, 16, 16), image=np.full((4, 4, 3), 300)), ValueError, "'image'"),
    (presets.moss, dict(shape=(16, 16, 16), image=np.zeros((4, 4, 3), bool)), TypeError, "'image'"),
    (presets.elm_tree, dict(shape=(16, 16, 16), geometry="smoothe"), ValueError, "'geometry'"),
])
def test_bad_input_is_refused_before_any_kernel(func, kw, exc, match, launches):
    with pytest.raises(exc, match=match):
        func(**kw)
    assert launches == []


@pytest.mark.parametrize("args, words", [
    (["lichen-cluster", "--size", "32", "--bands", "4,2"], ["'bands' increasing", "(--bands)"]),
    (["lichen-cluster", "--size", "32", "--density", "0.5,2"], ["'density'", "(--density)"]),
    (["lichen", "--size", "16", "--bands", "1,1"], ["'bands' increasing"]),
    (["tree", "--size", "16", "--geometry", "cones"], ["--geometry expects one of smooth, tubes, spheres, isosurface"]),
])
def test_the_command_refuses_bad_values_and_writes_nothing(args, words, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main([*args, "-o", "out.png", "-o", "out.glb" if "lichen-cluster" not in args else "out.npy",
                     "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    assert not list(tmp_path.iterdir())


def test_the_command_writes_the_lichen_cluster_and_the_one_body_meshes(tmp_path, monkeypatch):
    import trimesh

    monkeypatch.chdir(tmp_path)
    assert cli.main(["lichen-cluster", "--size", "48", "--count", "3", "-o", "c.png", "--quiet"]) == 0
    assert cli.main(["moss", "--size", "24", "--endpoints", "20", "-o", "m.stl", "--quiet"]) == 0
    stl = trimesh.load(tmp_path / "m.stl")  # (STL welds coincident vertices: still one closed body)
    assert (tmp_path / "c.png").exists() and _one_body(stl)
