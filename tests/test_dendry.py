"""Dendry against brute-force NumPy constructions of the whole tree (``dendry_reference``), plus locality properties."""

import importlib

import numpy as np
import pytest
import warp as wp

from wdendrite import control
from wdendrite.dendry import _OUTPUTS, DendryParams, _cached_tree, _setup, _slots_for_pixels, dendry, dendry_points
from wdendrite.kernels import dendry as _kd
from wdendrite.kernels import dendry_pixels as _kp

from dendry_reference import (CTL, DOMAIN, _PIECES, _SEGMENT, _cell_rand, _check_tree, _key_points, _lowest,
                              _piece_distance, _pieces_of, _pixel_grid_units, _polyline, _region_tree,
                              _spline_tolerance, _straight, _tree)

# ------------------------------------------------------------------ the function


@pytest.mark.parametrize("eps", [0.0, 0.25, 0.5])
def test_level1_distance_equals_bruteforce_tree(device, eps):
    p = _straight(levels=1, eps=eps, resolution=2.0, seed=3)
    got = dendry((32, 32), domain=DOMAIN, params=p, control=CTL, device=device).ravel()
    want, _, _ = _tree(p).nearest(_pixel_grid_units((32, 32), p))
    np.testing.assert_allclose(got, want, atol=2e-5)


def _terrain(p, tree, pts):
    """Eq. 4-7 at domain points ``pts`` (N, 2): the blend of the primitives on the 5 x 5 finest cells
    around each point, each from the brute-force nearest tree point of its key point."""
    pl = p.levels + p.primitive_steps
    f = 2 ** (pl - 1)
    out = []
    for u in pts * p.resolution:
        c = np.floor(u * f).astype(int)
        ci, cj = np.meshgrid(np.arange(c[0] - 2, c[0] + 3), np.arange(c[1] - 2, c[1] + 3), indexing="ij")
        q = _key_points(p.seed, p.primitive_epsilon(), pl, ci.ravel(), cj.ravel())
        d, z, _ = tree.nearest(q)
        # eq. 7: smooth step from the control's minimum to its maximum at h^beta
        t = np.clip((np.maximum(z, 0) ** p.beta - CTL.minimum) / (CTL.maximum - CTL.minimum), 0, 1)
        tan = t * t * t * (t * (6 * t - 15) + 10)
        wobble = 1 + p.noise * (2 * _cell_rand(p.seed, pl, ci.ravel(), cj.ravel(), 2) - 1)
        h = z + tan * d * wobble
        r2 = ((q - u) ** 2).sum(1) / (2.0 / f) ** 2
        g = np.where(r2 < 1, (1 - r2) ** 3, 0)
        out.append((g * h).sum() / g.sum())
    return np.array(out)


def test_level2_distance_matches_global_tree(device):
    p = _straight(levels=2, eps=0.25, resolution=2.0, seed=1, beta=0.5, noise=0.1, primitive_steps=2)
    tree = _tree(p)
    tree.add_level(2, DendryParams.min_slopes()[1])
    u = _pixel_grid_units((48, 48), p)
    want_d, _, want_l = tree.nearest(u)
    got_d = dendry((48, 48), domain=DOMAIN, params=p, control=CTL, device=device).ravel()
    got_l = dendry((48, 48), domain=DOMAIN, params=p, control=CTL, output="level", device=device).ravel()
    # the kernel searches the 3 x 3 cells around each ancestor, the reference the whole tree
    np.testing.assert_allclose(got_d, want_d, atol=2e-5)
    # the level is only defined where one level is clearly nearer (junctions are ties)
    clear = np.abs(tree.per_level[0] - tree.per_level[1]) > 1e-4
    assert clear.mean() > 0.9
    np.testing.assert_array_equal(got_l[clear], want_l[clear])
    assert set(np.unique(got_l)) <= {1.0, 2.0}
    # key point elevations: the control at level 1, max(control, z_join + min_slope * distance) at level 2
    for level, (cells, keyp, _) in enumerate(_cached_tree((48, 48), domain=DOMAIN, params=p, control=CTL,
                                                          device=device), start=1):
        known = [i for i, c in enumerate(map(tuple, cells.tolist())) if c in tree.z[level]]
        assert len(known) >= 100
        want = [tree.z[level][tuple(cells[i])] for i in known]
        np.testing.assert_allclose(keyp[known, 2], want, atol=1e-5)
    # the terrain: primitives on the elevations of their nearest tree points
    pts = np.random.default_rng(2).uniform(0.3, 1.7, (25, 2))
    got = dendry_points(pts, domain=DOMAIN, params=p, control=CTL, output="elevation", device=device)
    np.testing.assert_allclose(got, _terrain(p, tree, pts), atol=5e-5)


@pytest.mark.parametrize("beta, steps", [(0.7, 2), (0.5, 2), (0.5, 1), (0.5, 3), (0.5, 4)])
def test_level1_elevation_equals_bruteforce_primitives(device, beta, steps):
    p = _straight(levels=1, eps=0.25, resolution=2.0, seed=5, beta=beta, noise=0.2, primitive_steps=steps)
    pts = np.random.default_rng(1).uniform(0.3, 1.7, (25, 2))
    got = dendry_points(pts, domain=DOMAIN, params=p, control=CTL, output="elevation", device=device)
    np.testing.assert_allclose(got, _terrain(p, _tree(p), pts), atol=5e-5)


@pytest.mark.parametrize("steps, eps, kw", [(3, 0.25, {}), (3, (0.25, 0.0), {}), (1, (0.25, 0.5), {}),
                                           (3, 0.25, dict(fine_eps=0.0, primitive_eps=0.45)),
                                           (2, 0.25, dict(fine_eps=0.5, primitive_eps=0.0))])
def test_level2_elevation_equals_bruteforce_primitives(device, steps, eps, kw):
    # the default primitive step (3) and others, one eps per level and the finer levels' and the
    # primitives' own: the primitives take primitive_eps, else the finest level's (the reference
    # draws them so), their noise the primitives' own level
    p = _straight(levels=2, eps=eps, resolution=2.0, seed=1, beta=0.5, noise=0.1, primitive_steps=steps, **kw)
    tree = _tree(p)
    tree.add_level(2, DendryParams.min_slopes()[1])
    pts = np.random.default_rng(6).uniform(0.3, 1.7, (25, 2))
    got = dendry_points(pts, domain=DOMAIN, params=p, control=CTL, output="elevation", device=device)
    np.testing.assert_allclose(got, _terrain(p, tree, pts), atol=5e-5)


def test_level1_polylines_are_displaced_chordal_catmull_rom_splines(device):
    p = DendryParams(levels=1, eps=0.1, delta=0.3, seed=8)
    cells, keyp, verts = _region_tree(p, 9)[0]
    index = {tuple(c): i for i, c in enumerate(cells.tolist())}
    z = keyp[:, 2]
    lo, hi = cells.min(0) + 2, cells.max(0) - 2
    ratios = []
    for i, c in enumerate(map(tuple, cells.tolist())):
        if not (lo <= c).all() or not (c <= hi).all():
            continue
        t = _lowest(z, index, c)
        tt = _lowest(z, index, t)
        a, b = keyp[i, :3].astype(float), keyp[index[t], :3].astype(float)
        # the spline continues into the target's own segment, else mirrors the far end; the
        # near end always mirrors (no segment ends at a key point's start)
        p3 = keyp[index[tt], :2].astype(float) if tt != t else 2 * b[:2] - a[:2]
        p0 = 2 * a[:2] - b[:2]
        np.testing.assert_allclose(verts[i, :5], _polyline(p, 1, c, a, b, p0, p3), atol=_spline_tolerance(a, b, p3), err_msg=str(c))
        # the inner vertices leave the smooth spline sideways, by at most delta * length
        length = np.linalg.norm(b[:2] - a[:2])
        if length > 0:
            offset = verts[i, 1:4, :2] - _polyline(p, 1, c, a, b, p0, p3, displaced=False)[1:4, :2]
            np.testing.assert_allclose(offset @ (b[:2] - a[:2]) / length, 0.0, atol=1e-5)
            ratios += list(np.linalg.norm(offset, axis=1) / (p.delta * length))
    assert len(ratios) > 3 * 40
    # |offset| <= delta * L, and the offsets fill that range (uniform draws)
    assert max(ratios) <= 1.0 + 1e-4 and max(ratios) > 0.95 and np.mean(ratios) == pytest.approx(0.5, abs=0.1)


def test_deltas_and_min_slopes_per_level():
    assert DendryParams(levels=6, delta=0.2).deltas() == (0.2, 0.05, 0.0125, 0.0, 0.0, 0.0)
    assert DendryParams(levels=2, delta=0.2).deltas() == (0.2, 0.05, 0.0, 0.0, 0.0, 0.0)
    assert DendryParams(levels=3, delta=(0.3, 0.2, 0.1)).deltas() == (0.3, 0.2, 0.1, 0.0, 0.0, 0.0)
    # Flint's law as the paper gives it: 0.09, 0.18, 0.38, 1.0 at levels 2-5; level 6 as level 5
    slopes = DendryParams.min_slopes()
    np.testing.assert_allclose(slopes[1:5], (0.09, 0.18, 0.38, 1.0), atol=0.005)
    assert slopes[5] == slopes[4] == 1.0 and slopes[0] < slopes[1]


def test_lichtenberg_branches_join_at_45_degrees(device):
    p = DendryParams(levels=3, eps=0.25, delta=0.05, rule="lichtenberg", seed=4)
    tree = _region_tree(p, 9)
    lo1, hi1 = tree[0][0].min(0), tree[0][0].max(0)
    unclamped = 0
    for level in (2, 3):
        cells, keyp, verts = tree[level - 1]
        new = keyp[:, 3] == _SEGMENT
        inner = ((cells[new] >> (level - 1) >= lo1 + 3) & (cells[new] >> (level - 1) <= hi1 - 3)).all(1)
        q = keyp[new][inner, :2].astype(float)
        x = verts[new][inner, _PIECES[level - 1], :2].astype(float)  # the polyline's end: its join
        a, b, _ = _pieces_of(p, tree, level)
        dist, tproj = _piece_distance(q, a[:, :2], b[:, :2])
        for k in range(len(q)):
            m = int(np.argmin(dist[k]))
            if np.sort(dist[k])[1] - dist[k, m] < 1e-4:
                continue  # two pieces nearly as near: the join's piece is ambiguous
            pa, pb = a[m, :2], b[m, :2]
            length = np.linalg.norm(pb - pa)
            t = tproj[k, m]
            # clamped joins: the projection at an end, or 45 degrees would run past the piece's end
            if length == 0 or not 1e-4 < t < 1 - 1e-4 or t + dist[k, m] / length >= 1 - 1e-4:
                continue
            chord = x[k] - q[k]
            cos = chord @ (pb - pa) / (np.linalg.norm(chord) * length)
            # float32 vertices (about 1e-6 here) turn short chords by up to 1e-6 / |chord| radians
            tol = np.degrees(4e-6 / np.linalg.norm(chord)) + 1e-3
            assert np.degrees(np.arccos(cos)) == pytest.approx(45.0, abs=tol), (level, k, np.linalg.norm(chord))
            # and the join lies on that piece, downstream of the projection
            side = (pb - pa)[0] * (x[k] - pa)[1] - (pb - pa)[1] * (x[k] - pa)[0]
            assert abs(side) / length < 1e-5 and (x[k] - pa) @ (pb - pa) / length**2 > t
            unclamped += 1
    assert unclamped > 150


