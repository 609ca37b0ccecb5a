"""Weight distributions: hash reference, statistics, seeds, tropism, maps, in-kernel evaluation, bad input."""

import math

import numpy as np
import pytest
from PIL import Image

import wdendrite as wd
from wdendrite import weights
from wdendrite.kernels import weights as kw
from wdendrite.lattice import half_offsets

# ---------------------------------------------------------------------------
# an independent NumPy version of kernels/random.py's hash


def _mix32(x):
    x = x ^ (x >> np.uint32(16))
    x = x * np.uint32(0x7FEB352D)
    x = x ^ (x >> np.uint32(15))
    x = x * np.uint32(0x846CA68B)
    x = x ^ (x >> np.uint32(16))
    return x


def _hash_unit(seed, a, b):
    a = np.asarray(a, dtype=np.uint32)
    b = np.asarray(b, dtype=np.uint32)
    h = _mix32(np.array([seed], dtype=np.uint32) ^ np.uint32(0x9E3779B9))
    h = _mix32(h ^ a)
    h = _mix32((h + np.uint32(0x632BE5AB)) ^ b)
    return ((h >> np.uint32(9)).astype(np.float32) + np.float32(0.5)) * np.float32(1.0 / 8388608.0)


def _reference_u(shape, k_count, seed):
    """``(K, *shape)`` hash values: ``u[k][idx] = hash_unit(seed, flat(idx), k)``."""
    n = math.prod(shape)
    nodes = np.arange(n, dtype=np.uint32)[None, :]
    ks = np.arange(k_count, dtype=np.uint32)[:, None]
    return _hash_unit(seed, nodes, ks).reshape((k_count, *shape))


def _lengths(ndim, conn):
    off = half_offsets(ndim, conn)
    return np.sqrt((off**2).sum(1)).astype(np.float32)


def test_uniform_equals_numpy_hash_bit_for_bit(device):
    # r = 8: 8 * u is exact, so 1 + 8u and length * (...) are single roundings on both sides
    shape, lens = (3, 5), _lengths(2, 8)
    got = weights.Uniform(r=8.0, seed=7).sample(shape, lens, device=device)
    u = _reference_u(shape, len(lens), 7)
    want = lens.reshape(-1, 1, 1) * (np.float32(1.0) + np.float32(8.0) * u)
    np.testing.assert_array_equal(got, want)


def test_power_and_polynomial_follow_their_formulas_on_the_hash():
    shape, lens = (4, 3, 2), _lengths(3, 6)
    u = _reference_u(shape, len(lens), 11).astype(np.float64)
    L = lens.reshape(-1, 1, 1, 1).astype(np.float64)
    got = weights.Power(alpha=2.5, max=7.0, seed=11).sample(shape, lens)
    np.testing.assert_allclose(got, L * (1 + 6.0 * u) ** 2.5, rtol=2e-6)
    got = weights.Polynomial(n=3.0, seed=11).sample(shape, lens)
    np.testing.assert_allclose(got, L * (1 + (100.0 * u) ** 3), rtol=2e-6)


def test_hash_values_lie_strictly_inside_unit_interval():
    u = _reference_u((256, 256), 2, 0)
    assert u.min() > 0 and u.max() < 1


@pytest.mark.parametrize(
    "dist,low,high,mean",
    [
        (weights.Uniform(r=10.0, seed=1), 1.0, 11.0, 6.0),
        (weights.Uniform(r=100.0, seed=2), 1.0, 101.0, 51.0),
        (weights.Power(alpha=3.0, max=11.0, seed=3), 1.0, 1331.0, (11.0**4 - 1) / (4 * 10.0)),
        (weights.Power(alpha=0.3, max=5.0, seed=4), 1.0, 5.0**0.3, (5.0**1.3 - 1) / (1.3 * 4.0)),
        (weights.Polynomial(n=0.0, seed=5), 2.0, 2.0, 2.0),
        (weights.Polynomial(n=2.0, seed=6), 1.0, 1.0 + 1e4, 1.0 + 1e4 / 3.0),
        (weights.Polynomial(n=4.0, seed=7), 1.0, 1.0 + 1e8, 1.0 + 1e8 / 5.0),
    ],
)
def test_distribution_range_and_mean_match_theory(dist, low, high, mean):
    w = dist.sample((256, 256), _lengths(2, 4)).astype(np.float64)
    assert w.min() >= low * (1 - 1e-6) and w.max() <= high * (1 + 1e-6)
    # 131072 samples: the standard error is under 1% of the mean for all of these
    assert w.mean() == pytest.approx(mean, rel=0.03)


