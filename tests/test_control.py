"""Control functions evaluated by the kernels against NumPy formulas."""

import numpy as np
import pytest

from wdendrite import control


def _grid_points(domain, n=9):
    (x0, y0), (x1, y1) = domain
    xs, ys = np.meshgrid(np.linspace(x0, x1, n), np.linspace(y0, y1, n))
    return np.stack([xs.ravel(), ys.ravel()], 1).astype(np.float32)


def test_plane_matches_formula_and_corner_extremes(device):
    c = control.plane((0.5, -2.0), offset=1.0, domain=((0, 0), (2, 1)))
    pts = _grid_points(c.domain)
    np.testing.assert_allclose(c.evaluate(pts, device=device), 1.0 + 0.5 * pts[:, 0] - 2.0 * pts[:, 1], atol=1e-6)
    assert (c.minimum, c.maximum) == (-1.0, 2.0)


def test_radial_ramp_matches_formula_and_extremes(device):
    c = control.radial((0.25, 0.5), radius=2.0, domain=((0, 0), (1, 1)))
    pts = _grid_points(c.domain, 33)
    want = np.hypot(pts[:, 0] - 0.25, pts[:, 1] - 0.5) / 2.0
    np.testing.assert_allclose(c.evaluate(pts, device=device), want, atol=1e-6)
    assert c.minimum == 0.0
    assert c.maximum == pytest.approx(np.hypot(0.75, 0.5) / 2.0)
    outside = control.radial((2.0, 0.5), domain=((0, 0), (1, 1)))
    assert outside.minimum == pytest.approx(1.0)


def test_lichtenberg_bowl_inside_and_outside(device):
    c = control.lichtenberg()
    pts = np.array([[0, 0], [0.5, -1], [-1, 1], [1.5, 0], [0, -1.01]], np.float32)
    np.testing.assert_allclose(c.evaluate(pts, device=device), [1.0, 0.25, 5.0, 16.0, 16.0], atol=1e-6)
    assert c.bounded
    # the declared extremes are those on the domain [-1, 1]^2 (the 16 outside is not the function's)
    inside = _grid_points(c.domain, 201)
    want = inside[:, 0].astype(float) ** 2 + (inside[:, 1].astype(float) + 1) ** 2
    got = c.evaluate(inside, device=device)
    np.testing.assert_allclose(got, want, atol=1e-5)
    assert (c.minimum, c.maximum) == (0.0, 5.0) == (want.min(), want.max())


def test_declared_extremes_bracket_the_samples_on_the_domain(device):
    rng = np.random.default_rng(2)
    controls = [control.plane((0.5, -2.0), offset=1.0, domain=((0, 0), (2, 1))),
                control.radial((0.3, 1.5), radius=0.7, domain=((-1, 0), (1, 2))),
                control.lichtenberg(),
                control.image(rng.random((5, 7)), domain=((0, 0), (7, 5))),
                control.perlin(seed=3, octaves=2, domain=((-0.2, -0.4), (1.4, 0.7))),
                control.ridged(seed=3, octaves=3, domain=((0, 0), (2, 2)))]
    for c in controls:
        v = c.evaluate(_grid_points(c.domain, 301), device=device)
        # every sample lies within the extremes, and the extremes are nearly reached (ridged crests are
        # sharp: a 301^2 grid misses its maximum by about 0.3 % of the range)
        assert c.minimum - 1e-6 <= v.min() and v.max() <= c.maximum + 1e-6, c.kind
        span = c.maximum - c.minimum
        assert v.min() - c.minimum < 5e-3 * span and c.maximum - v.max() < 5e-3 * span, c.kind


def test_image_reproduces_pixels_and_linear_ramps(device):
    rng = np.random.default_rng(0)
    img = rng.random((6, 8)).astype(np.float32)
    c = control.image(img, domain=((0, 0), (8, 6)))
    rows, cols = np.mgrid[0:6, 0:8]
    centres = np.stack([cols.ravel() + 0.5, rows.ravel() + 0.5], 1)
    np.testing.assert_allclose(c.evaluate(centres, device=device), img.ravel(), atol=1e-6)
    # Catmull-Rom interpolation is exact on linear functions away from the clamped border
    ramp = (0.1 * cols + 0.3 * rows).astype(np.float32)
    r = control.image(ramp, domain=((0, 0), (8, 6)))
    pts = rng.uniform([2.0, 2.0], [6.0, 4.0], (50, 2)).astype(np.float32)
    np.testing.assert_allclose(r.evaluate(pts, device=device), 0.1 * (pts[:, 0] - 0.5) + 0.3 * (pts[:, 1] - 0.5), atol=1e-5)
    # overshoot is clamped to the image's range
    step = np.zeros((4, 8), np.float32)
    step[:, 4:] = 1.0
    s = control.image(step, domain=((0, 0), (8, 4))).grid((16, 64), device=device)
    assert s.min() >= 0.0 and s.max() <= 1.0


