"""Meshes: closed tubes/spheres with the asked radii, isosurfaces on the iso level, rock regions, previews."""

import numpy as np
import pytest
from scipy import ndimage

import wdendrite as wd
from wdendrite.geometry import (
    field_mesh,
    isosurface,
    preview,
    region_mesh,
    signed_region_field,
    spheres,
    surface_nodes,
    tubes,
)
from wdendrite.render import Taper, node_widths

LAT = wd.Lattice((20, 20, 20), 26, weights=wd.weights.Uniform(r=10, seed=4))
DEN = wd.trace(wd.shortest_paths(LAT, [[1, 10, 10]]), [[18, 3, 3], [18, 16, 15], [15, 10, 3], [12, 17, 8]])


def _empty3():
    return empty_dendrite((4, 4, 4))

def empty_dendrite(shape):
    """A dendrite with no nodes (what a failed or filtered trace could leave)."""
    from wdendrite.dendrite import Dendrite

    nd = len(shape)
    return Dendrite(shape=shape, nodes=np.zeros((0, nd), np.int64), parent=np.zeros(0, np.int64),
                    cost=np.zeros(0, np.float32), label=np.zeros(0, np.int32), generation=np.zeros(0, np.int32),
                    endpoints=np.zeros(0, np.int64), _padded=np.zeros(0, np.int64))



def test_spheres_are_closed_with_the_asked_radii():
    r = node_widths(DEN, Taper(2.0, 0.5))
    mesh = spheres(DEN, Taper(2.0, 0.5), subdivisions=2)
    assert mesh.is_watertight and mesh.volume > 0
    per = len(mesh.vertices) // len(DEN)
    v = mesh.vertices.reshape(len(DEN), per, 3)
    centers = DEN.positions[:, ::-1]
    np.testing.assert_allclose(np.linalg.norm(v - centers[:, None], axis=2), r[:, None].repeat(per, 1), rtol=1e-5)
    # sum of sphere volumes, less the inscribed icosphere's polygon error
    exact = (4 / 3 * np.pi * r.astype(float) ** 3).sum()
    assert 0.95 * exact < mesh.volume < exact


def test_tubes_are_closed_and_follow_every_edge():
    mesh = tubes(DEN, 0.3, sides=10, joints=False)
    assert mesh.is_watertight and mesh.volume > 0
    child = np.flatnonzero(DEN.parent >= 0)
    length = np.linalg.norm(DEN.positions[child] - DEN.positions[DEN.parent[child]], axis=1).sum()
    polygon_area = 0.5 * 10 * 0.3**2 * np.sin(2 * np.pi / 10)
    assert mesh.volume == pytest.approx(polygon_area * length, rel=1e-6)
    tapered = tubes(DEN, Taper(1.0, 0.2))
    assert tapered.is_watertight and tapered.volume > 0
    with pytest.raises(TypeError, match="Expected a bool for 'joints', but got 'no'"):  # (had counted as true)
        tubes(DEN, 0.3, joints="no")
    assert tapered.bounds[0].min() >= -1.0 - 1e-9


def test_isosurface_vertices_lie_on_the_iso_level():
    iso = isosurface(DEN, 1.5)
    assert iso.is_watertight and iso.volume > 0
    # distance of every vertex to the nearest node is close to the radius (marching cubes interpolates
    # linearly between lattice nodes, so allow a fraction of a cell)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(DEN.positions[:, ::-1]).query(iso.vertices)
    assert np.abs(d - 1.5).max() < 0.5 and np.abs(d - 1.5).mean() < 0.1


def test_field_mesh_matches_a_sphere_and_has_outward_faces():
    z, y, x = np.mgrid[:24, :24, :24].astype(np.float32)
    f = np.sqrt((x - 12.3) ** 2 + (y - 11.6) ** 2 + (z - 12.0) ** 2) - 7.0
    mesh = field_mesh(f, 0.0, spacing=0.5, origin=(1.0, 2.0, 3.0))
    assert mesh.is_watertight and mesh.volume > 0
    c = np.array([12.3, 11.6, 12.0]) * 0.5 + [3.0, 2.0, 1.0]
    np.testing.assert_allclose(np.linalg.norm(mesh.vertices - c, axis=1), 3.5, atol=0.03)
    assert mesh.volume == pytest.approx(4 / 3 * np.pi * 3.5**3, rel=0.02)
    # linear interpolation on the level: trilinear field value at each vertex is ~0
    coords = ((mesh.vertices - [3.0, 2.0, 1.0]) / 0.5)[:, ::-1].T
    vals = ndimage.map_coordinates(f, coords, order=1)
    assert np.abs(vals).max() < 0.02
    smooth = field_mesh(f, 0.0, smooth=10)
    assert smooth.volume == pytest.approx(4 / 3 * np.pi * 7.0**3, rel=0.03)