@pytest.mark.parametrize("ndim,conn", [(2, 8), (3, 26)])
def test_diagonal_edges_are_scaled_by_their_length(ndim, conn):
    shape = (64, 64) if ndim == 2 else (16, 16, 16)
    lens = _lengths(ndim, conn)
    dist = weights.Uniform(r=10.0, seed=3)
    unit = dist.sample(shape, np.ones_like(lens), offsets=half_offsets(ndim, conn))
    scaled = dist.sample(shape, lens)
    np.testing.assert_allclose(scaled, unit * lens.reshape((-1,) + (1,) * ndim), rtol=1e-6)
    assert set(np.round(np.unique(lens) ** 2).astype(int)) == ({1, 2} if ndim == 2 else {1, 2, 3})
    # statistically too: mean per direction is length * 6
    means = scaled.reshape(len(lens), -1).mean(axis=1)
    np.testing.assert_allclose(means / lens, 6.0, rtol=0.05)
    np.testing.assert_allclose(weights.Constant().sample(shape, lens).reshape(len(lens), -1)[:, 0], lens)


def test_same_seed_same_weights_other_seed_other_weights(device):
    shape, lens = (32, 48), _lengths(2, 8)
    for cls in (weights.Uniform, weights.Power, weights.Polynomial):
        a = cls(seed=5).sample(shape, lens, device=device)
        b = cls(seed=5).sample(shape, lens, device=device)
        c = cls(seed=6).sample(shape, lens, device=device)
        np.testing.assert_array_equal(a, b)
        assert np.mean(a == c) < 0.01
        # directions are independent streams too
        assert np.mean(a[0] == a[1]) < 0.01


def test_lattice_takes_a_distribution():
    dist = weights.Power(alpha=3.0, seed=9) * weights.Tropism("bottom", strength=2.0)
    lat = wd.Lattice((12, 17), connectivity=8, weights=dist)
    want = dist.sample((12, 17), lat.lengths)
    for k, off in enumerate(lat.offsets):
        # entries whose neighbour lies outside are never used; the lattice fills them in
        inside = tuple(slice(max(0, -o), n - max(0, o)) for o, n in zip(off, (12, 17)))
        np.testing.assert_array_equal(lat.weights[k][inside], want[k][inside])


# ---------------------------------------------------------------------------
# tropism and maps


def test_tropism_ramp_formula_at_edge_midpoints():
    # 4-connected (1, 5): direction 0 is +x; its midpoint is x + 0.5, so g = (x + 0.5) / 4
    lens = _lengths(2, 4)
    assert tuple(half_offsets(2, 4)[0]) == (0, 1)
    w = (weights.Constant() * weights.Tropism("left", strength=2.0)).sample((1, 5), lens)
    x = np.arange(5)
    # (the last +x edge leaves the lattice; its entry is ignored, and its field clamps to 1)
    np.testing.assert_allclose(w[0, 0, :4], 1 + 2 * (x[:4] + 0.5) / 4, rtol=1e-6)
    # direction 1 is +y, midpoint y + 0.5 = 0.5 on a one-row lattice: g depends on x only
    np.testing.assert_allclose(w[1, 0], 1 + 2 * x / 4, rtol=1e-6)
    w = (weights.Constant() + weights.Tropism("right", strength=3.0, exponent=2.0)).sample((1, 5), lens)
    np.testing.assert_allclose(w[1, 0], 1 + 3 * ((4 - x) / 4) ** 2, rtol=1e-6)


