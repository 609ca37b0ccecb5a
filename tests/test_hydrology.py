"""Hydrology metrics against hand-made DEMs and brute-force priority-flood / D8 references."""

import heapq
import warnings

import numpy as np
import pytest

from wdendrite import control, hydrology
from wdendrite.dendry import DendryParams, dendry


def _priority_flood(z):
    """Barnes et al. priority-flood fill, written plainly with a heap."""
    h, w = z.shape
    out = z.astype(float).copy()
    seen = np.zeros(z.shape, bool)
    heap = []
    for r in range(h):
        for c in range(w):
            if r in (0, h - 1) or c in (0, w - 1):
                heapq.heappush(heap, (out[r, c], r, c))
                seen[r, c] = True
    while heap:
        v, r, c = heapq.heappop(heap)
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                rr, cc = r + dr, c + dc
                if 0 <= rr < h and 0 <= cc < w and not seen[rr, cc]:
                    seen[rr, cc] = True
                    out[rr, cc] = max(out[rr, cc], v)
                    heapq.heappush(heap, (out[rr, cc], rr, cc))
    return out


def _pits_dem():
    """A bowl draining to the border with 3 known pits (one of two diagonal cells)."""
    rows, cols = np.mgrid[0:9, 0:9]
    # a stepped dome: 10 on the border, 11 on the next ring, ... 14 at the centre; water runs outwards
    z = 10.0 + np.minimum(np.minimum(rows, 8 - rows), np.minimum(cols, 8 - cols)).astype(float)
    z[2, 2] = 5.0  # single-cell pit on ring 12: it spills over its ring-11 neighbours
    z[5, 5] = z[6, 6] = 4.0  # two diagonal cells (rings 13 and 12): one depression, spilling at 11
    z[2, 6] = 11.5  # lower than its ring but still above a ring-11 neighbour: drains
    return z


def test_depressions_on_a_hand_made_dem():
    z = _pits_dem()
    d = hydrology.depressions(z)
    assert d.count == 2
    assert d.mask.sum() == 3 and d.mask[2, 2] and d.mask[5, 5] and d.mask[6, 6]
    assert d.percent == pytest.approx(100 * 3 / 81)
    assert d.depth[2, 2] == 6.0  # 11 - 5
    assert d.depth[5, 5] == d.depth[6, 6] == 7.0
    assert not d.mask[2, 6]
    assert repr(d) == "Depressions(count=2, percent=3.704, shape=(9, 9))"
    assert d == d and d != hydrology.depressions(z) and len({d}) == 1  # (== and hash had raised)


def test_fill_equals_brute_force_priority_flood():
    rng = np.random.default_rng(0)
    for _ in range(5):
        z = rng.random((17, 23))
        np.testing.assert_array_equal(hydrology.fill(z), _priority_flood(z))
        # float32 elevations (filled in float32) give the same surface, as float64
        z32 = z.astype(np.float32)
        got = hydrology.fill(z32)
        assert got.dtype == np.float64
        np.testing.assert_array_equal(got, _priority_flood(z32.astype(np.float64)))
    # a pit shallower than float32 can tell is still filled (such elevations stay in float64)
    z = np.ones((5, 5))
    z[2, 2] = 1.0 - 1e-12
    assert hydrology.fill(z)[2, 2] == 1.0 and hydrology.depressions(z).count == 1
    # elevations beyond float32's range stay in float64, without a warning about the cast
    z = rng.random((9, 11)) * 1e300
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_array_equal(hydrology.fill(z), _priority_flood(z))


def test_no_depressions_on_a_plane_or_a_dome():
    rows, cols = np.mgrid[0:20, 0:30]
    assert hydrology.depressions(0.1 * rows + 0.2 * cols).count == 0
    assert hydrology.depressions(-((rows - 10) ** 2) - (cols - 15) ** 2.0).count == 0