def test_perlin_is_seeded_and_within_its_extremes(device):
    a = control.perlin(seed=1, octaves=3, domain=((-0.2, -0.4), (1.4, 0.7)))
    b = control.perlin(seed=1, octaves=3, domain=((-0.2, -0.4), (1.4, 0.7)))
    c = control.perlin(seed=2, octaves=3, domain=((-0.2, -0.4), (1.4, 0.7)))
    ga, gb, gc = (x.grid((40, 40), device=device) for x in (a, b, c))
    assert np.array_equal(ga, gb) and not np.array_equal(ga, gc)
    assert a.minimum <= ga.min() + 1e-3 and ga.max() <= a.maximum + 1e-3
    assert 0.0 <= a.minimum < a.maximum <= 1.0
    r = control.ridged(seed=1, domain=((0, 0), (4, 4)))
    gr = r.grid((40, 40), device=device)
    assert gr.std() > 0.01


def _perlin_reference(perm, p):
    """2D Perlin gradient noise in float64: corner hashes perm[perm[x] + y], 8 gradients, quintic fade."""
    gradients = np.array([[1, 1], [-1, 1], [1, -1], [-1, -1], [1, 0], [-1, 0], [0, 1], [0, -1]], float)
    f = np.floor(p)
    x, y = (p - f).T
    ix, iy = (f.astype(np.int64) & 255).T
    fade = lambda t: t**3 * (t * (t * 6 - 15) + 10)  # noqa: E731

    def ramp(cx, cy, ox, oy):
        g = gradients[perm[perm[ix + cx] + iy + cy] & 7]
        return g[:, 0] * (x - ox) + g[:, 1] * (y - oy)

    u, v = fade(x), fade(y)
    low = ramp(0, 0, 0, 0) + u * (ramp(1, 0, 1, 0) - ramp(0, 0, 0, 0))
    high = ramp(0, 1, 0, 1) + u * (ramp(1, 1, 1, 1) - ramp(0, 1, 0, 1))
    return low + v * (high - low)


def test_perlin_equals_a_numpy_gradient_noise(device):
    from wdendrite.control import _permutation

    perm = _permutation(5)
    assert sorted(perm[:256]) == list(range(256)) and (perm[:256] == perm[256:]).all()
    c = control.perlin(seed=5, frequency=1.0, domain=((-3.0, -2.0), (5.0, 4.0)))
    pts = np.random.default_rng(0).uniform((-3, -2), (5, 4), (500, 2)).astype(np.float32)
    np.testing.assert_allclose(c.evaluate(pts, device=device), 0.5 + 0.5 * _perlin_reference(perm, pts.astype(float)),
                               atol=2e-6)
    # zero (0.5 once mapped) at every lattice point
    lattice = np.stack(np.meshgrid(np.arange(-3, 5), np.arange(-2, 4)), -1).reshape(-1, 2).astype(np.float32)
    np.testing.assert_allclose(c.evaluate(lattice, device=device), 0.5, atol=1e-7)


def test_fbm_equals_a_numpy_fractal_sum(device):
    # octaves with their own gain and lacunarity (the one-octave test above takes another path)
    from wdendrite.control import _permutation

    perm = _permutation(9)
    c = control.perlin(seed=9, frequency=1.7, octaves=4, gain=0.6, lacunarity=2.3, domain=((-1.0, 0.0), (2.0, 2.0)))
    pts = np.random.default_rng(2).uniform((-1, 0), (2, 2), (400, 2)).astype(np.float32)
    q = 1.7 * pts.astype(float)
    total = sum(0.6**o * _perlin_reference(perm, 2.3**o * q + _octave_shift(o)) for o in range(4))
    want = 0.5 + 0.5 * total / sum(0.6**o for o in range(4))
    np.testing.assert_allclose(c.evaluate(pts, device=device), want, atol=3e-5)