def test_rock_from_a_label_segmentation():
    lat = wd.Lattice((24, 24, 24), 6, weights=wd.weights.Uniform(r=10, seed=1))
    gens = np.array([[12, 12, 12], [2, 2, 2], [21, 21, 3], [3, 21, 21], [21, 3, 21], [12, 1, 12], [12, 22, 12]])
    cf = wd.shortest_paths(lat, gens)
    inside = cf.label == 0
    rock = region_mesh(cf.label, 0)
    assert rock.is_watertight and rock.volume > 0
    # the surface runs halfway between inside and outside nodes: volume close to the node count
    assert rock.volume == pytest.approx(inside.sum(), rel=0.15)
    # the signed field equals a SciPy reference built from the same boundary nodes
    field = signed_region_field(inside, band=3.0)
    seeds = np.zeros_like(inside)
    seeds[tuple(surface_nodes(inside).T)] = True
    seeds |= ~inside & ndimage.binary_dilation(inside)  # outside nodes next to the rock
    d = np.minimum(ndimage.distance_transform_edt(~seeds), 3.0) + 0.5
    np.testing.assert_allclose(field, np.where(inside, -d, d), atol=1e-5)


def test_surface_nodes_of_a_ball():
    z, y, x = np.mgrid[:15, :15, :15]
    ball = (x - 7) ** 2 + (y - 7) ** 2 + (z - 7) ** 2 <= 25
    s = surface_nodes(ball)
    assert ball[tuple(s.T)].all()
    eroded = ndimage.binary_erosion(ball)
    assert len(s) == (ball & ~eroded).sum()


def test_preview_is_a_nonblank_shaded_picture(device):
    img = preview(tubes(DEN, 0.8), size=(64, 80), device=device)
    assert img.shape == (64, 80, 3) and img.dtype == np.float32
    hit = np.any(np.abs(img - 1.0) > 1e-6, axis=2)
    assert 0.02 < hit.mean() < 0.9
    assert img[hit].std() > 0.02  # shading varies over the surface
    assert np.all(img[0, 0] == 1.0)


