"""Dendry against a brute-force NumPy construction of the whole tree, plus locality properties.

The reference re-implements the counter-based hash in NumPy, builds the key
points and straight segments of every cell of a region (no smoothing, no
subdivision), and measures distances to all of them.
"""

import numpy as np
import pytest
import warp as wp

from wdendrite import control
from wdendrite.dendry import DendryParams, dendry, dendry_points
from wdendrite.kernels import dendry as _kd

# ------------------------------------------------------------------ NumPy reference

_M = 0xFFFFFFFF


def _mix32(x):
    x = np.asarray(x, np.uint64) & _M
    x ^= x >> 16
    x = (x * 0x7FEB352D) & _M
    x ^= x >> 15
    x = (x * 0x846CA68B) & _M
    x ^= x >> 16
    return x


def _hash3(seed, a, b):
    h = _mix32(np.uint64(seed) ^ 0x9E3779B9)
    h = _mix32(h ^ (np.asarray(a, np.int64).astype(np.uint64) & _M))
    return _mix32(((h + 0x632BE5AB) & _M) ^ (np.asarray(b, np.int64).astype(np.uint64) & _M))


def _cell_rand(seed, level, ci, cj, stream):
    # one hash of (seed + level * golden, cell), then a Weyl step and one mix per stream
    key = _hash3((seed + level * 0x9E3779B9) & _M, ci, cj)
    return ((_mix32((key + stream * 0x9E3779B9) & _M) >> 9).astype(np.float64) + 0.5) / 8388608.0


def _key_points(seed, eps, level, ci, cj):
    h = 1.0 / 2 ** (level - 1)
    span = 1.0 - 2.0 * eps
    x = (ci + eps + span * _cell_rand(seed, level, ci, cj, 0)) * h
    y = (cj + eps + span * _cell_rand(seed, level, ci, cj, 1)) * h
    return np.stack([x, y], -1)


def _project(q, a, b):
    ab = b - a
    den = (ab * ab).sum(-1)
    t = np.clip(((q - a) * ab).sum(-1) / np.where(den > 0, den, 1.0), 0.0, 1.0)
    t = np.where(den > 0, t, 0.0)
    return t, np.linalg.norm(q - (a + t[..., None] * ab), axis=-1)


class _Tree:
    """Straight-segment Dendry tree on cells lo..hi-1 of level 1 (grid units), all in float64."""

    def __init__(self, params, ctl, lo, hi):
        self.p = params
        self.ctl = ctl
        ci, cj = np.meshgrid(np.arange(lo, hi), np.arange(lo, hi), indexing="ij")
        pts = _key_points(params.seed, params.eps, 1, ci, cj)
        z = ctl.evaluate((pts / params.resolution).reshape(-1, 2)).reshape(ci.shape).astype(np.float64)
        n = hi - lo
        segs, zs = [], []
        for i in range(1, n - 1):
            for j in range(1, n - 1):
                block = z[i - 1 : i + 2, j - 1 : j + 2]
                # the lowest of the 3 x 3, the centre itself on ties (scan order j-major like the kernel)
                best, bz = (i, j), z[i, j]
                for dy in (-1, 0, 1):
                    for dx in (-1, 0, 1):
                        if block[dx + 1, dy + 1] < bz:
                            bz, best = block[dx + 1, dy + 1], (i + dx, j + dy)
                segs.append((pts[i, j], pts[best]))
                zs.append((z[i, j], z[best]))
        self.segs = [np.array(segs)]
        self.zs = [np.array(zs)]
        self.points = {1: {(lo + i, lo + j): pts[i, j] for i in range(n) for j in range(n)}}
        self.lo, self.hi = lo, hi

    def add_level(self, level, slope):
        """New key points join the globally nearest segment (terrain rule: a, midpoint or b)."""
        f = 2 ** (level - 1)
        lo, hi = (self.lo + 2) * f, (self.hi - 2) * f
        allseg = np.concatenate(self.segs)
        allz = np.concatenate(self.zs)
        segs, zs, pts = [], [], {}
        for ci in range(lo, hi):
            for cj in range(lo, hi):
                parent = self.points[level - 1].get((ci >> 1, cj >> 1))
                if parent is not None and tuple(np.floor(parent * f).astype(int)) == (ci, cj):
                    pts[(ci, cj)] = parent
                    continue
                q = _key_points(self.p.seed, self.p.eps, level, np.array(ci), np.array(cj))
                pts[(ci, cj)] = q
                _, d = _project(q, allseg[:, 0], allseg[:, 1])
                k = int(np.argmin(d))
                a, b = allseg[k]
                cand = [a, (a + b) / 2, b]
                tc = [0.0, 0.5, 1.0][int(np.argmin([np.linalg.norm(q - c) for c in cand]))]
                x = a + tc * (b - a)
                zx = allz[k, 0] + tc * (allz[k, 1] - allz[k, 0])
                zq = max(float(self.ctl.evaluate(q[None] / self.p.resolution)[0]), zx + slope * np.linalg.norm(q - x) / self.p.resolution)
                segs.append((q, x))
                zs.append((zq, zx))
        self.points[level] = pts
        self.segs.append(np.array(segs))
        self.zs.append(np.array(zs))

    def nearest(self, u):
        """(distance in domain units, z at the nearest point, level) for (N, 2) grid points."""
        best = np.full(len(u), np.inf)
        z = np.zeros(len(u))
        lev = np.zeros(len(u))
        self.per_level = []
        for level, (s, zz) in enumerate(zip(self.segs, self.zs), start=1):
            t, d = _project(u[:, None, :], s[None, :, 0], s[None, :, 1])
            k = np.argmin(d, axis=1)
            dk = d[np.arange(len(u)), k]
            self.per_level.append(dk / self.p.resolution)
            better = dk < best
            best = np.where(better, dk, best)
            tk = t[np.arange(len(u)), k]
            z = np.where(better, zz[k, 0] + tk * (zz[k, 1] - zz[k, 0]), z)
            lev = np.where(better, level, lev)
        return best / self.p.resolution, z, lev