@pytest.mark.parametrize("mode", ["cached", "pixel"])
def test_lichtenberg_terrain_takes_the_bowls_maximum_outside_its_square(mode):
    # no key point lies outside the bowl's square, and a primitive there takes the bowl's maximum
    # (5 * scale), not the height of a branch inside plus the slope times its distance (which
    # reached 3.4 here): two primitive cells (the blend's radius) beyond the edge the terrain is
    # that maximum; inside, branches still carve it
    p = DendryParams(levels=3, rule="lichtenberg", seed=1)
    dom = ((-4.0, -4.0), (4.0, 4.0))
    n = 128
    z = dendry((n, n), domain=dom, control_domain=dom, params=p, control=control.lichtenberg(0.2),
               output="elevation", mode=mode)
    centre = -4.0 + (np.arange(n) + 0.5) * 8.0 / n
    edge = np.maximum(np.abs(centre)[:, None], np.abs(centre)[None, :]) - 1.0  # Chebyshev, beyond the square
    radius = 2.0 * 2.0 ** (1 - p.levels - p.primitive_steps) / p.resolution  # the blend's, in domain units
    far, outside, inside = edge > 1.01 * radius, edge > 0.0, edge < -radius
    assert far.sum() > 0.5 * n * n and (outside & ~far).sum() > 100  # (the square is 32 pixels wide)
    np.testing.assert_allclose(z[far], 1.0, rtol=1e-6)
    assert z[inside].min() < 0.25 and z[inside].std() > 0.05


@pytest.mark.parametrize(
    "seed, size, kw",
    [
        # straight segments between packed key points: the authors' 3 x 3 link search
        (1, 12, dict(eps=0.25, delta=0.0, smoothing=False, subdivision=False)),
        # wider searches, on seeds where a 3 x 3 search misses links (the count after each case):
        (146, 14, dict(eps=0.25, delta=0.1)),  # 1; the paper's recommended parameters (curved segments)
        (1, 12, dict(eps=0.0, delta=0.0, smoothing=False, subdivision=False)),  # 2; free jitter
        (3, 12, dict(eps=0.0, delta=0.3)),  # 5; free jitter, large displacement
        (6, 12, dict(eps=0.25, delta=0.1, rule="lichtenberg")),  # 2; branches join downstream of projections
        # 7 x 7 searches, on seeds where a 5 x 5 search misses links too:
        (6, 12, dict(eps=0.1, delta=1.0)),  # 37 (5 x 5: 1); the largest displacement
        (21, 12, dict(eps=0.0, delta=0.3, rule="lichtenberg")),  # 1 (5 x 5: 1); they reach farther
        # one eps per level: level 1 packed, finer levels free (the free regime's searches; with
        # 3 x 3 links this seed missed some)
        (146, 14, dict(eps=(0.25, 0.0, 0.0), delta=0.1)),
        (4, 12, dict(eps=(0.25, 0.0, 0.0), delta=0.0, smoothing=False, subdivision=False)),
        # from 4 levels the searches widen (and the finer levels' minimum slopes come into play)
        (2, 10, dict(levels=4, eps=0.25, delta=0.1)),
        (5, 10, dict(levels=4, eps=0.0, delta=0.3)),
    ],
)
def test_links_join_the_nearest_piece_of_the_whole_tree(device, seed, size, kw):
    # a brute-force reference over every piece of the region: no key point may miss its nearest piece
    p = DendryParams(seed=seed, **{"levels": 3, **kw})
    checked, missed = _check_tree(p, size)
    assert checked > 900 and missed == 0, (checked, missed)


def test_the_papers_search_is_what_search_paper_runs_and_it_misses_links(device):
    # the seed where a 3 x 3 link search misses links at the paper's recommended parameters
    p = DendryParams(levels=3, seed=146, eps=0.25, delta=0.1, search="paper")
    assert p.radii() == (2, 2, 1)
    checked, missed = _check_tree(p, 14)
    assert checked > 900 and missed > 0, (checked, missed)


@pytest.mark.parametrize(
    "kw, want",
    [
        (dict(levels=1, smoothing=False), (3, 2, 1)),  # straight packed segments: the paper's rule
        (dict(levels=3, subdivision=False, delta=0.4), (2, 2, 1)),
        (dict(levels=1), (3, 2, 2)),  # splines bend segments
        (dict(levels=2, eps=0.2, smoothing=False), (2, 2, 2)),  # free enough jitter
        (dict(levels=2, delta=0.1), (2, 2, 2)),  # curved
        (dict(levels=2, delta=0.6), (3, 3, 3)),  # displaced far
        (dict(levels=4, smoothing=False, delta=0.0), (3, 3, 2)),  # straight but beyond 3 levels; 7 x 7 queries
        (dict(levels=3, delta=0.1, rule="lichtenberg"), (2, 2, 2)),
        (dict(levels=4, delta=0.1, rule="lichtenberg"), (3, 3, 3)),  # 5 x 5 missed 1 link in 60 000 there
        (dict(levels=3, delta=0.2, rule="lichtenberg"), (3, 3, 3)),
        (dict(levels=3, eps=0.2, rule="lichtenberg"), (3, 3, 3)),
        (dict(levels=6, delta=1.0, rule="lichtenberg", search="paper"), (2, 2, 1)),
        (dict(levels=1, search="paper"), (3, 2, 1)),
        # boundaries of the measured regimes, and displacements that bend nothing
        (dict(levels=2, delta=0.5), (2, 2, 2)),
        (dict(levels=2, delta=(0.0, 0.51)), (3, 3, 3)),
        (dict(levels=3, delta=0.1, eps=0.25, rule="lichtenberg"), (2, 2, 2)),
        (dict(levels=3, delta=0.11, rule="lichtenberg"), (3, 3, 3)),
        (dict(levels=3, delta=0.0, eps=0.25, smoothing=False), (2, 2, 1)),
        (dict(levels=3, delta=0.0, eps=0.2499, smoothing=False), (2, 2, 2)),
        (dict(levels=5, delta=(0.05, 0.0, 0.0, 0.0, 0.9)), (3, 3, 2)),  # levels 4+ have one piece each
        (dict(levels=4, subdivision=False, delta=0.6), (3, 3, 2)),  # no split, no displacement
        # 6 levels: 7 x 7 links unless packed with displacements up to 0.1 (the paper's regime)
        (dict(levels=6, eps=0.25, delta=0.1), (3, 3, 2)),
        (dict(levels=6, eps=0.25, delta=0.2), (3, 3, 3)),
        (dict(levels=6, eps=0.0, delta=0.5), (3, 3, 3)),
        # one eps per level: packed only when every level is (3 x 3 links missed some at (0.25, 0, 0))
        (dict(levels=3, delta=0.0, eps=(0.25, 0.25, 0.25), smoothing=False), (2, 2, 1)),
        (dict(levels=3, delta=0.0, eps=(0.25, 0.0, 0.0), smoothing=False), (2, 2, 2)),
        (dict(levels=3, delta=0.0, eps=(0.0, 0.25, 0.25), smoothing=False), (2, 2, 2)),
        (dict(levels=3, delta=0.1, eps=(0.25, 0.2, 0.25), rule="lichtenberg"), (3, 3, 3)),
    ],
)
def test_radii_follow_the_measured_regimes(kw, want):
    assert DendryParams(**kw).radii() == want


@pytest.mark.parametrize(
    "kw, idle",
    [
        (dict(levels=5, delta=(0.05, 0.02, 0.0, 0.0, 0.0)), dict(delta=(0.05, 0.02, 0.0, 0.9, 0.9))),
        (dict(levels=3, subdivision=False, delta=0.0), dict(delta=0.6)),
    ],
)
def test_displacements_that_radii_ignore_change_nothing(device, kw, idle):
    # radii() leaves out displacements of unsplit segments: they must not move a single pixel
    p, q = DendryParams(seed=3, **kw), DendryParams(seed=3, **{**kw, **idle})
    for mode in ("cached", "pixel"):
        a, b = (dendry((128, 128), domain=DOMAIN, params=r, control=CTL, mode=mode, window=(40, 40, 24, 24),
                       device=device) for r in (p, q))
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize(
    "seed, kw, window",
    [
        (6, dict(eps=0.25, delta=0.1, levels=2), (48, 48, 40, 40)),  # the paper's regime
        # the paper's 3 x 3 links: level-1 segments far from a pixel are drawn only on demand
        (6, dict(eps=0.25, delta=0.1, levels=2, search="paper"), (48, 48, 40, 40)),
        (6, dict(eps=0.0, delta=1.0, levels=1), (48, 48, 40, 40)),
        (6, dict(eps=0.1, delta=0.5, levels=2, rule="lichtenberg"), (48, 48, 40, 40)),
        # 5 x 5 queries got 4 of these pixels wrong (by up to 0.009): level-3 segments reaching 3 cells
        (200, dict(eps=0.0, delta=1.0, levels=3), (48, 48, 40, 40)),
        # from 4 levels finest segments reach farther: 5 x 5 queries got one of these pixels wrong
        (1, dict(eps=0.0, delta=0.5, levels=4), (48, 48, 40, 40)),
        (3, dict(eps=(0.25, 0.0, 0.0), delta=0.1, levels=3), (48, 48, 40, 40)),  # one eps per level
    ],
)
def test_pixels_measure_the_nearest_piece_of_the_whole_tree(device, seed, kw, window):
    # 16 pixels per unit over [6.5, 14.5]^2; the window covers [9.5, 12]^2, 3 cells inside
    p = DendryParams(seed=seed, **kw)
    origin, size, px = 6.5, 8.0, 128
    dom = ((origin, origin), (origin + size, origin + size))
    a, b, _ = _pieces_of(p, _region_tree(p, size, origin=origin), p.levels + 1)
    got = dendry((px, px), domain=dom, control_domain=dom, params=p, control=CTL, window=window, device=device)
    r, c, h, w = window
    u = _pixel_grid_units((px, px), p, dom).reshape(px, px, 2)[r : r + h, c : c + w].reshape(-1, 2)
    want = np.concatenate([_piece_distance(u[i : i + 400], a[:, :2], b[:, :2])[0].min(1) for i in range(0, len(u), 400)])
    np.testing.assert_allclose(got.ravel(), want, atol=2e-5)


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
        # (explicitly cached: "auto" would pick the per-pixel mode where its cost estimate says so)
        a = dendry((40, 40), domain=((0.1, 0.3), (2.1, 1.9)), params=p, control=CTL, output=output, mode="cached",
                   device=device)
        b = dendry((40, 40), domain=((0.1, 0.3), (2.1, 1.9)), params=p, control=CTL, output=output, mode="pixel",
                   device=device)
        assert np.array_equal(a, b, equal_nan=True), (levels, np.abs(a - b).max())


@pytest.mark.parametrize("levels, search", [(1, "exact"), (2, "exact"), (3, "exact"), (4, "exact"), (5, "exact"),
                                           (6, "exact"), (2, "paper")])
