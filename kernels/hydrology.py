"""Drainage kernels: D8 and D-infinity receivers per cell, and the area walk down the flow graph.

Cells are numbered row-major (``row * W + col``) and elevations are float64, so that the
receivers equal those of the same rule written with NumPy: a cell sends its area only to
strictly lower neighbours, which makes the flow graph acyclic. The receiver kernels run
one thread per cell on any device; :func:`accumulate_kernel` walks the whole graph in a
single thread (each cell once, after all its donors), which is why the accumulation runs
on the CPU device.
"""

import warp as wp

from . import OPTIONS
from .indexing import nonneg

wp.set_module_options(OPTIONS)

vec8i = wp.types.vector(length=8, dtype=int)

# D-infinity facets (Tarboton 1997), in the order ties are broken: cardinal neighbour e1 and
# diagonal neighbour e2 as (row, col) offsets
FACETS = [((0, 1), (-1, 1)), ((-1, 0), (-1, 1)), ((-1, 0), (-1, -1)), ((0, -1), (-1, -1)),
          ((0, -1), (1, -1)), ((1, 0), (1, -1)), ((1, 0), (1, 1)), ((0, 1), (1, 1))]
E1R = wp.constant(vec8i(*(f[0][0] for f in FACETS)))
E1C = wp.constant(vec8i(*(f[0][1] for f in FACETS)))
E2R = wp.constant(vec8i(*(f[1][0] for f in FACETS)))
E2C = wp.constant(vec8i(*(f[1][1] for f in FACETS)))
SQRT2 = wp.constant(wp.float64(1.4142135623730951))
QUARTER = wp.constant(wp.float64(0.7853981633974483))  # pi / 4
# two facet slopes this close (relative) are compared by their squares instead, which are exact
# where the slopes themselves round (integer terrains: sqrt(1 + 1) against 2 / sqrt(2))
TIE = wp.constant(wp.float64(1.0e-12))
FAR = wp.constant(wp.int64(2**63 - 1))  # a flat distance no source reaches


@wp.func
def inside(r: int, c: int, h: int, w: int) -> bool:
    return r >= 0 and c >= 0 and r < h and c < w


@wp.kernel
def d8_kernel(z_in: wp.array2d(dtype=wp.float64), rec_out: wp.array2d(dtype=int), donors_out: wp.array(dtype=int)):
    """Receiver of cell (row, col): the neighbour of steepest drop (drop / distance, diagonals
    at sqrt(2)), the first in row-major order among equals; -1 where no neighbour is lower.
    Counts the cell as a donor of its receiver."""
    r, c = wp.tid()
    h = z_in.shape[0]
    w = z_in.shape[1]
    here = z_in[r, c]
    best = wp.float64(0.0)
    to = int(-1)
    for dr in range(-1, 2):
        for dc in range(-1, 2):
            rr = r + dr
            cc = c + dc
            if (dr != 0 or dc != 0) and inside(rr, cc, h, w):
                drop = here - z_in[nonneg(rr), nonneg(cc)]
                if dr != 0 and dc != 0:
                    drop = drop / SQRT2
                if drop > best:
                    best = drop
                    to = rr * w + cc
    rec_out[0, nonneg(r * w + c)] = to
    if to >= 0:
        wp.atomic_add(donors_out, nonneg(to), 1)


@wp.func
def facet_slope(s1: wp.float64, s2: wp.float64) -> wp.float64:
    """Steepest slope of a facet falling ``s1`` towards its cardinal neighbour and then ``s2``
    on to its diagonal one, when the steepest direction lies inside it (``0 <= s2 <= s1``):
    ``hypot(s1, s2)``, scaled so that it neither overflows nor underflows."""
    out = wp.float64(0.0)
    if s1 > wp.float64(0.0):
        q = s2 / s1
        out = s1 * wp.sqrt(wp.float64(1.0) + q * q)
    return out


