"""Smooth centre lines: joined branches, pinned ends, continuous radii, turning angles against hand-made lines."""

import numpy as np
import pytest

import wdendrite as wd
from wdendrite.render import Taper, branch_order, node_widths
from wdendrite.skeleton import Skeleton, _catmull_rom, _mirrored_gaussian, skeleton, turning_angles


def _tree(seed=3, shape=(24, 24, 24), ends=8):
    lat = wd.Lattice(shape, 26, weights=wd.weights.Uniform(r=10, seed=seed))
    cf = wd.shortest_paths(lat, [[1, shape[1] // 2, shape[2] // 2]])
    return wd.trace(cf, wd.endpoints.random(lat, ends, seed=seed, within=wd.endpoints.Box((12, 2, 2), (22, 21, 21))))


DEN = _tree()


def _branch(lines, b):
    return lines.points[lines.offsets[b]: lines.offsets[b + 1]]


def test_side_branches_start_on_their_parent_line_and_ends_stay_put():
    lines = skeleton(DEN, Taper(2.0, 0.6, along="path"), side=Taper(1.2, 0.4), samples=3)
    pos = DEN.positions[:, ::-1]
    assert lines.branches == len(np.unique(branch_order(DEN).start))
    assert np.sum(lines.parent_branch < 0) == len(DEN.roots)
    for b in range(lines.branches):
        p = _branch(lines, b)
        if lines.parent_branch[b] < 0:
            np.testing.assert_allclose(p[0], pos[DEN.roots[0]])
        else:  # exactly a sample of the parent's line: the branches stay joined
            parent = _branch(lines, lines.parent_branch[b])
            assert np.min(np.linalg.norm(parent - p[0], axis=1)) < 1e-12
        # the tip is a node of the dendrite with no child
        tip = np.flatnonzero(np.all(np.isclose(pos, p[-1]), axis=1))
        assert len(tip) == 1 and not np.any(DEN.parent == tip[0])
    leaves = np.setdiff1d(np.arange(len(DEN)), DEN.parent)
    assert len(leaves) == lines.branches  # one branch per tip


def test_radii_follow_the_taper_and_run_on_across_junctions():
    radius, side = Taper(2.0, 0.6, along="path"), Taper(1.2, 0.4)
    lines = skeleton(DEN, radius, side=side, sigma=0.0, samples=1)
    widths = node_widths(DEN, radius, side=side)
    # without smoothing every sample is a node and takes its width (a side branch's first sample
    # takes its own first node's, which a side taper keeps no wider than the parent there)
    np.testing.assert_allclose(lines.points, DEN.positions[lines.row][:, ::-1])
    for b in np.flatnonzero(lines.parent_branch >= 0):
        first = lines.offsets[b]
        assert lines.radius[first] == pytest.approx(float(widths[lines.row[first + 1]]), rel=1e-6)
        parent = _branch(lines, lines.parent_branch[b])
        at = np.argmin(np.linalg.norm(parent - lines.points[first], axis=1))
        assert lines.radius[first] <= lines.radius[lines.offsets[lines.parent_branch[b]] + at] + 1e-9
    assert skeleton(DEN, radius, min_radius=1.5).radius.min() == pytest.approx(1.5)


def test_a_straight_lattice_run_stays_straight_and_evenly_sampled():
    nodes = np.array([[z, 5, 5] for z in range(12)])
    den = wd.Dendrite.from_arrays((12, 10, 10), nodes, np.r_[-1, np.arange(11)])
    lines = skeleton(den, 1.0, samples=4)
    np.testing.assert_allclose(lines.points[:, :2], 5.0)
    np.testing.assert_allclose(lines.points[:, 2], np.linspace(0, 11, 45), atol=1e-12)
    assert np.all(turning_angles(lines, 1.0) < 1e-6)


def test_the_mirrored_gaussian_keeps_ends_and_lines_and_matches_a_plain_sum():
    rng = np.random.default_rng(0)
    v = rng.normal(size=(20, 3)).cumsum(axis=0)
    sigma = 1.7
    got = _mirrored_gaussian(v, sigma)
    # reference: extend by point reflection through each end, then a weighted sum per row
    reach = int(np.ceil(3 * sigma))
    ext = {i: v[i] for i in range(20)}
    for k in range(1, reach + 1):
        ext[-k] = 2 * v[0] - v[k]
        ext[19 + k] = 2 * v[19] - v[19 - k]
    w = np.exp(-0.5 * (np.arange(-reach, reach + 1) / sigma) ** 2)
    w /= w.sum()
    ref = np.array([sum(w[j] * ext[i + j - reach] for j in range(len(w))) for i in range(20)])
    ref[0], ref[-1] = v[0], v[-1]
    np.testing.assert_allclose(got, ref, atol=1e-12)
    line = np.outer(np.arange(9.0), [1.0, 2.0, -0.5])
    np.testing.assert_allclose(_mirrored_gaussian(line, 2.5), line, atol=1e-12)


def test_catmull_rom_passes_through_its_points_and_follows_a_circle():
    t = np.linspace(0, np.pi, 9)
    pts = np.stack([np.cos(t), np.sin(t), np.zeros_like(t)], axis=1) * 10.0
    pos, interval, frac = _catmull_rom(pts, 8)
    np.testing.assert_allclose(pos[frac == 0], pts[:-1], atol=1e-12)
    np.testing.assert_allclose(pos[-1], pts[-1])
    assert np.all(np.diff(interval) >= 0) and len(pos) == 8 * 8 + 1
    inner = (interval > 0) & (interval < 7)  # (the ends continue straight, not round)
    assert np.abs(np.linalg.norm(pos[inner], axis=1) - 10.0).max() < 0.01


def test_turning_angles_of_hand_made_lines():
    # a staircase (x, z, x, z, ...) turns by 90 degrees at every corner at its own step
    stair = np.cumsum(np.array([[1, 0, 0], [0, 0, 1]] * 5, float), axis=0)
    lines = Skeleton(points=stair, radius=np.ones(len(stair)), offsets=np.array([0, len(stair)]),
                     row=np.zeros(len(stair), np.int64), parent_branch=np.array([-1]))
    np.testing.assert_allclose(turning_angles(lines, 1.0), 90.0)
    # a circle of radius 10 sampled every 1: each piece turns by the angle it subtends
    t = np.linspace(0, 2.0, 400)
    arc = np.stack([10 * np.cos(t), 10 * np.sin(t), np.zeros_like(t)], axis=1)
    lines = Skeleton(points=arc, radius=np.ones(400), offsets=np.array([0, 400]), row=np.zeros(400, np.int64),
                     parent_branch=np.array([-1]))
    np.testing.assert_allclose(turning_angles(lines, 1.0)[:-1], np.degrees(2 * np.arcsin(0.05)), rtol=1e-3)


def test_smoothing_takes_the_kinks_out_of_lattice_paths():
    raw = skeleton(DEN, 1.0, sigma=0.0, samples=1)
    smooth = skeleton(DEN, 1.0)
    assert np.percentile(turning_angles(raw, 1.0), 95) >= 45.0
    assert np.percentile(turning_angles(smooth, 1.0), 95) < 25.0


def test_a_lone_root_is_one_ball_sample():
    den = wd.Dendrite.from_arrays((8, 8, 8), [[3, 3, 3]], [-1])
    lines = skeleton(den, 1.0)
    assert len(lines) == 1 and lines.segments.tolist() == [[0, 0]]
    assert turning_angles(lines, 1.0).size == 0


@pytest.mark.parametrize(
    "call, exc, match",
    [
        (lambda: skeleton("den"), TypeError, "Dendrite"),
        (lambda: skeleton(wd.Dendrite.from_arrays((8, 8), [[1, 1]], [-1])), ValueError, "3D"),
        (lambda: skeleton(DEN, sigma=-1.0), ValueError, "'sigma'"),
        (lambda: skeleton(DEN, samples=0), ValueError, "'samples'"),
        (lambda: skeleton(DEN, min_radius=float("nan")), ValueError, "'min_radius'"),
        (lambda: skeleton(DEN, radius=0.0), ValueError, "radius"),
        (lambda: turning_angles(skeleton(DEN), 0.0), ValueError, "'step'"),
        (lambda: turning_angles(DEN, 1.0), TypeError, "Skeleton"),
    ],
)
def test_bad_input(call, exc, match):
    with pytest.raises(exc, match=match):
        call()
