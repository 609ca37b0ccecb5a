"""A NumPy reference of Dendry for the tests: the whole tree of a region built by brute force.

The references re-implement the counter-based hash in NumPy. One builds the key points and
straight segments of every cell of a region (no smoothing, no subdivision) and measures distances
to all of them. The other rebuilds every polyline the cached mode made over a region from its key
points: level 1 from the lowest neighbours, finer levels from the nearest piece of all coarser
polylines of the region (not only those the kernel searches), each as a chordal Catmull-Rom
spline (Barry-Goldman pyramid) displaced sideways.
"""

import numpy as np

from wdendrite import control
from wdendrite.dendry import DendryParams, _cached_tree

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
        pts = _key_points(params.seed, params.epses()[0], 1, ci, cj)
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
        self.z = {1: {(lo + i, lo + j): z[i, j] for i in range(n) for j in range(n)}}
        self.lo, self.hi = lo, hi

    def add_level(self, level, slope):
        """New key points join the globally nearest segment (terrain rule: a, midpoint or b)."""
        f = 2 ** (level - 1)
        lo, hi = (self.lo + 2) * f, (self.hi - 2) * f
        allseg = np.concatenate(self.segs)
        allz = np.concatenate(self.zs)
        segs, zs, pts, zpts = [], [], {}, {}
        for ci in range(lo, hi):
            for cj in range(lo, hi):
                parent = self.points[level - 1].get((ci >> 1, cj >> 1))
                if parent is not None and tuple(np.floor(parent * f).astype(int)) == (ci, cj):
                    pts[(ci, cj)] = parent
                    zpts[(ci, cj)] = self.z[level - 1][(ci >> 1, cj >> 1)]
                    continue
                q = _key_points(self.p.seed, self.p.epses()[level - 1], level, np.array(ci), np.array(cj))
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
                zpts[(ci, cj)] = zq
        self.points[level] = pts
        self.z[level] = zpts
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


# ------------------------------------------------------------------ reference polylines

_PIECES = (4, 3, 2, 1, 1, 1)
_NONE, _INHERITED, _SEGMENT = 0.0, 1.0, 2.0


def _catmull_rom(p0, p1, p2, p3, t):
    """Chordal Catmull-Rom point between p1 and p2 (apart) at fraction t, by the Barry-Goldman pyramid.

    A repeated end point (p3 = p2, where a branch joins a sink) is the pyramid's limit: a3 = p2,
    which makes the curve's derivative zero there.
    """
    k1 = np.linalg.norm(p1 - p0)
    k2 = k1 + np.linalg.norm(p2 - p1)
    k3 = k2 + np.linalg.norm(p3 - p2)
    s = k1 + t * (k2 - k1)
    a1 = ((k1 - s) * p0 + s * p1) / k1 if k1 > 0 else p1
    a2 = ((k2 - s) * p1 + (s - k1) * p2) / (k2 - k1)
    a3 = ((k3 - s) * p2 + (s - k2) * p3) / (k3 - k2) if k3 > k2 else p2
    b1 = ((k2 - s) * a1 + s * a2) / k2
    b2 = ((k3 - s) * a2 + (s - k1) * a3) / (k3 - k1)
    return ((k2 - s) * b1 + (s - k1) * b2) / (k2 - k1)


def _polyline(p, level, cell, a, b, p0, p3, *, displaced=True):
    """(pieces + 1, 3) vertices of segment a -> b ((x, y, z) each): the level's pieces along the spline
    through p0, a, b, p3, inner vertices moved sideways by U(-delta, delta) * length."""
    pieces = _PIECES[level - 1] if p.subdivision else 1
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b[:2] - a[:2]
    length = np.linalg.norm(d)
    out = [a]
    for j in range(1, pieces):
        t = j / pieces
        if length == 0.0:
            pos = a[:2]
        elif p.smoothing:
            pos = _catmull_rom(np.asarray(p0, float), a[:2], b[:2], np.asarray(p3, float), t)
        else:
            pos = a[:2] + t * d
        if displaced and length > 0.0:
            u = float(_cell_rand(p.seed, level, cell[0], cell[1], 8 + j))
            pos = pos + (2.0 * u - 1.0) * p.deltas()[level - 1] * length * np.array([-d[1], d[0]]) / length
        out.append(np.array([pos[0], pos[1], a[2] + t * (b[2] - a[2])]))
    out.append(b)
    return np.array(out)