@wp.kernel
def dinf_kernel(z_in: wp.array2d(dtype=wp.float64), rec_out: wp.array2d(dtype=int),
                frac_out: wp.array2d(dtype=wp.float64), donors_out: wp.array(dtype=int)):
    """Receivers of cell (row, col) by D-infinity: the steepest of the 8 triangular facets
    (the first among equals: slopes within rounding of each other are compared by their
    squares, ``s1^2 + s2^2``, ``(fall to e2)^2 / 2`` or ``s1^2``, exact for integer elevations
    of moderate size), its flow angle split between the facet's cardinal neighbour
    (row 0 of the outputs) and diagonal neighbour (row 1) in proportion to the angle. A
    neighbour that gets nothing repeats the other; -1 where no facet falls. Counts the cell
    as a donor of each distinct receiver."""
    r, c = wp.tid()
    h = z_in.shape[0]
    w = z_in.shape[1]
    here = z_in[r, c]
    best = wp.float64(0.0)
    best_sq = wp.float64(0.0)
    k = int(-1)
    across = wp.float64(0.0)  # the steepest facet's fall from e1 to e2 ...
    along = wp.float64(0.0)  # ... and from the cell to e1
    for f in range(8):
        r1 = r + E1R[f]
        c1 = c + E1C[f]
        r2 = r + E2R[f]
        c2 = c + E2C[f]
        if inside(r1, c1, h, w):
            z1 = z_in[nonneg(r1), nonneg(c1)]
            s1 = here - z1
            s2 = wp.float64(-1.0)  # no diagonal neighbour: the flow keeps to the facet's edge to e1
            slope = s1
            sq = s1 * s1
            if inside(r2, c2, h, w):
                z2 = z_in[nonneg(r2), nonneg(c2)]
                s2 = z1 - z2
                if s2 > s1:  # steepest direction beyond the diagonal: along it
                    slope = (here - z2) / SQRT2
                    sq = (here - z2) * (here - z2) * wp.float64(0.5)
                elif s2 >= wp.float64(0.0):  # inside the facet
                    slope = facet_slope(s1, s2)
                    sq = s1 * s1 + s2 * s2
            take = slope > best
            if k >= 0 and wp.abs(slope - best) <= best * TIE:
                take = sq > best_sq
            if take and slope > wp.float64(0.0):
                best = slope
                best_sq = sq
                k = f
                across = s2
                along = s1
    i = r * w + c
    to1 = int(-1)
    to2 = int(-1)
    f2 = wp.float64(0.0)
    if k >= 0:
        # share of the diagonal neighbour: the flow angle over 45 degrees (0 unless it exists)
        if across > along:
            f2 = wp.float64(1.0)
        elif across > wp.float64(0.0):
            f2 = wp.min(wp.atan2(across, along), QUARTER) / QUARTER
        to1 = (r + E1R[k]) * w + c + E1C[k]
        to2 = to1
        if f2 > wp.float64(0.0):
            to2 = (r + E2R[k]) * w + c + E2C[k]
            if f2 >= wp.float64(1.0):
                to1 = to2
        wp.atomic_add(donors_out, nonneg(to1), 1)
        if to2 != to1:
            wp.atomic_add(donors_out, nonneg(to2), 1)
    rec_out[0, nonneg(i)] = to1
    rec_out[1, nonneg(i)] = to2
    frac_out[0, nonneg(i)] = wp.float64(1.0) - f2
    frac_out[1, nonneg(i)] = f2


