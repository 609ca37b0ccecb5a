"""Smooth centre lines of a dendrite: its branches off the lattice, with continuous radii.

A lattice path turns by 45 or 90 degrees at almost every node. The papers
draw it as spheres or tubes on the nodes, kinks and all; here the lattice is
only a guide. The dendrite is cut into branches (:func:`wdendrite.render.branch_order`:
a main path per root, then side branches), and every branch is

1. smoothed: its node positions averaged by a Gaussian of width ``sigma``
   along the branch, the ends held in place (the sequence is mirrored through
   each end before averaging, which keeps the end point and its direction);
   a side branch starts at its parent branch's smoothed position where it
   leaves it, so branches stay joined;
2. interpolated: a centripetal Catmull-Rom spline through the smoothed nodes,
   sampled ``samples`` times per node interval.

Radii come from :func:`wdendrite.render.node_widths` (a constant, a
:class:`~wdendrite.render.Taper`, or per node), smoothed the same way; a
side branch starts with its own first node's radius, which a side taper keeps
no wider than its parent there, so the taper runs on across the junction.

The result, a :class:`Skeleton`, is what :func:`wdendrite.geometry.skeleton_mesh`
meshes as one closed body. Positions are world ``(x, y, z)`` (lattice axes
reversed, placed by the dendrite's ``origin`` and ``spacing``), as in
:mod:`wdendrite.geometry`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _checks
from .dendrite import Dendrite
from .render import Width, branch_order, node_widths

__all__ = ["Skeleton", "skeleton", "turning_angles"]


@dataclass(frozen=True, eq=False)
class Skeleton:
    """Smooth centre lines with a radius at every sample, one polyline per branch."""

    points: np.ndarray
    """``(P, 3)`` float64 world ``(x, y, z)`` samples; branch ``b`` is ``points[offsets[b]:offsets[b + 1]]``."""
    radius: np.ndarray
    """``(P,)`` float64 radius at each sample (world units), > 0."""
    offsets: np.ndarray
    """``(B + 1,)`` int64 start of each branch in ``points`` (the last entry is ``P``)."""
    row: np.ndarray
    """``(P,)`` int64 dendrite row each sample comes from (the node at the start of its interval)."""
    parent_branch: np.ndarray
    """``(B,)`` int64 branch each branch leaves (-1 for a root's main path); its first sample lies
    on that branch's line."""

    @property
    def segments(self) -> np.ndarray:
        """``(S, 2)`` int64 rows of ``points`` joined by a straight piece: consecutive samples of a
        branch, and ``(i, i)`` for a branch of one sample ``i`` (a ball)."""
        first = np.arange(len(self.points) - 1, dtype=np.int64)
        last = np.zeros(len(self.points), bool)
        last[self.offsets[1:] - 1] = True
        pairs = np.stack([first[~last[:-1]], first[~last[:-1]] + 1], axis=1)
        lone = self.offsets[:-1][np.diff(self.offsets) == 1]
        return np.concatenate([pairs, np.stack([lone, lone], axis=1)]) if len(lone) else pairs

    @property
    def branches(self) -> int:
        """Number of branches."""
        return len(self.offsets) - 1

    def __len__(self) -> int:
        return len(self.points)

    def __repr__(self) -> str:
        return f"Skeleton({self.branches} branches, {len(self)} samples)"


def _chains(den: Dendrite):
    """Each branch as rows from its first node to its tip, with the parent branch's row where it leaves
    it in front (side branches); and the branch each leaves (-1 for main paths). Parents come first."""
    br = branch_order(den)
    rows = np.lexsort((den.depth, br.start))  # grouped by branch, each from its start outward
    starts, first, counts = np.unique(br.start[rows], return_index=True, return_counts=True)
    # parents before children: a branch's order is one more than its parent's
    by_order = np.argsort(br.order[starts], kind="stable")
    index_of = np.full(len(den), -1, np.int64)
    index_of[starts[by_order]] = np.arange(len(starts))
    chains, parents = [], []
    branch_of_start = {}
    for k in by_order:
        s = starts[k]
        chain = rows[first[k]: first[k] + counts[k]]
        attach = br.attach[s]
        if attach != s:  # a side branch: begin on the parent branch
            chain = np.concatenate([[attach], chain])
            parents.append(branch_of_start[int(br.start[attach])])
        else:
            parents.append(-1)
        branch_of_start[int(s)] = len(chains)
        chains.append(chain)
    return chains, np.asarray(parents, np.int64)


def _mirrored_gaussian(values: np.ndarray, sigma: float) -> np.ndarray:
    """``values`` (rows along a branch) averaged by a Gaussian of ``sigma`` rows, each end held: the
    rows are mirrored through each end first (``2 v[0] - v[k]``), so a straight run stays straight
    and the ends keep their place and direction. Short branches use a kernel cut to their length."""
    m = len(values)
    if m < 3 or sigma <= 0:
        return values.copy()
    reach = int(min(np.ceil(3.0 * sigma), m - 1))
    k = np.arange(-reach, reach + 1)
    w = np.exp(-0.5 * (k / sigma) ** 2)
    w /= w.sum()
    left = 2.0 * values[0] - values[reach:0:-1]
    right = 2.0 * values[-1] - values[-2:-reach - 2:-1]
    padded = np.concatenate([left, values, right])
    out = np.zeros_like(values)
    for j, wj in enumerate(w):
        out += wj * padded[j: j + m]
    out[0], out[-1] = values[0], values[-1]  # (exactly, not to rounding)
    return out


def _blend(a: np.ndarray, b: np.ndarray, t: np.ndarray, ta: np.ndarray, tb: np.ndarray) -> np.ndarray:
    """One Barry-Goldman step: ``a`` and ``b`` (per interval, ``(I, 1 or S, 3)``) blended at parameters ``t``
    (``(I, S)``) between the knots ``ta`` and ``tb`` (``(I,)``)."""
    wa = ((tb[:, None] - t) / (tb - ta)[:, None])[..., None]
    return wa * a + (1.0 - wa) * b


def _catmull_rom(points: np.ndarray, samples: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A centripetal Catmull-Rom spline through ``points`` (``(m, 3)``, m >= 2), ``samples`` per interval;
    the ends continue straight (mirrored neighbours). Returns ``(m - 1) * samples + 1`` positions and, per
    position, its interval and the fraction of it travelled."""
    m = len(points)
    ext = np.concatenate([2.0 * points[:1] - points[1:2], points, 2.0 * points[-1:] - points[-2:-1]])
    i = np.arange(m - 1)
    p0, p1, p2, p3 = (ext[i + k][:, None, :] for k in range(4))
    # knots by the square root of the chord lengths (centripetal: no cusps or loops within an interval)
    floor = 1e-9
    t0 = np.zeros(m - 1)
    t1 = np.maximum(np.linalg.norm(ext[i + 1] - ext[i], axis=1), floor) ** 0.5
    t2 = t1 + np.maximum(np.linalg.norm(ext[i + 2] - ext[i + 1], axis=1), floor) ** 0.5
    t3 = t2 + np.maximum(np.linalg.norm(ext[i + 3] - ext[i + 2], axis=1), floor) ** 0.5
    u = np.arange(samples) / samples
    t = t1[:, None] + (t2 - t1)[:, None] * u[None, :]  # (m - 1, samples)
    a1, a2, a3 = _blend(p0, p1, t, t0, t1), _blend(p1, p2, t, t1, t2), _blend(p2, p3, t, t2, t3)
    c = _blend(_blend(a1, a2, t, t0, t2), _blend(a2, a3, t, t1, t3), t, t1, t2)
    pos = np.concatenate([c.reshape(-1, 3), points[-1:]])
    interval = np.concatenate([np.repeat(i, samples), [m - 2]])
    frac = np.concatenate([np.tile(u, m - 1), [1.0]])
    return pos, interval, frac


def skeleton(
    dendrite: Dendrite,
    radius: Width = 1.0,
    *,
    side: Width | None = None,
    sigma: float | None = None,
    samples: int = 2,
    min_radius: float = 0.0,
) -> Skeleton:
    """Smooth centre lines of every branch of a 3D dendrite, with a radius at every sample.

    Args:
        dendrite: a non-empty 3D dendrite.
        radius: radius in world units: a constant > 0, a :class:`~wdendrite.render.Taper`
            or an ``(N,)`` array (see :func:`~wdendrite.render.node_widths`).
        side: optional radius of side branches (``radius`` then applies to main paths).
        sigma: width of the Gaussian that smooths each branch, in world units along it
            (default: 2 node spacings, ``2 * dendrite.spacing``); 0 keeps the nodes
            and only interpolates.
        samples: samples per node interval of the spline, >= 1.
        min_radius: radii below it are raised to it (world units, >= 0).

    Returns:
        A :class:`Skeleton`.

    Raises:
        TypeError: ``dendrite`` is not a :class:`~wdendrite.Dendrite`.
        ValueError: an empty or 2D dendrite, a bad radius, a negative or non-finite ``sigma`` or
            ``min_radius``, ``samples`` not an integer >= 1 (before any work).
    """
    if not isinstance(dendrite, Dendrite):
        raise TypeError(f"Expected a wdendrite.Dendrite for 'dendrite', but got {type(dendrite).__name__}")
    if len(dendrite) == 0:
        raise ValueError("'dendrite' is empty (no nodes): there is no centre line to draw")
    if dendrite.ndim != 3:
        raise ValueError(f"skeleton() needs a 3D dendrite, but the dendrite has shape {tuple(dendrite.shape)}")
    sigma = 2.0 * float(dendrite.spacing) if sigma is None else _checks.nonnegative("sigma", sigma, allow_none=False)
    samples = _checks.integer("samples", samples, low=1)
    min_radius = _checks.nonnegative("min_radius", min_radius, allow_none=False)
    r = np.maximum(node_widths(dendrite, radius, side=side, _name="radius").astype(np.float64), min_radius)
    pos = dendrite.positions[:, ::-1].astype(np.float64)
    chains, parents = _chains(dendrite)
    # a side branch starts at its parent's smoothed position there, so parents are smoothed first
    smoothed = np.full((len(dendrite), 3), np.nan)
    pts, rad, rows, offsets = [], [], [], [0]
    for chain, parent in zip(chains, parents):
        p = pos[chain]
        rr = r[chain]
        if parent >= 0:
            p[0] = smoothed[chain[0]]
            rr[0] = r[chain[1]]  # the side branch's own first radius, not its parent's
        # Gaussian over rows: sigma in world units over the mean step along this branch
        step = float(np.linalg.norm(np.diff(p, axis=0), axis=1).mean()) if len(p) > 1 else 1.0
        s_rows = sigma / step if step > 0 else 0.0
        q = _mirrored_gaussian(p, s_rows)
        own = chain if parent < 0 else chain[1:]
        smoothed[own] = q if parent < 0 else q[1:]
        rq = _mirrored_gaussian(rr, s_rows)
        if len(q) == 1:  # a lone root: one sample
            pts.append(q)
            rad.append(rq)
            rows.append(chain)
        else:
            at, interval, frac = _catmull_rom(q, samples)
            pts.append(at)
            rad.append(rq[interval] * (1.0 - frac) + rq[interval + 1] * frac)
            rows.append(chain[interval + (frac > 0.5)])
        offsets.append(offsets[-1] + len(pts[-1]))
    return Skeleton(points=np.concatenate(pts), radius=np.concatenate(rad), offsets=np.asarray(offsets, np.int64),
                    row=np.concatenate(rows).astype(np.int64), parent_branch=parents)


def turning_angles(lines: Skeleton, step: float) -> np.ndarray:
    """Turning angles (degrees) between consecutive pieces of every branch, resampled every ``step``.

    Each branch is walked by arc length and sampled every ``step`` world units
    (its tip included when the last piece is at least half a step); the angle
    between the directions of consecutive pieces measures how sharply the line
    turns at that scale (0: straight on; a lattice path at its node spacing has
    45 and 90 degrees at most of its nodes).

    Args:
        lines: a :class:`Skeleton`.
        step: sampling distance along each branch, world units, > 0.

    Returns:
        ``(M,)`` float64 angles in [0, 180], all branches together (branches shorter than two steps give none).
    """
    if not isinstance(lines, Skeleton):
        raise TypeError(f"Expected a Skeleton for 'lines', but got {type(lines).__name__}")
    step = _checks.positive("step", step)
    out = []
    for b in range(lines.branches):
        p = lines.points[lines.offsets[b]: lines.offsets[b + 1]]
        if len(p) < 2:
            continue
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
        at = np.arange(0.0, s[-1] + 1e-12, step)
        if s[-1] - at[-1] >= 0.5 * step:
            at = np.append(at, s[-1])
        if len(at) < 3:
            continue
        q = np.stack([np.interp(at, s, p[:, k]) for k in range(3)], axis=1)
        d = np.diff(q, axis=0)
        d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
        out.append(np.degrees(np.arccos(np.clip((d[1:] * d[:-1]).sum(axis=1), -1.0, 1.0))))
    return np.concatenate(out) if out else np.zeros(0)
