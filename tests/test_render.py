"""Brightness images: exp(-(d/T)^2) against SciPy distances, tapering (eq. 2), branches, compositing, bad input."""

import numpy as np
import pytest
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra

import wdendrite as wd
from wdendrite.dendrite import Dendrite
from wdendrite.render import (
    Taper,
    branch_order,
    brightness,
    colorize,
    composite,
    distance_field,
    glow,
    node_widths,
    thesis_width,
)

LAT = wd.Lattice((40, 48), 8, weights=wd.weights.Uniform(r=10, seed=3))


def _dendrite(n_end=6, seed=1, lat=LAT):
    cf = wd.shortest_paths(lat, [[1, lat.shape[1] // 2]])
    ep = wd.endpoints.random(lat, n_end, within=wd.endpoints.Box((20, 2), (38, 45)), seed=seed)
    return wd.trace(cf, ep)


DEN = _dendrite()


def empty_dendrite(shape=(8, 8)):
    nd = len(shape)
    return Dendrite(shape=shape, nodes=np.zeros((0, nd), np.int64), parent=np.zeros(0, np.int64),
                    cost=np.zeros(0, np.float32), label=np.zeros(0, np.int32), generation=np.zeros(0, np.int32),
                    endpoints=np.zeros(0, np.int64), _padded=np.zeros(0, np.int64))


def _unit_path_distance(den):
    """Octile distance from the dendrite's nodes by SciPy's Dijkstra on a unit-weight 8-connected lattice."""
    unit = wd.Lattice(den.shape, 8)
    src = np.ravel_multi_index(tuple(den.nodes.T), den.shape)
    d = dijkstra(unit.to_csgraph(), indices=src, min_only=True)
    return d.reshape(den.shape)


@pytest.mark.parametrize("t", [1.6, 5.0])
def test_path_brightness_is_exp_of_scipy_dijkstra_distance(t, device):
    v = brightness(DEN, t, metric="path", reach=3.0, device=device)
    d = _unit_path_distance(DEN)
    ref = np.where(d <= 3.0 * t, np.exp(-((d / t) ** 2)), 0.0)
    np.testing.assert_allclose(v, ref, atol=2e-6)
    assert np.all(v[tuple(DEN.nodes.T)] == 1.0)


def test_euclidean_brightness_matches_scipy_distance_transform(device):
    t = 2.5
    v = brightness(DEN, t, metric="euclidean", reach=3.0, device=device)
    free = np.ones(DEN.shape, bool)
    free[tuple(DEN.nodes.T)] = False
    d = ndimage.distance_transform_edt(free)
    ref = np.where(d <= 3.0 * t, np.exp(-((d / t) ** 2)), 0.0)
    np.testing.assert_allclose(v, ref, atol=2e-6)


@pytest.mark.parametrize("metric", ["euclidean", "path"])
def test_a_limit_beyond_the_image_reaches_every_cell(metric, device):
    # limits past int32 and past the image give the field of a limit that just covers it, at once
    free = np.ones(DEN.shape, bool)
    free[tuple(DEN.nodes.T)] = False
    want = ndimage.distance_transform_edt(free) if metric == "euclidean" else _unit_path_distance(DEN)
    cover = float(sum(DEN.shape))
    for limit in (cover, 3.0e9, 1.0e30):
        dist, label = distance_field(DEN, limit=limit, metric=metric, device=device)
        np.testing.assert_allclose(dist, want, rtol=1e-6)
        assert (label >= 0).all()
    v = brightness(DEN, 1.0e9, reach=3.0, metric=metric, device=device)
    np.testing.assert_allclose(v, np.exp(-((want / 1.0e9) ** 2)), rtol=1e-6)


@pytest.mark.parametrize("metric", ["euclidean", "path"])
def test_cells_exactly_at_the_limit_are_in_reach(metric, device):
    # limits that are float32 roundings of cells' own distances: those cells lie "up to the
    # limit" as the field reports them, and the splat had scanned one column short of them
    ndim = 3 if metric == "euclidean" else 2  # (the path metric's closed form is 2D)
    one = wd.Dendrite.from_arrays((15,) * ndim, [[7] * ndim], [-1])
    d_all, _ = distance_field(one, limit=50.0, metric=metric, device=device)
    for limit in np.unique(d_all)[1:40]:
        d, label = distance_field(one, limit=float(limit), metric=metric, device=device)
        inside = d_all <= limit
        np.testing.assert_array_equal(np.isfinite(d), inside, err_msg=f"limit {limit!r}")
        np.testing.assert_array_equal(d[inside], d_all[inside])
        assert (label[inside] == 0).all() and (label[~inside] == -1).all()


def test_width_of_the_nearest_node_is_used(device):
    widths = np.linspace(1.0, 4.0, len(DEN)).astype(np.float32)
    dist, label = distance_field(DEN, limit=12.0, metric="euclidean", device=device)
    v = brightness(DEN, widths, metric="euclidean", reach=3.0, device=device)
    ok = label >= 0
    t = widths[label[ok]]
    ref = np.where(dist[ok] <= 3 * t, np.exp(-((dist[ok] / t) ** 2)), 0.0)
    np.testing.assert_allclose(v[ok], ref, atol=2e-6)
    # the label names a node at exactly that distance
    nodes = DEN.nodes[label[ok]]
    pix = np.argwhere(ok)
    np.testing.assert_allclose(np.linalg.norm(nodes - pix, axis=1), dist[ok], rtol=1e-6)


def test_closed_form_path_cost_equals_a_unit_lattice_search(device):
    widths = np.linspace(1.0, 3.0, len(DEN)).astype(np.float32)
    closed = brightness(DEN, widths, metric="path", device=device)
    searched = brightness(DEN, widths, metric="path", lattice=wd.Lattice(DEN.shape, 8), device=device)
    np.testing.assert_allclose(closed, searched, atol=1e-5)
    lat3 = wd.Lattice((9, 10, 11), 26)
    den3 = wd.trace(wd.shortest_paths(lat3, [[0, 0, 0]]), [[8, 9, 10], [8, 0, 5]])
    d_closed, _ = distance_field(den3, limit=6.0, metric="path", device=device)
    d_search, _ = distance_field(den3, limit=6.0, metric="path", lattice=lat3, device=device)
    np.testing.assert_allclose(d_closed, d_search, rtol=1e-5)


def test_weighted_lattice_path_costs_match_scipy():
    t = 12.0
    v = brightness(DEN, t, metric="path", lattice=LAT, reach=2.0)
    src = np.ravel_multi_index(tuple(DEN.nodes.T), DEN.shape)
    d = dijkstra(LAT.to_csgraph(), indices=src, min_only=True).reshape(DEN.shape)
    ref = np.where(d <= 2.0 * t, np.exp(-((d / t) ** 2)), 0.0)
    np.testing.assert_allclose(v, ref, atol=1e-5)


def test_taper_formula_along_a_single_path():
    den = _dendrite(n_end=1, seed=4)
    taper = Taper(start=5.0, end=1.0, beta=2.0, along="path")
    w = node_widths(den, taper)
    u = den.cost.astype(np.float64) / den.cost.max()
    np.testing.assert_allclose(w, 5.0 * (1 - u**2) + 1.0 * u**2, rtol=1e-6)
    tip = den.endpoints[0]
    assert w[den.roots[0]] == pytest.approx(5.0) and w[tip] == pytest.approx(1.0)


def test_taper_along_the_dendrite_uses_the_largest_cost():
    w = node_widths(DEN, Taper(4.0, 2.0, along="dendrite"))
    u = DEN.cost / DEN.cost.max()
    np.testing.assert_allclose(w, 4.0 * (1 - u) + 2.0 * u, rtol=1e-5)


def test_branches_main_path_reaches_the_farthest_tip_and_sides_taper_from_their_start():
    br = branch_order(DEN)
    far = DEN.endpoints[np.argmax(DEN.cost[DEN.endpoints])]
    main = DEN.path(far)
    assert np.all(br.order[main] == 0)
    assert np.count_nonzero(br.order == 0) == len(main)
    # a branch starts at a node whose parent is on a lower-order branch
    child = np.flatnonzero(DEN.parent >= 0)
    assert np.all(br.order[child] >= br.order[DEN.parent[child]])
    w = node_widths(DEN, Taper(5.0, 2.0, along="branch"), side=Taper(3.0, 0.5, along="branch"))
    sides = np.flatnonzero(br.order > 0)
    assert len(sides)
    # side branch nodes are never wider than where they attach, and their tips reach 0.5
    assert np.all(w[sides] <= w[br.attach[sides]] + 1e-6)
    tips = np.intersect1d(DEN.endpoints, sides)
    deepest = tips[np.isclose(DEN.cost[tips], br.tip_cost[tips])]
    np.testing.assert_allclose(w[deepest], 0.5, rtol=1e-5)
    const = node_widths(DEN, 5.0, side=1.6)
    assert set(np.unique(const[br.order == 0])) == {5.0} and set(np.unique(const[sides])) == {np.float32(1.6)}


def test_thesis_variant_with_clamp():
    t = thesis_width(0.2)  # a = 1e-4: T = 1 / (0.2 * 0.01) = 500 cost units
    assert t == pytest.approx(500.0)
    v = brightness(DEN, 3.0, clamp=0.7)
    assert not np.any((v > 0.7) & (v < 1.0))
    plain = brightness(DEN, 3.0)
    np.testing.assert_array_equal(v == 1.0, plain > 0.7)


def test_composite_modes_and_gains():
    rng = np.random.default_rng(0)
    a, b = rng.random((5, 6)).astype(np.float32), rng.random((5, 6)).astype(np.float32)
    np.testing.assert_allclose(composite([a, b]), np.maximum(a, b))
    np.testing.assert_allclose(composite([a, b], mode="add"), np.clip(a + b, 0, 1))
    np.testing.assert_allclose(composite([a, b], mode="screen"), 1 - (1 - a) * (1 - b), rtol=1e-6)
    np.testing.assert_allclose(composite([a, b], gains=[0.5, 0.0]), 0.5 * a)


def test_glow_keeps_the_total_and_is_symmetric(device):
    img = np.zeros((61, 61), np.float32)
    img[30, 30] = 1.0
    g = glow(img, radius=4.0, device=device)
    assert g.sum() == pytest.approx(1.0, rel=1e-5)
    np.testing.assert_allclose(g, g[::-1, ::-1], atol=1e-7)
    np.testing.assert_allclose(g, g.T, atol=1e-7)
    assert g[30, 30] == g.max()
    # spread close to the asked radius (three box passes approximate a Gaussian)
    ys = np.arange(61) - 30
    sigma = np.sqrt((g.sum(axis=1) * ys**2).sum())
    assert 3.5 < sigma < 4.5


@pytest.mark.parametrize("shape", [(37, 53), (5, 3), (1, 1), (8, 12)])
def test_glow_equals_scipy_box_filters(device, shape):
    # three box passes per axis with zeros outside: SciPy's uniform_filter in float64 is the reference;
    # sizes that are not multiples of 4 exercise the kernels' row and column groups
    from scipy import ndimage

    img = np.random.default_rng(shape[0]).random(shape).astype(np.float32)
    radius, passes = 3.0, 3
    half = max(1, int(round(0.5 * (np.sqrt(1.0 + 12.0 * radius * radius / passes) - 1.0))))
    ref = img.astype(np.float64)
    for _ in range(passes):
        ref = ndimage.uniform_filter(ref, size=2 * half + 1, mode="constant", cval=0.0)
    np.testing.assert_allclose(glow(img, radius=radius, passes=passes, device=device), ref, rtol=0, atol=1e-6)


def test_colorize_adds_light_over_the_background(device):
    v = np.array([[0.0, 1.0]], np.float32)
    rgb = colorize(v, device=device)
    np.testing.assert_allclose(rgb[0, 0], 0.0)
    np.testing.assert_allclose(rgb[0, 1], 1.0)
    bg = colorize(v, background=(0.1, 0.2, 0.3), glow=np.array([[1.0, 0.0]], np.float32), glow_color=(0.5, 0, 0))
    np.testing.assert_allclose(bg[0, 0], [0.6, 0.2, 0.3], atol=1e-6)
    grey = colorize(np.full((2, 2), 0.25, np.float32), colormap="grey")
    np.testing.assert_allclose(grey, 0.25, atol=1e-6)


def test_colorize_takes_any_matplotlib_colormap_a_callable_or_colours(device):
    mpl = pytest.importorskip("matplotlib")
    v = np.linspace(0.0, 1.0, 7 * 41, dtype=np.float32).reshape(7, 41)
    for name in ("viridis", "magma_r", "terrain"):
        table = mpl.colormaps[name](np.linspace(0.0, 1.0, 256))[:, :3]
        step = np.abs(np.diff(table, axis=0)).max()  # ours interpolates the 256 colours, Matplotlib picks one
        got = colorize(v, colormap=name, device=device)
        assert got.shape == (7, 41, 3) and got.dtype == np.float32
        assert np.abs(got - mpl.colormaps[name](v)[..., :3]).max() <= step + 1e-6, name
        # the Colormap object itself is a callable colormap: the same picture
        np.testing.assert_array_equal(colorize(v, colormap=mpl.colormaps[name], device=device), got)
    ramp = colorize(v, colormap=lambda t: np.stack([t, t * t, 1.0 - t], axis=1), device=device)
    np.testing.assert_allclose(ramp, np.stack([v, v * v, 1.0 - v], axis=-1), atol=1e-5)  # (t^2 between samples)
    two = colorize(v, colormap=[[0.0, 0.0, 0.0], [1.0, 0.5, 0.0]], device=device)
    np.testing.assert_allclose(two, np.stack([v, 0.5 * v, 0 * v], axis=-1), atol=1e-6)
    one = colorize(v, colormap=np.array([[0.2, 0.4, 0.6]]), device=device)
    np.testing.assert_allclose(one, np.broadcast_to([0.2, 0.4, 0.6], one.shape), atol=1e-6)


def test_colormap_names_beyond_ours_need_matplotlib(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # (an import of it now fails, as when it is missing)
    with pytest.raises(ValueError, match=r"other names are Matplotlib's colormaps, and Matplotlib is not "
                                         r"installed\), but got 'viridis'"):
        colorize(np.zeros((2, 2)), colormap="viridis")
    np.testing.assert_allclose(colorize(np.full((2, 2), 0.5), colormap="grey"), 0.5, atol=1e-6)  # ours need none


def test_rows_render_a_subset():
    br = branch_order(DEN)
    main = br.order == 0
    v = brightness(DEN, 2.0, rows=main, metric="euclidean")
    free = np.ones(DEN.shape, bool)
    free[tuple(DEN.nodes[main].T)] = False
    d = ndimage.distance_transform_edt(free)
    np.testing.assert_allclose(v, np.where(d <= 6.0, np.exp(-((d / 2.0) ** 2)), 0.0), atol=2e-6)


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: brightness(DEN, 0.0), "width"),
        (lambda: brightness(DEN, -1.0), "width"),
        (lambda: Taper(0.0, 1.0), "start"),
        (lambda: Taper(2.0, -1.0), "end"),
        (lambda: Taper(2.0, 1.0, beta=0), "beta"),
        (lambda: Taper(2.0, 1.0, along="tip"), "along"),
        (lambda: brightness(empty_dendrite()), "empty"),
        (lambda: node_widths(empty_dendrite(), 1.0), "empty"),
        (lambda: brightness(DEN, 2.0, metric="manhattan"), "metric"),
        # (a lattice with the Euclidean metric had been ignored without a word, as brightness refuses it)
        (lambda: distance_field(DEN, limit=5.0, metric="euclidean", lattice=LAT),
         r"'lattice' is only used with metric='path', but metric is 'euclidean'"),
        (lambda: brightness(DEN, 2.0, clamp=1.5), "clamp"),
        (lambda: brightness(DEN, 2.0, reach=0), "reach"),
        (lambda: brightness(DEN, np.ones(3)), "width"),
        (lambda: brightness(DEN, 2.0, rows=np.zeros(0, int)), "rows"),
        (lambda: brightness(DEN, 2.0, rows=[]), "'rows' is empty"),  # (a float array to NumPy)
        (lambda: brightness(DEN, 2.0, rows=np.zeros(len(DEN), bool)), "'rows' selects no node"),
        (lambda: colorize(np.zeros((2, 2)), colormap="no-such-map"), "colormap"),
        (lambda: composite([]), "layers"),
        (lambda: composite([np.zeros((2, 2)), np.zeros((3, 2))]), "layers"),
        (lambda: composite([np.zeros((2, 2))], mode="multiply"), "mode"),
        (lambda: glow(np.zeros((4, 4)), radius=-1), "radius"),
        (lambda: thesis_width(0.0), "factor"),
    ],
)
def test_bad_input_names_the_parameter(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_gains_that_are_not_a_sequence_are_named():
    with pytest.raises(TypeError, match="'gains' as a sequence"):
        composite([np.zeros((2, 2))], gains=2.0)


def test_brightness_refuses_3d_dendrites():
    lat = wd.Lattice((6, 6, 6))
    den = wd.trace(wd.shortest_paths(lat, [[0, 0, 0]]), [[5, 5, 5]])
    with pytest.raises(ValueError, match="2D"):
        brightness(den, 1.0)
    with pytest.raises(TypeError, match="Dendrite"):
        brightness(np.zeros((3, 2)), 1.0)


@pytest.mark.parametrize(
    "call, exc, match",
    [
        (lambda: glow(np.full((8, 8), np.nan)), ValueError, r"'value' must be finite, .* 64 NaN/inf .*\(0, 0\): nan"),
        (lambda: glow(np.zeros((0, 0))), ValueError, r"2D \(H, W\) array for 'value', but got shape \(0, 0\)"),
        (lambda: glow("abc"), TypeError, "'value', but got dtype <U3"),
        (lambda: glow(np.array([[0.0, 1e300]])), ValueError, r"'value' .*1e\+300 \(too large for float32\)"),
        (lambda: colorize(np.full((4, 4), np.inf)), ValueError, "'value' must be finite"),
        (lambda: colorize(np.zeros((4, 0))), ValueError, r"'value', but got shape \(4, 0\)"),
        (lambda: colorize(np.zeros((4, 4)), glow=np.full((4, 4), np.nan)), ValueError, "'glow' must be finite"),
        (lambda: colorize(np.zeros((4, 4)), background=(0.0, np.nan, 0.0)), ValueError, "'background' must be finite"),
        (lambda: colorize(np.zeros((4, 4)), background="sky"), TypeError, "'background', but got dtype <U3"),
        (lambda: colorize(np.zeros((4, 4)), glow_color=(1.0, 1.0)), ValueError, r"'glow_color', but got shape \(2,\)"),
        (lambda: composite([np.zeros((2, 2)), np.full((2, 2), np.nan)]), ValueError, r"'layers\[1\]' must be finite"),
        (lambda: composite([np.zeros((0, 3))]), ValueError, r"'layers\[0\]', but got shape \(0, 3\)"),
    ],
)
def test_bad_images_raise_before_any_kernel(call, exc, match, launches):
    with pytest.raises(exc, match=match):
        call()
    assert launches == []
    glow(np.ones((4, 4)))
    assert launches  # so the empty record above means that no kernel ran


def test_an_absent_device_is_a_value_error_naming_it(launches):
    import wdendrite as wd

    with pytest.raises(ValueError, match="'device'"):
        wd.render.glow(np.zeros((8, 8), np.float32), device="cuda:9")
    assert launches == []


@pytest.mark.parametrize("value", [-1.0, 0.0, float("nan"), float("inf"), -float("inf")])
def test_a_width_that_must_be_positive_says_so_for_every_bad_value(value):
    # one message for every value it refuses (a negative one had been told "non-negative")
    with pytest.raises(ValueError, match=r"Expected a positive finite number for 'width', but got"):
        brightness(DEN, value)


def test_widths_beyond_float32_are_refused():
    with pytest.raises(ValueError, match=r"'start' for Taper in \(0, 1e\+30\] .* got 1e\+308"):
        Taper(1e308, 1.0)
    with pytest.raises(ValueError, match=r"'end' for Taper in \(0, 1e\+30\]"):
        Taper(1.0, 1e31)
    # a width float32 makes 0 had drawn NaN (0 / 0), in a number or a Taper alike
    for call in (lambda: brightness(DEN, 1e-50), lambda: node_widths(DEN, 1e-50), lambda: Taper(1e-50, 1.0),
                 lambda: brightness(DEN, 1e39)):
        with pytest.raises(ValueError, match=r"in \(0, 1e\+30\] as a float32 width"):
            call()
    # and in an array of widths, naming the first
    wide = np.full(len(DEN), 2.0)
    wide[3] = 1e31
    for call in (lambda: node_widths(DEN, wide), lambda: brightness(DEN, wide)):
        with pytest.raises(ValueError, match=r"'width' in \(0, 1e\+30\] .* got 1e\+31 at index 3"):
            call()


def _numpy_relief(z, spacing, area=None):
    """The terrain picture written with NumPy: numpy.gradient slopes, hillshade, tint, rivers."""
    gy, gx = np.gradient(z.astype(np.float64), spacing)
    n = np.stack([-gx, -gy, np.ones_like(gx)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    light = np.array([-1.0, -1.0, 1.5]) / np.linalg.norm([-1.0, -1.0, 1.5])
    shade = np.clip(n @ light, 0, 1)[..., None]
    t = ((z - z.min()) / (z.max() - z.min()))[..., None]
    low, mid, high = np.array([0.3, 0.45, 0.25]), np.array([0.55, 0.45, 0.3]), np.array([0.95, 0.95, 0.95])
    img = np.where(t < 0.6, low + (mid - low) * t / 0.6, mid + (high - mid) * (t - 0.6) / 0.4) * (0.35 + 0.65 * shade)
    if area is not None:
        wet = np.clip(np.log(area / (0.001 * z.size)) / np.log(20.0), 0.0, 1.0)[..., None]
        img = img * (1 - 0.9 * wet) + 0.9 * wet * np.array([0.12, 0.3, 0.85])
    return img


def test_relief_equals_numpy_shading_with_and_without_rivers(device):
    from wdendrite import hydrology

    z = hydrology.fbm_terrain((61, 47), seed=4)
    area = hydrology.flow_accumulation(z, filled=True)
    assert (area > 0.02 * z.size).sum() > 0 and (area > 0.001 * z.size).sum() > 100  # rivers, some full blue
    for a in (None, area):
        got = wd.render.relief(z, 0.05, a, device=device)
        assert got.shape == (61, 47, 3) and got.dtype == np.float32
        np.testing.assert_allclose(got, _numpy_relief(z, 0.05, a), atol=2e-6)
    # a 2 x 2 terrain: one-sided slopes everywhere
    tiny = np.array([[0.0, 1.0], [3.0, 2.0]])
    np.testing.assert_allclose(wd.render.relief(tiny, 1.0, device=device), _numpy_relief(tiny, 1.0), atol=2e-6)
    # spacings and elevations beyond float32's comfort (the kernel works on scaled elevations)
    z64 = z.astype(np.float64)
    for zz, spacing in ((z64, 1e-40), (z64 * 1e37, 1.0), (z64 * 1e-30, 1e-30)):
        np.testing.assert_allclose(wd.render.relief(zz, spacing, device=device), _numpy_relief(zz, spacing), atol=2e-6)


def test_relief_in_bands_of_rows_equals_one_band(monkeypatch, launches):
    # bands a few rows high, each shaded from one more row on either side, against one launch
    from wdendrite import _parallel, hydrology

    z = hydrology.fbm_terrain((53, 41), seed=2)
    area = hydrology.flow_accumulation(z, filled=True)
    one = wd.render.relief(z, 0.05, area, device="cpu", workers=1)
    monkeypatch.setattr(_parallel, "cores", lambda: 4)
    monkeypatch.setattr(_parallel, "BAND_PIXELS", 41 * 3)
    launches.clear()
    many = wd.render.relief(z, 0.05, area, device="cpu", workers=4)
    assert launches.count("relief_kernel") == 4
    assert np.array_equal(many, one)


@pytest.mark.parametrize("kw, match", [
    (dict(z=np.zeros((1, 5))), r"2D \(H >= 2, W >= 2\) array for 'z'"), (dict(z=np.full((4, 4), np.nan)), "'z'"),
    (dict(spacing=0.0), "'spacing'"),
    (dict(area=np.ones((4, 5))), "'area'"), (dict(area=np.zeros((4, 4))), "'area'"), (dict(device="cuda:7"), "'device'"),
    (dict(workers=0), r"'workers' >= 1"), (dict(workers=2.0), "'workers'"),
])
def test_relief_refuses_bad_input_before_any_kernel(kw, match, launches):
    args = dict(z=np.random.default_rng(0).random((4, 4)), spacing=1.0) | kw
    with pytest.raises((ValueError, TypeError), match=match):
        wd.render.relief(**args)
    assert launches == []


def test_unit_range_maps_the_finite_values_onto_0_1():
    a = np.array([[2.0, 4.0, np.nan], [np.inf, 3.0, -np.inf]])
    np.testing.assert_array_equal(wd.render.unit_range(a), [[0.0, 1.0, 0.0], [0.0, 0.5, 0.0]])
    np.testing.assert_array_equal(wd.render.unit_range(np.full((2, 3), 7.0)), np.zeros((2, 3)))  # no span
    np.testing.assert_array_equal(wd.render.unit_range(np.full(4, np.nan)), np.zeros(4))  # nothing finite
    # a span float64 cannot hold (it overflowed to inf, and every value became NaN)
    np.testing.assert_array_equal(wd.render.unit_range(np.array([-1e308, 1e308, 0.0])), [0.0, 1.0, 0.5])


@pytest.mark.parametrize(
    "call, exc, match",
    [
        (lambda: brightness(DEN, 2.0, metric="euclidean", lattice=LAT), ValueError,
         r"'lattice' is only used with metric='path', but metric is 'euclidean'"),
        (lambda: colorize(np.zeros((4, 4)), colormap=["grey"]), TypeError,
         r"Expected a real-valued \(N, 3\) array for 'colormap', but got dtype <U4"),
        (lambda: colorize(np.zeros((4, 4)), colormap=3), TypeError,
         r"Expected 'colormap' as a name \(one of \('grey', 'lightning', .*\) or a Matplotlib colormap's\), a "
         r"callable or an \(N, 3\) array of colours, but got int"),
        (lambda: colorize(np.zeros((4, 4)), colormap=np.zeros((4, 4))), ValueError,
         r"Expected a non-empty \(N, 3\) array for 'colormap', but got shape \(4, 4\)"),
        (lambda: colorize(np.zeros((4, 4)), colormap=[[0, 0, 0], [2, 1, 1]]), ValueError,
         r"Expected the colours of 'colormap' in \[0, 1\], but they span \[0, 2\]"),
        (lambda: colorize(np.zeros((4, 4)), colormap=lambda t: t), ValueError,
         r"Expected a non-empty \(256, 3\) or \(256, 4\) \(returned by the callable\) array for 'colormap', "
         r"but got shape \(256,\)"),
        (lambda: colorize(np.zeros((4, 4)), colormap=lambda t: 1 / 0), ValueError,
         r"'colormap' <function .*> failed on 256 values from 0 to 1: ZeroDivisionError"),
        (lambda: glow(np.ones((4, 4)), passes=2**40), ValueError, r"Expected 'passes' <= 64, but got 1099511627776"),
    ],
    ids=["lattice", "colormap-text", "colormap-int", "colormap-shape", "colormap-range", "colormap-returns",
         "colormap-fails", "passes"],
)
def test_a_lattice_without_path_costs_an_unhashable_colormap_and_endless_passes_are_refused(call, exc, match,
                                                                                             launches):
    with pytest.raises(exc, match=match):
        call()
    assert launches == []
    glow(np.ones((4, 4)), passes=64)
    assert launches  # so the empty record above means that no kernel ran


def _line_dendrite(shape, a, b):
    """A dendrite along the rounded straight line from node ``a`` (its root) to node ``b``."""
    n = int(np.abs(np.subtract(b, a)).max())
    pts = np.rint(np.asarray(a) + np.outer(np.arange(n + 1) / n, np.subtract(b, a))).astype(np.int64)
    return Dendrite.from_arrays(shape, pts, np.arange(-1, n))


def _stroke_reference(den, width, ink=None, sigma=0.45):
    """The strokes by NumPy: every pixel's largest ink x Gaussian-filtered coverage over the edges."""
    from scipy.special import erf

    h, w = den.shape
    py, px = np.mgrid[:h, :w].astype(float)
    radius = 0.5 * np.asarray(node_widths(den, width), float)
    ink = np.ones(len(den)) if ink is None else np.asarray(ink, float)
    out = np.zeros((h, w))
    for row in range(len(den)):
        p = den.parent[row] if den.parent[row] >= 0 else row
        a, b = den.nodes[row].astype(float), den.nodes[p].astype(float)
        ab = b - a
        t = np.clip(((py - a[0]) * ab[0] + (px - a[1]) * ab[1]) / max(ab.dot(ab), 1e-300), 0, 1)
        d = np.hypot(py - a[0] - t * ab[0], px - a[1] - t * ab[1])
        r = radius[row] + t * (radius[p] - radius[row])
        k = 1 / (sigma * np.sqrt(2))
        out = np.maximum(out, ink[row] * 0.5 * (erf((r - d) * k) + erf((r + d) * k)))
    return out


@pytest.mark.parametrize("end", [(40, 8), (36, 28), (8, 40), (30, 30)])
@pytest.mark.parametrize("width", [1.0, 2.5])
def test_strokes_equal_a_numpy_reference(end, width, device):
    den = _line_dendrite((48, 48), (4, 4), end)
    v = wd.render.strokes(den, width, device=device)
    np.testing.assert_allclose(v, _stroke_reference(den, width), atol=2e-6)
    assert v.max() <= 1.0


@pytest.mark.parametrize("width", [1.0, 1.5, 2.5])
def test_strokes_weigh_the_same_at_every_slope(width):
    # the ink per unit length of the drawn path is the stroke's width, level, at slope 1/2 and
    # diagonal (through pixel centres); lit nodes (brightness by distance to nodes) weigh a diagonal
    # 1/sqrt(2) as much as a level line
    per_length = []
    for end in ((4, 92), (48, 92), (92, 92)):
        den = _line_dendrite((96, 96), (4, 4), end)
        caps = np.pi * (width / 2) ** 2  # the two round ends make one disc
        length = np.linalg.norm(np.diff(den.nodes, axis=0), axis=1).sum()  # the lattice path's, zigzags and all
        per_length.append((wd.render.strokes(den, width).sum() - caps) / length)
    assert np.allclose(per_length, width, rtol=0.02), per_length
    # exact across a level stroke 2 wide centred on row 10: erf profile, 2 pixels of ink in each column
    den = _line_dendrite((20, 40), (10, 5), (10, 34))
    column = wd.render.strokes(den, 2.0)[:, 20]
    assert column.sum() == pytest.approx(2.0, rel=1e-3) and column[10] > 0.97 and column[9] == column[11]


def test_strokes_taper_and_take_ink_per_node():
    base = _line_dendrite((30, 60), (15, 3), (15, 56))
    den = Dendrite.from_arrays(base.shape, base.nodes, base.parent, cost=np.arange(len(base), dtype=float))
    ink = np.linspace(1.0, 0.5, len(den))
    v = wd.render.strokes(den, Taper(6.0, 1.0, along="path"), ink=ink)
    np.testing.assert_allclose(v, _stroke_reference(den, Taper(6.0, 1.0, along="path"), ink), atol=2e-6)
    across = v[:, 5:55].sum(axis=0)
    assert np.all(np.diff(across) < 0)  # thinner and fainter away from the root


@pytest.mark.parametrize("call, exc, match", [
    (lambda: wd.render.strokes(DEN, 0.0), ValueError, "'width'"),
    (lambda: wd.render.strokes(DEN, 1.0, ink=np.full(len(DEN), 2.0)), ValueError, r"'ink' value in \[0, 1\]"),
    (lambda: wd.render.strokes(DEN, 1.0, ink=np.ones(3)), ValueError, "'ink' of shape"),
    (lambda: wd.render.strokes(empty_dendrite(), 1.0), ValueError, "empty"),
    (lambda: wd.render.strokes(_line_dendrite((8, 8, 8), (1, 1, 1), (5, 5, 5)), 1.0), ValueError, "2D"),
])
def test_strokes_refuse_bad_input_before_any_kernel(call, exc, match, launches):
    with pytest.raises(exc, match=match):
        call()
    assert launches == []


def test_coverage_of_a_distance_field_sums_to_the_width_and_refuses_bad_distances():
    d = np.abs(np.arange(-12.0, 13.0) - 0.3)[:, None] * np.ones((1, 4))  # a level line 0.3 px off the centres
    for width in (0.8, 1.5, 4.0):
        c = wd.render.coverage(d, width)
        np.testing.assert_allclose(c.sum(axis=0), width, rtol=5e-3)  # (pixel sampling: within 0.3 %)
    assert wd.render.coverage(np.array([np.inf]), 2.0)[0] == 0.0
    with pytest.raises(ValueError, match="'distance'"):
        wd.render.coverage(np.array([-1.0]), 1.0)
    with pytest.raises(ValueError, match="'width'"):
        wd.render.coverage(np.array([1.0]), 0.0)


# Dendry trees drawn as lines

_BOWL = dict(domain=((0.0, 0.0), (2.0, 2.0)), control=wd.control.lichtenberg())
_TREE = wd.DendryParams(levels=3, eps=0.25, delta=(0.05, 0.01, 0.0), rule="lichtenberg", seed=2)


def test_the_tree_of_the_first_levels_is_the_whole_trees_first_levels(device):
    # what dendry_lines rests on: cutting the parameters to k levels keeps levels 1..k as they are
    n = 96
    whole = wd.dendry((n, n), params=_TREE, output="distance", device=device, **_BOWL)
    level = wd.dendry((n, n), params=_TREE, output="level", device=device, **_BOWL)
    for k in (1, 2):
        cut = wd.DendryParams(levels=k, eps=0.25, delta=_TREE.delta[:k], rule="lichtenberg", seed=2)
        first = wd.dendry((n, n), params=cut, output="distance", device=device, **_BOWL)
        assert np.all(first >= whole)  # fewer branches, never nearer
        np.testing.assert_array_equal(first[level <= k], whole[level <= k])


def test_dendry_lines_draw_each_level_at_its_own_width(device):
    n = 128
    cover = wd.render.dendry_lines((n, n), params=_TREE, device=device, **_BOWL)
    assert cover.shape == (n, n) and cover.dtype == np.float32 and 0 <= cover.min() and cover.max() <= 1
    # the documented widths: the finest level an eighth of its 16-pixel cell, within [1, 1.5]; x 1.4 a level
    widths = [1.5 * 1.4**2, 1.5 * 1.4, 1.5]
    px = 2.0 / n
    d = wd.dendry((n, n), params=_TREE, output="distance", device=device, **_BOWL) / px
    level = wd.dendry((n, n), params=_TREE, output="level", device=device, **_BOWL)

    def line(w):  # a stroke of width w, seen by a pixel d from its middle (coverage's own tests hold it)
        return wd.render.coverage(d, w)

    # nearest to the trunk: the trunk's own width; elsewhere between the finest and the trunk's
    np.testing.assert_allclose(cover[level == 1], line(widths[0])[level == 1], atol=1e-6)
    assert np.all(cover >= line(widths[-1]) - 1e-6) and np.all(cover <= line(widths[0]) + 1e-6)
    assert (cover > line(widths[-1]) + 0.1).any()  # some finer branches lie within a coarser one's width
    assert len(np.unique(np.round(cover, 3))) > 50  # antialiased: many partial covers
    again = wd.render.dendry_lines((n, n), params=_TREE, distance=d * px, device=device, **_BOWL)
    np.testing.assert_array_equal(again, cover)
    thin = wd.render.dendry_lines((n, n), params=_TREE, widths=[1.0, 1.0, 1.0], device=device, **_BOWL)
    np.testing.assert_allclose(thin, line(1.0), atol=1e-6)  # one width for all: the whole tree at that width


def test_dendry_lines_on_several_threads_equal_one(monkeypatch):
    from wdendrite import _parallel

    one = wd.render.dendry_lines((72, 72), params=_TREE, device="cpu", workers=1, **_BOWL)
    monkeypatch.setattr(_parallel, "cores", lambda: 3)
    monkeypatch.setattr(_parallel, "BAND_PIXELS", 72 * 5)
    bands = []
    real = _parallel.each
    monkeypatch.setattr(_parallel, "each", lambda fn, items, threads: bands.append(len(items)) or real(fn, items, threads))
    many = wd.render.dendry_lines((72, 72), params=_TREE, device="cpu", workers=3, **_BOWL)
    assert bands.count(3) == 3  # each level's coverage in 3 bands (Dendry's own bands: its tests)
    assert np.array_equal(many, one)


@pytest.mark.parametrize("kw, exc, match", [
    (dict(widths=[1.0, 2.0]), ValueError, r"one width per level \(3\), but got \[1.0, 2.0\]"),
    (dict(widths=[1.0, 0.0, 1.0]), ValueError, r"'widths\[1\]'"),
    (dict(distance=np.zeros((5, 5))), ValueError, r"'distance' has shape \(5, 5\), but 'shape' is \(16, 16\)"),
    (dict(params=None), TypeError, "DendryParams for 'params'"),
    (dict(workers=-1), ValueError, r"'workers' >= 1 \(or None: every core\), but got -1"),
])
def test_dendry_lines_refuse_bad_input_before_any_kernel(kw, exc, match, launches):
    with pytest.raises(exc, match=match):
        wd.render.dendry_lines((16, 16), **{"params": _TREE, **_BOWL, **kw})
    assert launches == []