def test_cached_equals_per_pixel_in_adversarial_setups(device, levels, search):
    # the extremes where the searches' exact skipping of cells (bounding boxes against the best
    # distance so far) is most delicate: key points on a regular grid (eps 0.5: equal distances
    # everywhere, so ties decide), key points anywhere in their cells (eps 0), the largest
    # sideways displacement (delta 1), both connection rules; windows must match the image too
    # and one eps per level, alternating the extremes (the primitives take the finest level's)
    mixed = tuple(0.5 if k % 2 == 0 else 0.0 for k in range(levels))
    cases = ((0.5, 0.0, "terrain"), (0.0, 1.0, "terrain"), (0.5, 0.3, "lichtenberg"), (0.0, 1.0, "lichtenberg"),
             (mixed, 0.3, "terrain"), (mixed, 0.3, "lichtenberg"))
    for eps, delta, rule in cases:
        p = DendryParams(levels=levels, eps=eps, delta=delta, beta=0.5, noise=0.05, rule=rule, seed=11, search=search)
        for output in ("distance", "elevation", "level"):
            kw = dict(domain=((0.3, 0.2), (1.9, 1.8)), params=p, control=CTL, output=output, device=device)
            a = dendry((18, 18), mode="cached", **kw)  # ("auto" chose the per-pixel mode for 6 levels)
            b = dendry((18, 18), mode="pixel", **kw)
            assert np.array_equal(a, b, equal_nan=True), (eps, delta, rule, output)
            assert np.array_equal(dendry((18, 18), window=(5, 9, 7, 6), mode="pixel", **kw), a[5:12, 9:15])


def _per_pixel_points(p, s, u, output):
    """The per-pixel kernel's values at grid points ``u`` (n, 2) for Setup ``s`` (CPU, one slot)."""
    slots = _slots_for_pixels(p, output, 1, "cpu")
    out = wp.zeros(len(u), dtype=float, device="cpu")
    pts = wp.array(u.astype(np.float32), dtype=wp.vec2, device="cpu")
    wp.launch(_kp.points_kernel, dim=len(u), inputs=[s, CTL.struct("cpu"), _OUTPUTS[output], slots.cap, 1, 0,
                                                     pts, *slots.arrays()], outputs=[out, slots.overflow], device="cpu")
    assert slots.overflow.numpy()[0] == 0
    return out.numpy()


@pytest.mark.parametrize("eps, delta, rule", [(0.25, 0.1, "terrain"), (0.5, 0.0, "terrain"), (0.0, 1.0, "terrain"),
                                              (0.0, 1.0, "lichtenberg")])
def test_paper_search_per_pixel_whatever_it_leaves_pending(eps, delta, rule):
    # with the paper's 3 x 3 links a pixel leaves pending the level-1 segments of its block's outer
    # ring that lie farther than Setup.near1 from it, and draws them when a link search or its own
    # answer comes near one; every choice of that distance gives the cached mode's values bit for
    # bit: 0 leaves the whole ring pending, 50 draws it all at once. With wide displacements up to
    # half the points are ones whose nearest piece (brute force over the cached tree) is owned by a
    # level-1 cell of that ring: two cells from the point's own
    p = DendryParams(levels=2, eps=eps, delta=delta, beta=0.5, noise=0.05, rule=rule, seed=5, search="paper")
    dom = ((0.0, 0.0), (6.0, 6.0))
    tree = _cached_tree((16, 16), domain=dom, control_domain=dom, params=p, control=CTL)
    cells, keyp, verts = tree[0]
    seg = keyp[:, 3] == _SEGMENT
    owners = np.repeat(cells[seg], 4, axis=0)
    v = verts[seg, :5, :2].astype(float)
    a, b, _ = _pieces_of(p, tree, 3)
    u = np.random.default_rng(8).uniform(2.0, 4.0, (4000, 2))
    d = np.concatenate([_piece_distance(u[i : i + 500], a[:, :2], b[:, :2])[0] for i in range(0, len(u), 500)])
    lv1 = np.concatenate([_piece_distance(u[i : i + 500], v[:, :-1].reshape(-1, 2), v[:, 1:].reshape(-1, 2))[0]
                          for i in range(0, len(u), 500)])
    # (pieces ordered as in v: cell-major, then piece)
    ring = np.abs(owners[lv1.argmin(1)] - np.floor(u)).max(1) == 2
    ring &= lv1.min(1) <= d.min(1)
    if delta >= 1.0:  # (packed key points and short displacements never give such points)
        assert ring.sum() >= 10, ring.sum()
    u = np.concatenate([u[ring][:150], u[~ring][:150]])
    for output in _OUTPUTS:
        want = dendry_points(u / p.resolution, domain=dom, control_domain=dom, params=p, control=CTL, output=output,
                             mode="cached")
        s = _setup(p, dom, dom, output)
        assert s.near1 > 0.0  # (the library's choice for the paper's links)
        for near in (0.0, float(s.near1), 50.0):
            s.near1 = near
            np.testing.assert_array_equal(_per_pixel_points(p, s, u, output), want, err_msg=f"{output} {near}")


@wp.kernel
def _reach_kernel(s: _kd.Setup, level: int, spans: wp.array(dtype=float), reach_out: wp.array(dtype=float)):
    i = wp.tid()
    reach_out[i] = _kd.segment_reach(s, level, spans[i])


@wp.kernel
def _piece_kernel(s: _kd.Setup, level: int, reach: wp.array(dtype=float), piece_out: wp.array(dtype=float)):
    i = wp.tid()
    piece_out[i] = _kd.piece_bound(s, level, reach[i])


@pytest.mark.parametrize(
    "kw",
    [dict(eps=0.0, delta=1.0), dict(eps=0.5, delta=0.0), dict(eps=0.25, delta=0.3, rule="lichtenberg"),
     dict(eps=0.1, delta=0.5, smoothing=False), dict(eps=0.0, delta=0.3, subdivision=False)],
)
def test_segment_reach_bounds_every_drawn_polyline(kw):
    # the per-pixel mode leaves a finest-level segment undrawn when segment_reach shows it stays
    # away from the pixel: every vertex of every drawn polyline must lie within that reach of its
    # key point, and the longest piece each cell records must be its longest piece
    p = DendryParams(levels=3, seed=5, **kw)
    s = _setup(p, DOMAIN, DOMAIN, "distance")
    ratios, piece_ratios = [], []
    for level, (cells, keyp, verts) in enumerate(_region_tree(p, 6), start=1):
        seg = keyp[:, 3] == float(_kd.STATE_SEGMENT)
        v = verts[seg, :5, :2].astype(np.float64)
        span = np.linalg.norm(v[:, 4] - v[:, 0], axis=1)
        reach = wp.zeros(len(span), dtype=float, device="cpu")
        wp.launch(_reach_kernel, dim=len(span), inputs=[s, level, wp.array(span, dtype=float, device="cpu")],
                  outputs=[reach], device="cpu")
        reach = reach.numpy()
        far = np.linalg.norm(v - v[:, :1], axis=2).max(axis=1)
        assert (far <= reach).all(), (level, (far - reach).max())
        ratios += list(far[span > 0] / span[span > 0])
        longest = np.linalg.norm(np.diff(v, axis=1), axis=2).max(axis=1)
        np.testing.assert_allclose(verts[seg, int(_kd.BOUND) + 1, 1], longest, rtol=1e-5, atol=1e-6)
        # and no piece is longer than piece_bound of that reach (the per-pixel mode's bound on the
        # pieces of segments it has not drawn yet)
        pieces = wp.zeros(len(span), dtype=float, device="cpu")
        wp.launch(_piece_kernel, dim=len(span), inputs=[s, level, wp.array(reach, dtype=float, device="cpu")],
                  outputs=[pieces], device="cpu")
        assert (longest <= pieces.numpy()).all(), (level, (longest - pieces.numpy()).max())
        piece_ratios += list(longest[span > 0] / span[span > 0] / s.piece[level - 1])
    assert len(ratios) > 100
    if p.subdivision:
        # the factors are not slack beyond what the vertices' spread allows
        assert max(piece_ratios) > 0.4, max(piece_ratios)
    if p.rule == "terrain" and p.smoothing and p.subdivision and p.delta > 0:
        assert max(ratios) > 1.0  # splines and displacements do carry vertices beyond the segment's span


@wp.kernel
def _polyline_kernel(
    s: _kd.Setup, level: int, a: wp.array(dtype=wp.vec3), b: wp.array(dtype=wp.vec3), p0: wp.array(dtype=wp.vec2),
    p3: wp.array(dtype=wp.vec2), verts_out: wp.array(dtype=wp.vec3),
):
    i = wp.tid()
    _kd.write_polyline(s, level, wp.vec2i(i, 7), a[i], b[i], p0[i], p3[i], i, verts_out)


