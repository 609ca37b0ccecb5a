"""The Dendry function (Gaillard et al. 2019) as per-cell and per-pixel Warp functions.

Coordinates inside kernels are *grid units* ``u = x * resolution``: a level-1
cell is 1 x 1, a level-k cell ``2^(1-k)`` wide, and cell ``(i, j)`` of level k
holds one key point. Every quantity of a cell (its key point, elevation, state,
and the polyline of the segment it owns) is a function of the cell alone, so
values never depend on which pixel or window asked for them.

Storage. A *block* is a rectangle of cells of one level, ``vec4i(i0, j0, ni, nj)``;
``blocks[slot * 8 + L]`` describes block L of a slot and ``bases[slot * 8 + L]``
where its cells start in the flat arrays:

- L = 0: level-1 key points (``pts1``: x, y, z, valid; valid -1 marks a point the per-pixel
  mode has not drawn yet, see :func:`build`), two cells wider than L = 1;
- L = 1..n: cells of level L (``keyp``: x, y, z, state; ``verts``: per cell, up
  to 5 polyline vertices x, y, z, upstream first, then their bounding box), after one
  ``keyp`` record holding the level's overhang (see :func:`note_overhang`);
- L = 7: terrain primitives (``prims``: x, y, h).

Per-pixel elevation also keeps, per slot, a shortlist of the polyline pieces near
its pixel (``nearby``, see :func:`answer`), read by the queries of its primitives.

In the cached mode one slot (0) covers a whole window and each stage is one
launch over its cells; in the per-pixel mode each thread uses a slot of its own
(shared in turn on the CPU, which runs a launch's threads one by one), plans
blocks just around its pixel and fills them itself with the same functions.
There the finest level is filled last and lazily (:func:`finish`): once the
pixel's answer is bounded, a finest segment proved to lie beyond that bound is
not drawn, which changes no value (the finest level links nothing). With two
levels, the level-1 segments that only the finest level's links can read are
left pending, as boxes that hold them (:func:`defer1`), and drawn only when a
link search comes near one (:func:`nearest_on_tree`) or, where links are narrower
than queries, the pixel's answer does (:func:`draw_near1`).
The module is longer than most because both modes must share every function
that decides a value: that sharing is what makes them agree bit for bit.
"""

import warp as wp

from . import OPTIONS
from .indexing import nonneg
from .noise import Control, control_inside, control_value
from .random import hash3, mix32

wp.set_module_options(OPTIONS)

NV = wp.constant(7)  # stride of a cell in `verts`: up to 5 polyline vertices, then its bounding box
PIECES = wp.constant(4)  # pieces searched per cell: shorter polylines are padded with copies of their last vertex
BOUND = wp.constant(5)  # position of the bounding box in a cell's stride: (x0, y0, x1), then (y1, longest piece, -)
SLOT = wp.constant(8)  # blocks per slot
PRIM = wp.constant(7)  # block id of the terrain primitives
STATE_NONE = wp.constant(0.0)  # no usable key point (outside the domain, or no segment to join)
STATE_INHERITED = wp.constant(1.0)  # key point of the parent level, already on the tree
STATE_SEGMENT = wp.constant(2.0)  # key point owning a segment
STATE_FAR = wp.constant(3.0)  # per-pixel mode: a finest-level segment too far from the pixel to matter, not drawn
# per-pixel mode, 2 levels: a level-1 segment no query of the pixel reads, drawn only if a link
# search comes near the box that bounds it (see fill_links1); keyp holds its key point as for a segment
STATE_PENDING = wp.constant(4.0)
# per-pixel mode, levels drawn on demand (see build): a cell of levels 2..n-1 with a key point of
# its own whose segment is drawn only if some search may need it (see prepare_levels); keyp holds
# (x, y, reach, state)
STATE_WAIT = wp.constant(5.0)
STATE_WANTED = wp.constant(6.0)  # such a cell that a search may need: the next draw pass draws it

OUT_DISTANCE = wp.constant(0)
OUT_ELEVATION = wp.constant(1)
OUT_LEVEL = wp.constant(2)

GOLDEN = wp.constant(wp.uint32(0x9E3779B9))  # Weyl increment between a cell's random streams

vec6 = wp.types.vector(length=6, dtype=float)
vec6i = wp.types.vector(length=6, dtype=int)
vec49i = wp.types.vector(length=49, dtype=int)
vec64i = wp.types.vector(length=64, dtype=int)
vec25 = wp.types.vector(length=25, dtype=float)
vec16 = wp.types.vector(length=16, dtype=float)


def _search_order(r: int) -> list[tuple[int, int]]:
    """The search order of a (2r+1)^2 neighbourhood: its centre, then the rings at Chebyshev
    distance 1..r, each from its (-ring, -ring) corner round through (ring, -ring), (ring, ring)
    and (-ring, ring)."""
    order = [(0, 0)]
    for ring in range(1, r + 1):
        order += [(-ring + i, -ring) for i in range(2 * ring)] + [(ring, -ring + i) for i in range(2 * ring)]
        order += [(ring - i, ring) for i in range(2 * ring)] + [(-ring, ring - i) for i in range(2 * ring)]
    return order


ORDER_X = wp.constant(vec49i(*(x for x, _ in _search_order(3))))
ORDER_Y = wp.constant(vec49i(*(y for _, y in _search_order(3))))


@wp.struct
class Setup:
    """Dendry parameters as the kernels use them (see wdendrite.dendry.DendryParams)."""

    levels: int
    seed: wp.uint32
    eps: vec6  # key points in [eps, 1 - eps] of their cells, per level
    prim_eps: float  # the same for the terrain primitives (levels beyond the tree's)
    resolution: float
    inv_resolution: float  # 1 / resolution: kernels multiply (a division costs several multiplications)
    delta: vec6  # sideways displacement per level, times the segment length
    pieces: vec6i  # polyline pieces per level (1..4)
    slope: vec6  # minimum slope per level (elevation per domain unit)
    reach: vec6  # per level, how many spans a polyline may stray from its key point (see segment_reach)
    piece: vec6  # per level, how many spans long a piece of a polyline may be (see piece_bound)
    smoothing: int
    beta: float
    noise: float
    steps: int  # the primitives sit on the grid of level `levels + steps`
    rule: int  # 0: join the nearest of a, midpoint, b; 1: join at 45 degrees downstream
    r1: int  # query neighbourhood radius at level 1 (see wdendrite.dendry.DendryParams.radii)
    rq: int  # query neighbourhood radius at levels 2..n
    rl: int  # link neighbourhood radius: new key points join pieces owned within rl cells of their ancestors
    # per-pixel mode, 2 levels: pending level-1 cells whose boxes come within near1 grid units of the
    # pixel are drawn at once instead (see fill_links1; wdendrite.dendry._setup chooses it)
    near1: float
    need_z: int  # 0: elevations of finer key points are not needed (distance, level), skip the control there
    # query domain -> control coordinates: c = c_lo + (x - d_lo) * scale
    d_lo: wp.vec2
    c_lo: wp.vec2
    scale: wp.vec2
    # level-1 outlets (wdendrite.dendry.DendryParams.outlets): the values of the level-1 key points of
    # cells outlet_lo + (0..outlet_n - 1), drained by the host; outlet_n (0, 0) when there are none
    outlet_lo: wp.vec2i
    outlet_n: wp.vec2i
    outlet_z: wp.array(dtype=float)


@wp.func
def level_factor(level: int) -> float:
    """Cells per grid unit at ``level`` (an exact power of two)."""
    return float(1 << (level - 1))


@wp.func
def cell_size(level: int) -> float:
    """Width of a cell of ``level`` in grid units, ``1 / level_factor`` without a division (exact)."""
    return float(1 << (21 - level)) * (1.0 / 1048576.0)


@wp.func
def cell_corner(c: wp.vec2i, level: int) -> wp.vec2:
    """The lower corner of cell ``c`` of ``level`` in grid units (exact: the cell size is a power of two)."""
    h = cell_size(level)
    return wp.vec2(float(c[0]) * h, float(c[1]) * h)


@wp.func
def cell_of(u: wp.vec2, level: int) -> wp.vec2i:
    """The cell of ``level`` holding point ``u`` (grid units).

    The host keeps ``|u| * 2^(level - 1)`` below 2^22 at the finest level used (see
    ``wdendrite.dendry._check_reach``): the index fits int32 and float32 holds it exactly.
    """
    f = level_factor(level)
    return wp.vec2i(int(wp.floor(u[0] * f)), int(wp.floor(u[1] * f)))


@wp.func
def cell_key(seed: wp.uint32, level: int, c: wp.vec2i) -> wp.uint32:
    """The random state of cell ``c`` of ``level``: one hash of (seed, level, cell)."""
    return hash3(seed + wp.uint32(level) * GOLDEN, wp.uint32(c[0]), wp.uint32(c[1]))


@wp.func
def key_uniform(key: wp.uint32, stream: int) -> float:
    """Uniform number ``stream`` of a cell's state ``key``, strictly inside (0, 1).

    A Weyl step and one mix per number; the top 23 bits plus one half are exact in float32.
    """
    h = mix32(key + wp.uint32(stream) * GOLDEN)
    return (float(h >> wp.uint32(9)) + 0.5) * (1.0 / 8388608.0)


@wp.func
def cell_rand(seed: wp.uint32, level: int, c: wp.vec2i, stream: int) -> float:
    """Uniform (0, 1) number ``stream`` of cell ``c`` of ``level``."""
    return key_uniform(cell_key(seed, level, c), stream)


@wp.func
def jitter(s: Setup, level: int, c: wp.vec2i) -> wp.vec2:
    """The jittered key point of cell ``c``: uniform in the cell shrunk by its level's ``eps`` on
    each side (levels beyond the tree's, the primitives', take the finest level's)."""
    h = cell_size(level)
    e = s.prim_eps
    if level <= s.levels:
        e = s.eps[level - 1]
    span = 1.0 - 2.0 * e
    key = cell_key(s.seed, level, c)
    return wp.vec2(
        (float(c[0]) + e + span * key_uniform(key, 0)) * h,
        (float(c[1]) + e + span * key_uniform(key, 1)) * h,
    )


@wp.func
def to_control(s: Setup, u: wp.vec2) -> wp.vec2:
    """Grid units -> control-function coordinates."""
    x = u * s.inv_resolution - s.d_lo
    return s.c_lo + wp.cw_mul(x, s.scale)


@wp.func
def block_cell(blocks: wp.array(dtype=wp.vec4i), bi: int, k: int) -> wp.vec2i:
    """The cell at linear position ``k`` of block ``bi``."""
    b = blocks[nonneg(bi)]
    return wp.vec2i(b[0] + k % b[2], b[1] + k / b[2])


@wp.func
def block_index(blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), bi: int, c: wp.vec2i) -> int:
    """Flat index of cell ``c`` in block ``bi``, or -1 when the block does not hold it."""
    b = blocks[nonneg(bi)]
    dx = c[0] - b[0]
    dy = c[1] - b[1]
    if dx < 0 or dy < 0 or dx >= b[2] or dy >= b[3]:
        return -1
    return bases[nonneg(bi)] + dy * b[2] + dx


@wp.func
def spline_tangents(p0: wp.vec2, p1: wp.vec2, p2: wp.vec2, p3: wp.vec2) -> wp.vec4:
    """Hermite tangents (scaled to the span p1 -> p2) of the chordal Catmull-Rom spline through p0..p3.

    The chordal spline between p1 and p2 is the cubic Hermite curve whose end
    derivatives follow from the knot spacings d1, L, d3 (the chord lengths):
    ``m1 = (p1 - p0) / d1 - (p2 - p0) / (d1 + L) + (p2 - p1) / L`` and likewise at p2;
    this is the Barry-Goldman pyramid of the spline written out once per segment.
    Returns (L * m1, L * m2), with the factor L taken into each term's ratio of lengths
    (four divisions instead of ten).
    """
    d1 = wp.length(p1 - p0) + 1.0e-6
    span = wp.length(p2 - p1) + 1.0e-6
    d3 = wp.length(p3 - p2) + 1.0e-6
    e12 = p2 - p1
    t1 = (span / d1) * (p1 - p0) - (span / (d1 + span)) * (p2 - p0) + e12
    t2 = e12 - (span / (span + d3)) * (p3 - p1) + (span / d3) * (p3 - p2)
    return wp.vec4(t1[0], t1[1], t2[0], t2[1])


@wp.func
def hermite(p1: wp.vec2, p2: wp.vec2, tan: wp.vec4, t: float) -> wp.vec2:
    """The Hermite curve from p1 to p2 with scaled tangents ``tan`` at fraction ``t``."""
    u = 1.0 - t
    h01 = t * t * (3.0 - 2.0 * t)
    h10 = t * u * u
    h11 = -t * t * u
    return wp.vec2(
        p1[0] + h01 * (p2[0] - p1[0]) + h10 * tan[0] + h11 * tan[2],
        p1[1] + h01 * (p2[1] - p1[1]) + h10 * tan[1] + h11 * tan[3],
    )