CTL = control.perlin(seed=4, frequency=1.5, domain=((0.0, 0.0), (2.0, 2.0)))
DOMAIN = ((0.0, 0.0), (2.0, 2.0))


def _pixel_grid_units(shape, params, domain=DOMAIN):
    (x0, y0), (x1, y1) = domain
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    x = x0 + (cols + 0.5) * (x1 - x0) / shape[1]
    y = y0 + (rows + 0.5) * (y1 - y0) / shape[0]
    return np.stack([x.ravel(), y.ravel()], 1) * params.resolution


def _straight(**kw):
    return DendryParams(smoothing=False, subdivision=False, **kw)


def _tree(params):
    return _Tree(params, CTL, -6, 11)


# ------------------------------------------------------------------ the function


@pytest.mark.parametrize("eps", [0.0, 0.25, 0.5])
def test_level1_distance_equals_bruteforce_tree(device, eps):
    p = _straight(levels=1, eps=eps, resolution=2.0, seed=3)
    got = dendry((32, 32), domain=DOMAIN, params=p, control=CTL, device=device).ravel()
    want, _, _ = _tree(p).nearest(_pixel_grid_units((32, 32), p))
    np.testing.assert_allclose(got, want, atol=2e-5)


def test_level2_distance_matches_global_tree(device):
    p = _straight(levels=2, eps=0.25, resolution=2.0, seed=1)
    tree = _tree(p)
    tree.add_level(2, DendryParams.min_slopes()[1])
    u = _pixel_grid_units((48, 48), p)
    want_d, want_z, want_l = tree.nearest(u)
    got_d = dendry((48, 48), domain=DOMAIN, params=p, control=CTL, device=device).ravel()
    got_l = dendry((48, 48), domain=DOMAIN, params=p, control=CTL, output="level", device=device).ravel()
    # the kernel searches the 3 x 3 cells around each ancestor, not the whole tree: nearly always the same
    same = np.abs(got_d - want_d) < 2e-5
    assert same.mean() > 0.97, same.mean()
    # the level is only defined where one level is clearly nearer (junctions are ties)
    clear = same & (np.abs(tree.per_level[0] - tree.per_level[1]) > 1e-4)
    assert clear.mean() > 0.9
    assert np.mean(got_l[clear] == want_l[clear]) > 0.995
    assert set(np.unique(got_l)) <= {1.0, 2.0}