def _areas(rec, shape):
    """Drainage areas of receivers ``rec`` ({cell: next cell or None}), walking each cell's path."""
    area = np.zeros(shape)
    for start in rec:
        cell = start
        while cell is not None:
            area[cell] += 1
            cell = rec[cell]
    return area


def _d8_reference(z):
    h, w = z.shape
    rec = {}
    for r in range(h):
        for c in range(w):
            best, to = 0.0, None
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    rr, cc = r + dr, c + dc
                    if (dr or dc) and 0 <= rr < h and 0 <= cc < w:
                        s = (z[r, c] - z[rr, cc]) / np.hypot(dr, dc)
                        if s > best:
                            best, to = s, (rr, cc)
            rec[(r, c)] = to
    return _areas(rec, z.shape), rec


def test_d8_accumulation_equals_brute_force_and_conserves_area():
    rng = np.random.default_rng(3)
    z = rng.random((12, 15))
    area = hydrology.flow_accumulation(z)
    want, rec = _d8_reference(z)
    np.testing.assert_array_equal(area, want)
    ends = np.array([[rec[(r, c)] is None for c in range(15)] for r in range(12)])
    assert area[ends].sum() == z.size
    # D-infinity splits flow but ends in the same cells (those without a lower neighbour)
    dinf = hydrology.flow_accumulation(z, method="dinf")
    assert np.isclose(dinf[ends].sum(), z.size) and (dinf >= 1).all()



def test_d8_with_ties_and_flats_equals_brute_force():
    # small integer heights: equal drops (the first neighbour in row-major order wins), flats
    # that pass nothing, and long chains through the flow graph
    rng = np.random.default_rng(5)
    for z in (rng.integers(0, 4, (31, 29)).astype(float), np.round(hydrology.fbm_terrain((40, 50), seed=2) * 8)):
        area = hydrology.flow_accumulation(z)
        want, _ = _d8_reference(z)
        np.testing.assert_array_equal(area, want)


def _dinf_reference(z):
    """Tarboton's D-infinity, one cell at a time with math.atan2, passed on highest first; facets
    are compared by their squared slopes in exact rational arithmetic (the first of equals wins)."""
    import math
    from fractions import Fraction

    h, w = z.shape
    facets = [((0, 1), (-1, 1)), ((-1, 0), (-1, 1)), ((-1, 0), (-1, -1)), ((0, -1), (-1, -1)),
              ((0, -1), (1, -1)), ((1, 0), (1, -1)), ((1, 0), (1, 1)), ((0, 1), (1, 1))]
    inside = lambda r, c: 0 <= r < h and 0 <= c < w  # noqa: E731
    share = {}
    for r in range(h):
        for c in range(w):
            best, choice = Fraction(0), None
            for (a, b), (d, e) in facets:
                if not inside(r + a, c + b):
                    continue
                s1 = Fraction(z[r, c]) - Fraction(z[r + a, c + b])
                if s1 <= 0 and not inside(r + d, c + e):
                    continue
                if not inside(r + d, c + e):
                    square, angle = s1 * s1, 0.0
                else:
                    s2 = Fraction(z[r + a, c + b]) - Fraction(z[r + d, c + e])
                    angle = math.atan2(s2, s1)
                    square = s1 * s1 + s2 * s2
                    if angle < 0:
                        square, angle = (s1 * s1 if s1 > 0 else Fraction(0)), 0.0
                    elif angle > math.pi / 4:
                        fall = Fraction(z[r, c]) - Fraction(z[r + d, c + e])
                        square, angle = (fall * fall / 2 if fall > 0 else Fraction(0)), math.pi / 4
                if square > best:
                    best, choice = square, ((r + a, c + b), (r + d, c + e), angle / (math.pi / 4))
            share[(r, c)] = choice
    area = np.ones(z.shape)
    for i in np.argsort(-z.ravel(), kind="stable"):
        cell = divmod(int(i), w)
        if share[cell] is not None:
            e1, e2, f = share[cell]
            if f < 1:
                area[e1] += (1 - f) * area[cell]
            if f > 0:
                area[e2] += f * area[cell]
    return area