@wp.func
def write_polyline(
    s: Setup,
    level: int,
    c: wp.vec2i,
    a: wp.vec3,
    b: wp.vec3,
    p0: wp.vec2,
    p3: wp.vec2,
    vi: int,
    verts_out: wp.array(dtype=wp.vec3),
) -> float:
    """Subdivide segment a -> b (x, y, z) into the level's pieces, smoothed and displaced sideways.

    Returns how far the polyline's bounding box reaches beyond cell ``c`` of ``level`` (at
    least 0), which searches use to stop at the first ring of cells beyond their reach
    (see :func:`note_overhang`)."""
    pieces = s.pieces[level - 1]
    pa = wp.vec2(a[0], a[1])
    pb = wp.vec2(b[0], b[1])
    d = pb - pa
    length = wp.length(d)
    side = wp.vec2(0.0, 0.0)
    if length > 0.0:
        side = wp.vec2(-d[1], d[0]) * (1.0 / length)
    tan = wp.vec4(0.0, 0.0, 0.0, 0.0)
    if s.smoothing != 0 and pieces > 1:
        tan = spline_tangents(p0, pa, pb, p3)
    key = cell_key(s.seed, level, c)
    amp = s.delta[level - 1] * length
    verts_out[nonneg(vi * NV)] = a
    lo = wp.min(pa, pb)
    hi = wp.max(pa, pb)
    step = 1.0 / float(pieces)
    prev = pa
    longest = float(0.0)  # squared
    for j in range(1, pieces):
        t = float(j) * step
        pos = pa + t * d
        if s.smoothing != 0:
            pos = hermite(pa, pb, tan, t)
        pos = pos + (2.0 * key_uniform(key, 8 + j) - 1.0) * amp * side
        verts_out[nonneg(vi * NV + j)] = wp.vec3(pos[0], pos[1], a[2] + t * (b[2] - a[2]))
        lo = wp.min(lo, pos)
        hi = wp.max(hi, pos)
        longest = wp.max(longest, wp.length_sq(pos - prev))
        prev = pos
    longest = wp.max(longest, wp.length_sq(pb - prev))
    # the last vertex, then zero-length padding pieces up to it (searches take 4 pieces per cell)
    verts_out[nonneg(vi * NV + PIECES)] = b
    for j in range(pieces, PIECES):
        verts_out[nonneg(vi * NV + j)] = b
    # the polyline's bounding box, widened against rounding (relative to its size and to the
    # coordinates), lets searches skip the cell exactly; the longest piece bounds how far a
    # finer key point's link can land from the point of the piece nearest to it (see link_span)
    pad = 1.0e-4 * (hi[0] - lo[0] + hi[1] - lo[1]) + 1.0e-6 * (1.0 + wp.abs(lo[0]) + wp.abs(lo[1]))
    verts_out[nonneg(vi * NV + BOUND)] = wp.vec3(lo[0] - pad, lo[1] - pad, hi[0] + pad)
    verts_out[nonneg(vi * NV + BOUND + 1)] = wp.vec3(hi[1] + pad, wp.sqrt(longest), 0.0)
    h = cell_size(level)
    corner = cell_corner(c, level)
    out = wp.max(corner - (lo - wp.vec2(pad, pad)), (hi + wp.vec2(pad, pad)) - (corner + wp.vec2(h, h)))
    return wp.max(wp.max(out[0], out[1]), 0.0)


@wp.func
def outlet_value(s: Setup, c: wp.vec2i, z: float) -> float:
    """The value of level-1 cell ``c``'s key point whose control value is ``z``: the drained one of
    the outlet table where the table holds the cell, else ``z``."""
    i = c[0] - s.outlet_lo[0]
    j = c[1] - s.outlet_lo[1]
    if i >= 0 and j >= 0 and i < s.outlet_n[0] and j < s.outlet_n[1]:
        return s.outlet_z[nonneg(j * s.outlet_n[0] + i)]
    return z


@wp.func
def point1(s: Setup, ctl: Control, c: wp.vec2i) -> wp.vec4:
    """Level-1 key point of cell ``c``: (x, y, value, 1 if inside the control's domain); the value
    is the control's there, or the drained one where the host gave the cell an outlet."""
    q = jitter(s, 1, c)
    cp = to_control(s, q)
    inside = float(0.0)
    if control_inside(ctl, cp):
        inside = 1.0
    return wp.vec4(q[0], q[1], outlet_value(s, c, control_value(ctl, cp)), inside)


@wp.func
def lowest1(
    pts1: wp.array(dtype=wp.vec4), blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), bi: int, c: wp.vec2i
) -> wp.vec2i:
    """The cell of the lowest level-1 key point among the 3 x 3 around ``c`` (``c`` itself on ties).

    The point block always holds the whole 3 x 3 (the plan keeps it 2 cells wider than the cells
    that ask), so neighbours are read at fixed offsets from the centre.
    """
    w = blocks[nonneg(bi)][2]
    centre = block_index(blocks, bases, bi, c)
    best = c
    bz = pts1[nonneg(centre)][2]
    for dy in range(-1, 2):
        for dx in range(-1, 2):
            z = pts1[nonneg(centre + dy * w + dx)][2]
            if z < bz:
                bz = z
                best = wp.vec2i(c[0] + dx, c[1] + dy)
    return best


@wp.func
def fill_point1(
    s: Setup, ctl: Control, bases: wp.array(dtype=int), slot: int, k: int, c: wp.vec2i,
    pts1_out: wp.array(dtype=wp.vec4),
):
    """Store the level-1 key point of cell ``c``, at position ``k`` of the slot's block 0."""
    pts1_out[nonneg(bases[nonneg(slot * SLOT)] + k)] = point1(s, ctl, c)


@wp.func
def note_overhang(keyp: wp.array(dtype=wp.vec4), bases: wp.array(dtype=int), bi: int, over: float):
    """Raise the overhang of block ``bi`` to ``over``: the most that the bounding box of any
    segment drawn in the block reaches beyond its own cell (see :func:`write_polyline`).

    The overhang lives in the record just before the block's first cell (``plan`` leaves one
    there per level), so a search reads it with the block's cells. Threads of the cached mode
    draw one level's cells together, hence the atomic maximum."""
    wp.atomic_max(keyp, nonneg(bases[nonneg(bi)] - 1), wp.vec4(over, 0.0, 0.0, 0.0))


@wp.func
def store_point1(
    blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, vi: int, c: wp.vec2i, t: wp.vec2i,
    segment: float, pts1: wp.array(dtype=wp.vec4), keyp_out: wp.array(dtype=wp.vec4),
) -> wp.mat33:
    """Store at ``vi`` the key point of level-1 cell ``c``, whose segment joins ``t``, with state
    ``segment`` (``STATE_NONE`` when either point lies outside the control's domain); return
    rows (x, y, z) of the two points."""
    bp = slot * SLOT
    p = pts1[nonneg(block_index(blocks, bases, bp, c))]
    pt = pts1[nonneg(block_index(blocks, bases, bp, t))]
    state = STATE_NONE
    if p[3] > 0.0 and pt[3] > 0.0:
        state = segment
    keyp_out[nonneg(vi)] = wp.vec4(p[0], p[1], p[2], state)
    return wp.mat33(p[0], p[1], p[2], pt[0], pt[1], pt[2], 0.0, 0.0, 0.0)


@wp.func
def link1(
    s: Setup, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, k: int, c: wp.vec2i,
    t: wp.vec2i, tt: wp.vec2i, pts1: wp.array(dtype=wp.vec4), keyp_out: wp.array(dtype=wp.vec4),
    verts_out: wp.array(dtype=wp.vec3),
):
    """Level-1 cell ``c`` (position ``k`` of its block): its segment to ``t``, the lowest of its 3 x 3
    neighbours, whose own lowest neighbour is ``tt``."""
    bp = slot * SLOT
    vi = bases[nonneg(bp + 1)] + k
    ends = store_point1(blocks, bases, slot, vi, c, t, STATE_SEGMENT, pts1, keyp_out)
    a = wp.vec3(ends[0, 0], ends[0, 1], ends[0, 2])
    b = wp.vec3(ends[1, 0], ends[1, 1], ends[1, 2])
    pa = wp.vec2(a[0], a[1])
    pb = wp.vec2(b[0], b[1])
    # the tangent at the far end follows the target's own segment, else continues straight
    ptt = pts1[nonneg(block_index(blocks, bases, bp, tt))]
    p3 = 2.0 * pb - pa
    if (tt[0] != t[0] or tt[1] != t[1]) and ptt[3] > 0.0:
        p3 = wp.vec2(ptt[0], ptt[1])
    note_overhang(keyp_out, bases, bp + 1, write_polyline(s, 1, c, a, b, 2.0 * pa - pb, p3, vi, verts_out))


@wp.func
def fill_segment1(
    s: Setup, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, k: int, c: wp.vec2i,
    pts1: wp.array(dtype=wp.vec4), keyp_out: wp.array(dtype=wp.vec4), verts_out: wp.array(dtype=wp.vec3),
):
    """Level-1 cell ``c`` (position ``k`` of its block): link its key point to the lowest of its 3 x 3 neighbours."""
    bp = slot * SLOT
    t = lowest1(pts1, blocks, bases, bp, c)
    link1(s, blocks, bases, slot, k, c, t, lowest1(pts1, blocks, bases, bp, t), pts1, keyp_out, verts_out)


@wp.func
def defers1(s: Setup, blocks: wp.array(dtype=wp.vec4i), slot: int) -> int:
    """1 when the per-pixel mode leaves some level-1 segments of ``slot`` pending: with 2 levels,
    in level-1 blocks of up to 64 cells (see :func:`fill_links1`). Those are the cells of the
    block's outer ring more than ``rl`` cells from the query's level-1 cells (the ancestors of the
    finest block lie a cell farther out). The links of the finest level's other cells may read
    them, and where links are narrower than queries (``rl < r1``, the paper's 3 x 3) the queries
    too (:func:`draw_near1`); :func:`build`'s own links (those of the query's cells) never do."""
    b = blocks[nonneg(slot * SLOT + 1)]
    if s.levels == 2 and b[2] * b[3] <= 64:
        return 1
    return 0


@wp.func
def draw_around1(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, t: wp.vec2i,
    pts1: wp.array(dtype=wp.vec4),
):
    """Per-pixel mode: draw the level-1 points of the 3 x 3 around ``t`` that :func:`build` left undrawn.

    ``t`` is the target of a cell of the level-1 block, so it lies at most one cell outside that
    block, and the point block (two cells wider) holds its whole 3 x 3 at fixed offsets from it,
    as for :func:`lowest1`."""
    w = blocks[nonneg(slot * SLOT)][2]
    centre = block_index(blocks, bases, slot * SLOT, t)
    for dy in range(-1, 2):
        for dx in range(-1, 2):
            o = centre + dy * w + dx
            if pts1[nonneg(o)][3] < 0.0:
                pts1[nonneg(o)] = point1(s, ctl, wp.vec2i(t[0] + dx, t[1] + dy))


@wp.func
def draw_if_pending1(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, c: wp.vec2i,
    o: int, q: wp.vec2, reach2: float, pts1: wp.array(dtype=wp.vec4), keyp: wp.array(dtype=wp.vec4),
    verts: wp.array(dtype=wp.vec3),
) -> int:
    """Per-pixel mode: draw level-1 cell ``c`` (at ``o`` in ``keyp``) with :func:`fill_segment1`,
    as :func:`fill_links1` would have, when it is ``STATE_PENDING`` and its box lies within
    ``sqrt(reach2)`` of ``q`` (``<=``); return 1 when drawn, else 0."""
    if keyp[nonneg(o)][3] == STATE_PENDING:
        if box_gap2(q, verts, o) <= reach2:
            bp = slot * SLOT
            # the points around its target first (the block's outer ring may be undrawn)
            draw_around1(s, ctl, blocks, bases, slot, lowest1(pts1, blocks, bases, bp, c), pts1)
            fill_segment1(s, blocks, bases, slot, o - bases[nonneg(bp + 1)], c, pts1, keyp, verts)
            return 1
    return 0