def _octave_shift(o):
    # the kernels' per-octave offset (golden ratio and sqrt(2) - 1 fractions, times 7)
    return np.array([o * 0.6180339887, o * 0.4142135624]) * 7.0


def ridged_reference(seed, p, *, frequency=1.0, octaves=8, gain=0.5, lacunarity=2.0, offset=1.0):
    """Ridged multifractal in float64: octaves of (offset - |noise|)^2, each weighted by the last one."""
    from wdendrite.control import _permutation

    perm = _permutation(seed)
    q = np.asarray(p, float) * frequency
    total, norm, amp, weight = 0.0, 0.0, 1.0, 1.0
    for o in range(octaves):
        s = (offset - np.abs(_perlin_reference(perm, q + _octave_shift(o)))) ** 2 * weight
        weight = np.clip(2.0 * s, 0.0, 1.0)
        total, norm, amp, q = total + amp * s, norm + amp, amp * gain, q * lacunarity
    return total / norm


def test_ridged_equals_a_numpy_ridged_multifractal(device):
    c = control.ridged(seed=6, frequency=1.3, octaves=4, gain=0.6, lacunarity=2.1, offset=0.9,
                       domain=((-1.0, 0.0), (2.0, 2.0)))
    pts = np.random.default_rng(1).uniform((-1, 0), (2, 2), (400, 2)).astype(np.float32)
    want = ridged_reference(6, pts.astype(float), frequency=1.3, octaves=4, gain=0.6, lacunarity=2.1, offset=0.9)
    np.testing.assert_allclose(c.evaluate(pts, device=device), want, atol=2e-5)
    # the declared extremes hold a dense sampling of the reference and are nearly reached
    dense = ridged_reference(6, _grid_points(c.domain, 401).astype(float), frequency=1.3, octaves=4, gain=0.6,
                             lacunarity=2.1, offset=0.9)
    assert c.minimum <= dense.min() + 1e-5 and dense.max() <= c.maximum + 1e-5
    assert dense.min() - c.minimum < 5e-3 and c.maximum - dense.max() < 5e-3


@pytest.mark.parametrize("seed, frequency, octaves", [(844, 5.437226844597018, 5), (412, 6.1, 4), (7, 3.3, 6)])
def test_ridged_maximum_holds_a_dense_grid_of_its_creases(seed, frequency, octaves):
    # the maxima lie on creases a 257^2 grid straddles: the declared maximum had been 0.981
    # where a 2049^2 grid reaches 0.989 (the first case)
    c = control.ridged(seed=seed, frequency=frequency, octaves=octaves, domain=((-1, -0.5), (1.3, 0.9)))
    dense = c.grid((2049, 2049), device="cpu")
    assert dense.max() <= c.maximum + 1e-6 and c.minimum <= dense.min() + 1e-6


def test_an_image_control_keeps_its_own_copy():
    a = np.zeros((4, 4), np.float32)
    a[1, 1] = 1.0
    c = control.image(a)
    a[:] = 5.0  # the caller's array changes; the frozen control must not
    assert c.maximum == 1.0 and c.values.max() == 1.0 and not c.values.flags.writeable
    assert c.evaluate([[0.375, 0.375]], device="cpu")[0] == pytest.approx(1.0)


def test_noise_extremes_are_refined_beyond_the_sampling_grid(device):
    c = control.perlin(seed=2, octaves=2, domain=((0.0, 0.0), (3.0, 2.0)))
    dense = c.grid((1500, 1000), device=device)
    # the extremes hold the dense samples (up to float32 rounding) and are nearly reached by them
    assert c.minimum <= dense.min() + 1e-6 and dense.max() <= c.maximum + 1e-6
    assert dense.min() - c.minimum < 1e-4 and c.maximum - dense.max() < 1e-4