@pytest.mark.parametrize(
    "call, exc, match",
    [
        (lambda: tubes(_empty3()), ValueError, "empty"),
        (lambda: spheres(_empty3()), ValueError, "empty"),
        (lambda: isosurface(_empty3()), ValueError, "empty"),
        (lambda: tubes(DEN, 0.0), ValueError, "radius"),
        (lambda: tubes(DEN, Taper(1.0, 0.5), sides=2), ValueError, "sides"),
        (lambda: spheres(DEN, -1.0), ValueError, "radius"),
        (lambda: field_mesh(np.zeros((4, 4))), ValueError, "3D"),
        (lambda: field_mesh(np.zeros((4, 4, 4)), 1.0), ValueError, "level"),
        # Warp's marching cubes (the CUDA path) says so too, instead of an empty mesh
        (lambda: field_mesh(np.zeros((4, 4, 4)), 1.0, _backend="warp"), ValueError, "outside the field's range"),
        (lambda: field_mesh(np.arange(64.0).reshape(4, 4, 4), -0.5, _backend="warp"), ValueError,
         "outside the field's range"),
        (lambda: region_mesh(np.zeros((4, 4, 4), np.int32), 3), ValueError, "region"),
        (lambda: region_mesh(np.zeros((4, 4), np.int32), 0), ValueError, "3D"),
        (lambda: region_mesh(np.zeros((4, 4, 4), np.int32), 0, band=0.5), ValueError, "band"),
        (lambda: isosurface(DEN, metric="cheb"), ValueError, "metric"),
        (lambda: preview(np.zeros(3)), ValueError, "mesh"),
    ],
)
def test_bad_input(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


def test_meshes_need_3d_dendrites():
    lat = wd.Lattice((10, 10), 8)
    den2 = wd.trace(wd.shortest_paths(lat, [[0, 0]]), [[9, 9]])
    for fn in (tubes, spheres, isosurface):
        with pytest.raises(ValueError, match="3D"):
            fn(den2)


def test_marching_only_near_the_surface_gives_the_same_mesh():
    from skimage.measure import marching_cubes

    # a rock touching the lattice's edge, and a dendrite touching it too
    lat = wd.Lattice((20, 22, 24), 6, weights=wd.weights.Uniform(r=10, seed=7))
    cf = wd.shortest_paths(lat, np.array([[2, 11, 12], [18, 3, 3], [18, 19, 21], [10, 20, 2]]))
    rock = region_mesh(cf.label, 0)
    field = np.pad(signed_region_field(cf.label == 0, band=2.0), 1, constant_values=0.5)
    v, f, _, _ = marching_cubes(field, 0.0, method="lorensen")  # (region_mesh's cases)
    assert len(rock.faces) == len(f) and rock.is_watertight
    np.testing.assert_allclose(np.sort(rock.vertices, axis=0), np.sort(v[:, ::-1] - 1.0, axis=0), atol=1e-5)
    iso = isosurface(DEN, Taper(2.0, 1.0))
    r = node_widths(DEN, Taper(2.0, 1.0))
    free = np.ones(DEN.shape, bool)
    free[tuple(DEN.nodes.T)] = False
    d, idx = ndimage.distance_transform_edt(free, return_indices=True)
    rows = np.full(DEN.shape, -1)
    rows[tuple(DEN.nodes.T)] = np.arange(len(DEN))
    ref = np.pad(d - r[rows[idx[0], idx[1], idx[2]]], 1, constant_values=float(r.max()) + 2.0 - 0.01)
    v, f, _, _ = marching_cubes(ref.astype(np.float32), 0.0)
    assert iso.is_watertight
    # ties between equidistant nodes of other radii may differ from SciPy's pick: compare volumes
    assert iso.volume == pytest.approx(abs(_signed_volume(v, f)), rel=0.03)


def _signed_volume(v, f):
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return np.einsum("ij,ij->", a, np.cross(b, c)) / 6.0


def test_preview_of_several_meshes_uses_their_colours():
    a = spheres(DEN, 1.0)
    b = tubes(DEN, 0.3)
    b.apply_translation([30.0, 0.0, 0.0])
    # one ray per pixel and no shadow on the ground: every pixel is one mesh's colour or the background
    img = preview([a, b], color=[(1.0, 0.0, 0.0), (0.0, 0.0, 1.0)], size=(60, 120), elevation=0, azimuth=-90,
                  samples=1, ground=False)
    hit = np.any(img < 0.999, axis=2)
    red = hit & (img[..., 0] > 0) & (img[..., 2] == 0)
    blue = hit & (img[..., 2] > 0) & (img[..., 0] == 0)
    assert red.any() and blue.any() and (red | blue).sum() == hit.sum()
    # looking along +y with z up: the red mesh is left of the blue one
    assert np.argwhere(red)[:, 1].mean() < np.argwhere(blue)[:, 1].mean()
    with pytest.raises(ValueError, match="color"):
        preview([a, b], color=[(1.0, 0.0, 0.0)] * 3)


def test_warp_marching_cubes_branch_matches_scikit_image():
    # the branch CUDA fields take, run on the CPU
    z, y, x = np.mgrid[:20, :22, :24].astype(np.float32)
    f = np.sqrt((x - 13.2) ** 2 + (y - 10.6) ** 2 + (z - 9.0) ** 2) - 6.0
    a = field_mesh(f, 0.0, spacing=0.5, origin=(1.0, 2.0, 3.0))
    b = field_mesh(f, 0.0, spacing=0.5, origin=(1.0, 2.0, 3.0), _backend="warp")
    assert b.volume > 0
    assert b.volume == pytest.approx(a.volume, rel=1e-3)
    np.testing.assert_allclose(b.bounds, a.bounds, atol=1e-4)


def _warp_field():
    import warp as wp

    return wp.array(np.random.default_rng(0).random((4, 4, 4)), dtype=float, device="cpu")


def _nan_warp_field():
    import warp as wp

    f = np.zeros((4, 4, 4), np.float32)
    f[2, 1, 3] = f[3, 0, 0] = np.inf
    return wp.array(f, dtype=float, device="cpu")


@pytest.mark.parametrize(
    "call, exc, match",
    [
        (lambda: isosurface(DEN, smooth=-1), ValueError, "'smooth' >= 0, but got -1"),
        (lambda: isosurface(DEN, smooth=1.5), ValueError, "'smooth' >= 0, but got 1.5"),
        (lambda: region_mesh(np.zeros((4, 4, 4), np.int32), 0, smooth=-1), ValueError, "'smooth' >= 0, but got -1"),
        (lambda: region_mesh(np.zeros((4, 4, 4), np.int32), 0, spacing=0), ValueError, "'spacing', but got 0"),
        (lambda: field_mesh(np.full((4, 4, 4), np.nan), 0.5), ValueError, r"'field' must be finite.*\(0, 0, 0\): nan"),
        (lambda: field_mesh(_nan_warp_field(), 0.5), ValueError, r"'field' must be finite.* 2 .*\(2, 1, 3\): inf"),
        (lambda: field_mesh(np.full((4, 4, 4), "a"), 0.5), TypeError, "'field', but got dtype <U1"),
        (lambda: field_mesh(np.zeros((0, 4, 4)), 0.5), ValueError, r"'field', but got shape \(0, 4, 4\)"),
        (lambda: field_mesh(np.random.default_rng(0).random((4, 4, 4)), np.nan), ValueError, "'level', but got nan"),
        (lambda: field_mesh(np.random.default_rng(0).random((4, 4, 4)), "0.5"), TypeError, "'level', but got '0.5'"),
        (lambda: field_mesh(np.zeros((4, 4, 4)), 0.5, origin=(0, 0, np.inf)), ValueError, "'origin' must be finite"),
        (lambda: field_mesh(np.zeros((4, 4, 4)), 0.5, band=-1), ValueError, "'band', but got -1"),
        (lambda: field_mesh(_warp_field(), 0.5, device="nonsense"), ValueError, "'device'.*'nonsense'"),
        (lambda: field_mesh(_warp_field(), 0.5, device="cuda:7"), ValueError, "'device'.*'cuda:7'"),
        (lambda: preview(spheres(DEN, 1.0), elevation=np.nan), ValueError, "'elevation', but got nan"),
        (lambda: preview(spheres(DEN, 1.0), azimuth="east"), TypeError, "'azimuth', but got 'east'"),
        (lambda: preview(spheres(DEN, 1.0), background="white"), TypeError, "'background', but got dtype <U5"),
    ],
)
def test_bad_scalars_and_fields_raise_before_any_kernel(call, exc, match, launches):
    with pytest.raises(exc, match=match):
        call()
    assert set(launches) <= {"nonfinite_kernel"}  # a Warp field is checked in place
    isosurface(DEN, 1.0)
    assert launches  # so the empty record above means that no kernel ran


def _degenerate_faces(mesh) -> int:
    return int(np.count_nonzero(mesh.area_faces <= 1e-12))


@pytest.mark.parametrize("backend", ["auto", "warp"])
def test_a_level_held_exactly_by_nodes_gives_a_closed_surface_without_pinches(backend):
    # distances between lattice nodes are square roots of integers: with radius 1 or 2 many nodes lie
    # exactly on the level, where marching cubes would put vertices on nodes and pinch the surface
    for r in (1.0, 2.0):
        mesh = isosurface(DEN, r) if backend == "auto" else None
        if mesh is not None:
            assert mesh.is_watertight and _degenerate_faces(mesh) == 0 and mesh.volume > 0
    z, y, x = np.mgrid[:9, :9, :9]
    field = np.maximum(np.abs(z - 4), np.maximum(np.abs(y - 4), np.abs(x - 4))).astype(np.float32)  # a cube
    mesh = field_mesh(field, 2.0, _backend=backend)
    assert mesh.is_watertight and _degenerate_faces(mesh) == 0
    # nodes at the level count as outside: the cube ends a thousandth of a step inside them
    np.testing.assert_allclose(mesh.bounds, [[2.001, 2.001, 2.001], [5.999, 5.999, 5.999]], atol=1e-5)
    assert np.array_equal(field, np.maximum(np.abs(z - 4), np.maximum(np.abs(y - 4), np.abs(x - 4))))  # unchanged


@pytest.mark.parametrize("backend", ["auto", "warp"])
def test_open_surfaces_point_toward_the_outside_too(backend):
    # low values are inside: the surface's normals point up the field, whether or not it is closed
    z = np.arange(7, dtype=np.float32)[:, None, None] * np.ones((7, 7, 7), np.float32)
    for field, out_z in ((2.5 - z, -1.0), (z - 2.5, 1.0)):
        mesh = field_mesh(field, 0.0, _backend=backend)
        normals = mesh.face_normals
        np.testing.assert_allclose(normals[:, 2], out_z, atol=1e-6)  # world z is array axis 0
    sphere = field_mesh(np.sqrt((z - 3) ** 2 + (z.transpose(1, 0, 2) - 3) ** 2 + (z.transpose(2, 1, 0) - 3) ** 2)
                        .astype(np.float32), 2.2, _backend=backend)
    assert sphere.is_watertight and sphere.volume > 0


def test_isosurface_with_path_costs_is_closed_and_takes_no_lattice_with_euclidean_distances():
    mesh = isosurface(DEN, 6.0, metric="path", lattice=LAT)  # radius in path-cost units (weights 1-11)
    assert mesh.is_watertight and mesh.volume > 0
    assert isosurface(DEN, 1.5, metric="path").is_watertight
    with pytest.raises(ValueError, match="'lattice' is only used with metric='path'"):
        isosurface(DEN, 1.5, lattice=LAT)


def test_thin_branches_stay_one_piece():
    # chains along a straight, a face-diagonal and a body-diagonal step, tapering far below a node
    for step in ((1, 0, 0), (0, 1, 1), (1, 1, 1)):
        nodes = np.array([2, 2, 2]) + np.arange(8)[:, None] * np.array(step)
        den = wd.Dendrite.from_arrays((14, 14, 14), nodes, np.arange(-1, 7))
        mesh = isosurface(den, Taper(1.2, 0.1))
        assert len(mesh.split(only_watertight=False)) == 1, step
    assert len(isosurface(DEN, 0.2).split(only_watertight=False)) == 1


@pytest.mark.parametrize("shape", [(2, 9, 9), (1, 9, 9), (3, 1, 5)])
def test_a_region_touching_the_lattice_edge_ends_halfway_past_its_last_nodes(shape):
    mesh = region_mesh(np.zeros(shape, np.int64), 0)
    hi = np.array(shape[::-1], float) - 0.5  # (x, y, z)
    np.testing.assert_allclose(mesh.bounds, [[-0.5, -0.5, -0.5], hi], atol=1e-5)
    assert mesh.is_watertight and mesh.volume == pytest.approx(np.prod(shape), rel=0.35)


def test_preview_refuses_an_empty_list_and_a_bad_size():
    mesh = spheres(DEN, 1.0)
    with pytest.raises(ValueError, match="'mesh' is an empty list"):
        preview([])
    for size in (100, (100,), (100, 0), (100.0, 100), "ab"):
        with pytest.raises(ValueError, match="'size'"):
            preview(mesh, size=size)


@pytest.mark.parametrize("joints", [False, True])
def test_tubes_stay_closed_once_welded_as_stl_does(tmp_path, joints):
    import trimesh

    # a straight run (one tube, no caps inside), a bend and a fork, rooted at (1, 4, 4)
    nodes = [[1, 4, 4], [2, 4, 4], [3, 4, 4], [4, 4, 4], [5, 5, 4], [5, 6, 4], [5, 3, 4], [6, 2, 4]]
    den = wd.Dendrite.from_arrays((9, 9, 9), nodes, [-1, 0, 1, 2, 3, 4, 3, 6], origin=(0.1, 0.2, 0.3),
                                  spacing=0.7)
    mesh = tubes(den, Taper(0.3, 0.1), sides=7, joints=joints)
    assert mesh.is_watertight and mesh.volume > 0
    welded = trimesh.Trimesh(mesh.vertices, mesh.faces, process=True)  # what loaders and STL do
    if not joints:
        assert welded.is_watertight and welded.is_winding_consistent
        # the straight runs 0-1-2-3 and 3-6-7 are one tube each, the bent 3-4-5 two
        assert len(mesh.split(only_watertight=False)) == 4
    path = wd.io.save_mesh(tmp_path / "t.stl", mesh)
    back = trimesh.load(path, force="mesh")
    assert back.volume == pytest.approx(mesh.volume, rel=1e-5)
    if not joints:
        assert back.is_watertight


def test_a_straight_run_through_a_fork_welds_closed():
    # node 1 continues 0-1-2 straight on and also has a side branch: the straight run is still one tube
    import trimesh

    den = wd.Dendrite.from_arrays((8, 8, 8), [[1, 4, 4], [2, 4, 4], [3, 4, 4], [2, 5, 4]], [-1, 0, 1, 1])
    mesh = tubes(den, 0.3, joints=False, sides=8)
    welded = trimesh.Trimesh(mesh.vertices, mesh.faces, process=True)
    assert welded.is_watertight and len(mesh.split(only_watertight=False)) == 2


def test_a_single_straight_chain_is_one_closed_tube():
    den = wd.Dendrite.from_arrays((8, 8, 8), [[1, 4, 4], [2, 4, 4], [3, 4, 4]], [-1, 0, 1])
    mesh = tubes(den, 1.0, joints=False, sides=8)
    assert len(mesh.faces) == 2 * 8 * 2 + 2 * 8 and mesh.is_watertight
    polygon_area = 0.5 * 8 * np.sin(2 * np.pi / 8)
    assert mesh.volume == pytest.approx(polygon_area * 2.0, rel=1e-9)


def _region_meshes_closed(labels, region) -> bool:
    mesh = region_mesh(labels, region)
    return mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0


def test_region_meshes_are_closed_where_nodes_touch_along_an_edge_only():
    # nodes of a region that share an edge but no face: the field is +-1/2 across each such cube face,
    # a tie that scikit-image's Lewiner cases split one way from one cube and the other way from the next
    labels = np.zeros((3, 3, 3), np.int32)
    labels[1] = [[0, 1, 1], [1, 0, 1], [0, 0, 0]]
    labels[2] = [[1, 0, 1], [1, 1, 0], [0, 0, 0]]
    assert _region_meshes_closed(labels, 1)
    rng = np.random.default_rng(5)
    for i in range(40):
        mask = rng.random((8, 8, 8)) < rng.uniform(0.15, 0.85)
        mask[rng.integers(0, 8, 3).tolist()] = True  # (never empty)
        assert _region_meshes_closed(mask.astype(np.int32), 1), i
    # a segmentation of several regions, each closed
    cf = wd.shortest_paths(wd.Lattice((10, 10, 10), 26, weights=wd.weights.Uniform(r=10, seed=3)),
                           rng.integers(0, 10, (6, 3)))
    for region in np.unique(cf.label):
        assert _region_meshes_closed(cf.label, region), region


@pytest.mark.parametrize("radius", [3e5, 1e30])
def test_isosurfaces_of_huge_radii_are_closed(radius):
    # every node lies inside: the surface closes on the padded border, halfway past the lattice's edge
    two = wd.Dendrite.from_arrays((3, 3, 3), [[1, 1, 1], [2, 2, 2]], [-1, 0])
    mesh = isosurface(two, radius)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    np.testing.assert_allclose(mesh.bounds, [[-0.5] * 3, [2.5] * 3], atol=1e-3)


def test_spheres_refuse_more_subdivisions_than_memory_allows(monkeypatch):
    one = wd.Dendrite.from_arrays((3, 3, 3), [[1, 1, 1]], [-1])
    with pytest.raises(ValueError, match=r"'subdivisions' <= 8 \(1310720 faces per sphere\), but got 12"):
        spheres(one, subdivisions=12)
    with pytest.raises(ValueError, match=r"'subdivisions' <= 8 .*, but got 1000000000"):
        spheres(one, subdivisions=10**9)
    # allowed subdivisions, but more spheres than memory holds: refused before they are built
    monkeypatch.setattr(wd._checks, "available_bytes", lambda device: 2**20)
    with pytest.raises(MemoryError, match=rf"spheres\(\) of {len(DEN)} nodes with 'subdivisions' = 3"):
        spheres(DEN, subdivisions=3)
    assert len(spheres(one, subdivisions=1).faces) == 80


def test_tubes_refuse_more_sides_than_memory_holds_before_any_work(monkeypatch):
    # a billion sides a tube would take hundreds of GiB: refused at once, naming 'sides'
    with pytest.raises(MemoryError, match=rf"tubes\(\) of {len(DEN)} nodes with 'sides' = 1000000000"):
        tubes(DEN, sides=10**9)
    monkeypatch.setattr(wd._checks, "available_bytes", lambda device: 2**16)
    with pytest.raises(MemoryError, match=r"'sides' = 64"):
        tubes(DEN, sides=64)
    monkeypatch.undo()
    assert tubes(DEN, sides=64).is_watertight


def test_preview_refuses_vertices_that_are_not_finite_float32():
    import trimesh

    for bad, said in ((np.nan, "NaN/inf"), (1e300, "float32")):
        m = trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [0, 1, bad]], faces=[[0, 1, 2]], process=False)
        with pytest.raises(ValueError, match=rf"'mesh\.vertices'.*{said}"):
            preview(m, size=(16, 16))
        with pytest.raises(ValueError, match=rf"'mesh\[1\]\.vertices'.*{said}"):
            preview([_triangle([[0, 1, 2]]), m], size=(16, 16))