@wp.func
def draw_near1(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, u: wp.vec2,
    limit: float, pts1: wp.array(dtype=wp.vec4), keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3),
):
    """Per-pixel mode, links narrower than queries (``rl < r1``), at the end of :func:`finish`:
    draw the pending level-1 cells (of the block's outer ring, see :func:`defers1`) whose boxes lie
    within ``limit`` of ``u`` (all of them when ``limit`` < 0), as :func:`fill_links1` would have.

    Those cells lie within the queries' neighbourhoods, and only pieces within ``limit`` can
    answer the pixel or its primitives (see :func:`answer`), so the queries and the shortlist
    then see every piece that can answer them. :func:`finish` calls this only when the nearest
    pending box (kept by :func:`fill_links1`) lies within ``limit``."""
    b = blocks[nonneg(slot * SLOT + 1)]
    o0 = bases[nonneg(slot * SLOT + 1)]
    reach2 = float(wp.inf)
    if limit >= 0.0:
        reach2 = limit * limit
    for j in range(b[3]):
        # (the first and last rows whole, the others' two ends; blocks are at least 3 cells wide)
        step = wp.max(b[2] - 1, 1)
        if j == 0 or j == b[3] - 1:
            step = 1
        i = int(0)
        while i < b[2]:
            draw_if_pending1(s, ctl, blocks, bases, slot, wp.vec2i(b[0] + i, b[1] + j), o0 + j * b[2] + i, u, reach2,
                             pts1, keyp, verts)
            i += step


@wp.func
def pending_bounds(s: Setup, pa: wp.vec2, pb: wp.vec2) -> wp.vec2:
    """(side, piece) for the level-1 segment from ``pa`` to ``pb`` that :func:`link1` draws:
    its polyline lies within ``side`` of the chord and no piece of it is longer than ``piece``.

    :func:`link1` starts the spline with ``p0 = 2 pa - pb``, which makes its first tangent
    the chord itself; the second is at most a span long (see :func:`segment_reach`). A vertex
    at fraction t then lies at ``pa + (t + t^2 - t^3) (pb - pa) - t^2 (1 - t) m2``, within
    ``t^2 (1 - t) <= 0.140625`` spans of the chord at t = 1/4, 1/2, 3/4, and two vertices a
    quarter apart lie at most 0.40625 spans apart (between t = 1/4 and 1/2), plus the sideways
    displacements of at most delta spans each. A straight segment's pieces obey both bounds too.
    Level 1 has 4 pieces, or 1 without subdivision; for any other count the bounds fall back to
    ``4/27`` spans from the chord and ``1 + 4/27`` spans a piece (``t + t^2 - t^3`` rises from
    0 to 1).
    """
    span = wp.length(pb - pa) + 1.0e-6
    d = s.delta[0]
    side = 0.14815 + d
    piece = (1.14815 + 2.0 * d) * span
    if s.pieces[0] == 4:
        side = 0.140625 + d
        piece = (0.40625 + 2.0 * d) * span
    elif s.pieces[0] == 1:
        piece = span
    return wp.vec2(widened(side * span, pa), widened(piece, pa))


@wp.func
def defer1(
    s: Setup, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, k: int, c: wp.vec2i,
    t: wp.vec2i, pts1: wp.array(dtype=wp.vec4), keyp_out: wp.array(dtype=wp.vec4), verts_out: wp.array(dtype=wp.vec3),
):
    """Per-pixel mode: leave the segment of level-1 cell ``c`` (position ``k`` of its block) to
    ``t`` undrawn, as ``STATE_PENDING`` (``STATE_NONE`` where :func:`link1` stores that), with
    only what searches and :func:`finish` read of it: its key point, a box holding the polyline
    :func:`link1` would draw, and a bound on that polyline's longest piece (:func:`pending_bounds`).
    """
    vi = bases[nonneg(slot * SLOT + 1)] + k
    ends = store_point1(blocks, bases, slot, vi, c, t, STATE_PENDING, pts1, keyp_out)
    pa = wp.vec2(ends[0, 0], ends[0, 1])
    pb = wp.vec2(ends[1, 0], ends[1, 1])
    bound = pending_bounds(s, pa, pb)
    lo = wp.min(pa, pb) - wp.vec2(bound[0], bound[0])
    hi = wp.max(pa, pb) + wp.vec2(bound[0], bound[0])
    verts_out[nonneg(vi * NV + BOUND)] = wp.vec3(lo[0], lo[1], hi[0])
    verts_out[nonneg(vi * NV + BOUND + 1)] = wp.vec3(hi[1], bound[1], 0.0)


@wp.func
def pending_gap(
    blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, anc: wp.vec2i, r: int, q: wp.vec2,
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3),
) -> float:
    """Squared distance from ``q`` to the nearest box of a ``STATE_PENDING`` level-1 cell among
    the (2r + 1)^2 around ``anc`` (1e30: none). Pending cells form the outer ring of the level-1
    block (see :func:`build`), so only the ring's rows and columns within reach are read."""
    bi = slot * SLOT + 1
    b = blocks[nonneg(bi)]
    g = float(1.0e30)
    for side in range(4):
        # the block's left and right columns, then its top and bottom rows
        edge = b[0]
        lo = anc[0] - r
        if side == 1:
            edge = b[0] + b[2] - 1
        elif side >= 2:
            edge = b[1]
            lo = anc[1] - r
            if side == 3:
                edge = b[1] + b[3] - 1
        if edge >= lo and edge <= lo + 2 * r:
            for m in range(2 * r + 1):
                c = wp.vec2i(edge, anc[1] - r + m)
                if side >= 2:
                    c = wp.vec2i(anc[0] - r + m, edge)
                o = block_index(blocks, bases, bi, c)
                if o >= 0:
                    if keyp[nonneg(o)][3] == STATE_PENDING:
                        g = wp.min(g, box_gap2(q, verts, o))
    return g


@wp.func
def draw_pending1(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int,
    anc: wp.vec2i, q: wp.vec2, sb: float, pts1: wp.array(dtype=wp.vec4), keyp: wp.array(dtype=wp.vec4),
    verts: wp.array(dtype=wp.vec3),
) -> int:
    """Draw the ``STATE_PENDING`` level-1 cells among the (2 rl + 1)^2 around ``anc`` whose boxes
    lie within ``sb`` of ``q`` (see :func:`defer1`; ``<=``, as :func:`nearest_on_tree` asks), with
    :func:`fill_segment1`, as :func:`fill_links1` would have; return how many."""
    drawn = int(0)
    for dy in range(-s.rl, s.rl + 1):
        for dx in range(-s.rl, s.rl + 1):
            c = wp.vec2i(anc[0] + dx, anc[1] + dy)
            o = block_index(blocks, bases, slot * SLOT + 1, c)
            if o >= 0:
                drawn += draw_if_pending1(s, ctl, blocks, bases, slot, c, o, q, sb * sb, pts1, keyp, verts)
    return drawn


@wp.func
def coord_margin(u: wp.vec2) -> float:
    """An absolute margin against float32 rounding for distances measured at coordinates the size
    of ``u``'s (grid units), used wherever a bound decides which pieces can be left out."""
    return 1.0e-5 * (1.0 + wp.abs(u[0]) + wp.abs(u[1]))


@wp.func
def widened(d: float, u: wp.vec2) -> float:
    """Distance bound ``d`` at ``u`` widened by 0.1 % and :func:`coord_margin`, so that no piece
    within ``d`` falls outside it by rounding."""
    return d * 1.001 + coord_margin(u)


@wp.func
def piece_near(q: wp.vec2, a: wp.vec3, b: wp.vec3) -> wp.vec2:
    """(squared distance, fraction along the piece) of the point of piece a -> b nearest to ``q``."""
    pa = wp.vec2(a[0], a[1])
    ab = wp.vec2(b[0], b[1]) - pa
    den = wp.dot(ab, ab)
    t = float(0.0)
    if den > 0.0:
        t = wp.clamp(wp.dot(q - pa, ab) / den, 0.0, 1.0)
    return wp.vec2(wp.length_sq(q - (pa + t * ab)), t)


@wp.func
def reach_of(best: float) -> float:
    """A distance a little above ``sqrt(best)``: cells whose box lies farther cannot hold a piece nearer than best."""
    return wp.sqrt(best) * 1.00001


@wp.func
def box_gap2(q: wp.vec2, verts: wp.array(dtype=wp.vec3), o: int) -> float:
    """Squared distance from ``q`` to cell ``o``'s bounding box (0 inside)."""
    lo = verts[nonneg(o * NV + BOUND)]
    hi = verts[nonneg(o * NV + BOUND + 1)]
    dx = wp.max(wp.max(lo[0] - q[0], q[0] - lo[2]), 0.0)
    dy = wp.max(wp.max(lo[1] - q[1], q[1] - hi[0]), 0.0)
    return dx * dx + dy * dy


@wp.func
def cell_far(q: wp.vec2, verts: wp.array(dtype=wp.vec3), o: int, sb: float) -> bool:
    """True when cell ``o``'s bounding box lies at least ``sb`` away from ``q``."""
    return box_gap2(q, verts, o) >= sb * sb


@wp.struct
class Hit:
    """The best piece found so far by a search (``o`` -1 while none)."""

    best: float  # squared distance
    sb: float  # reach_of(best)
    o: int  # cell index
    j: int  # piece
    t: float  # fraction along the piece
    l: int  # level


@wp.func
def no_hit() -> Hit:
    """A search result before any piece is found."""
    h = Hit()
    h.best = 1.0e30
    h.sb = 1.0e15
    h.o = -1
    h.j = 0
    h.t = 0.0
    h.l = 0
    return h


@wp.func
def scan_range(
    blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), bi: int, l: int, c: wp.vec2i, r: int,
    k0: int, k1: int, q: wp.vec2, keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3), hit: Hit,
) -> Hit:
    """:func:`scan` over positions ``k0..k1-1`` of the search order only (``k1`` at most
    ``(2r + 1)^2``): a scan split in two parts updates the hit exactly as one scan does."""
    b = blocks[nonneg(bi)]
    dx = c[0] - b[0]
    dy = c[1] - b[1]
    # the plans make blocks hold every neighbourhood asked for; cells are then at fixed offsets
    whole = dx >= r and dy >= r and dx + r < b[2] and dy + r < b[3]
    centre = bases[nonneg(bi)] + dy * b[2] + dx
    # q lies in cell c, so the cells of ring m lie at least (m - 1) cells beyond c's nearest
    # edge to q, and their boxes at least that less the block's overhang: once that passes the
    # reach, no cell of this ring or beyond can hold a nearer piece (the test below would skip
    # each of them). (Worked out inside the loop, only for scans that reach ring 2, it cost
    # 0.6 % more instructions per pixel at the Table 1 setup.)
    h = cell_size(l)
    corner = cell_corner(c, l)
    inner = wp.min(wp.min(q - corner), wp.min(corner + wp.vec2(h, h) - q))
    gap = h + wp.max(inner, 0.0) - keyp[nonneg(bases[nonneg(bi)] - 1)][0] - coord_margin(q)
    # a while loop: Warp's range() with a run-time bound compiled to a slower loop here
    # (per-pixel queries 8-20 % slower)
    k = k0
    while k < k1:
        if k == 9 or k == 25:  # (the first cells of rings 2 and 3 in the search order)
            if gap + float(k / 16) * h >= hit.sb:  # (k / 16: 0 at ring 2, 1 at ring 3)
                break
        off = wp.vec2i(ORDER_X[k], ORDER_Y[k])
        k += 1
        o = int(-1)
        if whole:
            o = centre + off[1] * b[2] + off[0]
        else:
            o = block_index(blocks, bases, bi, c + off)
        if o >= 0:
            if keyp[nonneg(o)][3] == STATE_SEGMENT:
                # the pieces update the hit in place: returning them as one vector assembled lane
                # by lane and read back whole stalled the CPU's store forwarding on every cell
                if not cell_far(q, verts, o, hit.sb):
                    for j in range(PIECES):
                        pr = piece_near(q, verts[nonneg(o * NV + j)], verts[nonneg(o * NV + j + 1)])
                        if pr[0] < hit.best:
                            hit.best = pr[0]
                            hit.sb = reach_of(pr[0])
                            hit.o = o
                            hit.j = j
                            hit.t = pr[1]
                            hit.l = l
    return hit


@wp.func
def scan(
    blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), bi: int, l: int, c: wp.vec2i, r: int,
    q: wp.vec2, keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3), hit: Hit,
) -> Hit:
    """Search the segments owned by the (2r+1)^2 cells of block ``bi`` (level ``l``) around ``c``
    for a piece nearer to ``q`` than ``hit``: centre first, then ring by ring, so far cells are
    mostly skipped by their bounding boxes."""
    return scan_range(blocks, bases, bi, l, c, r, 0, (2 * r + 1) * (2 * r + 1), q, keyp, verts, hit)