def test_dinf_equals_a_cell_by_cell_reference():
    rng = np.random.default_rng(6)
    # (the first: two facets of exactly equal slope, sqrt(1 + 1) and 2 / sqrt(2), which rounding had
    # told apart, against the rule that the first of equals wins)
    for z in (np.array([[3.0, 1.0], [3.0, 3.0], [2.0, 1.0]]), rng.random((23, 27)),
              rng.integers(0, 5, (19, 21)).astype(float), rng.integers(0, 11, (31, 29)).astype(float),
              hydrology.fbm_terrain((48, 40), seed=3).astype(float)):
        np.testing.assert_allclose(hydrology.flow_accumulation(z, method="dinf"), _dinf_reference(z), rtol=1e-12)


@pytest.mark.parametrize("method", ["d8", "dinf"])
def test_accumulation_on_degenerate_grids(method):
    acc = lambda z, **kw: hydrology.flow_accumulation(np.asarray(z, float), method=method, **kw)  # noqa: E731
    np.testing.assert_array_equal(acc([[3.0]]), [[1.0]])
    np.testing.assert_array_equal(acc(np.zeros((4, 6))), np.ones((4, 6)))  # flat: nothing moves
    np.testing.assert_array_equal(acc([[5, 4, 3, 2, 1, 0]]), [[1, 2, 3, 4, 5, 6]])  # one row
    np.testing.assert_array_equal(acc([[0], [1], [2], [3]]), [[4], [3], [2], [1]])  # one column
    pit = np.full((3, 3), 2.0)
    pit[1, 1] = 1.0
    np.testing.assert_array_equal(acc(pit), [[1, 1, 1], [1, 9, 1], [1, 1, 1]])
    # the fill makes the centre a flat, drained to its nearest border cell (a side, the first one)
    np.testing.assert_array_equal(acc(pit, filled=True), [[1, 2, 1], [1, 1, 1], [1, 1, 1]])
    # a long chain (a snake down a 1 x N ramp): the walk reaches every cell once
    n = 100_000
    np.testing.assert_array_equal(acc(-np.arange(n, dtype=float)[None]), np.arange(1, n + 1)[None])
    # tiny and huge drops keep their directions (slopes neither underflow nor overflow)
    for scale in (1e-170, 1e200):
        np.testing.assert_allclose(acc(scale * pit), [[1, 1, 1], [1, 9, 1], [1, 1, 1]])
        dome = scale * (2.0 - pit)
        assert acc(dome)[1, 1] == 1.0 and acc(dome).max() == 2.0  # the top passes its area to one side


def test_accumulation_refuses_too_many_cells_before_copying(launches):
    huge = np.broadcast_to(np.float64(0.0), (2**16, 2**15))  # 2**31 cells, no memory behind them
    with pytest.raises(ValueError, match="'elevation' has 2147483648 cells"):
        hydrology.flow_accumulation(huge)
    assert launches == []