def _spline_tolerance(a, b, p3):
    """How closely float32 vertices of the spline a -> b with far neighbour p3 follow the float64 ones.

    The chordal tangent at b divides by |p3 - b|: a short last span (a join just before a piece's
    end) amplifies the float32 rounding of the coordinates (about 1e-6 here) by |b - a| / |p3 - b|.
    """
    span = np.linalg.norm(np.asarray(b)[:2] - np.asarray(a)[:2])
    d3 = np.linalg.norm(np.asarray(p3) - np.asarray(b)[:2])
    return 2e-5 + (4e-6 * span / d3 if d3 > 0 else 0.0)


def _region_tree(p, size, ctl=CTL, origin=0.0):
    """The cached mode's cells over [origin, origin + size]^2, mapped 1:1 onto the control's coordinates."""
    assert p.resolution == 1.0  # then grid units, domain units and control coordinates coincide
    dom = ((origin, origin), (origin + size, origin + size))
    return _cached_tree((8, 8), domain=dom, control_domain=dom, params=p, control=ctl)


def _lowest(z, index, c):
    """The cell of the lowest of the 3 x 3 around c (c itself on ties, then row by row)."""
    best, bz = c, z[index[c]]
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            n = (c[0] + dx, c[1] + dy)
            if z[index[n]] < bz:
                best, bz = n, z[index[n]]
    return best


def _pieces_of(p, tree, below):
    """Every piece of the segments of levels < ``below``: a, b (x, y, z), the vertex after b (NaN
    where b ends its polyline). Polylines of fewer than 4 pieces end in zero-length pieces at
    their last vertex (a join there may take either: they are equally near)."""
    a, b, nxt = [], [], []
    for level in range(1, below):
        _, keyp, verts = tree[level - 1]
        v = verts[keyp[:, 3] == _SEGMENT].astype(float)
        n = _PIECES[level - 1] if p.subdivision else 1
        for j in range(4):
            a.append(v[:, min(j, n)])
            b.append(v[:, min(j + 1, n)])
            nxt.append(v[:, j + 2, :2] if j + 1 < n else np.full((len(v), 2), np.nan))
    return np.concatenate(a), np.concatenate(b), np.concatenate(nxt)


def _piece_distance(q, a, b):
    """(Q, P) distances from points q (Q, 2) to pieces a -> b (P, 2), and the projections' fractions."""
    ab = b - a
    den = (ab * ab).sum(-1)
    t = ((q[:, None] - a[None]) * ab[None]).sum(-1) / np.where(den > 0, den, 1.0)
    t = np.where(den > 0, np.clip(t, 0.0, 1.0), 0.0)
    return np.linalg.norm(q[:, None] - (a[None] + t[..., None] * ab[None]), axis=-1), t


def _joins(p, q, a, b, tproj):
    """The fractions along piece a -> b where key point q may join it (near-ties of the terrain rule all count)."""
    if p.rule == "lichtenberg":
        length = np.linalg.norm(b - a)
        if length == 0.0:
            return [0.0]
        h = np.linalg.norm(q - (a + tproj * (b - a)))
        return [min(tproj + h / length, 1.0)]
    d = [np.linalg.norm(q - (a + t * (b - a))) for t in (0.0, 0.5, 1.0)]
    return [t for t, dt in zip((0.0, 0.5, 1.0), d) if dt <= min(d) + 1e-6]