def test_grid_equals_evaluate_at_pixel_centres(device):
    c = control.perlin(seed=3, frequency=2.0, domain=((0, 0), (2, 1)))
    g = c.grid((4, 8), device=device)
    rows, cols = np.mgrid[0:4, 0:8]
    pts = np.stack([(cols.ravel() + 0.5) * 0.25, (rows.ravel() + 0.5) * 0.25], 1)
    np.testing.assert_allclose(g.ravel(), c.evaluate(pts, device=device), atol=1e-6)


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: control.image(np.zeros((0, 4))), r"non-empty 2D .* for 'values', but got shape \(0, 4\)"),
        (lambda: control.image(np.zeros((4,))), r"2D .* for 'values', but got shape \(4,\)"),
        (lambda: control.image(np.zeros((2, 2, 2))), r"2D .* for 'values', but got shape \(2, 2, 2\)"),
        (lambda: control.image(np.array([[0.0, np.nan]])), r"'values' must be finite.*first at \(0, 1\): nan"),
        (lambda: control.image(np.array([["a"]])), r"real-valued .* for 'values', but got dtype <U1"),
        (lambda: control.perlin(domain=((1, 0), (0, 1))), "domain"),
        (lambda: control.perlin(domain=((0, 0), (0, 1))), "domain"),
        (lambda: control.perlin(octaves=0), "octaves"),
        (lambda: control.radial(radius=-1.0), "radius"),
        (lambda: control.plane((np.inf, 0.0)), "gradient"),
        (lambda: control.image([[0.0, 1.0], [1.0]]), "'values', but got rows of different lengths"),
        (lambda: control.image(np.array([[1e39, 1.0]])), r"'values'.*1e\+39 \(too large for float32\)"),
        # ranges that float32 cannot hold: the kernels would give inf or NaN everywhere
        (lambda: control.perlin(gain=1e6, octaves=8), "a smaller 'gain' or fewer 'octaves'"),
        (lambda: control.ridged(gain=1e10), "a smaller 'gain' or fewer 'octaves', or a smaller 'offset'"),
        (lambda: control.ridged(offset=1e30), "'offset'"),
        (lambda: control.plane((1e200, 0.0)), "'gradient'"),
        (lambda: control.radial(radius=1e-44), "'radius'"),
        (lambda: control.lichtenberg(1e300), "'scale'"),
    ],
)
def test_bad_input_raises(make, match):
    with pytest.raises((ValueError, TypeError), match=match):
        make()


def _interior_drains(v: np.ndarray) -> bool:
    """True when every interior sample of ``v`` has a strictly lower 8-neighbour."""
    h, w = v.shape
    pad = np.pad(v, 1, constant_values=np.inf)
    lower = np.zeros(v.shape, bool)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr or dc:
                lower |= pad[1 + dr : 1 + dr + h, 1 + dc : 1 + dc + w] < v
    return bool(lower[1:-1, 1:-1].all())


def test_drained_control_has_no_interior_minimum(device):
    from scipy.ndimage import minimum_filter

    # a bowl whose lowest point lies inside its rectangle
    base = control.radial((0.6, 0.1), radius=2.0, domain=((-0.2, -0.4), (1.4, 0.7)))
    g = base.grid((65, 65), device=device)
    inner = (g == minimum_filter(g, size=3, mode="nearest"))[1:-1, 1:-1]
    assert inner.any()  # the base field has a pit inside its rectangle
    d = control.drained(base, samples=65)
    v = d.values
    assert (v >= g - 1e-6).all() and d.domain == base.domain
    assert _interior_drains(v)  # water reaches the border
    # with no rise it is the plain depression fill, which scikit-image's reconstruction gives apart
    from wdendrite import hydrology

    flat = control.drained(base, samples=65, slope=0.0).values
    np.testing.assert_array_equal(flat, hydrology.fill(g).astype(np.float32))
    # the rises tilt the filled pit (and the gentle slopes below its outlet) towards the border: at
    # most a rise per step of the way out, so fewer than the grid's side of them
    pit = flat > g
    rise = 1e-4 * (base.maximum - base.minimum)
    assert pit.sum() > 1000 and (v[pit] > flat[pit]).mean() > 0.9
    assert (v - flat).max() <= 65 * rise * 1.001
    with pytest.raises(ValueError, match="samples"):
        control.drained(base, samples=2)