def _triangle(faces):
    import trimesh

    return trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [0, 1, 0]], faces=faces, process=False)


@pytest.mark.parametrize(
    "call, exc, match",
    [
        (lambda: preview(_triangle([[0, 1, 10**9]]), size=(32, 32)), ValueError,
         r"Expected 'mesh.faces' indices in \[0, 3\), but got 1000000000"),
        (lambda: preview(_triangle([[0, 1, -1]]), size=(32, 32)), ValueError,
         r"Expected 'mesh.faces' indices in \[0, 3\), but got -1"),
        (lambda: preview([_triangle([[0, 1, 2]]), _triangle([[0, 1, 3]])], size=(32, 32)), ValueError,
         r"'mesh\[1\].faces' indices in \[0, 3\), but got 3"),
        (lambda: preview(_triangle([[0, 1, 2]]), color=(2, -1, 0.5)), ValueError,
         r"'color' RGB values in \[0, 1\], but got \(2, -1, 0.5\)"),
        (lambda: preview([_triangle([[0, 1, 2]])] * 2, color=[(1, 0, 0), (0, 0, 1.5)]), ValueError,
         r"'color' RGB values in \[0, 1\]"),
        (lambda: preview(_triangle([[0, 1, 2]]), background=(5, 5, 5)), ValueError,
         r"'background' RGB values in \[0, 1\], but got \(5, 5, 5\)"),
    ],
    ids=["face-beyond", "face-negative", "face-in-a-list", "color", "colors", "background"],
)
def test_preview_refuses_faces_off_the_vertices_and_colours_outside_0_1(call, exc, match, launches):
    with pytest.raises(exc, match=match):
        call()
    assert launches == []
    img = preview(_triangle([[0, 1, 2]]), size=(16, 16), color=(0, 1, 0), background=(0, 0, 0))
    assert img.min() >= 0 and img.max() <= 1 and img[..., 1].max() > 0 and launches