def _check_tree(p, size, ctl=CTL, margin=4):
    """Rebuild every cell of the cached mode's tree over [0, size]^2 in NumPy; return
    (links checked, links that joined no nearest piece of the whole region).

    Key points, inheritance, level-1 polylines and elevations are asserted to match. A new
    key point of level k >= 2 whose level-1 ancestor lies ``margin`` cells inside the region
    counts as checked; it is a miss unless its polyline (join point, elevation, spline through
    the piece's next vertex, displacement) is the one built on a piece nearest to it among all
    pieces of levels < k (up to rounding: every piece within 1e-5 of the least distance counts).
    """
    tree = _region_tree(p, size, ctl)
    cells, keyp, verts = tree[0]
    index = {tuple(c): i for i, c in enumerate(cells.tolist())}
    np.testing.assert_allclose(keyp[:, :2], _key_points(p.seed, p.epses()[0], 1, cells[:, 0], cells[:, 1]), atol=2e-6)
    z = ctl.evaluate(keyp[:, :2])
    np.testing.assert_array_equal(keyp[:, 2], z)
    lo1, hi1 = cells.min(0), cells.max(0)
    for i, c in enumerate(map(tuple, cells.tolist())):
        if min(c[0] - lo1[0], c[1] - lo1[1], hi1[0] - c[0], hi1[1] - c[1]) < 2:
            continue  # the block's rim: the lowest neighbour's lowest neighbour lies outside
        t = _lowest(z, index, c)
        tt = _lowest(z, index, t)
        qc, qt = keyp[i, :2].astype(float), keyp[index[t], :2].astype(float)
        p3 = keyp[index[tt], :2].astype(float) if tt != t else 2 * qt - qc
        want = _polyline(p, 1, c, keyp[i, :3], keyp[index[t], :3], 2 * qc - qt, p3)
        np.testing.assert_allclose(verts[i, : len(want)], want, atol=_spline_tolerance(qc, qt, p3), err_msg=str(c))
    checked = missed = 0
    for level in range(2, p.levels + 1):
        cells, keyp, verts = tree[level - 1]
        pcells, pkeyp, _ = tree[level - 2]
        pindex = {tuple(c): i for i, c in enumerate(pcells.tolist())}
        parent = pkeyp[[pindex[(ci >> 1, cj >> 1)] for ci, cj in cells.tolist()]]
        inherits = (parent[:, 3] != _NONE) & (np.floor(parent[:, :2] * 2 ** (level - 1)) == cells).all(1)
        np.testing.assert_array_equal(keyp[:, 3] == _INHERITED, inherits)
        np.testing.assert_array_equal(keyp[inherits, :3], parent[inherits, :3])
        new = keyp[:, 3] == _SEGMENT
        assert (new == ~inherits).all()  # an unbounded control: every other cell joins the tree
        q = keyp[new, :2].astype(float)
        np.testing.assert_allclose(q, _key_points(p.seed, p.epses()[level - 1], level, cells[new, 0], cells[new, 1]), atol=2e-6)
        inner = ((cells[new] >> (level - 1) >= lo1 + margin) & (cells[new] >> (level - 1) <= hi1 - margin)).all(1)
        a, b, nxt = _pieces_of(p, tree, level)
        control_z = ctl.evaluate(keyp[new, :2])
        ks = np.flatnonzero(inner)
        # distances to every piece, 256 key points at a time
        dist, tproj = (np.concatenate(v) for v in zip(*(_piece_distance(q[ks[i : i + 256]], a[:, :2], b[:, :2])
                                                        for i in range(0, len(ks), 256))))
        for row, k in enumerate(ks):
            cell = tuple(cells[new][k])
            got = verts[new][k]
            near = np.flatnonzero(dist[row] <= dist[row].min() + 1e-5)
            ok = False
            for m in near:
                for tc in _joins(p, q[k], a[m, :2], b[m, :2], tproj[row, m]):
                    x = a[m] + tc * (b[m] - a[m])
                    p3 = b[m, :2] if tc < 1.0 else (nxt[m] if np.isfinite(nxt[m, 0]) else 2 * x[:2] - q[k])
                    zq = max(float(control_z[k]), x[2] + p.min_slopes()[level - 1] * np.linalg.norm(q[k] - x[:2]))
                    want = _polyline(p, level, cell, (q[k, 0], q[k, 1], zq), x, 2 * q[k] - x[:2], p3)
                    ok = ok or np.allclose(got[: len(want)], want, rtol=0, atol=_spline_tolerance(q[k], x, p3))
            checked += 1
            missed += not ok
    return checked, missed

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