def test_drained_control_stays_in_its_bases_range():
    # a pit ringed by the base's maximum drains only by filling above that maximum: the samples
    # are first scaled towards their minimum instead, so a control in [0, 1] stays a terrain's
    # control (a drained map in [0, 1] had spanned [0.15, 1.0001] and been refused)
    import wdendrite as wd

    a = np.full((9, 9), 0.5)
    a[1:-1, 1:-1] = 1.0
    a[2:-2, 2:-2] = 0.0
    base = control.image(a)
    g = base.grid((33, 33))
    assert g.max() == base.maximum == 1.0 and g[16, 16] == 0.0
    d = control.drained(base, samples=33)
    v = d.values
    assert base.minimum <= d.minimum and d.maximum <= base.maximum
    assert _interior_drains(v) and v[16, 16] > 0.99  # the pit filled to its rim, and drains
    # the scale is the least that does it: the rim's samples moved by about the fill's rise
    rim = g == 1.0
    assert 0.0 < (g - v)[rim].max() < 0.01
    z = wd.dendry((16, 16), domain=((0.0, 0.0), (1.0, 1.0)), params=wd.DendryParams(levels=2), control=d,
                  output="elevation")
    assert np.isfinite(z).all()


@pytest.mark.parametrize(
    "shape, exc, match",
    [
        ((0, 0), ValueError, r"positive sizes in 'shape', but got \(0, 0\)"),
        ((-2, 3), ValueError, r"positive sizes in 'shape', but got \(-2, 3\)"),
        ((2.7, 3), TypeError, r"integer sizes in 'shape', but got \(2\.7, 3\)"),
        ((4, 4, 4), ValueError, r"'shape' of rank 2 \(H, W\), but got \(4, 4, 4\)"),
        ((4,), ValueError, r"'shape'.*\(4,\)"),
        (None, TypeError, "'shape', but got None"),
        (5, TypeError, r"Expected a tuple \(H, W\) for 'shape', but got 5$"),  # (had offered (D, H, W) too)
    ],
)
def test_bad_grid_shape_names_shape(shape, exc, match):
    with pytest.raises(exc, match=match):
        control.plane().grid(shape)


def test_grid_larger_than_free_memory_raises(monkeypatch):
    from wdendrite import _checks

    monkeypatch.setattr(_checks, "available_bytes", lambda device: 4 * 64 * 64 - 1)
    with pytest.raises(MemoryError, match=r"'shape' \(64, 64\)"):
        control.plane().grid((64, 64))
    assert control.plane().grid((32, 32)).shape == (32, 32)


@pytest.mark.parametrize(
    "make, exc, match",
    [
        (lambda: control.plane(offset="a"), TypeError, "'offset', but got 'a'"),
        (lambda: control.plane(offset=np.nan), ValueError, "'offset', but got nan"),
        (lambda: control.plane(offset=True), TypeError, "'offset', but got True"),
        (lambda: control.plane(("a", 1.0)), TypeError, r"'gradient', but got \('a', 1\.0\)"),
        (lambda: control.plane((1.0, np.nan)), ValueError, r"'gradient', but got \(1\.0, nan\)"),
        (lambda: control.plane(1.0), TypeError, "'gradient', but got 1.0"),
        (lambda: control.radial(("x", 0.5)), TypeError, r"'center', but got \('x', 0\.5\)"),
        (lambda: control.radial(radius="1"), TypeError, "'radius', but got '1'"),
        (lambda: control.perlin(frequency="2"), TypeError, "'frequency', but got '2'"),
        (lambda: control.perlin(gain=True), TypeError, "'gain', but got True"),
        (lambda: control.perlin(lacunarity=np.inf), ValueError, "'lacunarity', but got inf"),
        (lambda: control.ridged(offset="1"), TypeError, "'offset', but got '1'"),
        (lambda: control.perlin(octaves=2.0), TypeError, "'octaves', but got 2.0"),
        (lambda: control.perlin(octaves=17), ValueError, "'octaves' in \\[1, 16\\], but got 17"),
        (lambda: control.perlin(seed=1.5), TypeError, "'seed', but got 1.5"),
        (lambda: control.perlin(seed=-5), ValueError, r"'seed' in \[0, 2\*\*32\), but got -5"),
        (lambda: control.ridged(seed=2**32), ValueError, r"'seed' in \[0, 2\*\*32\), but got 4294967296"),
        (lambda: control.perlin(domain=((0, 0), (1, "1"))), TypeError, r"'domain', but got \(\(0, 0\), \(1, '1'\)\)"),
        (lambda: control.perlin(domain=((0, 0), (1, np.nan))), ValueError, r"'domain', but got .*nan"),
        (lambda: control.drained(control.plane(), samples=3.0), TypeError, "'samples', but got 3.0"),
        (lambda: control.drained(control.plane(), slope="x"), TypeError, "'slope', but got 'x'"),
        (lambda: control.plane().evaluate([["a", "b"]]), TypeError, "'points', but got dtype <U1"),
    ],
)
def test_bad_numbers_name_the_parameter_and_value(make, exc, match):
    with pytest.raises(exc, match=match):
        make()