@wp.kernel
def accumulate_kernel(rec_in: wp.array2d(dtype=int), frac_in: wp.array2d(dtype=wp.float64),
                      donors_inout: wp.array(dtype=int), stack_scratch: wp.array(dtype=int),
                      area_inout: wp.array(dtype=wp.float64)):
    """One thread: pass every cell's area to its receivers once all its donors have passed
    theirs (``donors_inout`` counts the donors still to come; -1 once a cell is done).

    ``rec_in``: (k, N) receivers (-1: none; a repeated receiver is counted once in the
    donors); ``frac_in``: (k, N) shares they get (with k = 1, none is read: the one
    receiver gets it all); ``stack_scratch``: N ints; ``area_inout``: the cells' own areas
    in, drainage areas out.
    """
    n = area_inout.shape[0]
    kinds = rec_in.shape[0]
    start = int(0)
    while start < n:
        if donors_inout[start] == 0:
            stack_scratch[0] = start
            top = int(1)
            while top > 0:
                top -= 1
                i = stack_scratch[nonneg(top)]
                donors_inout[nonneg(i)] = -1
                a = area_inout[nonneg(i)]
                first = rec_in[0, nonneg(i)]
                for k in range(kinds):
                    to = rec_in[k, nonneg(i)]
                    if to >= 0:
                        share = a
                        if kinds > 1:
                            share = frac_in[k, nonneg(i)] * a
                        area_inout[nonneg(to)] += share
                        if k == 0 or to != first:
                            left = donors_inout[nonneg(to)] - 1
                            donors_inout[nonneg(to)] = left
                            if left == 0:
                                stack_scratch[nonneg(top)] = to
                                top += 1
        start += 1


@wp.func
def push_flat(j: int, dist: wp.int64, dist_inout: wp.array(dtype=wp.int64), next_scratch: wp.array(dtype=int),
              heads_scratch: wp.array(dtype=int)):
    """Give cell ``j`` the distance ``dist`` and put it in that distance's bucket (of 4, by
    ``dist % 4``): the head of a list linked through ``next_scratch``."""
    b = int(dist & wp.int64(3))
    dist_inout[nonneg(j)] = dist
    next_scratch[nonneg(j)] = heads_scratch[b]
    heads_scratch[b] = j


@wp.func
def spread_flat(z_in: wp.array(dtype=wp.float64), lost_in: wp.array(dtype=wp.uint8), w: int, pending: int,
                next_scratch: wp.array(dtype=int), heads_scratch: wp.array(dtype=int),
                dist_inout: wp.array(dtype=wp.int64)):
    """Spread the ``pending`` cells already in the buckets (all at distance 0) over the lost
    cells of their height, in steps of 2 (sides) and 3 (diagonals): Dial's buckets in a ring
    of 4, one pass over the cells. Each bucket is spread in two passes, sides first, so a
    cell gets its final distance the first time it is reached and is listed once."""
    n = z_in.shape[0]
    h = n / w
    d = wp.int64(0)
    while pending > 0:
        b = int(d & wp.int64(3))
        for diagonal in range(2):
            to = d + wp.int64(2 + diagonal)
            i = heads_scratch[b]
            while i >= 0:
                if diagonal == 0:
                    pending -= 1
                r = i / w
                c = i - r * w
                here = z_in[nonneg(i)]
                for k in range(9):
                    dr = k / 3 - 1
                    dc = k % 3 - 1
                    rr = r + dr
                    cc = c + dc
                    if (dr != 0 and dc != 0) == (diagonal == 1) and k != 4 and inside(rr, cc, h, w):
                        j = rr * w + cc
                        if lost_in[nonneg(j)] != wp.uint8(0) and dist_inout[nonneg(j)] > to:
                            if z_in[nonneg(j)] == here:
                                push_flat(j, to, dist_inout, next_scratch, heads_scratch)
                                pending += 1
                i = next_scratch[nonneg(i)]
        heads_scratch[b] = -1
        d += wp.int64(1)