# --------------------------------------------------------------------------- bodies around centre lines


def _lines(points, radius, offsets):
    from wdendrite.skeleton import Skeleton

    points = np.asarray(points, np.float64)
    return Skeleton(points=points, radius=np.broadcast_to(np.asarray(radius, np.float64), (len(points),)).copy(),
                    offsets=np.asarray(offsets, np.int64), row=np.zeros(len(points), np.int64),
                    parent_branch=np.full(len(offsets) - 1, -1, np.int64))


def _capsules(lines, at):
    """Brute force: least over the segments of (distance to the segment - radius interpolated there)."""
    best = np.full(len(at), np.inf)
    for a_, b_ in lines.segments:
        a, b = lines.points[a_], lines.points[b_]
        ab = b - a
        t = np.zeros(len(at)) if ab @ ab == 0 else np.clip((at - a) @ ab / (ab @ ab), 0, 1)
        r = lines.radius[a_] + t * (lines.radius[b_] - lines.radius[a_])
        d = np.linalg.norm(at - (a + t[:, None] * ab), axis=1) - r
        best = np.minimum(best, d)
    return best


Y = ([[0, 0, 0], [0, 0, 3], [0, 0, 6], [2, 0, 9], [0, 0, 6], [-2, 1, 8.5]], [0, 4, 6])  # a fork