@wp.func
def segment_reach(s: Setup, level: int, span: float) -> float:
    """Bound on how far the polyline a new key point of ``level`` draws to a tree point ``span``
    away strays from the key point (see :func:`write_polyline`).

    Each scaled tangent of :func:`spline_tangents` is at most one span long: written over the
    chords, ``t1 = (p1 - p0) L^2 / (d1 (d1 + L)) + (p2 - p1) d1 / (d1 + L)``, whose lengths add up
    to at most L, and likewise t2. The Hermite basis then puts the vertex at fraction t within
    ``t + 2 t^2 (1 - t)`` spans of its start (1 at the end; 1.03125 at t = 3/4, the only inner
    vertex beyond 1), plus the sideways displacement of at most delta spans. The pieces are
    straight between vertices, so the whole polyline lies within the largest of these. The host
    computes that factor per level, with a 0.1 % margin against rounding (``Setup.reach``).
    """
    return (span + 1.0e-6) * s.reach[level - 1]


@wp.func
def piece_bound(s: Setup, level: int, reach: float) -> float:
    """Bound on the pieces of a polyline of ``level`` whose :func:`segment_reach` is ``reach``:
    ``reach / s.reach`` spans at most, times the level's piece factor (computed on the host,
    ``wdendrite.dendry._piece_factors``), widened by 0.1 % against rounding."""
    return reach / s.reach[level - 1] * s.piece[level - 1] * 1.001


@wp.func
def link_span(s: Setup, d: float, longest: float) -> float:
    """Bound on the distance from a new key point to the tree point it links to, when the piece
    it joins lies ``d`` from it and no piece is longer than ``longest``.

    Terrain rule: the point joined is the nearest of the piece's ends and midpoint. When the
    point of the piece nearest to the key point is an end, that is the point joined; otherwise
    the key point lies square to the piece from it, and the end or midpoint within a quarter of
    the piece along it lies within ``sqrt(d^2 + (longest / 4)^2)``. Lichtenberg rule: the point
    joined lies downstream of that nearest point by at most ``d``.
    """
    if s.rule == 0:
        return wp.sqrt(d * d + 0.0625 * longest * longest)
    return 2.0 * d


@wp.func
def link_stays_far(s: Setup, level: int, d: float, longest: float, far: float) -> bool:
    """True when the polyline of a new key point of ``level`` whose link joins a piece within ``d``
    of it (no coarser piece longer than ``longest``) stays farther than ``far`` from it."""
    return segment_reach(s, level, link_span(s, d, longest)) < far


@wp.func
def parent_reach(parent: wp.vec4, q: wp.vec2) -> float:
    """Bound on the distance from new key point ``q`` to the piece its link joins, from its
    parent cell's ``parent`` (x, y, z, state): that key point starts a polyline of the tree (the
    parent's own segment, drawn or not yet, or the one it inherits), owned by the centre cell
    of the link search's first ring (inf when the parent has no point). The distance as
    measured: the margins of :func:`segment_reach` and of the limit cover its rounding, as they
    cover that of the distances the link search measures."""
    if parent[3] == STATE_NONE:
        return wp.inf
    return wp.length(q - wp.vec2(parent[0], parent[1]))


@wp.func
def nearest_on_tree(
    s: Setup, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, level: int, c: wp.vec2i,
    q: wp.vec2, far: float, longest: float, pending: float, keyp: wp.array(dtype=wp.vec4),
    verts: wp.array(dtype=wp.vec3),
) -> wp.mat33:
    """Nearest polyline piece to ``q`` among the segments of levels < ``level`` owned within
    the (2 rl + 1)^2 cells around the ancestors of ``c`` (finest level first, centre cell first;
    ``rl`` is 1 in the paper's 3 x 3 rule, see wdendrite.dendry.DendryParams.radii).

    Returns rows a = (x, y, z), b = (x, y, z) of the piece (upstream first) and
    (x, y, code) of the vertex after b: code -1 when nothing was found, 0 when b ends
    its polyline, 1 when the vertex exists. With ``far`` > 0 (the per-pixel mode's lazy
    finest level, see :func:`finish`), code -2 as soon as the nearest of the pieces searched so
    far (the parent cell's, then its 3 x 3's) shows that the new polyline stays within less than
    ``far`` of ``q`` (no piece of the coarser levels being longer than ``longest``).

    ``pending`` is a lower bound on the distance from ``q`` to the box of any pending level-1
    cell (see :func:`defer1`; inf when there is none). Once the search's reach ``sb`` is at least
    that: code -3, with ``sb`` in the first entry, when the box of a pending cell lies within that
    reach: the caller draws those (:func:`draw_pending1`) and searches again. Pending cells
    beyond the reach of the search over the others cannot hold the nearest piece, so the
    answer, the first piece in the search's order at the least distance, is the one a search
    over every segment gives.
    """
    hit = no_hit()
    cells = (2 * s.rl + 1) * (2 * s.rl + 1)
    for i in range(1, level):
        l = level - i
        anc = wp.vec2i(c[0] >> i, c[1] >> i)
        # one scan in parts (one call site keeps the inlined code small): with ``far`` > 0, the
        # parent cell's pieces first, then the rest of its 3 x 3, then the wider rings; each
        # part bounds the link, and the search stops as soon as that keeps the segment far
        k0 = int(0)
        k1 = cells
        if i == 1 and far > 0.0:
            k1 = 1
        while k0 < cells:
            hit = scan_range(blocks, bases, slot * SLOT + l, l, anc, s.rl, k0, k1, q, keyp, verts, hit)
            if k1 < cells and hit.o >= 0:
                if link_stays_far(s, level, wp.sqrt(hit.best), longest, far):
                    return wp.mat33(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -2.0)
            k0 = k1
            k1 = cells
            if k0 == 1:
                k1 = wp.min(9, cells)
        if l == 1 and hit.sb >= pending:
            # (<=: a pending piece at distance 0 earlier in the search's order would win a tie)
            if pending_gap(blocks, bases, slot, anc, s.rl, q, keyp, verts) <= hit.sb * hit.sb:
                return wp.mat33(hit.sb, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -3.0)
    if hit.o < 0:
        return wp.mat33(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0)
    a = verts[nonneg(hit.o * NV + hit.j)]
    b = verts[nonneg(hit.o * NV + hit.j + 1)]
    rn = wp.vec3(b[0], b[1], 0.0)
    if hit.j + 1 < s.pieces[hit.l - 1]:
        nx = verts[nonneg(hit.o * NV + hit.j + 2)]
        rn = wp.vec3(nx[0], nx[1], 1.0)
    return wp.mat33(a[0], a[1], a[2], b[0], b[1], b[2], rn[0], rn[1], rn[2])


@wp.func
def inherits(parent: wp.vec4, level: int, c: wp.vec2i) -> bool:
    """True when cell ``c`` of ``level`` takes the key point of its parent, ``parent`` (x, y, z,
    state): the parent has one and it lies in ``c``."""
    if parent[3] == STATE_NONE:
        return False
    pc = cell_of(wp.vec2(parent[0], parent[1]), level)
    return pc[0] == c[0] and pc[1] == c[1]


@wp.func
def fill_levelk(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, level: int,
    k: int, c: wp.vec2i, u: wp.vec2, limit: float, longest: float, pending: float, keyp: wp.array(dtype=wp.vec4),
    verts: wp.array(dtype=wp.vec3),
) -> float:
    """Cell ``c`` (position ``k`` of its block) of ``level`` >= 2: inherit the parent's key point, or
    draw one and join the tree.

    With ``limit`` >= 0 (the per-pixel mode's lazy finest level, see :func:`finish`) a segment
    whose polyline provably stays farther than ``limit`` from ``u`` is not drawn: the cell is
    marked ``STATE_FAR``, which every search skips as it skips cells without a segment.
    ``longest`` bounds the pieces of the coarser levels (see :func:`link_span`).

    Returns -1, or (leaving the cell untouched) the reach of its link search when that search
    must first see pending level-1 segments drawn (``pending``: the distance from ``u`` to the
    nearest pending box, inf when none is pending; see :func:`nearest_on_tree`; only
    :func:`finish`'s cells can reach them).
    """
    bi = slot * SLOT + level
    vi = bases[nonneg(bi)] + k
    parent = keyp[nonneg(block_index(blocks, bases, bi - 1, wp.vec2i(c[0] >> 1, c[1] >> 1)))]
    if inherits(parent, level, c):
        keyp[nonneg(vi)] = wp.vec4(parent[0], parent[1], parent[2], STATE_INHERITED)
        return -1.0
    q = jitter(s, level, c)
    cp = to_control(s, q)
    if not control_inside(ctl, cp):
        keyp[nonneg(vi)] = wp.vec4(q[0], q[1], 0.0, STATE_NONE)
        return -1.0
    far = float(-1.0)
    if limit >= 0.0:
        # the polyline matters only if some point of it comes within limit of u
        far = wp.length(u - q) - limit - coord_margin(u)
        # when the parent's key point keeps the new polyline far, no search is needed (the test
        # after the search would mark the cell far too)
        if link_stays_far(s, level, parent_reach(parent, q), longest, far):
            keyp[nonneg(vi)] = wp.vec4(q[0], q[1], 0.0, STATE_FAR)
            return -1.0
    pgap = pending
    if pending < wp.inf:
        pgap = pending - wp.length(u - q) - coord_margin(u)
    m = nearest_on_tree(s, blocks, bases, slot, level, c, q, far, longest, pgap, keyp, verts)
    if m[2, 2] < -2.5:
        return m[0, 0]
    if m[2, 2] < -1.5:
        keyp[nonneg(vi)] = wp.vec4(q[0], q[1], 0.0, STATE_FAR)
        return -1.0
    if m[2, 2] < 0.0:
        keyp[nonneg(vi)] = wp.vec4(q[0], q[1], 0.0, STATE_NONE)
        return -1.0
    pa = wp.vec2(m[0, 0], m[0, 1])
    pb = wp.vec2(m[1, 0], m[1, 1])
    ab = pb - pa
    tc = float(0.0)
    if s.rule == 0:
        # terrain: the nearest of a, the midpoint and b leaves room for the branch to bend
        da = wp.length_sq(q - pa)
        dm = wp.length_sq(q - (pa + 0.5 * ab))
        db = wp.length_sq(q - pb)
        if dm < da:
            tc = 0.5
            da = dm
        if db < da:
            tc = 1.0
    else:
        # Lichtenberg: join downstream of the projection so the branch meets at 45 degrees
        den = wp.dot(ab, ab)
        if den > 0.0:
            tp = wp.clamp(wp.dot(q - pa, ab) / den, 0.0, 1.0)
            h = wp.length(q - (pa + tp * ab))
            tc = wp.min(tp + h / wp.sqrt(den), 1.0)
    x = pa + tc * ab
    if far > 0.0 and segment_reach(s, level, wp.length(x - q)) < far:
        keyp[nonneg(vi)] = wp.vec4(q[0], q[1], 0.0, STATE_FAR)
        return -1.0
    zx = m[0, 2] + tc * (m[1, 2] - m[0, 2])
    zq = zx + s.slope[level - 1] * wp.length(q - x) * s.inv_resolution
    if s.need_z != 0:
        zq = wp.max(control_value(ctl, cp), zq)
    keyp[nonneg(vi)] = wp.vec4(q[0], q[1], zq, STATE_SEGMENT)
    p3 = 2.0 * x - q
    if tc < 1.0:
        p3 = pb
    elif m[2, 2] > 0.5:
        p3 = wp.vec2(m[2, 0], m[2, 1])
    over = write_polyline(s, level, c, wp.vec3(q[0], q[1], zq), wp.vec3(x[0], x[1], zx), 2.0 * q - x, p3, vi, verts)
    note_overhang(keyp, bases, bi, over)
    return -1.0


@wp.func
def query_radius(s: Setup, level: int) -> int:
    """Radius of the query neighbourhood at ``level``: ``(2r + 1)^2`` cells around the query's cell."""
    if level == 1:
        return s.r1
    return s.rq


@wp.func
def query(
    s: Setup, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, u: wp.vec2,
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3),
) -> wp.vec3:
    """(distance in domain units, elevation at the nearest tree point, its level) at ``u``.

    The candidates are the segments owned by the (2r+1)^2 cells around ``u`` at every
    level (r from :func:`query_radius`), searched finest level first (see :func:`scan`).
    Distance is inf and level 0 when there is no candidate.
    """
    hit = no_hit()
    for i in range(s.levels):
        l = s.levels - i
        hit = scan(blocks, bases, slot * SLOT + l, l, cell_of(u, l), query_radius(s, l), u, keyp, verts, hit)
    if hit.o < 0:
        return wp.vec3(wp.inf, 0.0, 0.0)
    a = verts[nonneg(hit.o * NV + hit.j)]
    b = verts[nonneg(hit.o * NV + hit.j + 1)]
    return wp.vec3(wp.sqrt(hit.best) * s.inv_resolution, a[2] + hit.t * (b[2] - a[2]), float(hit.l))