@wp.kernel
def flat_distance_kernel(z_in: wp.array(dtype=wp.float64), lost_in: wp.array(dtype=wp.uint8), w: int,
                         from_higher: int, next_scratch: wp.array(dtype=int), heads_scratch: wp.array(dtype=int),
                         dist_out: wp.array(dtype=wp.int64)):
    """One thread: a distance over every flat, in steps of 2 (sides) and 3 (diagonals) over
    the lost cells (``lost_in`` 1: interior cells with no receiver, so no lower neighbour)
    of one height, from its sources (distance 0), by :func:`spread_flat`.

    ``from_higher`` 0: towards lower terrain; the sources are the flats' ways out, cells that
    are not lost next to a lost cell of their height. 1: away from higher terrain; the
    sources are the lost cells next to a higher cell. ``z_in``: the N elevations,
    row-major, ``w`` per row; ``dist_out``: N int64s (a path over a flat of N cells may be
    3N long; :data:`FAR` where no source reaches); ``next_scratch``: N ints;
    ``heads_scratch``: 4 ints.
    """
    n = z_in.shape[0]
    for b in range(4):
        heads_scratch[b] = -1
    cell = int(0)
    while cell < n:
        dist_out[nonneg(cell)] = FAR
        cell += 1
    pending = int(0)
    i = int(0)
    while i < n:
        if lost_in[nonneg(i)] != wp.uint8(0):
            here = z_in[nonneg(i)]
            for k in range(9):
                j = i + (k / 3 - 1) * w + (k % 3 - 1)  # interior: all 8 neighbours exist
                if k != 4:
                    there = z_in[nonneg(j)]
                    if from_higher != 0:
                        if there > here and dist_out[nonneg(i)] != wp.int64(0):
                            push_flat(i, wp.int64(0), dist_out, next_scratch, heads_scratch)
                            pending += 1
                    elif lost_in[nonneg(j)] == wp.uint8(0) and dist_out[nonneg(j)] != wp.int64(0):
                        if there == here:
                            push_flat(j, wp.int64(0), dist_out, next_scratch, heads_scratch)
                            pending += 1
        i += 1
    spread_flat(z_in, lost_in, w, pending, next_scratch, heads_scratch, dist_out)


@wp.func
def flat_mask(lower: wp.int64, higher: wp.int64) -> wp.int64:
    """``2 * lower - higher``, with ``higher`` 0 where no higher cell reaches (then on the whole flat)."""
    away = higher
    if away == FAR:
        away = wp.int64(0)
    return wp.int64(2) * lower - away


@wp.kernel
def flat_receiver_kernel(z_in: wp.array(dtype=wp.float64), lost_in: wp.array(dtype=wp.uint8),
                         cells_in: wp.array(dtype=int), lower_in: wp.array(dtype=wp.int64),
                         higher_in: wp.array(dtype=wp.int64), w: int, rec_out: wp.array2d(dtype=int),
                         frac_out: wp.array2d(dtype=wp.float64), donors_out: wp.array(dtype=int)):
    """Receiver of lost cell ``cells_in[tid]`` (flats without a way out are left alone): of its
    neighbours of its height, the nearest way out (not lost; a side before a diagonal) if it
    has one, else the lost one of lowest :func:`flat_mask` below its own; the first in
    row-major order among equals (:func:`wdendrite.hydrology._drain_flats` proves that such a
    neighbour exists). Writes every row of ``rec_out`` (k, N), and shares 1 and 0 in
    ``frac_out`` when k = 2; counts the cell as a donor of its receiver."""
    i = cells_in[wp.tid()]
    if lower_in[nonneg(i)] < FAR:
        here = z_in[nonneg(i)]
        best = flat_mask(lower_in[nonneg(i)], higher_in[nonneg(i)])
        to = int(-1)
        out = int(-1)  # the nearest way out, if any
        out_step = int(4)
        for k in range(9):
            dr = k / 3 - 1
            dc = k % 3 - 1
            j = i + dr * w + dc  # interior: all 8 neighbours exist
            if k != 4 and z_in[nonneg(j)] == here:
                if lost_in[nonneg(j)] == wp.uint8(0):
                    step = 2
                    if dr != 0 and dc != 0:
                        step = 3
                    if step < out_step:
                        out = j
                        out_step = step
                else:
                    mask = flat_mask(lower_in[nonneg(j)], higher_in[nonneg(j)])
                    if mask < best:
                        best = mask
                        to = j
        if out >= 0:
            to = out
        for row in range(rec_out.shape[0]):
            rec_out[row, nonneg(i)] = to
        if rec_out.shape[0] > 1:
            frac_out[0, nonneg(i)] = wp.float64(1.0)
            frac_out[1, nonneg(i)] = wp.float64(0.0)
        if to >= 0:
            wp.atomic_add(donors_out, nonneg(to), 1)