@pytest.mark.parametrize("delta", [0.0, 0.5])
def test_segment_reach_holds_for_the_most_bent_splines(delta):
    # the same bound on splines bent as far as their neighbours can bend them: the far tangent
    # turned back along the segment by a short next segment, or thrown sideways by long ones
    rng = np.random.default_rng(3)
    n = 4000
    a = np.zeros((n, 3), np.float32)
    a[:, :2] = rng.uniform(0.0, 1.0, (n, 2))
    span = rng.uniform(0.01, 1.0, n)
    ang = rng.uniform(0.0, 2.0 * np.pi, n)
    e = np.stack([np.cos(ang), np.sin(ang)], 1) * span[:, None]
    b = a.copy()
    b[:, :2] += e
    back = rng.uniform(0.0, 2.0 * np.pi, n)
    # next segments from 1e-3 to 10 spans long, a third of them turned straight back
    w = np.stack([np.cos(back), np.sin(back)], 1) * (span * 10.0 ** rng.uniform(-3, 1, n))[:, None]
    w[: n // 3] = -e[: n // 3] * rng.uniform(1e-3, 0.05, (n // 3, 1))
    p3 = (b[:, :2] + w).astype(np.float32)
    p0 = np.where(rng.uniform(size=(n, 1)) < 0.5, 2 * a[:, :2] - b[:, :2],
                  a[:, :2] - rng.uniform(-2, 2, (n, 2)) * span[:, None]).astype(np.float32)
    p = DendryParams(levels=3, delta=delta, seed=2)
    s = _setup(p, DOMAIN, DOMAIN, "distance")
    for level, pieces in ((1, 4), (2, 3), (3, 2)):
        verts = wp.zeros(n * int(_kd.NV), dtype=wp.vec3, device="cpu")
        arrays = [wp.array(x, dtype=t, device="cpu")
                  for x, t in ((a, wp.vec3), (b, wp.vec3), (p0, wp.vec2), (p3, wp.vec2))]
        wp.launch(_polyline_kernel, dim=n, inputs=[s, level, *arrays], outputs=[verts], device="cpu")
        v = verts.numpy().reshape(n, int(_kd.NV), 3)[:, :5, :2].astype(np.float64)
        length = np.linalg.norm(v[:, 4] - v[:, 0], axis=1)
        reach = wp.zeros(n, dtype=float, device="cpu")
        wp.launch(_reach_kernel, dim=n, inputs=[s, level, wp.array(length, dtype=float, device="cpu")],
                  outputs=[reach], device="cpu")
        ratio = np.linalg.norm(v - v[:, :1], axis=2).max(axis=1) / length
        assert (ratio * length <= reach.numpy()).all(), (level, ratio.max())
        if pieces == 4 and delta == 0.0:
            # a vertex does go beyond the span (the bound's 1.03125 at t = 3/4 is nearly reached)
            assert ratio.max() > 1.02, ratio.max()


@wp.kernel
def _pending_kernel(s: _kd.Setup, a: wp.array(dtype=wp.vec3), b: wp.array(dtype=wp.vec3),
                    bounds_out: wp.array(dtype=wp.vec2)):
    i = wp.tid()
    bounds_out[i] = _kd.pending_bounds(s, wp.vec2(a[i][0], a[i][1]), wp.vec2(b[i][0], b[i][1]))


def _chord_gap(v, a, b):
    """Distance from each vertex v[i, k] to the chord a[i] -> b[i] (float64)."""
    ab = (b - a)[:, None, :]
    den = np.maximum((ab ** 2).sum(axis=2), 1e-300)
    t = np.clip(((v - a[:, None, :]) * ab).sum(axis=2) / den, 0.0, 1.0)
    return np.linalg.norm(v - (a[:, None, :] + t[..., None] * ab), axis=2)


@pytest.mark.parametrize("kw", [dict(delta=0.0), dict(delta=0.1), dict(delta=1.0), dict(delta=0.5, smoothing=False),
                                dict(delta=0.5, subdivision=False)])
def test_pending_bounds_hold_for_the_most_bent_level1_polylines(kw):
    # a level-1 segment the per-pixel mode leaves pending stands in searches as a box around its
    # chord and in finish() as a bound on its longest piece: the polyline link1 draws must lie
    # in that box and have no longer piece, however its far neighbour bends it (the start
    # tangent is the chord: link1 passes p0 = 2 a - b)
    rng = np.random.default_rng(11)
    n = 6000
    a = np.zeros((n, 3), np.float32)
    a[:, :2] = rng.uniform(-50.0, 50.0, (n, 2))
    span = 10.0 ** rng.uniform(-4, 0.5, n)
    ang = rng.uniform(0.0, 2.0 * np.pi, n)
    b = a.copy()
    b[:, :2] += np.stack([np.cos(ang), np.sin(ang)], 1) * span[:, None]
    e = b[:, :2] - a[:, :2]
    back = rng.uniform(0.0, 2.0 * np.pi, n)
    w = np.stack([np.cos(back), np.sin(back)], 1) * (span * 10.0 ** rng.uniform(-3, 1, n))[:, None]
    w[: n // 3] = -e[: n // 3] * rng.uniform(1e-3, 0.05, (n // 3, 1))
    p3 = (b[:, :2] + w).astype(np.float32)
    p0 = (2.0 * a[:, :2] - b[:, :2]).astype(np.float32)
    p = DendryParams(levels=2, seed=5, **kw)
    s = _setup(p, DOMAIN, DOMAIN, "distance")
    verts = wp.zeros(n * int(_kd.NV), dtype=wp.vec3, device="cpu")
    arrays = [wp.array(x, dtype=d, device="cpu") for x, d in ((a, wp.vec3), (b, wp.vec3), (p0, wp.vec2), (p3, wp.vec2))]
    wp.launch(_polyline_kernel, dim=n, inputs=[s, 1, *arrays], outputs=[verts], device="cpu")
    bounds = wp.zeros(n, dtype=wp.vec2, device="cpu")
    wp.launch(_pending_kernel, dim=n, inputs=[s, arrays[0], arrays[1]], outputs=[bounds], device="cpu")
    side, piece = bounds.numpy().astype(np.float64).T
    v = verts.numpy().reshape(n, int(_kd.NV), 3)[:, :5, :2].astype(np.float64)
    gap = _chord_gap(v, a[:, :2].astype(np.float64), b[:, :2].astype(np.float64)).max(axis=1)
    longest = np.linalg.norm(np.diff(v, axis=1), axis=2).max(axis=1)
    assert (gap <= side).all(), (gap / side).max()
    assert (longest <= piece).all(), (longest / piece).max()
    if p.smoothing and p.subdivision:
        # and neither bound is slack by more than the vertices' spread allows
        assert (gap / side).max() > 0.5 and (longest / piece).max() > 0.6, ((gap / side).max(), (longest / piece).max())


@pytest.mark.parametrize("kw", [dict(eps=0.25, delta=0.1), dict(eps=0.0, delta=0.5),
                                dict(eps=0.25, delta=0.1, rule="lichtenberg"),
                                dict(eps=0.0, delta=0.5, rule="lichtenberg"), dict(eps=0.5, delta=0.0, search="paper")])
def test_a_pixels_own_cells_equal_the_cached_modes(kw):
    # every cell a pixel draws for itself equals the cached mode's cell bit for bit, down to the
    # level-1 segments at the edge of its blocks, whose far tangents read level-1 points the
    # per-pixel mode draws only on demand; finest cells it leaves undrawn are ones with a segment
    p = DendryParams(levels=2, beta=0.5, noise=0.05, seed=9, **kw)
    dom = ((0.0, 0.0), (6.0, 6.0))
    tree = _cached_tree((16, 16), domain=dom, control_domain=dom, params=p, control=CTL)
    known = [{tuple(c): (k, v) for c, k, v in zip(cells.tolist(), keyp, verts)} for cells, keyp, verts in tree]
    s = _setup(p, dom, dom, "elevation")
    ctl = CTL.struct("cpu")
    rng = np.random.default_rng(4)
    far = drawn = pending = on_demand = 0
    for n, u in enumerate(rng.uniform(2.0, 4.0, (40, 2)).astype(np.float32)):
        slots = _slots_for_pixels(p, "elevation", 1, "cpu")
        out = wp.zeros(1, dtype=float, device="cpu")
        point = wp.array(u[None], dtype=wp.vec2, device="cpu")
        # every other pixel through the CPU's rolled kernel, the others through the general one
        if n % 2:
            wp.launch(_kp.points_kernel, dim=1, inputs=[s, ctl, int(_kd.OUT_ELEVATION), slots.cap, 1, 0, point,
                                                        *slots.arrays()], outputs=[out, slots.overflow], device="cpu")
        else:
            wp.launch(_kd.points_kernel, dim=1, inputs=[s, ctl, int(_kd.OUT_ELEVATION), 0, slots.cap, 1, 0, point,
                                                        *slots.arrays()], outputs=[out, slots.overflow], device="cpu")
        blocks, bases = slots.blocks.numpy(), slots.bases.numpy()
        keyp, verts = slots.keyp.numpy(), slots.verts.numpy().reshape(-1, int(_kd.NV), 3)
        gaps = {"far": [np.inf], "drawn": [np.inf]}  # distances from u to the pieces of each kind of cell
        lv1 = slice(int(bases[1]), int(bases[1]) + int(blocks[1][2] * blocks[1][3]))
        pending_here = bool((keyp[lv1, 3] == float(_kd.STATE_PENDING)).any())
        # level 1's header keeps the least squared distance from u to a pending box (searches skip
        # their pending checks by it): no pending box lies nearer
        box, top = verts[lv1, int(_kd.BOUND)], verts[lv1, int(_kd.BOUND) + 1]
        gx = np.maximum(np.maximum(box[:, 0] - u[0], u[0] - box[:, 2]), 0.0)
        gy = np.maximum(np.maximum(box[:, 1] - u[1], u[1] - top[:, 0]), 0.0)
        gap2 = (gx * gx + gy * gy)[keyp[lv1, 3] == float(_kd.STATE_PENDING)]
        if len(gap2):
            assert keyp[int(bases[1]) - 1, 1] <= gap2.min() * (1 + 1e-6), (u, keyp[int(bases[1]) - 1], gap2.min())
        for level in (1, 2):
            i0, j0, ni, nj = (int(v) for v in blocks[level])
            for j in range(nj):
                for i in range(ni):
                    o = int(bases[level]) + j * ni + i
                    want_k, want_v = known[level - 1][(i0 + i, j0 + j)]
                    if keyp[o, 3] == float(_kd.STATE_FAR):
                        assert level == 2 and want_k[3] == float(_kd.STATE_SEGMENT)
                        far += 1
                    elif keyp[o, 3] == float(_kd.STATE_PENDING):
                        # a level-1 segment left pending: its key point as drawn, its polyline
                        # within the box it stands in for, its pieces within the bound
                        assert level == 1 and want_k[3] == float(_kd.STATE_SEGMENT)
                        assert np.array_equal(keyp[o, :3], want_k[:3])
                        box, top = verts[o, int(_kd.BOUND)], verts[o, int(_kd.BOUND) + 1]
                        wv = want_v[:5, :2]
                        assert (wv[:, 0] >= box[0]).all() and (wv[:, 1] >= box[1]).all(), (u, (i0 + i, j0 + j))
                        assert (wv[:, 0] <= box[2]).all() and (wv[:, 1] <= top[0]).all(), (u, (i0 + i, j0 + j))
                        assert want_v[int(_kd.BOUND) + 1, 1] <= top[1]
                        pending += 1
                        continue
                    else:
                        assert np.array_equal(keyp[o], want_k), (u, level, (i0 + i, j0 + j))
                        if keyp[o, 3] != float(_kd.STATE_SEGMENT):
                            continue
                        assert np.array_equal(verts[o], want_v), (u, level, (i0 + i, j0 + j))
                        drawn += 1
                        # a segment of the level-1 block's outer ring: left pending, then drawn
                        # when a link search came near it
                        ring = level == 1 and (i in (0, ni - 1) or j in (0, nj - 1))
                        on_demand += ring and pending_here
                    v = want_v[:5, :2].astype(np.float64)
                    d = _piece_distance(u[None].astype(np.float64), v[:-1], v[1:])[0].min()
                    gaps["far" if keyp[o, 3] == float(_kd.STATE_FAR) else "drawn"].append(d)
        # a segment left undrawn never holds the piece nearest to the pixel
        assert min(gaps["far"]) > min(gaps["drawn"]), u
    assert far > 100 and drawn > 500 and drawn + pending > 1000, (far, drawn, pending)
    if p.radii()[2] <= 2:
        # 5 x 5 links: the level-1 segments beyond the queries' reach are left pending; the paper's
        # 3 x 3: those of the block's outer ring far from the pixel (7 x 7 links make blocks too
        # large for either)
        assert pending > 100, pending
        if p.delta >= 0.5:
            # wide displacements make wide boxes: some pending segments are drawn after all
            assert on_demand > 5, on_demand


@pytest.mark.parametrize("kw", [dict(levels=2, eps=0.25, delta=0.1), dict(levels=2, eps=0.0, delta=0.5),
                                dict(levels=4, eps=0.1, delta=0.3, rule="lichtenberg")])
@pytest.mark.parametrize("mode", ["cached", "pixel"])
def test_overhang_records_bound_every_drawn_box(kw, mode):
    # searches stop at the first ring of cells that lies beyond their reach by more than the
    # record before each level's block (kernels.dendry.note_overhang): that record must be at
    # least how far every drawn segment's box reaches beyond its own cell, in both modes
    p = DendryParams(beta=0.5, noise=0.05, seed=3, **kw)
    dom = ((0.0, 0.0), (3.0, 3.0))
    ctl = control.perlin(seed=1)
    u = np.array([[1.3, 1.7]], np.float32)
    s = _setup(p, dom, dom, "elevation")
    wdd = importlib.import_module("wdendrite.dendry")  # (the package's name `dendry` is the function)
    if mode == "cached":
        plan = wdd._host_plan(p, "elevation", u[0].tolist(), u[0].tolist())
        slots = wdd._cached_slots(plan, p, "cpu")
        wdd._fill_cached(s, ctl.struct("cpu"), p, "elevation", slots, plan[2], "cpu")
    else:
        slots = _slots_for_pixels(p, "elevation", 1, "cpu")
        out = wp.zeros(1, dtype=float, device="cpu")
        wp.launch(_kp.points_kernel, dim=1, inputs=[s, ctl.struct("cpu"), _OUTPUTS["elevation"], slots.cap, 1, 0,
                                                    wp.array(u, dtype=wp.vec2, device="cpu"), *slots.arrays()],
                  outputs=[out, slots.overflow], device="cpu")
    blocks, bases = slots.blocks.numpy(), slots.bases.numpy()
    keyp, verts = slots.keyp.numpy(), slots.verts.numpy().reshape(-1, int(_kd.NV), 3)
    seen = 0
    for level in range(1, p.levels + 1):
        i0, j0, ni, nj = (int(v) for v in blocks[level])
        record = keyp[int(bases[level]) - 1, 0]
        h = 2.0 ** (1 - level)
        worst = 0.0
        for j in range(nj):
            for i in range(ni):
                o = int(bases[level]) + j * ni + i
                if keyp[o, 3] == float(_kd.STATE_SEGMENT):
                    lo = verts[o, _kd.BOUND, :2].astype(np.float64)
                    hi = np.array([verts[o, _kd.BOUND, 2], verts[o, _kd.BOUND + 1, 0]], np.float64)
                    corner = np.array([i0 + i, j0 + j], np.float64) * h
                    worst = max(worst, *(corner - lo), *(hi - corner - h))
                    seen += 1
        assert record >= worst - 1e-6, (level, record, worst)
        assert record < 4.0 * h  # (a bound, not a blanket: no polyline strays that far)
    assert seen > 0


@pytest.mark.parametrize("kw", [dict(levels=3, eps=0.25, delta=0.1), dict(levels=4, eps=0.0, delta=0.5),
                                dict(levels=4, eps=0.25, delta=0.1, rule="lichtenberg"),
                                dict(levels=5, eps=0.1, delta=0.3, rule="lichtenberg"),
                                dict(levels=4, eps=0.1, delta=0.3, rule="lichtenberg", search="paper")])
def test_levels_drawn_on_demand_bound_the_segments_they_leave_undrawn(kw):
    # from 3 levels on, with links wider than the paper's 3 x 3, a pixel draws the segments of
    # levels 2..n-1 only where a search may need them: each one left waiting must be a segment of the whole tree whose polyline lies within
    # the reach it records and whose link search's answer lies within the bound it records;
    # every cell it drew equals the cached mode's; near the domain's edge it draws them all
    # a bounded control (the Lichtenberg bowl on [-1, 1]^2), so that cells beyond its edge have no key point
    p = DendryParams(beta=0.5, noise=0.05, seed=9, resolution=6.5, **kw)
    dom = ((-1.4, -1.4), (1.4, 1.4))
    ctl = control.lichtenberg(scale=0.2)
    tree = _cached_tree((16, 16), domain=dom, control_domain=dom, params=p, control=ctl)
    known = [{tuple(c): (k, v) for c, k, v in zip(cells.tolist(), keyp, verts)} for cells, keyp, verts in tree]
    coarser = {level: _pieces_of(p, tree, level) for level in range(2, p.levels)}
    rng = np.random.default_rng(5)
    # in grid units: 16 inside, 4 by the bowl's corner (its edge at 6.5 crosses cells)
    points = np.concatenate([rng.uniform(-2.0, 2.0, (16, 2)), rng.uniform(6.0, 6.5, (4, 2))]).astype(np.float32)
    waiting = drawn = whole = 0
    for n, u in enumerate(points):
        output = ("distance", "elevation")[n % 2]
        s = _setup(p, dom, dom, output)
        slots = _slots_for_pixels(p, output, 1, "cpu")
        out = wp.zeros(1, dtype=float, device="cpu")
        wp.launch(_kp.points_kernel, dim=1, inputs=[s, ctl.struct("cpu"), _OUTPUTS[output], slots.cap, 1, 0,
                                                    wp.array(u[None], dtype=wp.vec2, device="cpu"), *slots.arrays()],
                  outputs=[out, slots.overflow], device="cpu")
        blocks, bases = slots.blocks.numpy(), slots.bases.numpy()
        keyp, verts = slots.keyp.numpy(), slots.verts.numpy().reshape(-1, int(_kd.NV), 3)
        here = 0
        for level in range(2, p.levels):
            i0, j0, ni, nj = (int(v) for v in blocks[level])
            for j in range(nj):
                for i in range(ni):
                    o = int(bases[level]) + j * ni + i
                    want_k, want_v = known[level - 1][(i0 + i, j0 + j)]
                    state = keyp[o, 3]
                    assert state != float(_kd.STATE_WANTED)  # every cell wanted is drawn
                    if state == float(_kd.STATE_WAIT):
                        assert want_k[3] == float(_kd.STATE_SEGMENT) and np.array_equal(keyp[o, :2], want_k[:2])
                        q = want_k[:2].astype(np.float64)
                        assert np.linalg.norm(want_v[:5, :2] - q, axis=1).max() <= keyp[o, 2]
                        a, b, _ = coarser[level]
                        assert _piece_distance(q[None], a[:, :2], b[:, :2])[0].min() <= verts[o, 0, 0]
                        here += 1
                        continue
                    # (an inherited key point's elevation is never read: a waiting parent's is its reach)
                    assert np.array_equal(keyp[o, [0, 1, 3]], want_k[[0, 1, 3]]), (u, level, (i0 + i, j0 + j))
                    if state == float(_kd.STATE_SEGMENT):
                        # (elevations along the tree are computed for elevations only)
                        z = slice(None) if output == "elevation" else slice(0, 2)
                        assert np.array_equal(keyp[o, z], want_k[z]) and np.array_equal(verts[o, :, z], want_v[:, z])
                        assert np.array_equal(verts[o, int(_kd.BOUND):], want_v[int(_kd.BOUND):])
                        drawn += 1
        waiting += here
        whole += here == 0
        got = dendry_points(u[None].astype(np.float64) / p.resolution, domain=dom, control_domain=dom, params=p,
                            control=ctl, output=output, mode="pixel", device="cpu")
        assert np.array_equal(out.numpy(), got)
    assert drawn > 100, drawn
    if p.search == "paper":
        assert waiting == 0  # the paper's 3 x 3 links need most cells: all are drawn
    else:
        assert waiting >= 10, (waiting, drawn)
        assert whole >= 2  # points by the domain's corner, where cells have parents beyond it


@pytest.mark.parametrize("trial", range(6))
def test_per_pixel_cells_left_undrawn_never_change_a_value(device, trial):
    # random setups over the whole parameter space: the per-pixel mode, which skips drawing the
    # finest segments it proves too far from its pixel, must still equal the cached mode, which
    # draws them all (both rules, with and without smoothing and subdivision, extreme jitter
    # and displacements, 2-6 levels, every primitive step)
    rng = np.random.default_rng(1000 + trial)
    for _ in range(4):
        p = DendryParams(
            levels=int(rng.integers(2, 7)), eps=float(rng.choice([0.0, 0.1, 0.25, 0.5])),
            delta=float(rng.choice([0.0, 0.1, 0.5, 1.0])), rule=str(rng.choice(["terrain", "lichtenberg"])),
            smoothing=bool(rng.integers(2)), subdivision=bool(rng.integers(2)), beta=0.5, noise=0.05,
            primitive_steps=int(rng.integers(1, 5)), resolution=float(rng.choice([1.0, 2.0, 3.0])),
            seed=int(rng.integers(2**31)),
        )
        x0, y0 = rng.uniform(-1.0, 1.0, 2)
        dom = ((x0, y0), (x0 + rng.uniform(0.5, 2.0), y0 + rng.uniform(0.5, 2.0)))
        for output in ("distance", "elevation", "level"):
            kw = dict(domain=dom, control_domain=((-1.0, -1.0), (3.0, 3.0)), params=p, control=CTL, output=output,
                      device=device)
            a = dendry((14, 14), mode="cached", **kw)
            b = dendry((14, 14), mode="pixel", **kw)
            assert np.array_equal(a, b, equal_nan=True), (p, output, np.nanmax(np.abs(a - b)))


def test_cached_equals_per_pixel_where_cells_have_no_segment(device):
    # a bounded control: cells outside the bowl own no segment, so some pixels cannot bound
    # their primitives' answers and query them in full, next to pixels that use the shortlist
    p = DendryParams(levels=2, eps=0.25, delta=0.05, beta=0.5, noise=0.05, resolution=2.0, seed=3)
    kw = dict(domain=((-1.4, -1.4), (1.4, 1.4)), control_domain=((-1.4, -1.4), (1.4, 1.4)), params=p,
              control=control.lichtenberg(scale=0.2), output="elevation", device=device)
    a = dendry((48, 48), **kw)
    b = dendry((48, 48), mode="pixel", **kw)
    assert np.array_equal(a, b, equal_nan=True), np.nanmax(np.abs(a - b))
    assert np.isfinite(a).all()


@pytest.mark.parametrize("levels", [1, 2, 3, 4, 5, 6])
@pytest.mark.parametrize("mode", ["cached", "pixel"])
@pytest.mark.parametrize("output", ["distance", "elevation", "level"])
def test_windows_equal_the_whole_image_at_tile_borders(device, output, mode, levels):
    p = DendryParams(levels=levels, eps=0.25, delta=0.1, beta=0.5, noise=0.05, seed=2)
    # a smaller domain at levels 5-6, whose cached windows build every primitive cell they span
    side = 3.0 if levels <= 4 else 1.25
    kw = dict(domain=((0.1, 0.2), (0.1 + side, 0.2 + side)), params=p, control=CTL, output=output, device=device)
    whole = dendry((40, 40), **kw)
    for win in ((0, 0, 20, 20), (20, 20, 20, 20), (19, 18, 3, 5), (0, 39, 40, 1), (10, 5, 12, 30)):
        r, c, h, w = win
        assert np.array_equal(dendry((40, 40), window=win, mode=mode, **kw), whole[r : r + h, c : c + w]), win


@pytest.mark.parametrize("levels, output", [(1, "distance"), (6, "level"), (2, "elevation"), (4, "elevation")])
def test_modes_and_windows_agree_just_inside_the_coordinate_bound(device, levels, output):
    p = DendryParams(levels=levels, eps=0.25, delta=0.1, beta=0.5, noise=0.05, seed=5)
    finest = levels + (p.primitive_steps if output == "elevation" else 0)
    edge = 2.0**22 / 2 ** (finest - 1)  # the bound on |x| (resolution 1)
    kw = dict(params=p, control=CTL, output=output, control_domain=((0.0, 0.0), (2.0, 2.0)), device=device)
    # pixel centres reach 0.999 of the bound at +x and at -y (12 x 12 pixels over 8 x 8 units)
    lo, hi = edge * 0.999 - 8.0 + 1.0 / 3.0, edge * 0.999 + 1.0 / 3.0
    dom = ((lo, -hi), (hi, -lo))
    a = dendry((12, 12), domain=dom, **kw)
    assert np.isfinite(a).all()
    assert np.array_equal(dendry((12, 12), domain=dom, mode="pixel", **kw), a)
    for win in ((0, 0, 5, 7), (4, 6, 8, 6), (11, 11, 1, 1)):
        r, c, h, w = win
        for mode in ("cached", "pixel"):
            assert np.array_equal(dendry((12, 12), domain=dom, window=win, mode=mode, **kw), a[r : r + h, c : c + w])
    # just outside: refused before any kernel runs, naming what reached too far
    out = ((edge - 7.0, -hi), (edge + 1.0, -lo))  # only the last column's centres lie beyond the bound
    with pytest.raises(ValueError, match="'domain'"):
        dendry((12, 12), domain=out, **kw)
    with pytest.raises(ValueError, match="'window'"):
        dendry((12, 12), domain=out, window=(0, 11, 1, 1), **kw)
    assert dendry((12, 12), domain=out, window=(0, 0, 12, 1), **kw).shape == (12, 1)
    with pytest.raises(ValueError, match="'points'"):
        dendry_points([[0.0, 0.0], [-edge * 1.001, 0.0]], domain=dom, **kw)


def test_a_window_of_an_image_too_large_to_make_whole_equals_its_points():
    # 65536^2 pixels (2^32) overflow int32 as a whole image, but each window is indexed on its own:
    # the one at (30000, 40000) equals the points at its pixel centres (made independently)
    p = DendryParams(levels=3, seed=2)
    dom = ((0.0, 0.0), (64.0, 64.0))
    kw = dict(params=p, control=CTL, control_domain=((0.0, 0.0), (2.0, 2.0)))
    got = dendry((65536, 65536), domain=dom, window=(30000, 40000, 12, 16), **kw)
    rows, cols = np.mgrid[30000:30012, 40000:40016]
    pts = np.stack([(cols + 0.5) * 64.0 / 65536, (rows + 0.5) * 64.0 / 65536], -1).reshape(-1, 2)
    want = dendry_points(pts, domain=dom, **kw).reshape(12, 16)
    assert np.isfinite(want).all() and np.ptp(want) > 0.0
    assert np.array_equal(got, want)


def test_far_coordinates_are_refused_not_crashed_on():
    # cell indices near 3e9 overflow int32: the per-pixel mode wrote outside its blocks
    far = ((3.0e9, 3.0e9), (3.0e9 + 4.0, 3.0e9 + 4.0))
    with pytest.raises(ValueError, match="domain"):
        dendry((8, 8), domain=far, params=DendryParams(levels=2), control=CTL, mode="pixel")
    with pytest.raises(ValueError, match="points"):
        dendry_points([[3.0e9, 1.0]], domain=DOMAIN, params=DendryParams(levels=2), control=CTL)
    # a mapping onto control coordinates that float32 cannot hold
    with pytest.raises(ValueError, match="control_domain"):
        dendry((8, 8), domain=DOMAIN, params=DendryParams(), control=CTL, control_domain=((0, 0), (1e39, 1)))
    with pytest.raises(ValueError, match="domain"):
        dendry((8, 8), domain=((0, 0), (1e-40, 1)), params=DendryParams(), control=CTL)


def test_a_primitive_block_planned_too_small_raises_instead_of_returning_nan(device, monkeypatch):
    wdd = importlib.import_module("wdendrite.dendry")  # the package's name `dendry` is the function
    plan = wdd._host_plan

    def first_pixel_only(params, output, u_first, u_last):
        return plan(params, output, u_first, u_first)

    monkeypatch.setattr(wdd, "_host_plan", first_pixel_only)
    with pytest.raises(RuntimeError, match="primitive block"):
        dendry((16, 16), domain=DOMAIN, params=DendryParams(levels=2), control=CTL, output="elevation",
               mode="cached", device=device)


@pytest.mark.parametrize("output", ["distance", "elevation"])
def test_a_few_pixels_over_a_wide_domain_are_evaluated_pixel_by_pixel(output, device, monkeypatch):
    # the cached mode builds every cell between the window's first and last pixel: 8 x 8 pixels
    # over a domain 1e5 cells wide had raised a bare OverflowError (or asked for 151 GiB)
    wdd = importlib.import_module("wdendrite.dendry")
    p = DendryParams(levels=3)
    ctl = control.plane((0.0, 1.0), domain=((0, 0), (1, 1)))
    far = ((0, 0), (1e5, 1e5))
    with pytest.raises(ValueError, match=r"mode='cached' would build \d+ cells for 64 pixels .* use mode='auto' or 'pixel'"):
        dendry((8, 8), domain=far, params=p, control=ctl, output=output, mode="cached", device=device)
    built = []
    run = wdd._run_cached
    monkeypatch.setattr(wdd, "_run_cached", lambda *a, **k: built.append(1) or run(*a, **k))
    auto = dendry((8, 8), domain=far, params=p, control=ctl, output=output, device=device)  # "auto", the default
    assert not built  # no cached plan for these
    np.testing.assert_array_equal(auto, dendry((8, 8), domain=far, params=p, control=ctl, output=output,
                                               mode="pixel", device=device))
    # an ordinary image is still cached, with the same values as the per-pixel mode
    near = dendry((24, 24), domain=DOMAIN, params=p, control=CTL, output=output, device=device)
    assert built
    np.testing.assert_array_equal(near, dendry((24, 24), domain=DOMAIN, params=p, control=CTL, output=output,
                                               mode="pixel", device=device))


@pytest.mark.parametrize("mode", ["auto", "cached", "pixel"])
@pytest.mark.parametrize("output", ["distance", "elevation", "level"])
def test_points_equal_pixels(device, output, mode):
    p = DendryParams(levels=3, eps=0.25, delta=0.08, seed=9, resolution=1.7, beta=0.5, noise=0.05)
    dom, (h, w) = ((0.1, -0.3), (2.3, 1.9)), (24, 20)
    img = dendry((h, w), domain=dom, params=p, control=CTL, output=output, device=device)
    # the points where the kernel puts the pixel centres: x0 + (col + 0.5) * step in float32 grid
    # units, with x0 and step rounded to float32 first (the host rounds points only once)
    f32 = np.float32
    x0 = f32(np.array([dom[0][0], dom[0][1]]) * p.resolution)
    step = f32(np.array([(dom[1][0] - dom[0][0]) / w, (dom[1][1] - dom[0][1]) / h]) * p.resolution)
    rows, cols = np.mgrid[0:h, 0:w].astype(f32)
    u = np.stack([x0[0] + (cols.ravel() + f32(0.5)) * step[0], x0[1] + (rows.ravel() + f32(0.5)) * step[1]], 1)
    pts = u.astype(np.float64) / p.resolution
    assert np.array_equal((pts * p.resolution).astype(f32), u)
    got = dendry_points(pts, domain=dom, params=p, control=CTL, output=output, mode=mode, device=device)
    # on every device: the kernels are compiled with fuse_fp=False, so CUDA rounds the pixel
    # centre's multiply and add apart, as the CPU does
    assert np.array_equal(got, img.ravel())


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
    # 16x amplification: a 16^2 DEM becomes a 256^2 terrain
    rng = np.random.default_rng(0)
    coarse = rng.random((16, 16)).astype(np.float32)
    dem = control.image(coarse, domain=((0.0, 0.0), (1.0, 1.0)))
    p = DendryParams(levels=3, eps=0.25, delta=0.05, resolution=1.0, beta=0.75)
    fine = dendry((256, 256), domain=((0.0, 0.0), (16.0, 16.0)), params=p, control=dem, output="elevation",
                  device=device)
    assert np.isfinite(fine).all()
    down = fine.reshape(16, 16, 16, 16).mean(axis=(1, 3))
    assert np.corrcoef(down.ravel(), coarse.ravel())[0, 1] > 0.7
    # and it adds detail the bicubic DEM does not have: valleys cut below it, and twice its
    # roughness from pixel to pixel (a DEM merely shifted down would pass the first test alone)
    smooth = dem.grid((256, 256), device=device)
    assert np.mean(fine < smooth - 0.01) > 0.05
    assert np.abs(np.diff(fine, axis=1)).mean() > 1.5 * np.abs(np.diff(smooth, axis=1)).mean()
    # the tree stands on the DEM: every level-1 key point's elevation is the DEM's value there
    # (the domain's 16 units map onto the DEM's 1)
    cells, keyp, _ = _cached_tree((256, 256), domain=((0.0, 0.0), (16.0, 16.0)), params=p, control=dem,
                                  device=device)[0]
    inside = keyp[:, 3] != 0
    assert inside.sum() > 250
    np.testing.assert_array_equal(keyp[inside, 2], dem.evaluate(keyp[inside, :2] / 16.0, device=device))


def test_a_scaled_lichtenberg_bowl_grows_the_same_tree(device):
    # scaling the bowl changes no link: the tree (distance, level) is the paper's at any scale, and
    # the scale that fits terrains' [0, 1] makes an elevation
    p = DendryParams(levels=3, eps=0.25, rule="lichtenberg", resolution=2.0)
    kw = dict(domain=((-1.0, -1.0), (1.0, 1.0)), params=p, device=device)
    for output in ("distance", "level"):
        want = dendry((40, 40), control=control.lichtenberg(), output=output, **kw)
        for scale in (0.2, 3.0):
            np.testing.assert_array_equal(dendry((40, 40), control=control.lichtenberg(scale), output=output, **kw), want)
    z = dendry((40, 40), control=control.lichtenberg(0.2), output="elevation", **kw)
    assert np.isfinite(z).all() and control.lichtenberg(0.2).maximum == 1.0
    with pytest.raises(ValueError, match="'scale'"):
        control.lichtenberg(0.0)


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
        (dict(levels=2, eps=(0.25,)), "one 'eps' per level"),
        (dict(levels=2, eps=(0.25, 0.7)), "eps"),
        (dict(delta=-0.1), "delta"),
        (dict(delta=(0.1, -0.1), levels=2), "delta"),
        (dict(delta=(0.1, 0.1, 0.1), levels=2), "delta"),
        (dict(resolution=-1.0), "resolution"),
        (dict(resolution=0.0), "resolution"),
        # 1 / resolution must stay finite in float32 (it overflowed: inf distances, NaN terrains)
        (dict(resolution=1e-39), r"'resolution' in \[1e-30, 1000000.0\], but got 1e-39"),
        (dict(beta=-1.0), "beta"),
        (dict(noise=float("nan")), "noise"),
        (dict(primitive_steps=0), "primitive_steps"),
        (dict(rule="diagonal"), "rule"),
        (dict(search="fast"), "search"),
        (dict(search=1), "search"),
        (dict(smoothing=1), "smoothing"),
        (dict(seed=-1), r"'seed' in \[0, 2\*\*32\), but got -1"),
        (dict(seed=2**32), r"'seed' in \[0, 2\*\*32\), but got 4294967296"),
    ],
)
def test_bad_params_raise(kw, match):
    with pytest.raises((ValueError, TypeError), match=match):
        DendryParams(**kw)