@wp.func
def primitive(s: Setup, ctl: Control, c: wp.vec2i, q: wp.vec2, r: wp.vec3) -> wp.vec3:
    """Terrain primitive of cell ``c`` (level ``levels + steps``) at its key point ``q``, given the
    query ``r`` = (distance, tree elevation, level) there: (x, y, height), eq. 4 and 7."""
    pl = s.levels + s.steps
    cq = to_control(s, q)
    if r[2] == 0.0 or not control_inside(ctl, cq):
        # outside a bounded control's domain (no key point lies there), or no branch near: the
        # control, within the range it takes on its domain (the Lichtenberg bowl's 16 * scale
        # outside its square is not counted: its maximum). Branches inside would otherwise raise
        # the primitives beyond the edge with their distance, past that maximum, until they fall
        # out of the query's reach
        return wp.vec3(q[0], q[1], wp.clamp(control_value(ctl, cq), ctl.vmin, ctl.vmax))
    # eq. 7: a smooth step from the control's minimum to its maximum, evaluated at h^beta
    # (the paper's control takes values in [0, 1]; lower values count as 0)
    t = float(0.0)
    if ctl.vmax > ctl.vmin:
        h = wp.max(r[1], 0.0)
        hb = float(0.0)
        if s.beta == 0.5:
            hb = wp.sqrt(h)  # the usual beta of the paper (Table 2): a square root is cheaper than a power
        else:
            hb = wp.pow(h, s.beta)
        t = wp.clamp((hb - ctl.vmin) / (ctl.vmax - ctl.vmin), 0.0, 1.0)
    tan_theta = t * t * t * (t * (6.0 * t - 15.0) + 10.0)
    wobble = 1.0 + s.noise * (2.0 * cell_rand(s.seed, pl, c, 2) - 1.0)
    return wp.vec3(q[0], q[1], r[1] + tan_theta * r[0] * wobble)


@wp.func
def owner_near(
    s: Setup, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, c: wp.vec2i, u: wp.vec2,
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3),
) -> float:
    """Squared distance from ``u`` to the polyline through the key point of finest cell ``c``: the
    segment it owns, or that of the ancestor it inherits its key point from; -1 when there is none.

    That polyline is a candidate of every query whose finest cell is ``c`` (the centre cells of
    its neighbourhoods), so it bounds their answers.
    """
    l = s.levels
    cc = c
    while l >= 1:
        o = block_index(blocks, bases, slot * SLOT + l, cc)
        if o < 0:
            return -1.0
        state = keyp[nonneg(o)][3]
        if state == STATE_SEGMENT:
            d2 = float(1.0e30)
            for j in range(PIECES):
                d2 = wp.min(d2, piece_near(u, verts[nonneg(o * NV + j)], verts[nonneg(o * NV + j + 1)])[0])
            return d2
        if state != STATE_INHERITED:
            return -1.0
        l -= 1
        cc = wp.vec2i(cc[0] >> 1, cc[1] >> 1)
    return -1.0


@wp.func
def shortlist(
    s: Setup, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, u: wp.vec2, limit: float,
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3), first: int, nearby_out: wp.array(dtype=wp.vec4i),
    gaps_out: wp.array(dtype=float),
) -> int:
    """Store every piece of the slot's segments within ``limit`` of ``u``, finest level first; return how many.

    Entries are (cell index, piece + 8 * level, cell x, cell y) in ``nearby_out`` and the
    piece's distance to ``u`` in ``gaps_out``, from index ``first`` on.
    """
    n = int(0)
    lim2 = limit * limit
    for i in range(s.levels):
        l = s.levels - i
        bi = slot * SLOT + l
        b = blocks[nonneg(bi)]
        # only cells within limit of u, widened by the level's overhang, can hold a box within
        # limit (the others would all fail the cell_far test below); u lies in the block, so a
        # reach beyond the block's extent takes the whole block (and keeps the cell indices small)
        reach = limit + keyp[nonneg(bases[nonneg(bi)] - 1)][0] + coord_margin(u)
        reach = wp.min(reach, float(b[2] + b[3]) * cell_size(l))
        lo = cell_of(u - wp.vec2(reach, reach), l)
        hi = cell_of(u + wp.vec2(reach, reach), l)
        x0 = wp.max(lo[0] - b[0], 0)
        x1 = wp.min(hi[0] - b[0] + 1, b[2])
        y1 = wp.min(hi[1] - b[1] + 1, b[3])
        cy = wp.max(lo[1] - b[1], 0)
        while cy < y1:
            cx = x0
            while cx < x1:
                o = bases[nonneg(bi)] + cy * b[2] + cx
                # (no pending level-1 cell can answer a query here: it lies beyond the queries'
                # neighbourhoods where links reach as far as queries, else beyond limit: finish)
                if keyp[nonneg(o)][3] == STATE_SEGMENT:
                    if not cell_far(u, verts, o, limit):
                        for j in range(PIECES):
                            d2 = piece_near(u, verts[nonneg(o * NV + j)], verts[nonneg(o * NV + j + 1)])[0]
                            if d2 <= lim2:
                                # insertion by distance, so that queries can stop at the first piece too far
                                gap = wp.sqrt(d2)
                                k = first + n
                                while k > first and gaps_out[nonneg(k - 1)] > gap:
                                    nearby_out[nonneg(k)] = nearby_out[nonneg(k - 1)]
                                    gaps_out[nonneg(k)] = gaps_out[nonneg(k - 1)]
                                    k -= 1
                                nearby_out[nonneg(k)] = wp.vec4i(o, j + 8 * l, b[0] + cx, b[1] + cy)
                                gaps_out[nonneg(k)] = gap
                                n += 1
                cx += 1
            cy += 1
    return n


@wp.func
def ring_rank(d: wp.vec2i) -> int:
    """Position of offset ``d`` in the search order of a neighbourhood (``ORDER_X``, ``ORDER_Y``)."""
    k = wp.max(wp.abs(d[0]), wp.abs(d[1]))
    if k == 0:
        return 0
    first = (2 * k - 1) * (2 * k - 1)
    if d[1] == -k and d[0] < k:
        return first + d[0] + k
    if d[0] == k and d[1] < k:
        return first + 3 * k + d[1]
    if d[1] == k and d[0] > -k:
        return first + 5 * k - d[0]
    return first + 7 * k - d[1]


@wp.func
def query_short(
    s: Setup, q: wp.vec2, u: wp.vec2, verts: wp.array(dtype=wp.vec3), nearby: wp.array(dtype=wp.vec4i),
    gaps: wp.array(dtype=float), first: int, n: int,
) -> wp.vec3:
    """:func:`query` at ``q`` from the shortlist of the pieces near ``u`` (see :func:`answer`).

    The query's answer is the first piece in its search order (finest level first, then ring
    order, then piece) with the least squared distance. Here the pieces of ``q``'s
    neighbourhoods are taken in the shortlist's order and ties are settled by that search
    order, so the answer is the same bit for bit. The shortlist is sorted by distance to
    ``u``: once that distance, less ``|q - u|`` and a rounding margin, exceeds the best
    distance, no later piece can be nearer.
    """
    top = cell_of(q, s.levels)
    off = wp.length(q - u) + coord_margin(u)
    best = float(1.0e30)
    brank = int(0)
    bz = float(0.0)
    bl = int(0)
    for e in range(n):
        lb = gaps[nonneg(first + e)] - off
        if lb > 0.0 and lb * lb > best:
            break  # this piece and all later ones (sorted by distance to u) lie farther than the best
        ent = nearby[nonneg(first + e)]
        l = ent[1] >> 3
        r = query_radius(s, l)
        shift = s.levels - l
        d = wp.vec2i(ent[2] - (top[0] >> shift), ent[3] - (top[1] >> shift))
        if wp.abs(d[0]) <= r and wp.abs(d[1]) <= r:
            j = ent[1] & 7
            a = verts[nonneg(ent[0] * NV + j)]
            b = verts[nonneg(ent[0] * NV + j + 1)]
            pr = piece_near(q, a, b)
            if pr[0] <= best:
                rank = (shift * 64 + ring_rank(d)) * 8 + j
                if pr[0] < best or rank < brank:
                    best = pr[0]
                    brank = rank
                    bz = a[2] + pr[1] * (b[2] - a[2])
                    bl = l
    if bl == 0:
        return wp.vec3(wp.inf, 0.0, 0.0)
    return wp.vec3(wp.sqrt(best) * s.inv_resolution, bz, float(bl))


@wp.struct
class Prims:
    """Per-pixel mode, elevation: the 5 x 5 terrain primitives around the pixel (see :func:`answer`)."""

    px: vec25  # key points
    py: vec25
    pr2: vec25  # squared distance to the pixel over the blend's radius squared (>= 1: no weight)


@wp.func
def prim_points(s: Setup, u: wp.vec2) -> Prims:
    """The primitives around ``u`` (the 5 x 5 cells of level ``levels + steps`` around its cell)."""
    pl = s.levels + s.steps
    pc = cell_of(u, pl)
    radius = 2.0 / level_factor(pl)
    inv_r2 = 1.0 / (radius * radius)
    p = Prims()
    for dy in range(5):
        for dx in range(5):
            k = dy * 5 + dx
            q = jitter(s, pl, wp.vec2i(pc[0] + dx - 2, pc[1] + dy - 2))
            p.px[k] = q[0]
            p.py[k] = q[1]
            p.pr2[k] = wp.length_sq(q - u) * inv_r2
    return p


@wp.func
def pixel_limit(
    s: Setup, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, u: wp.vec2, output: int,
    qlo: wp.vec2i, qhi: wp.vec2i, prim: Prims, keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3),
) -> float:
    """Per-pixel mode, once the query's finest cells ``qlo..qhi`` are drawn: a distance from ``u``
    beyond which no piece can answer the pixel (-1 when there is no such bound; see :func:`answer`).

    Distance and level: the distance to the polyline through the key point of u's finest cell.
    Elevation: the largest bound over the primitives that weigh (see :func:`answer`), from the
    distances from u to the polylines through the key points of ``qlo..qhi`` (inf where a cell
    has none); at least one primitive step keeps that square within 2.02 finest cells, so at
    most 4 x 4 cells.
    """
    if output != OUT_ELEVATION:
        if s.levels >= 2:
            d2 = owner_near(s, blocks, bases, slot, cell_of(u, s.levels), u, keyp, verts)
            if d2 >= 0.0:
                return widened(wp.sqrt(d2), u)
        return -1.0
    reach_u = vec16()
    nx = qhi[0] - qlo[0] + 1
    ncells = nx * (qhi[1] - qlo[1] + 1)
    for k in range(ncells):
        d2 = owner_near(s, blocks, bases, slot, wp.vec2i(qlo[0] + k % nx, qlo[1] + k / nx), u, keyp, verts)
        reach_u[k] = wp.inf
        if d2 >= 0.0:
            reach_u[k] = wp.sqrt(d2)
    bound = float(0.0)
    for k in range(25):
        if prim.pr2[k] < 1.0:  # (the primitives that weigh)
            q = wp.vec2(prim.px[k], prim.py[k])
            gap = wp.length(q - u)
            # any of those polylines within q's query neighbourhood bounds q's answer (an
            # inherited one is within it at its coarser level too: DendryParams.radii keeps
            # r1 >= rq)
            qc = cell_of(q, s.levels)
            best = float(wp.inf)
            for f in range(ncells):
                fx = qlo[0] + f % nx - qc[0]
                fy = qlo[1] + f / nx - qc[1]
                if wp.abs(fx) <= s.rq and wp.abs(fy) <= s.rq:
                    best = wp.min(best, reach_u[f] + gap)
            bound = wp.max(bound, best + gap)
    if bound < wp.inf:
        return widened(bound, u)
    return -1.0