_STEPS = [(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc]  # row-major


def _has_lower(surface):
    """Cells with a strictly lower 8-neighbour, (H, W) bool."""
    h, w = surface.shape
    pad = np.pad(surface, 1, constant_values=np.inf)
    out = np.zeros(surface.shape, bool)
    for dr, dc in _STEPS:
        out |= pad[1 + dr: 1 + dr + h, 1 + dc: 1 + dc + w] < surface
    return out


def _lost(surface):
    """Interior cells without a strictly lower neighbour, (H, W) bool."""
    out = ~_has_lower(surface)
    out[[0, -1], :] = out[:, [0, -1]] = False
    return out


def _scipy_flat_distances(surface, lost):
    """SciPy's Dijkstra over the flats (same-height 8-neighbours, steps 2 and diagonals 3):
    (towards lower, away from higher), each (H, W) float with inf where no source reaches.
    Towards lower: over the lost cells and the cells beside them of their height (the ways
    out, the sources). Away from higher: over the lost cells only, from those beside a higher cell."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    h, w = surface.shape
    edges, ways_out, high = [], set(), set()
    for r, c in zip(*np.nonzero(lost)):
        for dr, dc in _STEPS:
            rr, cc = r + dr, c + dc
            if surface[rr, cc] > surface[r, c]:
                high.add(r * w + c)
            elif surface[rr, cc] == surface[r, c]:
                edges.append((r * w + c, rr * w + cc, 3 if dr and dc else 2, bool(lost[rr, cc])))
                if not lost[rr, cc]:
                    ways_out.add(rr * w + cc)
    out = []
    for sources, keep in ((ways_out, lambda e: True), (high, lambda e: e[3])):
        kept = [e for e in edges if keep(e)]
        graph = coo_matrix(([e[2] for e in kept], ([e[0] for e in kept], [e[1] for e in kept])),
                           shape=(h * w, h * w)).tocsr()
        dist = np.full(h * w, np.inf)
        if sources:
            dist = dijkstra(graph, directed=False, indices=sorted(sources), min_only=True)
        out.append(dist.reshape(h, w))
    return out


def _drained_flats_reference(surface, rec):
    """Receivers for the lost cells of ``rec`` (a D8 reference's) on flats that drain: the nearest
    way out beside it (a side before a diagonal), else the neighbour of its height of lowest mask
    2 * lower - higher (0 for higher on a flat that touches no higher cell), the first in
    row-major order among equals; asserts that the mask falls (the receivers then end outside)."""
    h, w = surface.shape
    lost = _lost(surface)
    lower, higher = _scipy_flat_distances(surface, lost)
    higher[np.isinf(higher)] = 0
    mask = 2 * lower - higher
    out = dict(rec)
    for r, c in zip(*np.nonzero(lost & np.isfinite(lower))):
        same = [(dr, dc) for dr, dc in _STEPS if surface[r + dr, c + dc] == surface[r, c]]
        outs = sorted((3 if dr and dc else 2, k) for k, (dr, dc) in enumerate(same) if not lost[r + dr, c + dc])
        if outs:
            dr, dc = same[outs[0][1]]
        else:
            dr, dc = min(same, key=lambda s: mask[r + s[0], c + s[1]])  # (min keeps the first of equals)
            assert mask[r + dr, c + dc] < mask[r, c]
        out[(r, c)] = (r + dr, c + dc)
    return out


def test_flat_distances_equal_scipy_dijkstra():
    from wdendrite.hydrology import _flat_distances

    rng = np.random.default_rng(8)
    far = np.iinfo(np.int64).max
    terrains = [hydrology.fill(rng.integers(0, 3, (21, 26)).astype(float)) for _ in range(4)]
    terrains += [rng.integers(0, 2, (17, 19)).astype(float),  # natural flats, some closed (no way out)
                 np.zeros((7, 8)),  # a flat touching no higher cell: nothing is away from higher
                 hydrology.fill(np.round(hydrology.fbm_terrain((40, 36), seed=5) * 6).astype(float)),
                 _serpentine(15, 14)]
    for k, surface in enumerate(terrains):
        lost = _lost(surface)
        assert lost.sum() > 20
        got = [d.numpy().reshape(surface.shape) for d in _flat_distances(surface, lost)]
        want = _scipy_flat_distances(surface, lost)
        for g, ref in zip(got, want):
            np.testing.assert_array_equal(np.where(g == far, np.inf, g)[lost], ref[lost])
        if k == 4:
            assert np.isinf(want[0][lost]).any()
        if k == 5:
            assert np.isinf(want[1][lost]).all() and np.isfinite(want[0][lost]).all()


def _benchmark(name: str):
    """The module ``benchmarks/<name>.py`` (with its folder importable: some import ``_measure``)."""
    import importlib.util
    import sys
    from pathlib import Path

    folder = Path(__file__).resolve().parent.parent / "benchmarks"
    spec = importlib.util.spec_from_file_location(name, folder / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.path.insert(0, str(folder))
    try:
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(folder))
    return module


def _serpentine(h: int, w: int) -> np.ndarray:
    """The benchmark's worst case for the flat drainer (benchmarks/bench_hydrology.py)."""
    return _benchmark("bench_hydrology").serpentine(h, w)


def _trough(rng, h=9, w=60):
    """A long valley: walls of 10 around a rough floor below 3, spilling west at (h // 2, 0) (at 3),
    so that the fill makes its floor one flat of (h - 2) x (w - 2) cells."""
    z = np.full((h, w), 10.0)
    z[1:-1, 1:-1] = 3.0 * rng.random((h - 2, w - 2))
    z[h // 2, 0] = 3.0
    return z


@pytest.mark.parametrize("make", [lambda rng: rng.random((14, 17)),
                                  lambda rng: rng.integers(0, 4, (15, 13)).astype(float),  # natural flats too
                                  lambda rng: hydrology.fbm_terrain((24, 30), seed=2).astype(float),
                                  lambda rng: _serpentine(17, 12),
                                  lambda rng: rng.integers(0, 3, (30, 41)).astype(float),  # wide filled flats
                                  lambda rng: _trough(rng, 10, 33)])
def test_filled_d8_equals_brute_force_priority_flood_and_flat_draining(make):
    z = make(np.random.default_rng(4))
    area = hydrology.flow_accumulation(z, filled=True)
    surface = _priority_flood(z)
    _, rec = _d8_reference(surface)
    rec = _drained_flats_reference(surface, rec)
    np.testing.assert_array_equal(area, _areas(rec, z.shape))
    # filling changes the routing, so the test sees the fill
    assert not np.array_equal(area, hydrology.flow_accumulation(z))
    # every cell's area now ends on the border (the fill's promise), nowhere inside
    h, w = z.shape
    ends = [(r, c) for (r, c), to in rec.items() if to is None]
    assert all(r in (0, h - 1) or c in (0, w - 1) for r, c in ends)
    assert sum(area[e] for e in ends) == z.size
    # D-infinity drains the same flats the same way: its area ends in the same cells
    dinf = hydrology.flow_accumulation(z, method="dinf", filled=True)
    assert np.isclose(sum(dinf[e] for e in ends), z.size)


@pytest.mark.parametrize("method", ["d8", "dinf"])
def test_filled_flow_ends_on_the_border_on_random_terrains(method):
    # no cycle and no interior end: all the area reaches the border cells without a lower neighbour
    rng = np.random.default_rng(12)
    for k in range(8):
        shape = tuple(int(n) for n in rng.integers(8, 40, 2))
        z = rng.integers(0, 2 + k % 4, shape).astype(float)
        if k % 2:
            z += 1e-3 * rng.random(shape)  # rough floors: flats only where the fill makes them
        area = hydrology.flow_accumulation(z, method=method, filled=True)
        surface = hydrology.fill(z)
        ends = ~_has_lower(surface)
        ends[1:-1, 1:-1] = False  # border cells without a lower neighbour
        assert np.isclose(area[ends].sum(), z.size), (k, shape)
        assert (area >= 1).all()


def test_a_filled_basin_drains_through_its_outlet():
    # the review's case: a pit whose fill makes a flat of eight cells, spilling east at (2, 3)
    z = np.array([[5, 5, 5, 5, 5], [5, 2, 2, 2, 5], [5, 2, 1, 2, 0], [5, 2, 2, 2, 5], [5, 5, 5, 5, 5]], float)
    for method in ("d8", "dinf"):
        area = hydrology.flow_accumulation(z, method=method, filled=True)
        assert area[2, 4] == z.size, method  # everything, the border's 5s included, leaves there
        # the flat's east column drains out directly; its west column, away from the walls, onto the
        # flat's middle (2, 2), which passes it all (11 cells) to the outlet (2, 3)
        np.testing.assert_array_equal(area[1:4, 1:4], [[4, 2, 5], [2, 11, 12], [4, 2, 5]])


@pytest.mark.parametrize("method", ["d8", "dinf"])
def test_a_filled_trough_drains_along_one_line(method):
    # a flat drained only towards its way out ran down the valley in parallel lines, one per row
    # (drainage maps hatched along their rivers); drained also away from the walls, it gathers onto
    # one line: in every cross-section one cell carries nearly all the area from upstream
    rng = np.random.default_rng(11)
    for h, w in ((9, 60), (12, 50)):
        z = _trough(rng, h, w)
        area = hydrology.flow_accumulation(z, method=method, filled=True)
        assert np.isclose(area[h // 2, 0], z.size)
        for c in range(1, w - 20):  # (within 20 columns of its head the valley is still gathering)
            column = np.sort(area[1:-1, c])
            upstream = h * (w - 1 - c)  # every cell east of the column drains through it
            assert column[-1] >= 0.9 * upstream, (h, c, column)
            assert column[-2] <= 0.1 * column[-1], (h, c, column)


def test_dinf_splits_flow_by_angle_and_conserves_area():
    theta = np.deg2rad(30.0)
    rows, cols = np.mgrid[0:6, 0:7]
    z = rows * np.sin(theta) - cols * np.cos(theta)  # falls towards the east and the north
    area = hydrology.flow_accumulation(z, method="dinf")
    # reference: inside, 1 - 30/45 of a cell's area goes east and 30/45 north-east; the top row
    # (no north-east) sends all east, the last column (no east) all north, into the corner (0, 6)
    f = 30.0 / 45.0
    want = np.ones(z.shape)
    for i in np.argsort(-z.ravel(), kind="stable"):
        r, c = divmod(int(i), 7)
        if c < 6 and r > 0:
            want[r, c + 1] += (1 - f) * want[r, c]
            want[r - 1, c + 1] += f * want[r, c]
        elif c < 6:
            want[r, c + 1] += want[r, c]
        elif r > 0:
            want[r - 1, c] += want[r, c]
    np.testing.assert_allclose(area, want, rtol=1e-9)
    assert np.isclose(area[0, 6], z.size)
    # on a cardinal slope D-infinity and D8 agree
    zc = -cols.astype(float) + 1e-9 * rows
    np.testing.assert_allclose(hydrology.flow_accumulation(zc, method="dinf"), hydrology.flow_accumulation(zc))
    with pytest.raises(ValueError, match="method"):
        hydrology.flow_accumulation(zc, method="mfd")


def test_d8_on_a_tilted_plane_collects_along_rows():
    rows, cols = np.mgrid[0:5, 0:8]
    z = 100.0 - 10.0 * cols + 0.001 * (rows - 2) ** 2  # flows right, then to row 2
    area = hydrology.flow_accumulation(z)
    assert area[2, -1] == area.max() == z.size  # everything ends in the lowest cell of the last column
    img = hydrology.drainage_image(area)
    assert img.dtype == np.float32 and img.min() == 0.0 and img.max() == 1.0


def test_noise_baselines_equal_numpy_noise_on_pixel_centres(device):
    from test_control import _octave_shift, _perlin_reference, ridged_reference

    from wdendrite.control import _permutation

    shape = (24, 20)
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    centres = np.stack([(cols.ravel() + 0.5) / shape[1], (rows.ravel() + 0.5) / shape[0]], 1)
    ridged = hydrology.ridged_terrain(shape, seed=3, device=device)
    np.testing.assert_allclose(ridged.ravel(), ridged_reference(3, centres, frequency=4.0, octaves=8), atol=3e-5)
    # fBm: 0.5 + 0.5 * sum(gain^o * noise(lacunarity^o * p + shift_o)) / sum(gain^o)
    perm = _permutation(3)
    total = sum(0.5**o * _perlin_reference(perm, 4.0 * 2.0**o * centres + _octave_shift(o)) for o in range(8))
    fbm = hydrology.fbm_terrain(shape, seed=3, device=device)
    np.testing.assert_allclose(fbm.ravel(), 0.5 + 0.5 * total / sum(0.5**o for o in range(8)), atol=3e-5)
    # ridged crests: the ridged baseline's sharp maxima make it rougher than fBm at the pixel scale
    assert np.abs(np.diff(ridged, axis=1)).mean() > np.abs(np.diff(fbm, axis=1)).mean()


def test_dendry_terrain_drains_better_than_fbm(device):
    p = DendryParams(levels=2, eps=0.25, delta=0.1, beta=0.5, noise=0.05, seed=0)
    ctl = control.perlin(seed=0, domain=((-0.2, -0.4), (1.4, 0.7)))
    terrain = dendry((96, 96), domain=((0, 0), (4, 4)), params=p, control=ctl, output="elevation", device=device)
    fbm = hydrology.fbm_terrain((96, 96), seed=0, device=device)
    ours, theirs = hydrology.depressions(terrain), hydrology.depressions(fbm)
    assert 5 * ours.percent < theirs.percent and 2 * ours.count < theirs.count
    # the branches cut valleys into the control: the terrain is not the control's smooth field
    smooth = ctl.grid((96, 96), device=device)
    assert np.abs(terrain - smooth).mean() > 0.01 and hydrology.depressions(smooth).count < ours.count


@pytest.mark.parametrize("bad", [np.zeros((0, 3)), np.zeros(5), np.array([[1.0, np.nan]]), np.array([["x"]]),
                                 # integers float64 cannot tell apart: a pit of 1 in 2**62 had counted 0
                                 np.full((3, 3), 2**62 + 1, np.int64) - np.eye(3, dtype=np.int64)])
def test_bad_elevation_raises(bad):
    with pytest.raises((ValueError, TypeError), match="elevation"):
        hydrology.depressions(bad)
    with pytest.raises((ValueError, TypeError), match="elevation"):
        hydrology.flow_accumulation(bad)


def test_ragged_elevation_and_a_text_flag_are_named():
    # NumPy's own "inhomogeneous shape" error named nothing; any non-empty text counted as True
    for call in (hydrology.fill, hydrology.depressions, hydrology.flow_accumulation):
        with pytest.raises(ValueError, match="'elevation', but got rows of different lengths"):
            call([[1.0, 2.0], [3.0]])
    with pytest.raises(TypeError, match="'filled', but got 'no'"):
        hydrology.flow_accumulation(np.zeros((4, 4)), filled="no")
    with pytest.raises(ValueError, match="'method'"):
        hydrology.flow_accumulation(np.zeros((4, 4)), method=["d8"])


@pytest.mark.parametrize("make", [hydrology.fbm_terrain, hydrology.ridged_terrain])
@pytest.mark.parametrize(
    "shape, exc, match",
    [
        ((0, 0), ValueError, r"'shape', but got \(0, 0\)"),
        ((4, 4, 4), ValueError, r"'shape' of rank 2 \(H, W\), but got \(4, 4, 4\)"),
        ((-5, 5), ValueError, r"'shape', but got \(-5, 5\)"),
        ((2.7, 3), TypeError, r"'shape', but got \(2\.7, 3\)"),
        (None, TypeError, "'shape', but got None"),
    ],
)
def test_bad_terrain_shape_raises_before_any_kernel(make, shape, exc, match, launches):
    with pytest.raises(exc, match=match):
        make(shape)
    assert launches == []
    make((2, 3), octaves=1)
    assert launches  # so the empty record above means that no kernel ran


def test_terrain_larger_than_free_memory_raises_before_any_kernel(monkeypatch, launches):
    from wdendrite import _checks

    monkeypatch.setattr(_checks, "available_bytes", lambda device: 1024)
    with pytest.raises(MemoryError, match=r"'shape' \(64, 64\)"):
        hydrology.fbm_terrain((64, 64))
    assert launches == []


@pytest.mark.parametrize("make", ["fbm_terrain", "ridged_terrain"])
def test_noise_terrains_name_an_absent_device(make, launches):
    from wdendrite import hydrology

    with pytest.raises(ValueError, match="'device'"):
        getattr(hydrology, make)((8, 8), device="cuda:9")
    assert launches == []


def test_drainage_image_names_an_area_below_one():
    with pytest.raises(ValueError, match=r"'area' counts cells.*first at \(0, 1\): 0.5"):
        hydrology.drainage_image(np.array([[1.0, 0.5], [2.0, 3.0]]))
    img = hydrology.drainage_image(np.array([[1.0, 1.5], [2.0, 4.0]]))  # D-infinity shares are fractions of cells
    assert img.min() == 0.0 and img.max() == 1.0
    # log-scaled: each tenfold area one step up
    np.testing.assert_allclose(hydrology.drainage_image(np.array([[1.0, 10.0], [100.0, 1000.0]])),
                               [[0.0, 1 / 3], [2 / 3, 1.0]], rtol=1e-6)


def test_dem_terrains_basins_sit_around_level1_sinks_that_a_steeper_fill_removes():
    # benchmarks/dem_hydrology.py's finding, at 256^2 and 2 levels: the DEM-amplified terrain's large
    # basins (above 1 % of the surface) each hold a level-1 sink's key point, and the drained
    # control's steeper tilt leaves no sink and little depression; the sinks themselves are checked
    # against the key points' own values (a sink: none of its 8 neighbours strictly lower)
    from scipy.ndimage import label

    from wdendrite.dendry import _cached_tree

    dem = _benchmark("dem_hydrology")
    params = DendryParams(levels=2, eps=0.25, delta=0.1, beta=0.5, noise=0.05, seed=2)
    for slope in (1e-4, 1e-2):
        ctl = control.drained(dem.dem_map(), slope=slope)
        cells, keyp, _ = _cached_tree((8, 8), domain=dem.DOMAIN, params=params, control=ctl)[0]
        z = {(int(i), int(j)): float(v) for (i, j), v in zip(cells, keyp[:, 2])}
        brute = sorted((i, j) for (i, j), v in z.items() if 0 <= i < 16 and 0 <= j < 16
                       and all(z[i + di, j + dj] >= v for di in (-1, 0, 1) for dj in (-1, 0, 1)))
        assert sorted(dem.level1_sinks(params, ctl, dem.DOMAIN)) == brute
        points = dem.level1_sinks(params, ctl, dem.DOMAIN, points=True)
        assert len(points) == len(brute)
        terrain = dendry((256, 256), domain=dem.DOMAIN, params=params, control=ctl, output="elevation")
        d = hydrology.depressions(terrain)
        if slope == 1e-4:
            assert len(brute) >= 3 and d.percent > 4.0
            lab, n = label(d.mask, structure=np.ones((3, 3), int))
            sizes = np.bincount(lab.ravel())[1:]
            held = {int(lab[int(y * 16), int(x * 16)]) for x, y in points}
            large = {k + 1 for k in range(n) if sizes[k] > 0.01 * terrain.size}
            assert large and large <= held, (large, held)
        else:
            assert brute == [] and d.percent < 2.0


def test_a_masked_elevation_is_refused():
    # a DEM's nodata cells had been used as real values (a -9999 pit that 13 cells drained into)
    dem = np.ma.masked_equal(np.array([[5.0, 5.0, 5.0], [5.0, -9999.0, 5.0], [5.0, 5.0, 5.0]]), -9999.0)
    for call in (hydrology.fill, hydrology.depressions, hydrology.flow_accumulation):
        with pytest.raises(ValueError, match=r"'elevation' is a masked array with 1 masked cells .*elevation.filled"):
            call(dem)
    assert hydrology.fill(np.ma.masked_array(dem.data, mask=False))[1, 1] == 5.0  # nothing masked: an array