@pytest.mark.parametrize("field", ["levels", "seed", "eps", "delta", "resolution", "beta", "noise", "primitive_steps",
                                   "smoothing", "subdivision"])
def test_text_is_refused_for_every_number_field(field):
    # float("0.1") would parse, and "0.1" * length fails only much later in a kernel launch
    with pytest.raises(TypeError, match=field):
        DendryParams(**{field: "1"})
    with pytest.raises(TypeError, match="delta"):
        DendryParams(levels=2, delta=(0.1, "0.1"))


def test_params_are_stored_as_plain_python_values():
    p = DendryParams(levels=np.int64(2), seed=np.uint32(7), eps=np.float32(0.25), delta=[np.float64(0.1), 0],
                     resolution=np.int32(2), smoothing=np.bool_(False), beta=np.float16(0.5), noise=0,
                     primitive_steps=np.int8(2), rule=np.str_("lichtenberg"), search=np.str_("paper"))
    kinds = {"levels": int, "seed": int, "eps": float, "delta": tuple, "resolution": float, "smoothing": bool,
             "subdivision": bool, "beta": float, "noise": float, "primitive_steps": int, "rule": str,
             "search": str}
    for name, kind in kinds.items():
        assert type(getattr(p, name)) is kind, name
    assert [type(d) for d in p.delta] == [float, float]
    assert p == DendryParams(levels=2, seed=7, eps=0.25, delta=(0.1, 0.0), resolution=2.0, smoothing=False,
                             primitive_steps=2, rule="lichtenberg", search="paper")
    assert type(DendryParams(delta=np.float32(0.5)).delta) is float