@wp.func
def answer(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, u: wp.vec2,
    output: int, qlo: wp.vec2i, qhi: wp.vec2i, prim: Prims, limit: float, demand: int, pts1: wp.array(dtype=wp.vec4),
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3), cached: int,
    prims: wp.array(dtype=wp.vec3), sfirst: int, nearby: wp.array(dtype=wp.vec4i), gaps: wp.array(dtype=float),
    overflow_out: wp.array(dtype=int),
) -> float:
    """The requested output at ``u`` once the slot is built (per-pixel mode: but for the finest
    level's cells outside ``qlo..qhi``, which :func:`finish` fills here, at its only call site).

    Distance and level: the query at ``u``. The polyline through the key point of u's finest
    cell is a candidate of that query, so its distance bounds the answer for :func:`finish`.

    Elevation: the blend of the 5 x 5 primitives around ``u`` weighted by g(r) = (1 - r^2)^3
    (eq. 5-6).

    The radius is two primitive cells, so every primitive that can weigh lies in the 5 x 5 block.
    In the per-pixel mode the primitives' queries read a shortlist. The answer at a primitive q
    is at most ``D + |q - u|``, where D is the distance from ``u`` to the polyline through the
    key point of one of the query's finest cells ``qlo..qhi`` that lies in q's neighbourhood
    (a candidate of q's query), so q's nearest piece lies within ``D + 2 |q - u|`` of ``u``.
    The shortlist keeps the pieces within ``limit``, the largest such bound over the primitives
    that weigh (each taking its least D, with a margin against rounding), which :func:`build`
    found with :func:`pixel_limit` (-1: none; the cached mode ignores it). The finest cells
    outside ``qlo..qhi`` are filled only once that bound is known (:func:`finish`), which
    leaves undrawn the segments that lie beyond it.
    """
    pl = s.levels + s.steps
    pc = cell_of(u, pl)
    radius = 2.0 / level_factor(pl)
    inv_r2 = 1.0 / (radius * radius)
    # the primitives' key points and squared relative distances r^2 (>= 1: no weight); the
    # per-pixel mode's come from prim_points
    px = prim.px
    py = prim.py
    pr2 = prim.pr2
    corner = int(0)
    width = int(0)
    elev = output == OUT_ELEVATION
    if cached != 0 and elev:
        corner = block_index(blocks, bases, slot * SLOT + PRIM, wp.vec2i(pc[0] - 2, pc[1] - 2))
        if corner < 0 or block_index(blocks, bases, slot * SLOT + PRIM, wp.vec2i(pc[0] + 2, pc[1] + 2)) < 0:
            # the window's primitive block was planned too small (never expected within the coordinate
            # bound the host checks): flag it, so that the host raises instead of returning NaN
            wp.atomic_max(overflow_out, 0, 1)
            return wp.nan
        width = blocks[nonneg(slot * SLOT + PRIM)][2]
    if cached != 0 and elev:
        for dy in range(5):
            for dx in range(5):
                k = dy * 5 + dx
                pq = prims[nonneg(corner + dy * width + dx)]
                px[k] = pq[0]
                py[k] = pq[1]
                pr2[k] = wp.length_sq(wp.vec2(pq[0], pq[1]) - u) * inv_r2
    n = int(-1)
    if cached == 0:
        finish(s, ctl, blocks, bases, slot, qlo, qhi, u, limit, demand, pts1, keyp, verts)
        if limit >= 0.0 and elev:
            n = shortlist(s, blocks, bases, slot, u, limit, keyp, verts, sfirst, nearby, gaps)
    if not elev:
        r = query(s, blocks, bases, slot, u, keyp, verts)
        if output == OUT_LEVEL:
            return r[2]
        return r[0]
    total = float(0.0)
    wsum = float(0.0)
    for dy in range(5):
        for dx in range(5):
            r2 = pr2[dy * 5 + dx]
            if r2 < 1.0:
                h = float(0.0)
                if cached != 0:
                    h = prims[nonneg(corner + dy * width + dx)][2]
                else:
                    # only primitives that weigh are evaluated
                    q = wp.vec2(px[dy * 5 + dx], py[dy * 5 + dx])
                    r = wp.vec3(0.0, 0.0, 0.0)
                    if n >= 0:
                        r = query_short(s, q, u, verts, nearby, gaps, sfirst, n)
                    else:
                        r = query(s, blocks, bases, slot, q, keyp, verts)
                    h = primitive(s, ctl, wp.vec2i(pc[0] + dx - 2, pc[1] + dy - 2), q, r)[2]
                g = (1.0 - r2) * (1.0 - r2) * (1.0 - r2)
                total += g * h
                wsum += g
    return total / wsum


@wp.func
def set_block(
    slot: int, l: int, lo: wp.vec2i, hi: wp.vec2i, base: int,
    blocks_out: wp.array(dtype=wp.vec4i), bases_out: wp.array(dtype=int),
) -> int:
    """Store block ``l`` of ``slot`` spanning cells lo..hi (inclusive); return its cell count."""
    blocks_out[nonneg(slot * SLOT + l)] = wp.vec4i(lo[0], lo[1], hi[0] - lo[0] + 1, hi[1] - lo[1] + 1)
    bases_out[nonneg(slot * SLOT + l)] = base
    return (hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1)


@wp.func
def plan(
    s: Setup, qlo: wp.vec2i, qhi: wp.vec2i, plo: wp.vec2i, phi: wp.vec2i, slot: int, cap: wp.vec3i,
    blocks_out: wp.array(dtype=wp.vec4i), bases_out: wp.array(dtype=int),
) -> int:
    """Blocks that answer queries in level-n cells qlo..qhi (and primitives in plo..phi).

    Level l needs the cells around the query (radius r) and ``rl`` cells around every
    ancestor of the level-(l+1) block (the segments its new key points may join).
    Level-1 key points need 2 more cells (lowest neighbour, and its lowest neighbour
    for the spline tangent). Returns 1 when a block exceeds the slot capacity ``cap``
    (points, cells, primitives), else 0.
    """
    n = s.levels
    lo = qlo
    hi = qhi
    r = query_radius(s, n)
    rl = s.rl
    lo = wp.vec2i(lo[0] - r, lo[1] - r)
    hi = wp.vec2i(hi[0] + r, hi[1] + r)
    total = int(0)
    base = slot * cap[1]
    for i in range(n):
        l = n - i
        if l < n:
            shift = n - l
            r = query_radius(s, l)
            lo = wp.vec2i(wp.min((lo[0] >> 1) - rl, (qlo[0] >> shift) - r), wp.min((lo[1] >> 1) - rl, (qlo[1] >> shift) - r))
            hi = wp.vec2i(wp.max((hi[0] >> 1) + rl, (qhi[0] >> shift) + r), wp.max((hi[1] >> 1) + rl, (qhi[1] >> shift) + r))
        # (one record before each level's cells holds its overhang, see note_overhang)
        total += set_block(slot, l, lo, hi, base + total + 1, blocks_out, bases_out) + 1
    over = int(0)
    if total > cap[1]:
        over = 1
    npts = set_block(slot, 0, wp.vec2i(lo[0] - 2, lo[1] - 2), wp.vec2i(hi[0] + 2, hi[1] + 2), slot * cap[0], blocks_out, bases_out)
    if npts > cap[0]:
        over = 1
    if set_block(slot, PRIM, plo, phi, slot * cap[2], blocks_out, bases_out) > cap[2]:
        over = 1
    return over


@wp.func
def fill_links1(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int,
    clo: wp.vec2i, chi: wp.vec2i, u: wp.vec2, near: float, pts1: wp.array(dtype=wp.vec4),
    keyp_out: wp.array(dtype=wp.vec4), verts_out: wp.array(dtype=wp.vec3),
):
    """Per-pixel mode: every level-1 segment of ``slot``, as :func:`fill_segment1` makes them.

    A link needs its target's lowest neighbour too, mostly that of another cell of the block:
    each cell's is found once and kept as ``(x - x0 + 1) + 256 (y - y0 + 1)`` relative to the
    block's corner (blocks of up to 64 cells; larger ones search twice). For those blocks
    :func:`build` leaves the outer ring of level-1 points undrawn: only a target outside the
    block looks there, and its 3 x 3 is drawn here when one does. In those blocks too, the
    segments of cells outside ``clo..chi`` are left ``STATE_PENDING`` (:func:`defer1`), for
    link searches to draw if they come near (:func:`nearest_on_tree`), unless their boxes come
    within ``near`` of ``u`` (``Setup.near1``). The least squared distance from ``u`` to a box
    left pending goes to the second entry of level 1's header record (1e30: none), which
    :func:`finish` reads to skip every check that cannot find one.
    """
    b = blocks[nonneg(slot * SLOT + 1)]
    if b[2] * b[3] > 64:
        for j in range(b[3]):
            for i in range(b[2]):
                fill_segment1(s, blocks, bases, slot, j * b[2] + i, wp.vec2i(b[0] + i, b[1] + j), pts1, keyp_out, verts_out)
    else:
        gmin2 = float(1.0e30)
        low = vec64i()
        for j in range(b[3]):
            for i in range(b[2]):
                t = lowest1(pts1, blocks, bases, slot * SLOT, wp.vec2i(b[0] + i, b[1] + j))
                low[j * b[2] + i] = (t[0] - b[0] + 1) + 256 * (t[1] - b[1] + 1)
        for j in range(b[3]):
            for i in range(b[2]):
                k = j * b[2] + i
                rx = low[k] & 255
                ry = low[k] >> 8
                t = wp.vec2i(b[0] + rx - 1, b[1] + ry - 1)
                c = wp.vec2i(b[0] + i, b[1] + j)
                if c[0] < clo[0] or c[1] < clo[1] or c[0] > chi[0] or c[1] > chi[1]:
                    defer1(s, blocks, bases, slot, k, c, t, pts1, keyp_out, verts_out)
                    g2 = box_gap2(u, verts_out, bases[nonneg(slot * SLOT + 1)] + k)
                    if g2 >= near * near:
                        gmin2 = wp.min(gmin2, g2)
                        continue
                tt = wp.vec2i(0, 0)
                if rx >= 1 and ry >= 1 and rx <= b[2] and ry <= b[3]:
                    ct = low[(ry - 1) * b[2] + rx - 1]
                    tt = wp.vec2i(b[0] + (ct & 255) - 1, b[1] + (ct >> 8) - 1)
                else:
                    # the target lies outside the block: draw the points around it still missing
                    draw_around1(s, ctl, blocks, bases, slot, t, pts1)
                    tt = lowest1(pts1, blocks, bases, slot * SLOT, t)
                link1(s, blocks, bases, slot, k, c, t, tt, pts1, keyp_out, verts_out)
        # the least squared distance from u to a pending box, in the level's header record (whose
        # first entry is the overhang; note_overhang raises it component by component, with 0 here)
        hb = nonneg(bases[nonneg(slot * SLOT + 1)] - 1)
        head = keyp_out[hb]
        keyp_out[hb] = wp.vec4(head[0], gmin2, head[2], head[3])


@wp.func
def prepare_levels(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int,
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3),
) -> int:
    """Per-pixel mode, 3 levels or more (see :func:`build`), once level 1 is drawn: the key points of levels 2..n-1,
    without their segments. Return 1 when the pixel must draw those levels whole instead.

    A cell that inherits its parent's key point is stored as :func:`fill_levelk` stores it; one
    outside the control's domain as ``STATE_NONE``. Any other cell is left ``STATE_WAIT``: its
    segment is drawn only when a search may need it (:func:`want_box`). It keeps what
    bounds that segment without drawing it:

    - ``d`` (in ``verts``, at the cell's first vertex): its link search's answer lies no farther.
      The parent's key point lies on the tree, within that search (it belongs to an ancestor of
      the cell, the centre of the search's neighbourhood at its level), so ``d`` is the distance
      to that point, or at level 2 to the parent's drawn polyline, widened against rounding.
    - its reach (``keyp[2]``): the polyline lies within ``segment_reach(link_span(d, L))`` of the
      key point (:func:`segment_reach`, :func:`link_span`), where L bounds every piece of the
      coarser levels: the longest drawn piece at level 1, :func:`piece_bound` of the waiting
      cells' reach above.

    A cell whose parent has no point on the tree (beyond the domain's edge) would have no such
    bound, and its children could not know yet whether they inherit its key point: then 1.
    """
    longest = float(0.0)
    if s.rule == 0:
        b = blocks[nonneg(slot * SLOT + 1)]
        o = bases[nonneg(slot * SLOT + 1)]
        last = o + b[2] * b[3]
        while o < last:
            if keyp[nonneg(o)][3] == STATE_SEGMENT:
                longest = wp.max(longest, verts[nonneg(o * NV + BOUND + 1)][1])
            o += 1
    for level in range(2, s.levels):
        bi = slot * SLOT + level
        b = blocks[nonneg(bi)]
        o = bases[nonneg(bi)]
        grow = float(0.0)
        for j in range(b[3]):
            for i in range(b[2]):
                c = wp.vec2i(b[0] + i, b[1] + j)
                po = block_index(blocks, bases, bi - 1, wp.vec2i(c[0] >> 1, c[1] >> 1))
                parent = keyp[nonneg(po)]
                pp = wp.vec2(parent[0], parent[1])
                if inherits(parent, level, c):
                    keyp[nonneg(o)] = wp.vec4(parent[0], parent[1], parent[2], STATE_INHERITED)
                else:
                    q = jitter(s, level, c)
                    if not control_inside(ctl, to_control(s, q)):
                        keyp[nonneg(o)] = wp.vec4(q[0], q[1], 0.0, STATE_NONE)
                    else:
                        if parent[3] == STATE_NONE:
                            return 1
                        d2 = wp.length_sq(q - pp)
                        if level == 2:
                            for k in range(PIECES):
                                pk = piece_near(q, verts[nonneg(po * NV + k)], verts[nonneg(po * NV + k + 1)])
                                d2 = wp.min(d2, pk[0])
                        d = widened(wp.sqrt(d2), q)
                        r = segment_reach(s, level, link_span(s, d, longest))
                        keyp[nonneg(o)] = wp.vec4(q[0], q[1], r, STATE_WAIT)
                        verts[nonneg(o * NV)] = wp.vec3(d, 0.0, 0.0)
                        grow = wp.max(grow, r)
                o += 1
        longest = wp.max(longest, piece_bound(s, level, grow))
    return 0