@pytest.mark.parametrize("beta", [0.7, 0.5])
def test_level1_elevation_equals_bruteforce_primitives(device, beta):
    p = _straight(levels=1, eps=0.25, resolution=2.0, seed=5, beta=beta, noise=0.2, primitive_steps=2)
    tree = _tree(p)
    rng = np.random.default_rng(1)
    pts = rng.uniform(0.3, 1.7, (25, 2))
    got = dendry_points(pts, domain=DOMAIN, params=p, control=CTL, output="elevation", device=device)
    pl = p.levels + p.primitive_steps
    f = 2 ** (pl - 1)
    want = []
    for u in pts * p.resolution:
        c = np.floor(u * f).astype(int)
        ci, cj = np.meshgrid(np.arange(c[0] - 2, c[0] + 3), np.arange(c[1] - 2, c[1] + 3), indexing="ij")
        q = _key_points(p.seed, p.eps, pl, ci.ravel(), cj.ravel())
        d, z, _ = tree.nearest(q)
        # eq. 7: smooth step from the control's minimum to its maximum at h^beta
        t = np.clip((np.maximum(z, 0) ** p.beta - CTL.minimum) / (CTL.maximum - CTL.minimum), 0, 1)
        tan = t * t * t * (t * (6 * t - 15) + 10)
        wobble = 1 + p.noise * (2 * _cell_rand(p.seed, pl, ci.ravel(), cj.ravel(), 2) - 1)
        h = z + tan * d * wobble
        r2 = ((q - u) ** 2).sum(1) / (2.0 / f) ** 2
        g = np.where(r2 < 1, (1 - r2) ** 3, 0)
        want.append((g * h).sum() / g.sum())
    np.testing.assert_allclose(got, want, atol=5e-5)


@wp.kernel
def _rank_kernel(ranks_out: wp.array(dtype=int)):
    k = wp.tid()
    ranks_out[k] = _kd.ring_rank(wp.vec2i(_kd.ORDER_X[k], _kd.ORDER_Y[k]))


def test_search_order_covers_each_ring_once_and_ranks_invert_it(device):
    order = [(int(x), int(y)) for x, y in zip(_kd.ORDER_X, _kd.ORDER_Y)]
    # a ring-by-ring walk: every cell of the 7 x 7 once, rings in increasing Chebyshev distance,
    # each step to an 8-neighbour within its ring
    assert sorted(order) == sorted((x, y) for x in range(-3, 4) for y in range(-3, 4))
    rings = [max(abs(x), abs(y)) for x, y in order]
    assert rings == sorted(rings)
    for (x0, y0), (x1, y1), r0, r1 in zip(order, order[1:], rings, rings[1:]):
        assert r0 != r1 or max(abs(x1 - x0), abs(y1 - y0)) == 1
    ranks = wp.zeros(49, dtype=int, device=device)
    wp.launch(_rank_kernel, dim=49, outputs=[ranks], device=device)
    assert ranks.numpy().tolist() == list(range(49))


@pytest.mark.parametrize("output", ["distance", "elevation", "level"])
def test_cached_equals_per_pixel_bit_for_bit(device, output):
    for levels, rule in ((1, "terrain"), (3, "terrain"), (4, "lichtenberg")):
        p = DendryParams(levels=levels, eps=0.2, delta=0.1, beta=0.5, noise=0.05, rule=rule, seed=7)
        a = dendry((40, 40), domain=((0.1, 0.3), (2.1, 1.9)), params=p, control=CTL, output=output, device=device)
        b = dendry((40, 40), domain=((0.1, 0.3), (2.1, 1.9)), params=p, control=CTL, output=output, mode="pixel",
                   device=device)
        assert np.array_equal(a, b, equal_nan=True), (levels, np.abs(a - b).max())


