"""Ray-cast previews: antialiased edges, smooth shading without facets or specks, shadows, vertex colours."""

import numpy as np
import pytest
import trimesh

from wdendrite.preview import preview, vertex_normals

SPHERE = trimesh.creation.icosphere(subdivisions=2, radius=1.0)  # 320 faces: facets show when shaded flat


def _flat(mesh):
    """The same triangles, every face with vertices of its own: vertex normals are the face normals."""
    v = mesh.vertices[mesh.faces].reshape(-1, 3)
    return trimesh.Trimesh(vertices=v, faces=np.arange(len(v)).reshape(-1, 3), process=False)


def test_vertex_normals_are_the_area_weighted_face_normals():
    n = vertex_normals(SPHERE.vertices, SPHERE.faces)
    # on a sphere centred at the origin they point along the position vectors
    radial = SPHERE.vertices / np.linalg.norm(SPHERE.vertices, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", n, radial).min() > 0.99
    # a lone triangle: its vertices take its normal; a vertex no face uses gets zero
    tri = np.array([[0, 0, 0], [2, 0, 0], [0, 1, 0], [5, 5, 5]], float)
    np.testing.assert_allclose(vertex_normals(tri, np.array([[0, 1, 2]])), [[0, 0, 1]] * 3 + [[0, 0, 0]])


def test_smooth_shading_has_no_facet_edges():
    kw = dict(size=(96, 96), samples=1, ground=False, color=(0.8, 0.8, 0.8))
    smooth, flat = preview(SPHERE, **kw), preview(_flat(SPHERE), **kw)
    body = np.all(smooth < 0.999, axis=2)
    inner = body & np.roll(body, 1, 0) & np.roll(body, -1, 0) & np.roll(body, 1, 1) & np.roll(body, -1, 1)
    inner &= np.roll(inner, 2, 0) & np.roll(inner, -2, 0) & np.roll(inner, 2, 1) & np.roll(inner, -2, 1)
    jump = lambda img: np.abs(np.diff(img[..., 0], axis=1))[inner[:, 1:] & inner[:, :-1]]
    # flat facets jump in brightness at their edges; interpolated normals change a little per pixel
    assert np.percentile(jump(flat), 99) > 2.5 * np.percentile(jump(smooth), 99)
    assert jump(smooth).max() < 0.05


def test_a_closed_mesh_has_no_specks():
    img = preview(SPHERE, size=(128, 128), samples=1, ground=False)
    body = np.all(img < 0.999, axis=2)
    # the silhouette of a unit sphere seen orthographically is a disc: no background pixel inside it,
    # and no pixel of it darker than the least light a surface facing the viewer gets
    yy, xx = np.mgrid[:128, :128]
    half = 128 / 2
    ext = np.abs(SPHERE.vertices).max() * 1.05  # the picture's half-extent (a 5 % margin)
    r = np.hypot((xx + 0.5 - half) / half * ext, (yy + 0.5 - half) / half * ext)
    assert body[r < 0.95].all() and not body[r > 1.01].any()
    assert img[r < 0.9].min() > 0.15


def test_several_rays_per_pixel_blend_the_edges():
    kw = dict(size=(64, 64), ground=False, color=(1.0, 0.0, 0.0))
    one, nine = preview(SPHERE, samples=1, **kw), preview(SPHERE, samples=3, **kw)
    # one ray: a pixel is the background (white) or the red surface (no green at all)
    assert set(np.unique(one[..., 1])) <= {0.0, 1.0}
    # nine rays: pixels on the rim mix the two
    mixed = (nine[..., 1] > 0.05) & (nine[..., 1] < 0.95)
    assert mixed.sum() > 40


def test_the_ground_takes_the_shadow_and_otherwise_shows_the_background():
    post = trimesh.creation.cylinder(radius=0.3, height=4.0)
    post.apply_translation([0, 0, 2.0])
    with_ground = preview(post, size=(96, 96), samples=2, color=(0.5, 0.5, 0.5))
    without = preview(post, size=(96, 96), samples=2, color=(0.5, 0.5, 0.5), ground=False)
    body = np.any(without < 0.999, axis=2)
    shadow = np.any(with_ground < 0.999, axis=2) & ~body
    assert shadow.sum() > 20  # the post's shadow falls on the ground ...
    assert np.all(with_ground[~body & ~shadow] == 1.0)  # ... the rest of the ground is the background


def test_vertex_colours_are_used_unless_a_colour_is_given():
    mesh = SPHERE.copy()
    rgb = np.where(mesh.vertices[:, :1] > 0, [[0, 0, 255, 255]], [[255, 0, 0, 255]]).astype(np.uint8)
    mesh.visual.vertex_colors = rgb
    img = preview(mesh, size=(64, 64), samples=1, ground=False, elevation=0, azimuth=-90)
    body = np.any(img < 0.999, axis=2)
    cols = np.argwhere(body)[:, 1]
    left, right = body & (np.arange(64) < cols.min() + 8), body & (np.arange(64) > cols.max() - 8)
    # looking along +y: -x (red) on the left, +x (blue) on the right
    assert np.all(img[left][:, 0] > img[left][:, 2]) and np.all(img[right][:, 2] > img[right][:, 0])
    grey = preview(mesh, size=(64, 64), samples=1, ground=False, color=(0.5, 0.5, 0.5))
    assert np.allclose(grey[..., 0], grey[..., 2])


@pytest.mark.parametrize("kw, exc, match", [
    (dict(samples=0), ValueError, "'samples'"),
    (dict(samples=9), ValueError, "'samples'"),
    (dict(samples=2.5), TypeError, "'samples'"),
    (dict(ground="yes"), TypeError, "'ground'"),
])
def test_bad_input_is_refused_before_any_kernel(kw, exc, match, launches):
    with pytest.raises(exc, match=match):
        preview(SPHERE, size=(16, 16), **kw)
    assert launches == []