@wp.func
def want_box(
    s: Setup, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, level: int, lo: wp.vec2,
    hi: wp.vec2, d: float, keyp: wp.array(dtype=wp.vec4),
):
    """Mark ``STATE_WANTED`` the waiting cells (see :func:`prepare_levels`) of levels 2 to
    ``level - 1`` that the link searches of key points of ``level`` in the box ``lo..hi`` may
    need, each knowing its answer lies within ``d``: those whose reach comes within ``d`` of the
    box. The others' pieces all lie farther than each search's answer, so each search finds
    the same piece without them."""
    lim = d + coord_margin(lo) + coord_margin(hi)
    for l in range(2, level):
        bi = slot * SLOT + l
        b = blocks[nonneg(bi)]
        o = bases[nonneg(bi)]
        last = o + b[2] * b[3]
        while o < last:
            k = keyp[nonneg(o)]
            if k[3] == STATE_WAIT:
                p = wp.vec2(k[0], k[1])
                if wp.length(wp.max(wp.max(lo - p, p - hi), wp.vec2(0.0, 0.0))) - k[2] <= lim:
                    keyp[nonneg(o)] = wp.vec4(k[0], k[1], k[2], STATE_WANTED)
            o += 1


@wp.func
def want_finest(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int, c: wp.vec2i,
    u: wp.vec2, limit: float, longest: float, owner: int, keyp: wp.array(dtype=wp.vec4),
) -> wp.vec4:
    """What cell ``c`` of the finest level needs drawn before :func:`fill_levelk` draws it:
    (state, x, y, d) with d >= 0 when its link search from key point (x, y) finds its answer
    within d (for :func:`want_box`), else -1. When it inherits its parent's key point and
    ``owner`` is 1, the cell owning that point is marked ``STATE_WANTED`` (for :func:`owner_near`).

    With ``limit`` >= 0, a cell whose polyline provably stays farther than ``limit`` from ``u``
    (as in :func:`fill_levelk`, with ``longest`` bounding the coarser pieces) needs nothing:
    the state is ``STATE_FAR`` then, else ``STATE_NONE``.
    """
    n = s.levels
    parent = keyp[nonneg(block_index(blocks, bases, slot * SLOT + n - 1, wp.vec2i(c[0] >> 1, c[1] >> 1)))]
    if inherits(parent, n, c):
        l = n - 1
        a = wp.vec2i(c[0] >> 1, c[1] >> 1)
        if owner == 0:
            l = 1
        while l >= 2:
            o = block_index(blocks, bases, slot * SLOT + l, a)
            k = keyp[nonneg(o)]
            if k[3] == STATE_WAIT:
                keyp[nonneg(o)] = wp.vec4(k[0], k[1], k[2], STATE_WANTED)
            if k[3] != STATE_INHERITED:
                break
            l -= 1
            a = wp.vec2i(a[0] >> 1, a[1] >> 1)
        return wp.vec4(STATE_NONE, 0.0, 0.0, -1.0)
    q = jitter(s, n, c)
    if not control_inside(ctl, to_control(s, q)):
        return wp.vec4(STATE_NONE, 0.0, 0.0, -1.0)
    d = widened(parent_reach(parent, q), q)  # (widened: want_box compares it with bounds of its own)
    if limit >= 0.0:
        if link_stays_far(s, n, d, longest, wp.length(u - q) - limit - coord_margin(u)):
            return wp.vec4(STATE_FAR, 0.0, 0.0, -1.0)
    return wp.vec4(STATE_NONE, q[0], q[1], d)


@wp.func
def spread_wants(
    s: Setup, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int,
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3),
):
    """Levels n-1 down to 3: mark what the wanted cells' own link searches may need, so that
    drawing the wanted cells level by level (coarsest first) draws every segment they use."""
    for i in range(1, s.levels - 2):
        l = s.levels - i
        b = blocks[nonneg(slot * SLOT + l)]
        o = bases[nonneg(slot * SLOT + l)]
        last = o + b[2] * b[3]
        lo = wp.vec2(1.0e30, 1.0e30)
        hi = wp.vec2(-1.0e30, -1.0e30)
        d = float(-1.0)
        while o < last:
            k = keyp[nonneg(o)]
            if k[3] == STATE_WANTED:
                p = wp.vec2(k[0], k[1])
                lo = wp.min(lo, p)
                hi = wp.max(hi, p)
                d = wp.max(d, verts[nonneg(o * NV)][0])
            o += 1
        if d >= 0.0:
            want_box(s, blocks, bases, slot, l, lo, hi, d, keyp)


@wp.func
def want_pixel(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int,
    qlo: wp.vec2i, qhi: wp.vec2i, u: wp.vec2, limit: float, keyp: wp.array(dtype=wp.vec4),
    verts: wp.array(dtype=wp.vec3),
):
    """Per-pixel mode, levels drawn on demand (see :func:`build`), once the pixel's answer is
    bounded by ``limit`` (< 0: unbounded): mark the waiting segments that the pixel's queries
    may read (their reach comes within ``limit`` of ``u``) and those the finest cells outside
    ``qlo..qhi`` may need (:func:`want_finest`); store ``STATE_FAR`` for those finest cells
    that need not be drawn at all."""
    n = s.levels
    # the longest piece of levels 1..n-1, drawn or waiting (piece_bound), for the terrain rule's
    # link bound
    longest = float(0.0)
    lim = limit + coord_margin(u)
    for level in range(1, n):
        b = blocks[nonneg(slot * SLOT + level)]
        o = bases[nonneg(slot * SLOT + level)]
        last = o + b[2] * b[3]
        while o < last:
            k = keyp[nonneg(o)]
            if k[3] == STATE_SEGMENT:
                longest = wp.max(longest, verts[nonneg(o * NV + BOUND + 1)][1])
            elif k[3] == STATE_WAIT:
                longest = wp.max(longest, piece_bound(s, level, k[2]))
                if limit < 0.0 or wp.length(u - wp.vec2(k[0], k[1])) - k[2] <= lim:
                    keyp[nonneg(o)] = wp.vec4(k[0], k[1], k[2], STATE_WANTED)
            o += 1
    b = blocks[nonneg(slot * SLOT + n)]
    o = bases[nonneg(slot * SLOT + n)]
    lo = wp.vec2(1.0e30, 1.0e30)
    hi = wp.vec2(-1.0e30, -1.0e30)
    d = float(-1.0)
    for j in range(b[3]):
        for i in range(b[2]):
            c = wp.vec2i(b[0] + i, b[1] + j)
            if c[0] < qlo[0] or c[1] < qlo[1] or c[0] > qhi[0] or c[1] > qhi[1]:
                w = want_finest(s, ctl, blocks, bases, slot, c, u, limit, longest, 0, keyp)
                keyp[nonneg(o)] = wp.vec4(0.0, 0.0, 0.0, w[0])
                if w[3] >= 0.0:
                    lo = wp.min(lo, wp.vec2(w[1], w[2]))
                    hi = wp.max(hi, wp.vec2(w[1], w[2]))
                    d = wp.max(d, w[3])
            o += 1
    if d >= 0.0:
        want_box(s, blocks, bases, slot, n, lo, hi, d, keyp)
    spread_wants(s, blocks, bases, slot, keyp, verts)


@wp.func
def build(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int,
    u: wp.vec2, output: int, qlo: wp.vec2i, qhi: wp.vec2i, prim: Prims, pts1: wp.array(dtype=wp.vec4),
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3),
) -> wp.vec2:
    """Per-pixel mode: fill the blocks of ``slot`` in order: level-1 points, level-1 segments,
    levels 2..n, except that of the finest level (from 2 levels on) only the query's cells
    ``qlo..qhi`` are filled; :func:`finish` fills the others. Returns (the bound on the pixel's
    answer from :func:`pixel_limit`, demand).

    From 3 levels on, with links wider than the paper's 3 x 3 (``rl`` >= 2), levels 2..n-1 are
    drawn on demand (demand 1; 0 when drawn whole, see :func:`prepare_levels`): first the
    segments the query's cells need, then those that the other finest cells and the pixel's
    queries may need (:func:`want_pixel`).

    Cells are visited row by row, so no cell is found from its position by an integer division.
    """
    for level in range(1, s.levels + 1):
        keyp[nonneg(bases[nonneg(slot * SLOT + level)] - 1)] = wp.vec4(0.0, 0.0, 0.0, 0.0)  # no overhang yet
    b = blocks[nonneg(slot * SLOT)]
    b1 = blocks[nonneg(slot * SLOT + 1)]
    lazy = b1[2] * b1[3] <= 64  # fill_links1 then draws the outer ring's points it needs
    base = bases[nonneg(slot * SLOT)]
    ring = int(0)
    if lazy:
        ring = 1
        undrawn = wp.vec4(0.0, 0.0, 0.0, -1.0)
        last = (b[3] - 1) * b[2]
        for i in range(b[2]):
            pts1[nonneg(base + i)] = undrawn
            pts1[nonneg(base + last + i)] = undrawn
        for j in range(1, b[3] - 1):
            pts1[nonneg(base + j * b[2])] = undrawn
            pts1[nonneg(base + j * b[2] + b[2] - 1)] = undrawn
    for j in range(ring, b[3] - ring):
        for i in range(ring, b[2] - ring):
            fill_point1(s, ctl, bases, slot, j * b[2] + i, wp.vec2i(b[0] + i, b[1] + j), pts1)
    # with 2 levels, the level-1 segments more than rl cells from the query's level-1 cells (the
    # links of the query's cells stay within rl) are deferred (see defers1, fill_links1). They
    # make the block's outer ring, and only that ring is ever deferred (pending_gap reads no
    # other cell); where links are narrower than queries, those near the pixel are drawn anyway
    clo = wp.vec2i(b1[0], b1[1])
    chi = wp.vec2i(b1[0] + b1[2] - 1, b1[1] + b1[3] - 1)
    if defers1(s, blocks, slot) != 0:
        clo = wp.vec2i(wp.min((qlo[0] >> 1) - s.rl, b1[0] + 1), wp.min((qlo[1] >> 1) - s.rl, b1[1] + 1))
        chi = wp.vec2i(wp.max((qhi[0] >> 1) + s.rl, chi[0] - 1), wp.max((qhi[1] >> 1) + s.rl, chi[1] - 1))
    fill_links1(s, ctl, blocks, bases, slot, clo, chi, u, s.near1, pts1, keyp, verts)
    nowhere = wp.vec2(0.0, 0.0)
    demand = int(0)
    # (with the paper's 3 x 3 links a pixel needs most of those cells: the bounds would cost more
    # than they save, 4-13 % more instructions per pixel)
    if s.levels >= 3 and s.rl >= 2:
        if prepare_levels(s, ctl, blocks, bases, slot, keyp, verts) == 0:
            # levels 2..n-1 drawn on demand: what the query's finest cells need, first
            demand = 1
            lo = wp.vec2(1.0e30, 1.0e30)
            hi = wp.vec2(-1.0e30, -1.0e30)
            d = float(-1.0)
            for j in range(qlo[1], qhi[1] + 1):
                for i in range(qlo[0], qhi[0] + 1):
                    w = want_finest(s, ctl, blocks, bases, slot, wp.vec2i(i, j), nowhere, -1.0, 0.0, 1, keyp)
                    if w[3] >= 0.0:
                        lo = wp.min(lo, wp.vec2(w[1], w[2]))
                        hi = wp.max(hi, wp.vec2(w[1], w[2]))
                        d = wp.max(d, w[3])
            if d >= 0.0:
                want_box(s, blocks, bases, slot, s.levels, lo, hi, d, keyp)
            spread_wants(s, blocks, bases, slot, keyp, verts)
    # two passes over the levels (one call site of fill_levelk: its code is inlined): first
    # levels 2..n, then, once the pixel's answer is bounded, what finish's cells and the
    # queries may still want of levels 2..n-1
    limit = float(-1.0)
    top = s.levels + 1
    rounds = int(0)
    while rounds < 2:
        if rounds == 1:
            limit = pixel_limit(s, blocks, bases, slot, u, output, qlo, qhi, prim, keyp, verts)
            top = 2
            if demand != 0:
                want_pixel(s, ctl, blocks, bases, slot, qlo, qhi, u, limit, keyp, verts)
                top = s.levels
        rounds += 1
        for level in range(2, top):
            bi = slot * SLOT + level
            b = blocks[nonneg(bi)]
            i0 = int(0)
            j0 = int(0)
            i1 = b[2]
            j1 = b[3]
            if level == s.levels:
                i0 = qlo[0] - b[0]
                j0 = qlo[1] - b[1]
                i1 = qhi[0] - b[0] + 1
                j1 = qhi[1] - b[1] + 1
            for j in range(j0, j1):
                for i in range(i0, i1):
                    k = j * b[2] + i
                    draw = True
                    if demand != 0:
                        if level < s.levels:  # (Warp evaluates both sides of an `and`)
                            draw = keyp[nonneg(bases[nonneg(bi)] + k)][3] == STATE_WANTED
                    if draw:
                        # (no pending level-1 cell lies within reach of these: their parents are the query's)
                        fill_levelk(
                            s, ctl, blocks, bases, slot, level, k, wp.vec2i(b[0] + i, b[1] + j), nowhere, -1.0, 0.0,
                            wp.inf, keyp, verts,
                        )
    return wp.vec2(limit, float(demand))