def test_the_tube_field_is_the_least_capsule_distance_within_its_band():
    from wdendrite.geometry import _tube_field

    lines = _lines(Y[0], [1.2, 1.0, 0.9, 0.5, 0.9, 0.6], Y[1])
    voxel = 0.4
    field, label, origin = _tube_field(lines, voxel, np.array([-4.0, -3, -2]), np.array([4.0, 3, 11]), "cpu")
    zz, yy, xx = np.indices(field.shape)
    at = origin + voxel * np.stack([xx.ravel(), yy.ravel(), zz.ravel()], axis=1)
    ref = np.minimum(_capsules(lines, at), 2 * voxel).reshape(field.shape)
    np.testing.assert_allclose(field, ref, atol=2e-5)
    assert np.all((label >= 0) == (ref < 2 * voxel - 1e-5) | (label >= 0) & (ref >= 2 * voxel - 1e-5))


def test_a_capsule_body_is_closed_with_the_capsule_volume():
    from wdendrite.geometry import skeleton_mesh

    r, length = 1.3, 6.0
    lines = _lines([[0, 0, 0], [0, 0, 3], [0, 0, 6]], r, [0, 3])
    mesh = skeleton_mesh(lines, voxel=0.2)
    assert mesh.is_watertight and len(mesh.split(only_watertight=False)) == 1
    assert mesh.volume == pytest.approx(np.pi * r**2 * length + 4 / 3 * np.pi * r**3, rel=0.01)
    # smooth normals: unit length, pointing away from the axis
    n = mesh.vertex_normals
    radial = mesh.vertices.copy()
    radial[:, 2] -= np.clip(radial[:, 2], 0, length)
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0) and np.einsum("ij,ij->i", n, radial).min() > 0.95


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_dendrite_body_is_one_closed_piece_whose_volume_matches_the_voxels(seed):
    from wdendrite.geometry import skeleton_mesh
    from wdendrite.skeleton import skeleton

    lat = wd.Lattice((20, 20, 20), 26, weights=wd.weights.Uniform(r=10, seed=seed))
    den = wd.trace(wd.shortest_paths(lat, [[1, 10, 10]]), wd.endpoints.random(lat, 10, seed=seed))
    lines = skeleton(den, Taper(1.4, 0.5, along="path"), min_radius=0.5)
    mesh = skeleton_mesh(lines, voxel=0.5)
    assert mesh.is_watertight and len(mesh.split(only_watertight=False)) == 1 and mesh.volume > 0
    # the volume against a count of the grid points (a finer grid) inside some capsule, each capsule
    # tested on the points of its own box
    h = 0.2
    lo = lines.points.min(axis=0) - lines.radius.max() - h
    inside = np.zeros(tuple(np.ceil((lines.points.max(axis=0) + lines.radius.max() + h - lo) / h).astype(int)), bool)
    for a_, b_ in lines.segments:
        one = _lines(lines.points[[a_, b_]], lines.radius[[a_, b_]], [0, 2])
        r = lines.radius[[a_, b_]].max()
        i0 = np.floor((np.minimum(one.points[0], one.points[1]) - r - lo) / h).astype(int)
        i1 = np.ceil((np.maximum(one.points[0], one.points[1]) + r - lo) / h).astype(int) + 1
        idx = np.stack(np.meshgrid(*[np.arange(i0[k], i1[k]) for k in range(3)], indexing="ij"), -1).reshape(-1, 3)
        hit = _capsules(one, lo + idx * h) < 0
        inside[tuple(idx[hit].T)] = True
    assert mesh.volume == pytest.approx(inside.sum() * h**3, rel=0.03)


