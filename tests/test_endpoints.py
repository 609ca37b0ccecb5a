"""Endpoint placement: constraints hold for every point, counts, reproducibility, bias, bad input."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image as PILImage
from scipy.spatial.distance import pdist
from skimage.measure import points_in_poly

import wdendrite as wd
from wdendrite import endpoints as ep


def _distinct(pts):
    return len({tuple(p) for p in pts.tolist()}) == len(pts)


@pytest.mark.parametrize("shape", [(40, 50), (12, 13, 14)])
def test_random_counts_bounds_distinct_and_reproducible(shape):
    pts = ep.random(shape, 200, seed=3)
    assert pts.shape == (200, len(shape)) and pts.dtype == np.int64
    assert (pts >= 0).all() and (pts < np.array(shape)).all() and _distinct(pts)
    np.testing.assert_array_equal(pts, ep.random(shape, 200, seed=3))
    assert not np.array_equal(pts, ep.random(shape, 200, seed=4))
    a = ep.random(shape, 20, seed=np.random.default_rng(9))
    b = ep.random(shape, 20, seed=np.random.default_rng(9))
    np.testing.assert_array_equal(a, b)


def test_random_can_take_every_node_once():
    pts = ep.random((7, 9), 63, seed=0)
    assert sorted(map(tuple, pts.tolist())) == [(y, x) for y in range(7) for x in range(9)]


def test_random_respects_the_lattice_mask():
    rng = np.random.default_rng(1)
    mask = rng.random((30, 30)) < 0.3
    lat = wd.Lattice((30, 30), mask=mask)
    pts = ep.random(lat, int(mask.sum()), seed=2)
    assert mask[tuple(pts.T)].all() and len(pts) == mask.sum()
    with pytest.raises(ValueError, match=r"only \d+ candidate nodes"):
        ep.random(lat, int(mask.sum()) + 1, seed=2)


def _all_of(region, shape, lat_mask=None):
    """Every node of ``region`` that the sampler can reach, by asking for all of them."""
    want = region.mask(shape) if lat_mask is None else region.mask(shape) & lat_mask
    lat = wd.Lattice(shape, mask=lat_mask) if lat_mask is not None else shape
    pts = ep.random(lat, int(want.sum()), seed=0, within=region)
    got = np.zeros(shape, bool)
    got[tuple(pts.T)] = True
    return want, got


def test_disc_and_ball():
    pts = ep.random((50, 60), 100, seed=1, within=ep.Disc((20.0, 30.5), 9.5))
    assert (np.hypot(pts[:, 0] - 20.0, pts[:, 1] - 30.5) <= 9.5).all()
    pts = ep.random((20, 20, 20), 100, seed=1, within=ep.Disc((10, 8, 12), 6))
    assert (np.linalg.norm(pts - [10, 8, 12], axis=1) <= 6).all()
    want, got = _all_of(ep.Disc((10, 10), 4), (21, 21))
    assert np.array_equal(want, got) and want.sum() == sum(
        1 for y in range(21) for x in range(21) if (y - 10) ** 2 + (x - 10) ** 2 <= 16
    )


def test_box():
    pts = ep.random((10, 30, 40), 300, seed=2, within=ep.Box((2, 5, 10), (6, 20, 15)))
    assert (pts >= [2, 5, 10]).all() and (pts <= [6, 20, 15]).all()
    want, got = _all_of(ep.Box((1, 2), (3, 7)), (8, 9))
    assert np.array_equal(want, got) and want.sum() == 3 * 6


def _in_triangle(p, a, b, c):
    """Independent check: the three sub-triangle areas add up to the whole."""
    def area(u, v, w):
        return abs((v[..., 0] - u[..., 0]) * (w[..., 1] - u[..., 1]) - (w[..., 0] - u[..., 0]) * (v[..., 1] - u[..., 1]))

    a, b, c = (np.asarray(v, float) for v in (a, b, c))
    p = p.astype(float)
    return np.isclose(area(p, a, b) + area(p, b, c) + area(p, c, a), area(a, b, c))


def test_triangle():
    a, b, c = (3.0, 2.0), (40.0, 10.0), (10.0, 45.0)
    pts = ep.random((50, 50), 300, seed=3, within=ep.Triangle(a, b, c))
    assert _in_triangle(pts, a, b, c).all()
    nodes = np.argwhere(np.ones((50, 50), bool))
    want = _in_triangle(nodes, a, b, c).reshape(50, 50)
    assert np.array_equal(ep.Triangle(a, b, c).mask((50, 50)), want)


def test_polygon_matches_an_independent_point_in_polygon():
    verts = [(2.3, 3.1), (30.7, 5.2), (18.4, 20.6), (35.2, 38.9), (4.1, 33.3), (12.6, 17.7)]  # concave
    shape = (40, 42)
    nodes = np.argwhere(np.ones(shape, bool)).astype(float)
    want = points_in_poly(nodes, np.asarray(verts)).reshape(shape)
    assert np.array_equal(ep.Polygon(verts).mask(shape), want)
    pts = ep.random(shape, 150, seed=4, within=ep.Polygon(verts))
    assert want[tuple(pts.T)].all()


def test_image_region_from_array_and_file(tmp_path):
    img = np.full((20, 30), 255, np.uint8)
    img[5:15, 3:12] = 10
    PILImage.fromarray(img).save(tmp_path / "shape.png")
    for src in (img, tmp_path / "shape.png"):
        pts = ep.random((20, 30), 40, seed=5, within=ep.Image(src))
        assert (img[tuple(pts.T)] < 128).all()
        pts = ep.random((20, 30), 40, seed=5, within=ep.Image(src, dark=False))
        assert (img[tuple(pts.T)] > 128).all()


def test_within_and_lattice_mask_combine():
    mask = np.ones((30, 30), bool)
    mask[:, :15] = False
    want, got = _all_of(ep.Disc((15, 15), 8), (30, 30), lat_mask=mask)
    assert np.array_equal(want, got) and not got[:, :15].any()


@pytest.mark.parametrize("shape,spacing,count", [((80, 80), 7.5, 60), ((24, 24, 24), 5.0, 40)])
def test_min_spacing_holds_for_every_pair(shape, spacing, count):
    pts = ep.random(shape, count, seed=6, min_spacing=spacing)
    assert len(pts) == count and _distinct(pts)
    assert pdist(pts.astype(float)).min() >= spacing
    np.testing.assert_array_equal(pts, ep.random(shape, count, seed=6, min_spacing=spacing))


def test_spacing_within_a_region():
    region = ep.Disc((30, 30), 20)
    pts = ep.random((60, 60), 15, seed=1, within=region, min_spacing=6)
    assert region.mask((60, 60))[tuple(pts.T)].all() and pdist(pts.astype(float)).min() >= 6


def test_impossible_spacing_raises_instead_of_looping():
    # a 20 x 20 lattice cannot hold 30 points 8 apart
    with pytest.raises(ValueError, match=r"Could place only \d+ of 30 endpoints.*'min_spacing' = 8"):
        ep.random((20, 20), 30, seed=0, min_spacing=8)


def test_a_spacing_wider_than_the_lattice_allows_one_point_quickly():
    # offsets past the lattice's sides are never built: 1e5 or 1e300 costs what 30 costs
    for spacing in (30.0, 1.0e5, 1.0e300):
        one = ep.random((10, 20), 1, seed=3, min_spacing=spacing)
        np.testing.assert_array_equal(one, ep.random((10, 20), 1, seed=3, min_spacing=30.0))
        with pytest.raises(ValueError, match=r"Could place only 1 of 2 endpoints"):
            ep.random((10, 20), 2, seed=3, min_spacing=spacing)
    # a spacing every node has some node beyond (its farthest corner is at least 10.5 away)
    pts = ep.random((10, 20), 2, seed=3, min_spacing=10.0)
    assert pdist(pts.astype(float)).min() >= 10.0


@pytest.mark.parametrize("scale", [1e-320, 1.0, 1e300])
def test_a_uniform_density_at_any_scale_draws_as_without_one(scale):
    # only the ratios of densities matter: subnormal or huge values draw what 1.0 draws, and
    # different seeds draw differently (no overflow to equal keys), without warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        draws = [ep.random((10, 10), 3, seed=s, density=np.full((10, 10), scale)) for s in range(3)]
    for s, got in enumerate(draws):
        np.testing.assert_array_equal(got, ep.random((10, 10), 3, seed=s, density=np.ones((10, 10))))
    assert len({tuple(map(tuple, d)) for d in draws}) == 3


def _cost_field():
    lat = wd.Lattice((60, 70), 8, weights=wd.weights.Uniform(r=10, seed=2))
    return wd.shortest_paths(lat, [[30, 35]])


def test_in_band_every_point_in_the_band():
    cf = _cost_field()
    d, r = 80.0, 8.0
    for cost in (cf, cf.dist):
        pts = ep.in_band(cost, 40, d, r, seed=7)
        c = cf.dist[tuple(pts.T)]
        assert len(pts) == 40 and ((c > d - r) & (c < d + r)).all()
    pts = ep.in_band(cf, 10, d, r, seed=7, min_spacing=10)
    c = cf.dist[tuple(pts.T)]
    assert ((c > d - r) & (c < d + r)).all() and pdist(pts.astype(float)).min() >= 10
    # the candidates are exactly the band: ask for all of them
    band = (cf.dist > d - r) & (cf.dist < d + r)
    pts = ep.in_band(cf, int(band.sum()), d, r, seed=1)
    got = np.zeros(band.shape, bool)
    got[tuple(pts.T)] = True
    assert np.array_equal(got, band)


def test_in_band_reads_a_cost_field_as_it_reads_its_dist_array():
    # a cost field's band is read from the lattice's records, without unpacking its dist:
    # the same candidates, so the same draws, as from the array
    mask = np.ones((50, 60), bool)
    mask[10:40, 20:25] = False
    lat = wd.Lattice((50, 60), 8, weights=wd.weights.Uniform(r=10, seed=5), mask=mask)
    cf = wd.shortest_paths(lat, [[25, 10]], limit=150.0)
    within = ep.Disc(center=(10, 20), radius=15)
    for kwargs in ({}, {"within": within}, {"min_spacing": 3.0}):
        a = ep.in_band(cf, 30, 70.0, 12.0, seed=9, **kwargs)
        assert cf._fields.dist is None
        b = ep.in_band(np.array(cf.dist), 30, 70.0, 12.0, seed=9, **kwargs)
        cf = wd.shortest_paths(lat, [[25, 10]], limit=150.0)
        np.testing.assert_array_equal(a, b)


def test_in_band_respects_mask_and_reports_empty_band():
    mask = np.ones((40, 40), bool)
    mask[:, 25:] = False
    lat = wd.Lattice((40, 40), weights=wd.weights.Uniform(seed=1), mask=mask)
    cf = wd.shortest_paths(lat, [[20, 5]])
    pts = ep.in_band(cf, 30, 60.0, 20.0, seed=0)
    assert mask[tuple(pts.T)].all()
    with pytest.raises(ValueError, match=r"No candidate nodes.*cost in \(9990, 10010\).*finite costs range"):
        ep.in_band(cf, 3, 1e4, 10.0)


def test_biased_shifts_endpoints_toward_the_bottom():
    shape = (200, 50)
    uniform = ep.random(shape, 1000, seed=8)[:, 0].mean()
    low = ep.biased(shape, 1000, seed=8, power=3.0)[:, 0].mean()
    high = ep.biased(shape, 1000, seed=8, power=3.0, toward="start")[:, 0].mean()
    # density ~ (i/n)^3 has mean row 0.8 n = 160 (0.2 n = 40 from the top); uniform 99.5
    assert abs(uniform - 99.5) < 10
    assert low > 140 and high < 60
    flat = ep.biased(shape, 1000, seed=8, power=0.0)[:, 0].mean()
    assert abs(flat - 99.5) < 10
    # along another axis, in 3D
    pts = ep.biased((10, 10, 100), 200, seed=1, power=4.0, axis=2)
    assert pts[:, 2].mean() > 70


def test_density_zero_nodes_are_never_drawn():
    density = np.zeros((30, 30))
    density[10:20, 5:8] = 1.0
    density[0, 0] = 500.0
    pts = ep.random((30, 30), 31, seed=2, density=density)
    assert (density[tuple(pts.T)] > 0).all()
    # the heavy node is drawn first almost always
    firsts = [tuple(ep.random((30, 30), 1, seed=s, density=density)[0]) for s in range(20)]
    assert firsts.count((0, 0)) >= 15  # p = 500 / 530 each


def test_manual_validates():
    lat = wd.Lattice((10, 12), mask=np.pad(np.ones((8, 10), bool), 1))
    pts = ep.manual(lat, [[1, 1], [8, 10]])
    assert pts.dtype == np.int64 and pts.tolist() == [[1, 1], [8, 10]]
    with pytest.raises(ValueError, match=r"'points' row 1 = \(10, 3\) lies outside"):
        ep.manual(lat, [[1, 1], [10, 3]])
    with pytest.raises(ValueError, match=r"'points' row 0 = \(0, 0\) is a masked-out node"):
        ep.manual(lat, [[0, 0]])
    with pytest.raises(TypeError, match="'points'"):
        ep.manual(lat, [[1.5, 2.0]])
    dist = np.ones((10, 12), np.float32)
    dist[5, 5] = np.inf
    with pytest.raises(ValueError, match=r"row 1 = \(5, 5\) is unreachable"):
        ep.manual(lat, [[2, 2], [5, 5]], cost=dist)
    with pytest.raises(ValueError, match=r"'points' rows 0 and 4 are the same node \(1, 1\)"):
        ep.manual(lat, [[1, 1], [4, 4], [2, 2], [4, 4], [1, 1]])


def test_in_band_refuses_a_band_above_the_cost_fields_limit():
    lat = wd.Lattice((30, 30), weights=wd.weights.Uniform(seed=3))
    cf = wd.shortest_paths(lat, [[15, 15]], limit=50.0)
    assert len(ep.in_band(cf, 5, 40.0, 10.0, seed=1)) == 5  # top at the limit: fine
    with pytest.raises(ValueError, match=r"'d' \+ 'r' = 65.*'limit' 50"):
        ep.in_band(cf, 5, 55.0, 10.0, seed=1)


# ---------------------------------------------------------------------------
# bad input


@pytest.mark.parametrize(
    "call,error,match",
    [
        (lambda: ep.random((10, 10), 0), ValueError, "'count'"),
        (lambda: ep.random((10, 10), 2.5), TypeError, "'count'"),
        (lambda: ep.random((10, 10), 101), ValueError, "'count' = 101.*only 100"),
        (lambda: ep.random((10, 10), 3, seed=-1), ValueError, "'seed'"),
        (lambda: ep.random((10, 10), 3, seed="a"), TypeError, "'seed'"),
        (lambda: ep.random((10, 10), 3, within=np.ones((9, 10), bool)), ValueError, "'within'"),
        (lambda: ep.random((10, 10), 3, within=np.ones((10, 10))), TypeError, "'within'"),
        (lambda: ep.random((10, 10), 3, within=np.zeros((10, 10), bool)), ValueError, "No candidate.*0 of them inside 'within'"),
        (lambda: ep.random((10, 10), 3, density=-np.ones((10, 10))), ValueError, "'density'"),
        (lambda: ep.random((10, 10), 3, density=np.full((10, 10), np.nan)), ValueError, "'density'"),
        (lambda: ep.random((10, 10), 3, density=np.zeros((10, 10))), ValueError, "No candidate.*positive 'density'"),
        (lambda: ep.random((10, 10), 3, min_spacing=0), ValueError, "'min_spacing'"),
        (lambda: ep.random((10, 10), 3, min_spacing=float("inf")), ValueError, "'min_spacing'"),
        (lambda: ep.random((10,), 3), ValueError, "'shape'"),
        (lambda: ep.Disc((5, 5), 0), ValueError, "'radius'"),
        (lambda: ep.random((10, 10), 3, within=ep.Disc((5, 5, 5), 2)), ValueError, "'center'"),
        (lambda: ep.random((10, 10), 3, within=ep.Box((5, 5), (2, 8))), ValueError, "'hi' >= 'lo'"),
        (lambda: ep.Triangle((0, 0), (1, 1), (2, 2)), ValueError, "collinear"),
        (lambda: ep.Polygon([(0, 0), (1, 1)]), ValueError, "'vertices'"),
        (lambda: ep.random((5, 10, 10), 3, within=ep.Polygon([(0, 0), (0, 5), (5, 0)])), ValueError, "2D lattice"),
        (lambda: ep.random((10, 10), 3, within=ep.Image(np.zeros((8, 8), np.uint8))), ValueError, "'image'.*\\(10, 10\\)"),
        (lambda: ep.Image("/nonexistent/shape.png"), ValueError, "Could not read 'image'"),
        (lambda: ep.Image(np.zeros((8, 8)), threshold=0), ValueError, "'threshold'"),
        (lambda: ep.biased((10, 10), 3, power=-1), ValueError, "'power'"),
        (lambda: ep.biased((10, 10), 3, axis=2), ValueError, "'axis'"),
        (lambda: ep.biased((10, 10), 3, toward="up"), ValueError, "'toward'"),
        (lambda: ep.in_band(np.zeros((10, 10)), 3, 5.0, 0.0), ValueError, "'r'"),
        (lambda: ep.in_band(np.zeros((10, 10)), 3, float("nan"), 1.0), ValueError, "'d'"),
        (lambda: ep.in_band(np.zeros((10, 10), np.int32), 3, 5.0, 1.0), TypeError, "'cost'"),
        (lambda: ep.in_band(np.zeros((10,)), 3, 5.0, 1.0), ValueError, r"'cost' as a non-empty 2D .*shape \(10,\)"),
        (lambda: ep.in_band(np.zeros((0, 4)), 3, 5.0, 1.0), ValueError, r"'cost' .*shape \(0, 4\)"),
        (lambda: ep.manual((10, 10), [[1, 2], [3]]), ValueError, "'points' in rows of one length"),
    ],
)
def test_bad_input_raises_clearly(call, error, match):
    with pytest.raises(error, match=match):
        call()


@settings(max_examples=40, deadline=None)
@given(
    h=st.integers(3, 25),
    w=st.integers(3, 25),
    count=st.integers(1, 30),
    spacing=st.floats(0.5, 6.0),
    radius=st.floats(1.0, 12.0),
    seed=st.integers(0, 2**16),
)
def test_property_spaced_points_in_region_or_clear_error(h, w, count, spacing, radius, seed):
    region = ep.Disc(((h - 1) / 2, (w - 1) / 2), radius)
    try:
        pts = ep.random((h, w), count, seed=seed, within=region, min_spacing=spacing)
    except ValueError as err:
        assert "Could place only" in str(err) or "candidate nodes" in str(err)
        return
    assert len(pts) == count and region.mask((h, w))[tuple(pts.T)].all()
    if count > 1:
        assert pdist(pts.astype(float)).min() >= spacing


def test_a_band_below_cost_zero_is_refused_before_any_kernel(launches):
    cf = wd.shortest_paths(wd.Lattice((8, 8)), [[0, 0]])
    launches.clear()
    with pytest.raises(ValueError, match="below cost 0"):
        ep.in_band(cf, 5, -10, 1)
    assert launches == []


def test_a_spacing_equal_to_a_pairs_distance_lets_the_pair_be():
    # "at least min_spacing apart": sqrt(2)**2 rounds above 2, which had refused the diagonal pair
    for seed in range(20):  # (whichever node comes first, its diagonal is the one left)
        got = ep.random((2, 2), 2, seed=seed, min_spacing=math.sqrt(2))
        assert np.abs(got[0] - got[1]).tolist() == [1, 1]


@pytest.mark.parametrize("shape, count, spacing", [((40, 50), 30, 4.5), ((12, 14, 16), 20, 3.0), ((64, 64), 5, 30.0)])
def test_wide_spacings_compared_directly_keep_what_the_footprint_keeps(shape, count, spacing, monkeypatch):
    # spacings whose footprint would be large compare candidates with the kept points instead;
    # both ways keep the same endpoints
    want = ep.random(shape, count, seed=3, min_spacing=spacing)
    monkeypatch.setattr(ep, "_FOOTPRINT_MAX", 0)
    got = ep.random(shape, count, seed=3, min_spacing=spacing)
    np.testing.assert_array_equal(got, want)
    d = np.linalg.norm(got[:, None] - got[None], axis=-1)
    assert (d[~np.eye(len(got), dtype=bool)] >= spacing).all()


def test_a_spacing_wider_than_the_region_fails_before_any_table(monkeypatch):
    # 200^3 with spacing 400 had built a 5 GB offset table before failing
    monkeypatch.setattr(ep, "_footprint", lambda *a: pytest.fail("built a footprint"))
    monkeypatch.setattr(ep, "_spaced_far", lambda *a: pytest.fail("scanned the candidates"))
    with pytest.raises(ep.TooManyEndpoints, match="'min_spacing' = 400"):
        ep.random((200, 200, 200), 2, min_spacing=400)


def test_a_steep_bias_still_reaches_every_node():
    # ((i + 1) / n) ** 200 underflows to 0 near the start: those nodes had been left out
    got = ep.biased((1000, 3), 3000, power=200)
    assert len(np.unique(got, axis=0)) == 3000
    first = ep.biased((1000, 3), 30, power=200, seed=1)
    assert (first[:, 0] > 900).all()  # and the draw still follows the profile


def test_path_planning_inputs_refuse_text_flags_masked_arrays_and_costs_that_are_none():
    lat = wd.Lattice((8, 8), 4)
    # text for a flag had counted as true; a masked array's mask had been dropped
    with pytest.raises(TypeError, match="Expected a bool for 'dark', but got 'no'"):
        ep.Image(np.zeros((4, 4)), dark="no")
    masked = np.ma.masked_array([[1, 2], [3, 4]], mask=[[0, 0], [1, 1]])
    with pytest.raises(ValueError, match="'generators' is a masked array with 2 masked cells"):
        wd.shortest_paths(lat, masked)
    with pytest.raises(ValueError, match="'mask' is a masked array with 1 masked cells"):
        wd.Lattice((2, 2), 4, mask=np.ma.masked_array(np.ones((2, 2), bool), mask=[[1, 0], [0, 0]]))
    with pytest.raises(ValueError, match="'density' is a masked array"):
        ep.random(lat, 2, seed=0, density=np.ma.masked_array(np.ones((8, 8)), mask=np.eye(8, dtype=bool)))
    # a plain cost array holds path costs: NaN and negative entries had passed
    with pytest.raises(ValueError, match=r"'cost' holds path costs .* 2 NaN or negative entries \(first at \(0, 0\): -5.0\)"):
        ep.in_band(np.array([[-5.0, -3.0], [2.0, 3.0]]), 2, -4.0, 5.0)
    with pytest.raises(ValueError, match="1 NaN or negative"):
        ep.in_band(np.array([[0.0, np.nan], [2.0, 3.0]]), 1, 2.0, 1.0)
    with pytest.raises(TypeError, match="float array for 'cost', but got str"):
        ep.manual(lat, [[1, 1]], cost="abc")


@pytest.mark.parametrize(
    "make, plain",
    [
        (lambda: ep.Disc(np.array([3, 4]), np.float32(2.5)), lambda: ep.Disc((3.0, 4.0), 2.5)),
        (lambda: ep.Box(np.array([1, 1]), [np.int64(5), 6.0]), lambda: ep.Box((1.0, 1.0), (5.0, 6.0))),
        (lambda: ep.Triangle(np.array([0, 0]), (0, 9), [np.float32(9), 0]), lambda: ep.Triangle((0.0, 0.0), (0.0, 9.0), (9.0, 0.0))),
        (lambda: ep.Polygon(np.array([[0, 0], [0, 9], [9, 9]])), lambda: ep.Polygon(((0.0, 0.0), (0.0, 9.0), (9.0, 9.0)))),
    ],
)
def test_regions_keep_plain_values_whatever_numpy_values_made_them(make, plain):
    # (arrays had been kept as given: the region neither hashed nor compared, and printed array(...))
    region, ref = make(), plain()
    assert region == ref and hash(region) == hash(ref) and repr(region) == repr(ref)
    np.testing.assert_array_equal(region.mask((12, 12)), ref.mask((12, 12)))


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda: ep.Disc("middle", 2), "'center' as finite"),
        (lambda: ep.Disc((1, np.nan), 2), "'center' as finite"),
        (lambda: ep.Box((1, 1, 1, 1), (2, 2, 2, 2)), "'lo' as finite"),
        (lambda: ep.Box((1, 1), (2, 2, 2)), "'lo' and 'hi' with as many coordinates"),
        (lambda: ep.Box((3, 1), (2, 2)), "'hi' >= 'lo'"),
    ],
)
def test_regions_check_their_corners_when_made(make, words):
    with pytest.raises(ValueError, match=words):
        make()