@wp.func
def finish(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), slot: int,
    qlo: wp.vec2i, qhi: wp.vec2i, u: wp.vec2, limit: float, demand: int, pts1: wp.array(dtype=wp.vec4),
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3),
):
    """Per-pixel mode, after :func:`build`: the finest level's cells outside ``qlo..qhi`` (with
    ``demand`` 1, those that :func:`want_pixel` did not already find ``STATE_FAR``).

    Only pieces within ``limit`` of ``u`` can answer the pixel (``limit`` < 0: all can), and
    most of these cells' segments lie farther: :func:`fill_levelk` marks those ``STATE_FAR``
    without drawing them, from their parent's key point where that proves it (:func:`parent_reach`),
    else after as little of their link search as proves it. The finest level
    links nothing, so no other cell depends on them; the cells that stay have exactly the
    values the cached mode gives them. Where links are narrower than queries, it then draws the
    pending level-1 cells within ``limit`` (:func:`draw_near1`), for the queries.
    """
    n = s.levels
    if n < 2:
        return
    # the least squared distance from u to a pending box (see fill_links1; no cell drawn here
    # makes it wrong, only loose), and its root, which bounds the searches' pending checks
    gap2 = float(wp.inf)
    if defers1(s, blocks, slot) != 0:
        gap2 = keyp[nonneg(bases[nonneg(slot * SLOT + 1)] - 1)][1]
    pending = wp.sqrt(gap2)
    longest = float(0.0)
    if limit >= 0.0 and s.rule == 0:
        for level in range(1, n):
            b = blocks[nonneg(slot * SLOT + level)]
            o = bases[nonneg(slot * SLOT + level)]
            last = o + b[2] * b[3]
            while o < last:
                state = keyp[nonneg(o)][3]
                # (a bound for those pending; the nearest piece of each finest cell drawn here is
                # drawn, so waiting cells need none)
                if state == STATE_SEGMENT or state == STATE_PENDING:
                    longest = wp.max(longest, verts[nonneg(o * NV + BOUND + 1)][1])
                o += 1
    b = blocks[nonneg(slot * SLOT + n)]
    for j in range(b[3]):
        for i in range(b[2]):
            c = wp.vec2i(b[0] + i, b[1] + j)
            if c[0] < qlo[0] or c[1] < qlo[1] or c[0] > qhi[0] or c[1] > qhi[1]:
                # (one call site of fill_levelk: its code is inlined)
                pend = pending
                sb = float(0.0)
                if demand != 0:
                    # (a nested test: Warp evaluates both sides of an `and`)
                    if keyp[nonneg(bases[nonneg(slot * SLOT + n)] + j * b[2] + i)][3] == STATE_FAR:
                        sb = -1.0
                while sb >= 0.0:
                    sb = fill_levelk(s, ctl, blocks, bases, slot, n, j * b[2] + i, c, u, limit, longest, pend, keyp,
                                     verts)
                    if sb >= 0.0:
                        # its link search needs pending level-1 segments (2 levels: its parent's
                        # neighbours): draw those within its reach (at least the one that asked),
                        # then search again; the new search reaches no farther, so it asks no more
                        if draw_pending1(s, ctl, blocks, bases, slot, wp.vec2i(c[0] >> 1, c[1] >> 1),
                                         jitter(s, n, c), sb, pts1, keyp, verts) == 0:
                            pend = wp.inf  # (never expected) search without asking rather than leave the cell unwritten
    if s.rl < s.r1 and gap2 < wp.inf:
        # the queries come next: links narrower than queries leave pending cells within them (the
        # test of draw_near1, on the nearest pending box)
        if limit < 0.0 or gap2 <= limit * limit:
            draw_near1(s, ctl, blocks, bases, slot, u, limit, pts1, keyp, verts)


@wp.func
def evaluate(
    s: Setup, ctl: Control, u: wp.vec2, output: int, cached: int, slot: int, cap: wp.vec3i,
    blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), pts1: wp.array(dtype=wp.vec4),
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3), prims: wp.array(dtype=wp.vec3),
    nearby: wp.array(dtype=wp.vec4i), gaps: wp.array(dtype=float), overflow_out: wp.array(dtype=int),
) -> float:
    """The requested output at ``u``; in the per-pixel mode first plan and build the slot."""
    pc = cell_of(u, s.levels)
    qlo = pc
    qhi = pc
    limit = float(-1.0)
    demand = int(0)
    prim = Prims()
    if cached == 0:
        if output == OUT_ELEVATION:
            # the primitives that weigh lie within two primitive cells of u: their queries start
            # in the finest cells of that square (1 % wider against rounding)
            reach = 2.02 / level_factor(s.levels + s.steps)
            qlo = cell_of(u - wp.vec2(reach, reach), s.levels)
            qhi = cell_of(u + wp.vec2(reach, reach), s.levels)
        over = plan(s, qlo, qhi, pc, pc, slot, cap, blocks, bases)
        if over != 0:
            wp.atomic_max(overflow_out, 0, 1)
            return wp.nan
        if output == OUT_ELEVATION:
            prim = prim_points(s, u)
        built = build(s, ctl, blocks, bases, slot, u, output, qlo, qhi, prim, pts1, keyp, verts)
        limit = built[0]
        demand = int(built[1])
    return answer(
        s, ctl, blocks, bases, slot, u, output, qlo, qhi, prim, limit, demand, pts1, keyp, verts, cached, prims,
        slot * cap[1] * 4, nearby, gaps, overflow_out,
    )


@wp.func
def pixel_of(i: int, width: int) -> wp.vec2i:
    """(row, col) of pixel ``i`` of a window ``width`` pixels wide, row-major."""
    row = i / width
    return wp.vec2i(row, i - row * width)


@wp.func
def pixel_centre(rc: wp.vec2i, origin: wp.vec2i, x0: wp.vec2, step: wp.vec2) -> wp.vec2:
    """Grid units of the centre of window pixel ``rc``, the window's first pixel being ``origin``
    of an image whose pixel (0, 0) has its corner at ``x0`` (``step`` per pixel, x then y)."""
    return wp.vec2(
        x0[0] + (float(origin[1] + rc[1]) + 0.5) * step[0],
        x0[1] + (float(origin[0] + rc[0]) + 0.5) * step[1],
    )


# ---------------------------------------------------------------------------- kernels


@wp.kernel
def plan_kernel(
    s: Setup, qlo: wp.vec2i, qhi: wp.vec2i, plo: wp.vec2i, phi: wp.vec2i, cap: wp.vec3i,
    blocks_out: wp.array(dtype=wp.vec4i), bases_out: wp.array(dtype=int), overflow_out: wp.array(dtype=int),
):
    """Plan the blocks of slot 0 for a window (one thread). The library plans the cached mode on
    the host (``wdendrite.dendry._host_plan``); the tests check it against this kernel."""
    overflow_out[0] = plan(s, qlo, qhi, plo, phi, 0, cap, blocks_out, bases_out)


@wp.kernel
def points1_kernel(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int),
    pts1_out: wp.array(dtype=wp.vec4),
):
    """Cached mode: level-1 key points of slot 0, one thread per cell."""
    k = wp.tid()
    fill_point1(s, ctl, bases, 0, k, block_cell(blocks, 0, k), pts1_out)


@wp.kernel
def table1_kernel(s: Setup, ctl: Control, lo: wp.vec2i, width: int, pts1_out: wp.array(dtype=wp.vec4)):
    """Level-1 key points of the cells ``lo + (k % width, k // width)``, one thread per cell (the
    host drains them into the outlet table)."""
    k = wp.tid()
    pts1_out[k] = point1(s, ctl, wp.vec2i(lo[0] + k % width, lo[1] + k // width))


@wp.kernel
def segments1_kernel(
    s: Setup, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), pts1: wp.array(dtype=wp.vec4),
    keyp_out: wp.array(dtype=wp.vec4), verts_out: wp.array(dtype=wp.vec3),
):
    """Cached mode: level-1 segments of slot 0, one thread per cell."""
    k = wp.tid()
    fill_segment1(s, blocks, bases, 0, k, block_cell(blocks, 1, k), pts1, keyp_out, verts_out)


@wp.kernel
def levelk_kernel(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), level: int,
    keyp_inout: wp.array(dtype=wp.vec4), verts_inout: wp.array(dtype=wp.vec3),
):
    """Cached mode: key points and segments of ``level`` >= 2 (reads the coarser levels)."""
    k = wp.tid()
    fill_levelk(
        s, ctl, blocks, bases, 0, level, k, block_cell(blocks, level, k), wp.vec2(0.0, 0.0), -1.0, 0.0, wp.inf,
        keyp_inout, verts_inout,
    )


@wp.kernel
def prims_kernel(
    s: Setup, ctl: Control, blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int),
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3), prims_out: wp.array(dtype=wp.vec3),
):
    """Cached mode: terrain primitives of slot 0, one thread per primitive cell."""
    k = wp.tid()
    bi = PRIM
    c = block_cell(blocks, bi, k)
    q = jitter(s, s.levels + s.steps, c)
    prims_out[nonneg(bases[nonneg(bi)] + k)] = primitive(s, ctl, c, q, query(s, blocks, bases, 0, q, keyp, verts))


@wp.kernel
def image_kernel(
    s: Setup, ctl: Control, output: int, cached: int, cap: wp.vec3i, nslots: int, first: int, origin: wp.vec2i,
    width: int,
    x0: wp.vec2, step: wp.vec2,
    blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), pts1: wp.array(dtype=wp.vec4),
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3), prims: wp.array(dtype=wp.vec3),
    nearby: wp.array(dtype=wp.vec4i), gaps: wp.array(dtype=float), image_out: wp.array2d(dtype=float), overflow_out: wp.array(dtype=int),
):
    """Pixels ``first + tid`` of a window (row-major, ``width`` wide) at global pixel ``origin``.

    In the per-pixel mode thread ``tid`` works in slot ``tid % nslots``: one slot per thread
    where threads run concurrently (CUDA). On the CPU the library runs the per-pixel mode with
    :mod:`wdendrite.kernels.dendry_pixels` instead, in a single reused slot (a launch's threads
    run one after the other, so the slot stays in cache).

    Pixel (row, col) of the whole image sits at ``x0 + (col + 0.5, row + 0.5) * step`` in
    domain units; ``x0`` and ``step`` are already in grid units.
    """
    t = wp.tid()
    rc = pixel_of(first + t, width)
    slot = 0
    if cached == 0:
        slot = t % nslots
    image_out[rc[0], rc[1]] = evaluate(
        s, ctl, pixel_centre(rc, origin, x0, step), output, cached, slot, cap, blocks, bases, pts1, keyp, verts,
        prims, nearby, gaps, overflow_out,
    )


@wp.kernel
def points_kernel(
    s: Setup, ctl: Control, output: int, cached: int, cap: wp.vec3i, nslots: int, first: int,
    points_in: wp.array(dtype=wp.vec2),
    blocks: wp.array(dtype=wp.vec4i), bases: wp.array(dtype=int), pts1: wp.array(dtype=wp.vec4),
    keyp: wp.array(dtype=wp.vec4), verts: wp.array(dtype=wp.vec3), prims: wp.array(dtype=wp.vec3),
    nearby: wp.array(dtype=wp.vec4i), gaps: wp.array(dtype=float), values_out: wp.array(dtype=float), overflow_out: wp.array(dtype=int),
):
    """Arbitrary points ``first + tid`` (given in grid units): per-pixel mode with slots as in
    image_kernel, or (``cached``) from the cells slot 0 holds for all of them."""
    t = wp.tid()
    i = first + t
    slot = 0
    if cached == 0:
        slot = t % nslots
    values_out[i] = evaluate(
        s, ctl, points_in[i], output, cached, slot, cap, blocks, bases, pts1, keyp, verts, prims, nearby, gaps, overflow_out
    )