def test_thin_tubes_are_thickened_to_the_voxel_and_stay_one_piece():
    from wdendrite.geometry import skeleton_mesh

    t = np.linspace(0, 4 * np.pi, 60)
    helix = np.stack([3 * np.cos(t), 3 * np.sin(t), t], axis=1)
    mesh = skeleton_mesh(_lines(helix, 0.05, [0, 60]), voxel=0.3)
    assert mesh.is_watertight and len(mesh.split(only_watertight=False)) == 1
    # as thick as a tube of radius 0.3 along the helix (length 4 pi sqrt(10))
    assert mesh.volume == pytest.approx(np.pi * 0.09 * 4 * np.pi * 10**0.5 + 4 / 3 * np.pi * 0.027, rel=0.05)


def test_enclosed_hollows_are_dropped():
    import trimesh

    from wdendrite.geometry import _without_voids

    outer = trimesh.creation.icosphere(subdivisions=2, radius=3.0)
    inner = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
    inner.invert()  # a hollow: its faces point into it, its volume is negative
    both = trimesh.util.concatenate([outer, inner])
    kept = _without_voids(both)
    assert len(kept.faces) == len(outer.faces) and kept.volume == pytest.approx(outer.volume)
    assert _without_voids(outer) is outer


def test_only_the_crossed_cubes_give_the_whole_surface_of_a_steep_field():
    from skimage.measure import marching_cubes

    from wdendrite.geometry import _crossed_cubes

    z, y, x = np.mgrid[:24, :25, :26].astype(np.float32)
    steep = 5.0 * (np.sqrt((x - 12.3) ** 2 + (y - 11.6) ** 2 + (z - 12.2) ** 2) - 7.0)  # 5 per node
    v, f, _, _ = marching_cubes(steep, 0.0)
    mesh = field_mesh(steep, 0.0, _cubes=_crossed_cubes(steep > 0))
    assert len(mesh.faces) == len(f) and mesh.is_watertight
    np.testing.assert_allclose(np.sort(mesh.vertices, axis=0), np.sort(v[:, ::-1], axis=0), atol=1e-5)