@pytest.mark.parametrize("output", ["distance", "elevation"])
def test_the_cpus_rolled_per_pixel_kernels_equal_the_general_ones(output, monkeypatch):
    # on the CPU the per-pixel mode runs kernels compiled with rolled loops; CUDA runs the
    # general kernels with cached = 0: both must give the same values bit for bit
    p = DendryParams(levels=3, eps=0.1, delta=0.3, beta=0.5, noise=0.05, seed=2)
    pts = np.random.default_rng(0).uniform(0.0, 2.0, (300, 2))
    seen = []
    real = wp.launch

    def recording(kernel, *args, **kwargs):
        seen.append(kernel)
        return real(kernel, *args, **kwargs)

    monkeypatch.setattr(wp, "launch", recording)
    got = dendry_points(pts, domain=DOMAIN, params=p, control=CTL, output=output, mode="pixel", device="cpu")
    img = dendry((8, 8), domain=DOMAIN, params=p, control=CTL, output=output, mode="pixel", device="cpu")
    assert _kp.points_kernel in seen and _kp.image_kernel in seen
    assert _kd.points_kernel not in seen and _kd.image_kernel not in seen
    s = _setup(p, DOMAIN, DOMAIN, output)
    slots = _slots_for_pixels(p, output, len(pts), "cpu")
    out = wp.zeros(len(pts), dtype=float, device="cpu")
    u = wp.array((pts * p.resolution).astype(np.float32), dtype=wp.vec2, device="cpu")
    real(_kd.points_kernel, dim=len(pts), inputs=[s, CTL.struct("cpu"), _OUTPUTS[output], 0, slots.cap, 1, 0, u,
                                                  *slots.arrays()], outputs=[out, slots.overflow], device="cpu")
    assert np.array_equal(out.numpy(), got)
    assert np.array_equal(img, dendry((8, 8), domain=DOMAIN, params=p, control=CTL, output=output, device="cpu"))