@pytest.mark.parametrize("levels", [1, 2, 3, 4, 5, 6])
def test_cached_equals_per_pixel_in_adversarial_setups(device, levels):
    # the extremes where the searches' exact skipping of cells (bounding boxes against the best
    # distance so far) is most delicate: key points on a regular grid (eps 0.5: equal distances
    # everywhere, so ties decide), key points anywhere in their cells (eps 0), the largest
    # sideways displacement (delta 1), both connection rules; windows must match the image too
    cases = ((0.5, 0.0, "terrain"), (0.0, 1.0, "terrain"), (0.5, 0.3, "lichtenberg"), (0.0, 1.0, "lichtenberg"))
    for eps, delta, rule in cases:
        p = DendryParams(levels=levels, eps=eps, delta=delta, beta=0.5, noise=0.05, rule=rule, seed=11)
        for output in ("distance", "elevation", "level"):
            kw = dict(domain=((0.3, 0.2), (1.9, 1.8)), params=p, control=CTL, output=output, device=device)
            a = dendry((18, 18), **kw)
            b = dendry((18, 18), mode="pixel", **kw)
            assert np.array_equal(a, b, equal_nan=True), (eps, delta, rule, output)
            assert np.array_equal(dendry((18, 18), window=(5, 9, 7, 6), mode="pixel", **kw), a[5:12, 9:15])


def test_cached_equals_per_pixel_where_cells_have_no_segment(device):
    # a bounded control: cells outside the bowl own no segment, so some pixels cannot bound
    # their primitives' answers and query them in full, next to pixels that use the shortlist
    p = DendryParams(levels=2, eps=0.25, delta=0.05, beta=0.5, noise=0.05, resolution=2.0, seed=3)
    kw = dict(domain=((-1.4, -1.4), (1.4, 1.4)), control_domain=((-1.4, -1.4), (1.4, 1.4)), params=p,
              control=control.lichtenberg(), output="elevation", device=device)
    a = dendry((48, 48), **kw)
    b = dendry((48, 48), mode="pixel", **kw)
    assert np.array_equal(a, b, equal_nan=True), np.nanmax(np.abs(a - b))
    assert np.isfinite(a).all()


@pytest.mark.parametrize("mode", ["cached", "pixel"])
@pytest.mark.parametrize("output", ["distance", "elevation", "level"])
def test_windows_equal_the_whole_image_at_tile_borders(device, output, mode):
    p = DendryParams(levels=2, eps=0.25, delta=0.1, beta=0.5, noise=0.05, seed=2)
    kw = dict(domain=((0.0, 0.0), (3.0, 3.0)), params=p, control=CTL, output=output, mode=mode, device=device)
    whole = dendry((64, 64), **kw)
    for win in ((0, 0, 32, 32), (32, 32, 32, 32), (31, 30, 3, 5), (0, 63, 64, 1), (16, 8, 40, 48)):
        r, c, h, w = win
        assert np.array_equal(dendry((64, 64), window=win, **kw), whole[r : r + h, c : c + w]), win


def test_points_equal_pixels(device):
    p = DendryParams(levels=3, eps=0.25, delta=0.08, seed=9)
    img = dendry((24, 24), domain=DOMAIN, params=p, control=CTL, device=device)
    pts = _pixel_grid_units((24, 24), p) / p.resolution
    got = dendry_points(pts, domain=DOMAIN, params=p, control=CTL, device=device)
    np.testing.assert_allclose(got, img.ravel(), atol=1e-5)


def test_seed_determines_the_output(device):
    kw = dict(domain=DOMAIN, control=CTL, output="elevation", device=device)
    a = dendry((32, 32), params=DendryParams(levels=2, delta=0.1, seed=11), **kw)
    b = dendry((32, 32), params=DendryParams(levels=2, delta=0.1, seed=11), **kw)
    c = dendry((32, 32), params=DendryParams(levels=2, delta=0.1, seed=12), **kw)
    assert np.array_equal(a, b) and not np.array_equal(a, c)


def test_more_levels_bring_branches_closer(device):
    kw = dict(domain=DOMAIN, control=CTL, device=device)
    means = [dendry((48, 48), params=DendryParams(levels=n, seed=0), **kw).mean() for n in (1, 2, 3, 4)]
    assert all(a > b for a, b in zip(means, means[1:])), means


def test_dem_amplification_follows_the_coarse_map(device):
    rng = np.random.default_rng(0)
    coarse = rng.random((16, 16)).astype(np.float32)
    dem = control.image(coarse, domain=((0.0, 0.0), (1.0, 1.0)))
    p = DendryParams(levels=2, eps=0.25, delta=0.05, resolution=1.0, beta=0.75)
    fine = dendry((128, 128), domain=((0.0, 0.0), (16.0, 16.0)), params=p, control=dem, output="elevation",
                  device=device)
    down = fine.reshape(16, 8, 16, 8).mean(axis=(1, 3))
    assert np.corrcoef(down.ravel(), coarse.ravel())[0, 1] > 0.7