def test_body_colours_follow_the_nearest_segment():
    from wdendrite.geometry import skeleton_mesh

    lines = _lines([[0, 0, 0], [0, 0, 4], [0, 0, 4], [4, 0, 4]], 0.8, [0, 2, 4])
    colors = np.array([[1.0, 0, 0], [1.0, 0, 0], [0, 0, 1.0], [0, 0, 1.0]])
    mesh = skeleton_mesh(lines, voxel=0.2, colors=colors)
    rgb = mesh.visual.vertex_colors[:, :3]
    low = mesh.vertices[:, 2] < 2.0  # only the red upright reaches down there
    far = mesh.vertices[:, 0] > 2.5  # only the blue arm reaches out there
    assert np.all(rgb[low] == [255, 0, 0]) and np.all(rgb[far] == [0, 0, 255])


@pytest.mark.parametrize(
    "call, exc, match",
    [
        (lambda m: m(np.zeros(3)), TypeError, "Skeleton"),
        (lambda m: m(_lines(*Y[:1], 1.0, Y[1]), voxel=0.0), ValueError, "'voxel'"),
        (lambda m: m(_lines(*Y[:1], 1.0, Y[1]), voxel=-1.0), ValueError, "'voxel'"),
        (lambda m: m(_lines(*Y[:1], 1.0, Y[1]), colors=np.zeros((5, 3))), ValueError, "'colors'"),
        (lambda m: m(_lines(*Y[:1], 1.0, Y[1]), colors=np.full((6, 3), 2.0)), ValueError, "'colors'"),
        (lambda m: m(_lines(*Y[:1], 1.0, Y[1]), voxel=1e-4), ValueError, "larger 'voxel'"),
    ],
)
def test_bodies_refuse_bad_input_before_any_kernel(call, exc, match, launches):
    from wdendrite.geometry import skeleton_mesh

    with pytest.raises(exc, match=match):
        call(skeleton_mesh)
    assert launches == []