def test_every_seed_bit_selects_the_field():
    # seeds are used whole: 2**31 is not seed 0 again (they once were, taken modulo 2**31)
    fields = [control.perlin(seed=s).grid((16, 16)) for s in (0, 2**31, 2**32 - 1)]
    assert not np.array_equal(fields[0], fields[1]) and not np.array_equal(fields[0], fields[2])
    np.testing.assert_array_equal(fields[1], control.perlin(seed=2**31).grid((16, 16)))


def test_an_image_control_keeps_its_border_values_far_away(device):
    # past 2**31 pixel units the tap index overflowed int32 and read the first pixel instead
    c = control.image([[0.2, 0.9], [0.9, 0.9]])
    far = c.evaluate([[1e10, 1e10], [1e10, 0.25], [-1e10, -1e10], [1e12, 1e12]], device=device)
    np.testing.assert_allclose(far, [0.9, 0.9, 0.2, 0.9], atol=1e-6)


def test_a_masked_image_is_refused():
    with pytest.raises(ValueError, match="'values' is a masked array with 1 masked cells"):
        control.image(np.ma.masked_array([[0.0, 1e9], [2.0, 3.0]], mask=[[0, 1], [0, 0]]))
    assert control.image(np.ma.masked_array([[0.0, 1.0]], mask=[[0, 0]])).maximum == 1.0  # nothing masked


def test_drained_rises_survive_float32_and_slope_is_bounded():
    # a plane offset by 1000 rising 1e-3: rises of 1e-4 of its range are below float32's spacing
    # there, and had vanished in the cast from float64 (54 cells with no lower neighbour)
    assert _interior_drains(control.drained(control.plane((0.0, 1e-3), offset=1000.0), samples=20).values)
    for slope in (1e40, 1.5):
        with pytest.raises(ValueError, match=r"'slope' in \[0, 1\]"):
            control.drained(control.plane(), slope=slope)


@pytest.mark.parametrize("slope", [0.01, 0.015, 0.03])
def test_a_steep_drained_slope_keeps_its_promise_or_is_refused(slope):
    # 0.015 and 0.03 had left a flat 61 x 61 plateau at the maximum (the rescaling gave up after 8
    # rounds and the values were clipped): every interior sample must keep a strictly lower
    # neighbour and the range, else the slope is refused by name
    base = control.perlin(seed=1, frequency=4, octaves=4)
    if slope == 0.03:  # its rises alone climb past the range
        with pytest.raises(ValueError, match=r"'slope' = 0.03 tilts the filled basins"):
            control.drained(base, slope=slope)
        return
    d = control.drained(base, slope=slope)
    v = d.values
    assert _interior_drains(v) and base.minimum <= d.minimum and d.maximum <= base.maximum
    assert (v == v.max()).sum() < 10


def test_drained_refuses_a_constant_base_and_keeps_a_bounded_ones_domain():
    import wdendrite as wd

    # a constant base had come back 1 + 7.6e-6 (its rises above its only value), which a terrain refused
    with pytest.raises(ValueError, match="'base' takes the one value 1.0 at all 129 x 129 samples"):
        control.drained(control.image(np.ones((4, 4))))
    # the Lichtenberg bowl is bounded: beyond its square there is no tree, drained or not
    bowl = control.lichtenberg(scale=0.2)
    d = control.drained(bowl)
    assert bowl.bounded and d.bounded and d.domain == bowl.domain
    kw = dict(domain=((-6.0, -6.0), (6.0, 6.0)), control_domain=((-6.0, -6.0), (6.0, 6.0)),
              params=wd.DendryParams(levels=1))
    for c in (bowl, d):
        z = wd.dendry((24, 24), control=c, **kw)
        assert np.isinf(z[:3]).all() and np.isfinite(z[9:15, 9:15]).all()