def test_the_launch_recorder_sees_dendry_kernels(launches):
    dendry((4, 4), domain=DOMAIN, params=DendryParams(), control=CTL)
    assert launches  # so an empty record below means that no kernel ran


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
        (dict(output=["distance"]), r"'output' in .*, but got \['distance'\]"),
        (dict(mode="lazy"), "mode"),
        (dict(mode=["pixel"]), r"'mode' in .*, but got \['pixel'\]"),
        # pixels float32 cannot place apart (the image was one value)
        (dict(domain=((1.0, 1.0), (1.0 + 1e-12, 1.0 + 1e-12))), "too narrow for 16 columns in float32: columns 0 and 1"),
        # a control whose range is not a number (no constructor makes one any more) is no terrain control
        (dict(control=control.Control("plane", ((0.0, 0.0), (1.0, 1.0)), float("nan"), float("nan")),
              output="elevation"), r"values in \[0, 1\].*spans \[nan, nan\]"),
        (dict(params=None), "params"),
        (dict(control=np.zeros((4, 4))), "control"),
        (dict(shape=(0, 16)), "shape"),
        (dict(shape=(4, 4, 4)), r"'shape' of rank 2 \(H, W\), but got \(4, 4, 4\)"),
        (dict(shape=(2**31, 16), window=(0, 0, 4, 4)), r"'shape' \(2147483648, 16\) has a size of 2147483648"),
        # an image computed whole must fit int32 indices; a window of it need not be (below)
        (dict(shape=(65536, 65536)), r"'shape' \(65536, 65536\) has 4294967296 pixels.*window by window"),
        # pixel centres (col + 0.5) beyond 2**23 are not exact in float32 (it had blamed a too narrow domain)
        (dict(shape=(8, 2**23 + 1), domain=((0.0, 0.0), (4.0e6, 1.0)), window=(0, 0, 4, 4)),
         r"'shape' \(8, 8388609\) has 8388609 columns, beyond the 2\*\*23"),
        (dict(window=(0, 0, 0, 4)), r"'window' \(0, 0, 0, 4\) is empty"),
        (dict(window=(8, 0, 9, 4)), r"'window' \(8, 0, 9, 4\) reaches outside .*rows 8..16"),
        (dict(domain=((0.0, 0.0), (5.0e6, 1.0))), "domain"),
        (dict(domain=((0.0, 0.0), (5.0e6, 1.0)), window=(0, 15, 1, 1)), "window"),
        (dict(domain=((0.0, 0.0), (6.0e5, 1.0)), output="elevation"), "domain"),
        (dict(control_domain=((0.0, 0.0), (1.0e39, 1.0))), "control_domain"),
        # a noise control read far from the origin is flat in float32 (it had run, one value throughout)
        (dict(control=control.perlin(frequency=3.0), control_domain=((5e6, 5e6), (5e6 + 1.0, 5e6 + 1.0))),
         r"'control_domain' \(\(5000000.0, 5000000.0\), .*noise \(frequency 3, .*sampled at up to 1.5e\+07"),
        (dict(control=None, control_domain=((5e6, 0.0), (5e6 + 1.0, 1.0))), r"reaches 5e\+06 in the perlin control"),
        (dict(device="cuda:9"), "device"),
        # terrains take control values in [0, 1] (eq. 7); a DEM in metres is refused with the fix
        (dict(control=control.image(np.array([[120.0, 340.0], [80.0, 95.0]])), output="elevation"),
         r"values in \[0, 1\].*spans \[80, 340\].*scale it"),
        (dict(control=control.lichtenberg(), output="elevation"), r"lichtenberg control spans \[0, 5\]"),
        # a plane in [0, 1] on its own domain, read over a wider one, leaves it
        (dict(control=control.plane((0.0, 1.0)), control_domain=((0.0, 0.0), (1.0, 2.0)), output="elevation"),
         r"plane control spans \[0, 2\] over 'control_domain'"),
    ],
)
def test_bad_dendry_input_raises_before_any_kernel(kw, match, launches):
    args = dict(shape=(16, 16), domain=DOMAIN, params=DendryParams(), control=CTL)
    args.update(kw)
    shape = args.pop("shape")
    with pytest.raises((ValueError, TypeError), match=match):
        dendry(shape, **args)
    assert launches == []


@pytest.mark.parametrize("output", ["distance", "elevation", "level"])
def test_point_modes_agree_bit_for_bit_across_tiles(device, output, launches):
    # dense clusters, a cluster across tile borders and points far apart, in shuffled order:
    # every mode gives the same values, in the caller's order
    rng = np.random.default_rng(11)
    p = DendryParams(levels=3, eps=0.25, delta=0.1, seed=2, beta=0.5, noise=0.05)
    wdd = importlib.import_module("wdendrite.dendry")
    side = max(1, 256 >> (p.levels - 1 + (p.primitive_steps if output == "elevation" else 0))) / p.resolution
    pts = np.concatenate([
        rng.uniform(0.2, 0.5, (300, 2)),  # dense
        side * 3 + rng.uniform(-0.2, 0.2, (300, 2)),  # dense, across a tile corner
        rng.uniform(-40.0, 40.0, (30, 2)),  # sparse
    ])
    pts = pts[rng.permutation(len(pts))]
    kw = dict(domain=DOMAIN, params=p, control=CTL, output=output, device=device)
    want = dendry_points(pts, mode="pixel", **kw)
    assert "levelk_kernel" not in launches
    assert np.isfinite(want).sum() > 600
    for mode in ("cached", "auto"):
        launches.clear()
        np.testing.assert_array_equal(dendry_points(pts, mode=mode, **kw), want)
        assert "levelk_kernel" in launches
    # auto evaluates sparse points one by one (their tiles would build far more cells than they use)
    launches.clear()
    sparse = dendry_points(pts[-30:], mode="auto", **kw)
    np.testing.assert_array_equal(sparse, dendry_points(pts[-30:], mode="pixel", **kw))
    assert "levelk_kernel" not in launches
    # tiles: each holds the points of one square, and no square is split
    u = (pts * p.resolution).astype(np.float32)
    order, starts = wdd._point_tiles(u, p, output)
    squares = np.floor(u.astype(np.float64) / (side * p.resolution)).astype(np.int64)[order]
    firsts = [tuple(squares[a]) for a in starts[:-1]]
    assert len(set(firsts)) == len(firsts) and starts[-1] == len(pts)
    for a, b in zip(starts[:-1], starts[1:]):
        assert (squares[a:b] == squares[a]).all()


def test_auto_point_mode_leaves_a_tile_whose_cells_cost_more_than_its_points(launches):
    # 80 points in two far corners of one tile: caching would build the whole tile's cells
    p = DendryParams(levels=3, eps=0.25, delta=0.1, seed=2)
    wdd = importlib.import_module("wdendrite.dendry")
    side = (256 >> (p.levels - 1)) / p.resolution
    rng = np.random.default_rng(3)
    pts = np.concatenate([rng.uniform(0.1, 0.3, (40, 2)), side - rng.uniform(0.1, 0.3, (40, 2))])
    assert len(wdd._point_tiles((pts * p.resolution).astype(np.float32), p, "distance")[0]) == 80
    assert len(wdd._point_tiles((pts * p.resolution).astype(np.float32), p, "distance")[1]) == 2  # one tile
    kw = dict(domain=((0.0, 0.0), (side, side)), params=p, control=CTL)
    got = dendry_points(pts, **kw)
    assert "levelk_kernel" not in launches
    np.testing.assert_array_equal(got, dendry_points(pts, mode="cached", **kw))
    assert "levelk_kernel" in launches