def test_lichtenberg_tree_stays_in_its_bowl(device):
    p = DendryParams(levels=3, eps=0.25, rule="lichtenberg", resolution=2.0)
    # the query rectangle maps onto the same rectangle of the bowl's coordinates: the corners lie outside
    kw = dict(domain=((-1.5, -1.5), (1.5, 1.5)), control_domain=((-1.5, -1.5), (1.5, 1.5)), params=p,
              control=control.lichtenberg(), device=device)
    lvl = dendry((48, 48), output="level", **kw)
    dist = dendry((48, 48), **kw)
    x = np.linspace(-1.5, 1.5, 48, endpoint=False) + 1.5 / 48
    inner = np.abs(x) < 0.9
    assert (lvl[np.ix_(inner, inner)] > 0).all()
    # every branch lies in the bowl (up to the splines' bulge): outside, the distance to it is a lower bound
    out = np.maximum(np.abs(x) - 1.0, 0.0)
    to_bowl = np.hypot(out[:, None], out[None, :])
    assert (dist >= to_bowl - 0.05).all()
    assert (to_bowl > 0.3).any()


# ------------------------------------------------------------------ bad input


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(levels=0), "levels"),
        (dict(levels=7), "levels"),
        (dict(levels=2.0), "levels"),
        (dict(eps=-0.1), "eps"),
        (dict(eps=0.6), "eps"),
        (dict(delta=-0.1), "delta"),
        (dict(delta=(0.1, -0.1), levels=2), "delta"),
        (dict(delta=(0.1, 0.1, 0.1), levels=2), "delta"),
        (dict(resolution=-1.0), "resolution"),
        (dict(resolution=0.0), "resolution"),
        (dict(beta=-1.0), "beta"),
        (dict(noise=float("nan")), "noise"),
        (dict(primitive_steps=0), "primitive_steps"),
        (dict(rule="diagonal"), "rule"),
        (dict(smoothing=1), "smoothing"),
    ],
)
def test_bad_params_raise(kw, match):
    with pytest.raises((ValueError, TypeError), match=match):
        DendryParams(**kw)


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(domain=((1.0, 0.0), (0.0, 1.0))), "domain"),
        (dict(domain=((0.0, 0.0), (0.0, 1.0))), "domain"),
        (dict(domain=((0.0, 0.0), (1.0, np.nan))), "domain"),
        (dict(domain=(0.0, 1.0)), "domain"),
        (dict(control_domain=((0.0, 1.0), (1.0, 0.0))), "control_domain"),
        (dict(window=(0, 0, 17, 4)), "window"),
        (dict(window=(-1, 0, 4, 4)), "window"),
        (dict(window=(0, 0, 0, 4)), "window"),
        (dict(window=(0, 0, 4)), "window"),
        (dict(output="height"), "output"),
        (dict(mode="lazy"), "mode"),
        (dict(params=None), "params"),
        (dict(control=np.zeros((4, 4))), "control"),
        (dict(shape=(0, 16)), "shape"),
        (dict(shape=(4, 4, 4)), "shape"),
    ],
)
def test_bad_dendry_input_raises_before_any_kernel(kw, match):
    args = dict(shape=(16, 16), domain=DOMAIN, params=DendryParams(), control=CTL)
    args.update(kw)
    shape = args.pop("shape")
    with pytest.raises((ValueError, TypeError), match=match):
        dendry(shape, **args)


@pytest.mark.parametrize("pts, match", [([[0.0, np.nan]], "points"), ([[0.0, 1.0, 2.0]], "points"),
                                        ([[np.inf, 0.0]], "points")])
def test_bad_points_raise(pts, match):
    with pytest.raises((ValueError, TypeError), match=match):
        dendry_points(pts, domain=DOMAIN, params=DendryParams(), control=CTL)


def test_default_control_is_the_authors_interactive_perlin(device):
    from wdendrite.dendry import default_control

    p = DendryParams(levels=2)
    a = dendry((16, 16), domain=((0, 0), (4, 4)), params=p, device=device)
    b = dendry((16, 16), domain=((0, 0), (4, 4)), params=p, control=default_control(), device=device)
    assert np.array_equal(a, b)
    assert default_control().domain == ((-0.2, -0.5), (1.4, 0.7))