def test_evaluate_checks_its_points_as_the_rest_of_the_api_does():
    c = control.perlin()
    assert c.evaluate([]).shape == (0,) and c.evaluate(np.zeros((0, 2))).shape == (0,)  # as dendry_points([])
    for pts, exc, match in [
        # a noise sampled beyond float32's reach had come back flat (0.5) or NaN without a word
        ([[1e8, 0.3]], ValueError, r"'points' reaches 1e\+08 in the perlin control's coordinates"),
        ([[1.0, 2.0], [3.0]], ValueError, r"\(N, 2\) array for 'points', but got rows of different lengths"),
        ([[1e39, 1.0]], ValueError, r"'points' must fit in float32.*1e\+39"),
        ([[np.nan, 1.0]], ValueError, r"'points' must be finite"),
        (np.zeros((3, 3)), ValueError, r"\(N, 2\) array for 'points', but got shape \(3, 3\)"),
    ]:
        with pytest.raises(exc, match=match):
            c.evaluate(pts)
    with pytest.raises(ValueError, match=r"ridged control's coordinates.*over 8 octaves"):
        control.ridged().evaluate([[3e38, 1.0]])
    with pytest.raises(ValueError, match=r"frequency 1e\+07.*lower 'frequency', 'lacunarity' or 'octaves'"):
        control.perlin(frequency=1e7)
    # just inside the reach the noise still varies
    v = control.perlin(frequency=1.0).evaluate([[4.0e6 + 0.25, 0.25], [4.0e6 + 0.5, 0.5]])
    assert np.isfinite(v).all() and v[0] != v[1]


@pytest.mark.parametrize(
    "change, exc, words",
    [
        (dict(seed=-5), ValueError, "'seed'"),
        (dict(kind="bogus"), ValueError, "'kind' in"),  # (had been a KeyError at evaluate)
        (dict(octaves=0), ValueError, "'octaves'"),
        (dict(octaves=2.5), TypeError, "'octaves'"),
        (dict(params=(1.0, 0.5)), ValueError, "'params' as 4 numbers"),
        (dict(params=(1.0, 0.5, 2.0, np.nan)), ValueError, r"'params\[3\]'"),
        (dict(domain=((0, 0), (0, 1))), ValueError, "'domain'"),
        (dict(minimum=2.0, maximum=1.0), ValueError, "'minimum' <= 'maximum'"),
        (dict(minimum="0"), TypeError, "'minimum'"),
        (dict(bounded="no"), TypeError, "'bounded'"),
        (dict(values=np.zeros((2, 2))), ValueError, "'values' for an image control only, but got an array for kind"),
    ],
)
def test_a_control_replaced_by_hand_is_checked(change, exc, words):
    import dataclasses

    base = control.perlin(seed=3, domain=((0.0, 0.0), (2.0, 1.0)))
    with pytest.raises(exc, match=words):
        dataclasses.replace(base, **change)


def test_a_replaced_control_keeps_plain_values():
    import dataclasses

    base = control.plane((1.0, 2.0))
    c = dataclasses.replace(base, params=np.array([0.0, 1.0, 2.0, 0.0], np.float32), minimum=np.float32(0))
    assert c.params == (0.0, 1.0, 2.0, 0.0) and type(c.minimum) is float
    np.testing.assert_array_equal(c.evaluate([[0.5, 0.5]]), base.evaluate([[0.5, 0.5]]))


def test_a_controls_values_are_its_own_even_when_replaced():
    import dataclasses

    base = np.linspace(0.0, 1.0, 16, dtype=np.float32).reshape(4, 4)
    c = control.image(base)
    own = base.copy()
    twin = dataclasses.replace(c, values=own)  # a float32 array that finite_array hands back as it is
    base[:] = 0.5
    own[:] = 0.5  # (had changed the replaced control while its minimum and maximum stayed)
    np.testing.assert_array_equal(c.values, twin.values)
    assert c.values[0, 0] == 0.0 and c.values[-1, -1] == 1.0
    with pytest.raises(ValueError, match="read-only"):
        twin.values[0, 0] = 1.0


def test_an_image_control_needs_values_and_keeps_them_read_only_when_copied():
    import copy
    import dataclasses
    import pickle

    c = control.image(np.linspace(0.0, 1.0, 9).reshape(3, 3))
    with pytest.raises(ValueError, match="An image control needs its 'values', but got none"):
        dataclasses.replace(c, values=None)
    for twin in (pickle.loads(pickle.dumps(c)), copy.deepcopy(c)):  # (their values had been writeable)
        with pytest.raises(ValueError, match="read-only"):
            twin.values[0, 0] = 5.0
        np.testing.assert_array_equal(twin.evaluate([[0.5, 0.5]]), c.evaluate([[0.5, 0.5]]))