@pytest.mark.parametrize("output", ["distance", "elevation"])
def test_host_planning_equals_the_kernels(output):
    # the cached mode plans its blocks on the host: the same blocks and bases as the kernel's plan,
    # and block sizes (which "auto" weighs) that the host's per-axis mirror also gives
    wdd = importlib.import_module("wdendrite.dendry")
    rng = np.random.default_rng(4)
    for _ in range(20):
        p = DendryParams(levels=int(rng.integers(1, 7)), rule=str(rng.choice(["terrain", "lichtenberg"])),
                         eps=float(rng.choice([0.0, 0.25])), delta=float(rng.uniform(0, 0.4)), resolution=1.5,
                         search=str(rng.choice(["exact", "paper"])))
        lo = rng.uniform(-20, 20, 2)
        hi = lo + rng.uniform(0, 3, 2)
        s = wdd._setup(p, DOMAIN, CTL.domain, output)
        qlo, qhi, plo, phi = (wp.vec2i(*c) for c in wdd._query_cells(p, output, lo.tolist(), hi.tolist()))
        blocks = wp.zeros(8, dtype=wp.vec4i, device="cpu")
        bases = wp.zeros(8, dtype=int, device="cpu")
        wp.launch(_kd.plan_kernel, dim=1, inputs=[s, qlo, qhi, plo, phi, wp.vec3i(2**30, 2**30, 2**30)],
                  outputs=[blocks, bases, wp.zeros(1, dtype=int, device="cpu")], device="cpu")
        want_blocks, want_bases, sizes = wdd._host_plan(p, output, lo.tolist(), hi.tolist())
        np.testing.assert_array_equal(blocks.numpy(), want_blocks)
        np.testing.assert_array_equal(bases.numpy(), want_bases)
        for axis in range(2):
            widths = wdd._plan_axis(p, qlo[axis], qhi[axis], 0)
            assert widths[1:] == [int(b[2 + axis]) for b in want_blocks[1:p.levels + 1]]


@pytest.mark.parametrize("pts, match", [([[0.0, np.nan]], "points"), ([[0.0, 1.0, 2.0]], "points"),
                                        ([[np.inf, 0.0]], "points"), ([[1.0, 1.0], [0.0, 5.0e6]], "points"),
                                        (np.array([["a", "b"]]), "points"), ([[0.1, 0.2], [0.3]], "points")])
def test_bad_points_raise_before_any_kernel(pts, match, launches):
    with pytest.raises((ValueError, TypeError), match=match):
        dendry_points(pts, domain=DOMAIN, params=DendryParams(), control=CTL)
    assert launches == []


def test_bad_point_mode_raises_before_any_kernel(launches):
    with pytest.raises(ValueError, match="'mode'.*'tiled'"):
        dendry_points([[0.1, 0.2]], domain=DOMAIN, params=DendryParams(), control=CTL, mode="tiled")
    assert launches == []


def test_no_points_are_checked_like_some(launches):
    # an empty point set returned before its device and mapping were checked
    with pytest.raises(ValueError, match="'device'.*'bogus'"):
        dendry_points(np.zeros((0, 2)), domain=DOMAIN, params=DendryParams(), control=CTL, device="bogus")
    with pytest.raises(ValueError, match="mapping of 'domain'"):
        dendry_points(np.zeros((0, 2)), domain=((0.0, 0.0), (1e-300, 1e-300)), params=DendryParams(), control=CTL)
    assert launches == []
    assert dendry_points(np.zeros((0, 2)), domain=DOMAIN, params=DendryParams(), control=CTL).shape == (0,)
    # an empty list too (it had been refused as shape (0,)); other shapes of no points still are not
    assert dendry_points([], domain=DOMAIN, params=DendryParams(), control=CTL).shape == (0,)
    with pytest.raises(ValueError, match=r"shape \(N, 2\), but got shape \(0, 3\)"):
        dendry_points(np.zeros((0, 3)), domain=DOMAIN, params=DendryParams(), control=CTL)


@pytest.mark.parametrize("mode", ["cached", "pixel"])
def test_terrain_beyond_a_bounded_control_stays_in_its_range(device, mode):
    # primitives with no branch near take the control; outside the Lichtenberg bowl's square that
    # was its 16 * scale (3.2 here, 3.2 times the range the terrain check promises), now its maximum
    c = control.lichtenberg(0.2)
    z = dendry((48, 48), domain=((0.0, 0.0), (12.0, 12.0)), params=DendryParams(levels=2), control=c,
               control_domain=((-6.0, -6.0), (6.0, 6.0)), output="elevation", mode=mode, device=device)
    assert np.isfinite(z).all()
    far = z[:8, :8]  # control coordinates below (-4, -4): no branch within reach of any primitive
    np.testing.assert_array_equal(far, np.float32(c.maximum))
    assert z.min() >= 0.0 and (z <= c.maximum).mean() > 0.5


def test_an_image_too_big_for_memory_raises_before_any_kernel(monkeypatch, launches):
    from wdendrite import _checks

    monkeypatch.setattr(_checks, "available_bytes", lambda device: 4 * 64 * 64 - 1)
    with pytest.raises(MemoryError, match=r"Dendry image of shape \(64, 64\)"):
        dendry((64, 64), domain=DOMAIN, params=DendryParams(), control=CTL)
    assert launches == []


def test_default_control_is_the_authors_interactive_perlin(device):
    import wdendrite as wd
    from wdendrite.dendry import default_control

    assert wd.default_control is default_control  # (wd.dendry is the function, not the module)

    p = DendryParams(levels=2)
    a = dendry((16, 16), domain=((0, 0), (4, 4)), params=p, device=device)
    b = dendry((16, 16), domain=((0, 0), (4, 4)), params=p, control=default_control(), device=device)
    assert np.array_equal(a, b)
    # what it is, checked apart from the code that makes it: single-octave Perlin noise of seed 0
    # at frequency 1 on the authors' rectangle
    from test_control import _perlin_reference

    from wdendrite.control import _permutation

    c = default_control()
    assert (c.kind, c.seed, c.octaves, c.params[0]) == ("perlin", 0, 1, 1.0)
    assert c.domain == ((-0.2, -0.5), (1.4, 0.7))
    pts = np.random.default_rng(3).uniform((-0.2, -0.5), (1.4, 0.7), (200, 2)).astype(np.float32)
    np.testing.assert_allclose(c.evaluate(pts, device=device), 0.5 + 0.5 * _perlin_reference(_permutation(0), pts),
                               atol=2e-6)


def test_one_eps_per_level_keeps_each_levels_key_points_in_its_band(device):
    # a single eps equals the same value given per level, bit for bit; per level, level 1's key
    # points stay in their cells' middle half while finer ones spread over whole cells
    base = dict(levels=3, delta=0.1, beta=0.5, noise=0.05, seed=4)
    dom = ((0.0, 0.0), (4.0, 4.0))
    one = dendry((48, 48), domain=dom, params=DendryParams(eps=0.25, **base), output="elevation", device=device)
    each = dendry((48, 48), domain=dom, params=DendryParams(eps=(0.25,) * 3, **base), output="elevation", device=device)
    assert one.tobytes() == each.tobytes()
    p = DendryParams(eps=(0.25, 0.0, 0.0), **base)
    tree = _cached_tree((64, 64), domain=dom, params=p, control=CTL, control_domain=dom, device=device)
    for level, (cells, keyp, _) in enumerate(tree, 1):
        own = keyp[:, 3] == _SEGMENT
        frac = keyp[own, :2] * 2 ** (level - 1) - cells[own]  # position inside the cell, in [0, 1)
        if level == 1:
            assert frac.min() >= 0.25 - 1e-6 and frac.max() <= 0.75 + 1e-6
        else:
            assert frac.min() < 0.1 and frac.max() > 0.9  # (hundreds of points: some near the borders)
    assert p.radii() == DendryParams(eps=0.0, **base).radii()  # the free regime's searches


@pytest.mark.parametrize("output", ["distance", "elevation", "level"])
def test_the_gpus_per_pixel_branches_give_the_cpus_values(output, monkeypatch):
    # what a CUDA device runs in the per-pixel mode, here on the CPU: the general kernels with a
    # slot per thread, in launches a few slots long (first > 0), for images, windows and points
    wdd = importlib.import_module("wdendrite.dendry")
    p = DendryParams(levels=3, eps=0.1, delta=0.3, beta=0.5, noise=0.05, seed=2)
    kw = dict(domain=DOMAIN, params=p, control=CTL, output=output, mode="pixel", device="cpu")
    pts = np.random.default_rng(0).uniform(0.0, 2.0, (97, 2))
    ref = (dendry((9, 11), **kw), dendry((9, 11), window=(2, 3, 5, 6), **kw), dendry_points(pts, **kw))
    calls = []
    real_slots = wdd._slots_for_pixels

    def seven(*args):
        slots = real_slots(*args)
        calls.append(len(slots.blocks) // 8)
        return slots

    per_slot = wdd._Slots.nbytes(1, wdd._slot_capacity(p, output), shortlist=True)
    monkeypatch.setattr(wdd, "_GPU_PATHS", True)
    monkeypatch.setattr(wdd, "_PIXEL_SLOT_BYTES", 7 * per_slot)  # 7 threads a launch
    monkeypatch.setattr(wdd, "_slots_for_pixels", seven)
    monkeypatch.setattr(wdd, "_kp", None)  # the CPU's own per-pixel kernels are not used
    got = (dendry((9, 11), **kw), dendry((9, 11), window=(2, 3, 5, 6), **kw), dendry_points(pts, **kw))
    assert calls == [7, 7, 7]
    for a, b in zip(got, ref):
        assert np.array_equal(a, b, equal_nan=True)


@pytest.mark.parametrize("mode", ["auto", "cached", "pixel"])
@pytest.mark.parametrize("output", ["distance", "elevation", "level"])
def test_threads_in_bands_of_rows_give_one_threads_bytes(output, mode, monkeypatch, launches):
    # bands of a few rows, each a window evaluated by its own thread, against one thread over the whole
    wdd = importlib.import_module("wdendrite.dendry")
    monkeypatch.setattr(wdd._parallel, "cores", lambda: 3)
    monkeypatch.setattr(wdd, "_BAND_PIXELS", 40)
    p = DendryParams(levels=3, eps=0.25, delta=0.2, beta=0.5, noise=0.05, seed=3)
    kw = dict(domain=((0.1, 0.2), (2.1, 2.2)), params=p, control=CTL, output=output, mode=mode, device="cpu")
    for window in (None, (5, 3, 29, 31)):
        one = dendry((37, 35), window=window, workers=1, **kw)
        launches.clear()
        many = dendry((37, 35), window=window, workers=3, **kw)
        assert launches.count("image_kernel") == 12  # (3 threads, 4 bands each)
        assert many.dtype == one.dtype and np.array_equal(many.view(np.uint32), one.view(np.uint32)), window


@pytest.mark.parametrize("workers, error, match", [
    (0, ValueError, r"'workers' >= 1 .*, but got 0"), (-2, ValueError, r"'workers' >= 1 .*, but got -2"),
    (1.5, TypeError, r"integer >= 1 .* for 'workers', but got 1.5"), (True, TypeError, "'workers', but got True"),
    ("2", TypeError, r"'workers', but got '2'"),
])
def test_bad_workers_raise_before_any_kernel(workers, error, match, launches):
    with pytest.raises(error, match=match):
        dendry((16, 16), domain=DOMAIN, params=DendryParams(), control=CTL, workers=workers)
    assert launches == []


def test_more_workers_than_cores_are_capped_with_a_warning(monkeypatch):
    wdd = importlib.import_module("wdendrite.dendry")
    monkeypatch.setattr(wdd._parallel, "cores", lambda: 2)
    kw = dict(domain=DOMAIN, params=DendryParams(levels=2), control=CTL)
    with pytest.warns(UserWarning, match=r"'workers' = 5 is more than the 2 cores this process may use: using 2"):
        capped = dendry((16, 16), workers=5, **kw)
    assert np.array_equal(capped, dendry((16, 16), workers=1, **kw))