def _side_means(w, axis, ndim):
    """Mean weight over the first and last quarter of the lattice along ``axis`` (all directions)."""
    n = w.shape[1 + axis]
    lo = np.take(w, np.arange(n // 4), axis=1 + axis).mean()
    hi = np.take(w, np.arange(n - n // 4, n), axis=1 + axis).mean()
    return lo, hi


@pytest.mark.parametrize("combine", ["mul", "add"])
@pytest.mark.parametrize(
    "toward,axis,cheap",
    [("left", 1, "lo"), ("right", 1, "hi"), ("top", 0, "lo"), ("bottom", 0, "hi")],
)
def test_tropism_2d_makes_the_named_side_cheaper(toward, axis, cheap, combine):
    base, trop = weights.Uniform(r=10.0, seed=4), weights.Tropism(toward, strength=3.0)
    dist = base * trop if combine == "mul" else base + trop
    w = dist.sample((40, 40), _lengths(2, 8))
    lo, hi = _side_means(w, axis, 2)
    assert (lo < 0.8 * hi) if cheap == "lo" else (hi < 0.8 * lo)


def test_tropism_3d_vertical_and_radius():
    shape, lens = (16, 20, 20), _lengths(3, 6)
    base = weights.Uniform(r=10.0, seed=2)
    # 3D: z (axis 0) runs upward by default, so "top" is high z
    lo, hi = _side_means((base * weights.Tropism("top", strength=3.0)).sample(shape, lens), 0, 3)
    assert hi < 0.8 * lo
    lo, hi = _side_means(
        (base * weights.Tropism("top", strength=3.0, top_at_zero=True)).sample(shape, lens), 0, 3
    )
    assert lo < 0.8 * hi
    zz, yy, xx = np.meshgrid(*map(np.arange, shape), indexing="ij")
    r = np.hypot(yy - 9.5, xx - 9.5)
    near, far = r < 4, r > 11
    w = (base * weights.Tropism("axis", strength=3.0)).sample(shape, lens).mean(axis=0)
    assert w[near].mean() < 0.7 * w[far].mean()
    w = (base * weights.Tropism("away_from_axis", strength=3.0)).sample(shape, lens).mean(axis=0)
    assert w[far].mean() < 0.7 * w[near].mean()
    # an off-centre axis moves the cheap column
    w = (weights.Constant() * weights.Tropism("axis", strength=3.0, center=(2.0, 15.0))).sample(shape, lens)
    assert np.unravel_index(np.argmin(w.mean(axis=(0, 1))), (20, 20)) == (2, 15)


def test_tropism_2d_axis_is_horizontal_distance():
    w = (weights.Constant() * weights.Tropism("axis", strength=4.0)).sample((9, 21), _lengths(2, 4))
    # direction 1 (+y) has midpoints at integer x: g = |x - 10| / 10, independent of the row
    x = np.arange(21)
    np.testing.assert_allclose(w[1], np.broadcast_to(1 + 4 * np.abs(x - 10) / 10, (9, 21)), rtol=1e-6)


def _half_dark(shape):
    img = np.ones(shape, np.uint8) * 255
    img[:, : shape[1] // 2] = 0
    return img


@pytest.mark.parametrize("dark,left_cheaper", [("cheaper", True), ("dearer", False)])
def test_map_darkness_effect(dark, left_cheaper):
    shape = (30, 40)
    w = (weights.Uniform(seed=1) * weights.Map(_half_dark(shape), strength=4.0, dark=dark)).sample(
        shape, _lengths(2, 4)
    )
    left, right = w[:, :, :15].mean(), w[:, :, 25:].mean()
    assert (left < 0.5 * right) if left_cheaper else (right < 0.5 * left)


def test_map_uses_mean_of_edge_ends():
    b = np.array([[0.0, 1.0, 0.5]], np.float32)
    w = (weights.Constant() + weights.Map(b, strength=2.0)).sample((1, 3), _lengths(2, 4))
    # +x edges: mean of both ends; the last +x edge leaves the lattice and takes its inside end
    np.testing.assert_allclose(w[0, 0], [1 + 2 * 0.5, 1 + 2 * 0.75, 1 + 2 * 0.5])


def test_map_from_file_and_pil_image_equal_array(tmp_path):
    shape = (12, 16)
    img = (np.arange(np.prod(shape)).reshape(shape) % 251).astype(np.uint8)
    path = tmp_path / "sketch.png"
    Image.fromarray(img).save(path)
    lens = _lengths(2, 8)
    ref = (weights.Uniform(seed=3) * weights.Map(img, strength=2.0)).sample(shape, lens)
    for src in (path, str(path), Image.open(path)):
        got = (weights.Uniform(seed=3) * weights.Map(src, strength=2.0)).sample(shape, lens)
        np.testing.assert_array_equal(got, ref)
    # an RGB file is read as grayscale
    Image.fromarray(np.stack([img] * 3, axis=-1)).save(tmp_path / "rgb.png")
    got = (weights.Uniform(seed=3) * weights.Map(tmp_path / "rgb.png", strength=2.0)).sample(shape, lens)
    np.testing.assert_array_equal(got, ref)


def test_maps_read_16_bit_float_and_transparent_images_as_their_brightness(tmp_path):
    ramp = np.tile(np.linspace(0.0, 1.0, 8), (4, 1))
    from wdendrite.io import save_png

    path = save_png(tmp_path / "ramp16.png", ramp, bits=16)
    want = np.round(ramp * 65535) / 65535
    # Pillow < 10.3 opens 16-bit PNGs as mode "I"; "I" had been clipped to 255 (all white)
    for img in (Image.open(path), Image.open(path).convert("I")):
        np.testing.assert_allclose(weights.Map(img).brightness, want, atol=1e-6)
    # float images are brightness already ("F" had been truncated to 0, all black)
    f = Image.fromarray(ramp.astype(np.float32))
    assert f.mode == "F"
    np.testing.assert_allclose(weights.Map(f).brightness, ramp, atol=1e-6)
    # a sketch on a transparent background: the background reads as white paper, the strokes dark
    rgba = np.zeros((4, 8, 4), np.uint8)
    rgba[:, 3, 3] = 255  # one opaque black column
    want = np.where(np.arange(8) == 3, 0.0, 1.0)[None].repeat(4, 0)
    np.testing.assert_array_equal(weights.Map(Image.fromarray(rgba)).brightness, want)
    with pytest.raises(ValueError, match="16-bit grayscale image for 'image'"):
        weights.Map(Image.fromarray(np.full((2, 2), 70000, np.int32)))


# ---------------------------------------------------------------------------
# in-kernel evaluation equals the stored array


@pytest.mark.parametrize("ndim,conn", [(2, 8), (3, 26)])
def test_single_edge_evaluation_equals_sampled_array(ndim, conn, device):
    shape = (13, 17) if ndim == 2 else (5, 6, 7)
    lens = _lengths(ndim, conn)
    rng = np.random.default_rng(0)
    bright = rng.random(shape).astype(np.float32)
    dist = (
        weights.Polynomial(n=3.0, seed=8)
        + weights.Map(bright, strength=50.0, exponent=2.0)
        + weights.Tropism("away_from_axis", strength=9.0)
    ) * weights.Tropism("left", strength=1.5)
    full = dist.sample(shape, lens, device=device).reshape(len(lens), -1)
    nodes = rng.integers(0, full.shape[1], 200)
    ks = rng.integers(0, len(lens), 200)
    got = dist.evaluate(shape, lens, nodes, ks, device=device)
    np.testing.assert_array_equal(got, full[ks, nodes])


def test_kernel_params_struct():
    p = weights.Uniform(r=4.0, seed=3).kernel_params((8, 8), "cpu")
    assert isinstance(p, kw.WeightParams.cls)
    assert (p.kind, p.a, int(p.seed), p.num_terms) == (kw.UNIFORM, 4.0, 3, 0)
    q = (weights.Power(alpha=2.0, max=5.0) * weights.Tropism("left")).kernel_params((8, 8), "cpu")
    assert (q.kind, q.a, q.b, q.num_terms) == (kw.POWER, 2.0, 5.0, 1)


# ---------------------------------------------------------------------------
# bad input


@pytest.mark.parametrize(
    "make,name",
    [
        (lambda: weights.Uniform(r=-1.0), "'r'"),
        (lambda: weights.Uniform(r=float("nan")), "'r'"),
        (lambda: weights.Uniform(r=float("inf")), "'r'"),
        (lambda: weights.Power(alpha=0.0), "'alpha'"),
        (lambda: weights.Power(alpha=-2.0), "'alpha'"),
        (lambda: weights.Power(max=1.0), "'max'"),
        (lambda: weights.Power(max=0.5), "'max'"),
        (lambda: weights.Power(alpha=40.0, max=100.0), "'alpha'"),
        (lambda: weights.Polynomial(n=-1.0), "'n'"),
        (lambda: weights.Polynomial(n=30.0), "'n'"),
        (lambda: weights.Uniform(seed=-1), "'seed'"),
        (lambda: weights.Uniform(seed=2**32), "'seed'"),
        (lambda: weights.Constant(value=-1.0), "'value'"),
        (lambda: weights.Constant(value=1e-50), "'value' >= 1.175e-38"),  # would round to 0 in float32
        (lambda: weights.Constant(value=1e31), "'value' < 1e\\+30"),
        (lambda: weights.Biased(weights.Uniform(), ((weights.Tropism("left"), 7),)), "op in 'terms'"),
        (lambda: weights.Tropism("up"), "'toward'"),
        (lambda: weights.Tropism("left", strength=-1.0), "'strength'"),
        (lambda: weights.Tropism("left", exponent=0.0), "'exponent'"),
        (lambda: weights.Tropism("axis", center=(1.0, 2.0, 3.0)), "'center'"),
        (lambda: weights.Map(np.zeros((4, 4)), dark="black"), "'dark'"),
        (lambda: weights.Map(np.full((4, 4), 2.0)), "'image'"),
        (lambda: weights.Map(np.zeros(4)), "'image'"),
    ],
)
def test_bad_parameters_raise_value_error_naming_them(make, name):
    with pytest.raises(ValueError, match=name):
        make()


@pytest.mark.parametrize(
    "make,name",
    [
        (lambda: weights.Uniform(r="ten"), "'r'"),
        (lambda: weights.Uniform(seed=1.5), "'seed'"),
        (lambda: weights.Map(np.zeros((4, 4), np.int64)), "'image'"),
        (lambda: weights.Map(None), "'image'"),
    ],
)
def test_bad_types_raise_type_error_naming_them(make, name):
    with pytest.raises(TypeError, match=name):
        make()


def test_unreadable_image_raises(tmp_path):
    with pytest.raises(ValueError, match="Could not read 'image'.*missing.png"):
        weights.Map(tmp_path / "missing.png")
    bad = tmp_path / "corrupt.png"
    bad.write_bytes(b"not an image at all")
    with pytest.raises(ValueError, match="Could not read 'image'.*corrupt.png"):
        weights.Map(bad)


def test_map_of_the_wrong_size_raises_before_launch():
    dist = weights.Uniform() * weights.Map(np.zeros((10, 10), np.float32))
    with pytest.raises(ValueError, match=r"'image' of the lattice shape \(10, 12\).*\(10, 10\)"):
        dist.sample((10, 12), _lengths(2, 4))
    with pytest.raises(ValueError, match="'image'"):
        wd.Lattice((10, 12), weights=dist)


def test_tropism_center_of_the_wrong_rank_raises():
    dist = weights.Uniform() * weights.Tropism("axis", center=(1.0, 2.0))
    with pytest.raises(ValueError, match="'center'"):
        dist.sample((10, 12), _lengths(2, 4))


def test_composition_rules():
    u, t = weights.Uniform(), weights.Tropism("left")
    assert isinstance(t * u, weights.Biased) and isinstance(u + t, weights.Biased)
    with pytest.raises(ValueError, match="added after"):
        (u * t) + weights.Tropism("top")
    with pytest.raises(TypeError):
        u * 2.0
    with pytest.raises(TypeError):
        t * weights.Tropism("top")


def test_overflowing_composite_raises():
    dist = weights.Power(alpha=8.0, max=1000.0) * weights.Tropism("left", strength=1e10)
    with pytest.raises(ValueError, match="above the supported"):
        dist.sample((4, 4), _lengths(2, 4))


def test_constant_weights_must_be_positive():
    with pytest.raises(ValueError, match="value"):
        weights.Constant(0.0)


def test_smallest_constant_weight_stays_positive_in_the_lattice():
    tiny = float(np.finfo(np.float32).tiny)
    lat = wd.Lattice((3, 4), 8, weights=weights.Constant(tiny))
    assert lat.weights.min() > 0
    with pytest.raises(TypeError, match="'terms'"):
        weights.Biased(weights.Uniform(), (weights.Tropism("left"),))


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: weights.Uniform(r="1"), "'r'"),
        (lambda: weights.Power(alpha="3"), "'alpha'"),
        (lambda: weights.Tropism("left", strength="2"), "'strength'"),
        (lambda: weights.Uniform(r=True), "'r'"),
    ],
)
def test_text_and_bools_are_not_numbers(make, match):
    with pytest.raises(TypeError, match=match):
        make()


def test_an_empty_map_is_refused():
    with pytest.raises(ValueError, match="non-empty"):
        weights.Map(np.zeros((0, 0)))


def test_a_distribution_class_instead_of_an_instance_is_refused():
    with pytest.raises(TypeError, match=r"class Uniform \(call it"):
        wd.Lattice((8, 8), weights=weights.Uniform)


@pytest.mark.parametrize(
    "make, plain",
    [
        (lambda: weights.Uniform(r=np.array(5.0), seed=np.uint32(3)), lambda: weights.Uniform(r=5.0, seed=3)),
        (lambda: weights.Power(alpha=np.float32(0.5), max=np.int64(4)), lambda: weights.Power(alpha=0.5, max=4.0)),
        (lambda: weights.Constant(np.float16(2)), lambda: weights.Constant(2.0)),
        (lambda: weights.Polynomial(n=np.int8(2)), lambda: weights.Polynomial(n=2.0)),
        (lambda: weights.Tropism("axis", strength=np.float32(2), center=np.array([4]), top_at_zero=np.True_),
         lambda: weights.Tropism("axis", strength=2.0, center=(4.0,), top_at_zero=True)),
    ],
)
def test_distributions_keep_plain_values_whatever_numpy_values_made_them(make, plain):
    # (NumPy values had been kept as given: arrays made the distribution unhashable, reprs showed np.float32(...))
    d, ref = make(), plain()
    assert d == ref and hash(d) == hash(ref) and repr(d) == repr(ref)
    if isinstance(d, weights.Tropism):  # a field, which biases a distribution
        d, ref = weights.Uniform() * d, weights.Uniform() * ref
    lat_a, lat_b = wd.Lattice((9, 10), weights=d), wd.Lattice((9, 10), weights=ref)
    np.testing.assert_array_equal(lat_a.weights, lat_b.weights)


def test_top_at_zero_takes_a_bool_or_none():
    assert weights.Tropism("top", top_at_zero=None).top_at_zero is None
    with pytest.raises(TypeError, match="Expected a bool or None for 'top_at_zero', but got 'yes'"):
        weights.Tropism("top", top_at_zero="yes")
