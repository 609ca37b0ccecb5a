"""Near-far (delta-stepping) relaxation kernels for lattice shortest paths.

A node's state is one ``uint64`` word: the float32 bits of its cost in the
high half and the row of its generator in the low half. Non-negative float32
values order like their bit patterns, so ``wp.atomic_min`` on the packed word
keeps the least cost and, among equal costs, the lowest generator row. The
minimum does not depend on the order in which threads arrive, so costs are
bit-identical run to run on a device. Labels are too, but for one case: a
node may first offer its neighbours a cost from a costlier path, and when its
own least cost (from another generator) extends to the same float32 sum, the
lower label of the two stays. Which offers are made depends on the order of
relaxations: fixed on the CPU, free on a GPU, where such a rounding tie may
then label a node differently from run to run. Backtracking follows the costs
either way, but prefers the neighbour that reproduces the whole word (see
:mod:`wdendrite.kernels.dendrite`), so a path through such a node may then
take the other generator's way down.

Kernels index a *padded* lattice: the lattice with a one-node border (in
x, y and, for 3D, z), so a neighbour is always ``node + flat_offsets[k]``. The
border and masked-out nodes hold the packed word 0, which no candidate can
undercut, so they are never entered and need no test.

Each padded node owns a record of ``stride`` int32 words (an even number) in
the lattice's ``records`` array, so relaxing an edge touches one cache line per
neighbour: words 0-1 hold the node's packed state (read through ``state``, a
``uint64`` view of the same memory, at ``state[p * stride / 2]``), words
``2 .. n_weights + 1`` the float32 bits of its ``n_weights`` stored edge weights (direction
``k`` at word ``2 + k``; ``n_weights`` is 0 when weights are recomputed from their
hash), then its queue stamp (word ``n_weights + 2``). A lattice's records hold the
state of one search at a time; searches on a lattice take turns.

Frontiers are flat ``int32`` node lists with their lengths kept in a small
``counts`` array. A node enters a "near" list at most once per generation
(its stamp equals the generation while it waits) and the "far" pile at most
once per search (its stamp equals ``-far_id``, the negated search id, while
it waits there). One stamp serves both: a node's cost only falls and the
threshold only rises, so once a node has been queued near it never needs the
far pile again in that search, and a far node that drops below the threshold
is queued near at once (its far entry is dropped when the pile is next
split). With many threads, a far push racing a near push of the same node
must not undo it: :func:`push_far` changes the stamp by compare-and-swap and
leaves a node stamped with the current generation alone. Generations and
search ids only grow, so stamps never need clearing between searches.
Backtracking (:mod:`wdendrite.kernels.dendrite`) marks its walks in the same
word with ids of its own, which later searches' newer ids never equal.
"""

import warp as wp

from . import OPTIONS
from .indexing import dense_i32, dense_u64, nonneg
from .lattice import in_bounds, node_coords, node_index, padded_index
from .weights import REFINED, WeightParams, cell_of, is_plain, refined_blocked, refined_key, refined_value, weight_of_edge

# Warp's own CPU flags (its raised inlining thresholds: with LLVM's defaults the fractal's growth ran
# 1.45x slower), and loops of more than 12 trips left rolled: the 13 directions of relax_node, which
# unrolled tripled this module's compile time for no run-time gain measured (BENCHMARKS.md,
# "Start-up and kernel compilation")
wp.set_module_options({**OPTIONS, "optimization_level": 3, "cpu_compiler_flags": None, "max_unroll": 12})

UNREACHED = wp.constant(wp.uint64(0xFFFFFFFFFFFFFFFF))
"""Packed state of a node no path has reached."""

WEIGHT0 = wp.constant(2)
"""Record word of a node's first stored weight (words 0-1 are its packed state)."""


@wp.func
def state_at(state: wp.array(dtype=wp.uint64), stride: int, node: int) -> wp.uint64:
    """Packed state of padded node ``node`` (``state`` is the uint64 view of the records)."""
    return state[nonneg(node * (stride >> 1))]


@wp.func
def stamp_index(node: int, stride: int, n_weights: int) -> int:
    """Index in ``records`` of padded node ``node``'s queue stamp (the record word after its ``n_weights`` weights)."""
    return nonneg(node * stride + n_weights + 2)


@wp.func
def state_min(state: wp.array(dtype=wp.uint64), stride: int, node: int, word: wp.uint64) -> wp.uint64:
    """``atomic_min`` of ``node``'s packed state with ``word``; returns the previous state."""
    return wp.atomic_min(state, nonneg(node * (stride >> 1)), word)


@wp.struct
class HashedWeights:
    """Edge weights recomputed from a hash instead of read from an array."""

    use: int
    """Nonzero: compute weights with ``params``; zero: read the stored array."""
    params: WeightParams
    """The distribution (see :mod:`wdendrite.kernels.weights`)."""
    shape3: wp.vec3i
    """Unpadded lattice shape ``(D, H, W)``."""
    pad3: wp.vec3i
    """Border width of the padded layout per axis."""
    offsets: wp.array(dtype=wp.vec3i)
    """Half-offsets ``(dz, dy, dx)``, shape (K,)."""
    lengths: wp.array(dtype=float)
    """Length of each half-offset, shape (K,)."""


@wp.func
def hashed_weight(hashed: HashedWeights, plain: bool, node: int, coords: wp.vec3i, k: int) -> float:
    """Weight of the edge from (unpadded) ``node`` at ``coords`` in direction ``k``, from the hash.

    ``plain`` is :func:`~wdendrite.kernels.weights.is_plain` of ``hashed.params``,
    tested once per launch: plain weights are computed from scalars.
    """
    return weight_of_edge(hashed.params, plain, hashed.shape3, node, coords, k, hashed.offsets[k], hashed.lengths[k])


@wp.func
def edge_cost(records: wp.array(dtype=wp.int32), stride: int, hashed: HashedWeights, lower: int, k: int) -> float:
    """Weight of the padded lattice's edge ``lower <-> lower + flat_offsets[k]``."""
    if hashed.use == 0:
        return wp.cast(records[nonneg(lower * stride + WEIGHT0 + k)], wp.float32)
    padded = hashed.shape3 + hashed.pad3 + hashed.pad3
    coords = node_coords(lower, padded) - hashed.pad3
    return hashed_weight(hashed, is_plain(hashed.params), node_index(coords, hashed.shape3), coords, k)


@wp.func
def pack_cost(cost: float, label: int) -> wp.uint64:
    """Pack a non-negative cost and a generator row into one ordered word."""
    bits = wp.uint64(wp.cast(cost, wp.uint32))
    return (bits << wp.uint64(32)) | wp.uint64(wp.uint32(label))


@wp.func
def packed_cost(word: wp.uint64) -> float:
    """Cost stored in a packed word."""
    return wp.cast(wp.uint32(word >> wp.uint64(32)), wp.float32)


@wp.func
def packed_label(word: wp.uint64) -> int:
    """Generator row stored in a packed word."""
    return wp.int32(wp.uint32(word & wp.uint64(0xFFFFFFFF)))


@wp.func
def push_far(
    node: int,
    cost: float,
    far_id: int,
    generation: int,
    records: wp.array(dtype=wp.int32),
    stride: int,
    n_weights: int,
    far_out: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_slot: int,
    far_min: wp.array(dtype=float),
):
    """Add ``node`` to the far pile once, and keep the pile's least cost.

    The stamp only changes to ``-far_id`` from a value other than
    ``generation``: a node another thread has meanwhile queued in the near
    list being filled now costs less than the threshold, and a far entry
    would only be dropped later (and could let a later improvement queue it
    near a second time). A compare-and-swap loop makes the test and the
    change one step. Callers with no near list pass ``generation = -far_id``.
    """
    word = stamp_index(node, stride, n_weights)
    stamp = records[word]
    while stamp != -far_id and stamp != generation:
        seen = wp.atomic_cas(records, word, stamp, -far_id)
        if seen == stamp:
            far_out[nonneg(wp.atomic_add(counts, far_slot, 1))] = node
            stamp = -far_id
        else:
            stamp = seen
    wp.atomic_min(far_min, 0, cost)


@wp.func
def push_near(
    node: int,
    generation: int,
    records: wp.array(dtype=wp.int32),
    stride: int,
    n_weights: int,
    near_out: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    near_slot: int,
):
    """Add ``node`` to the near list of ``generation`` once (the list is a ring of its capacity)."""
    if wp.atomic_exch(records, stamp_index(node, stride, n_weights), generation) != generation:
        at = wp.atomic_add(counts, near_slot, 1)
        if at >= near_out.shape[0]:
            at = at % near_out.shape[0]  # only a work queue wraps: no division on the common path
        near_out[nonneg(at)] = node


@wp.kernel
def init_state_kernel(mask: wp.array(dtype=wp.uint8), stride: int, chunk: int, state: wp.array(dtype=wp.uint64)):
    """Mark every usable node unreached; ``chunk`` nodes per thread.

    Masked and border nodes keep the word 0 the records were built with.
    """
    start = wp.tid() * chunk
    stop = wp.min(start + chunk, mask.shape[0])
    i = int(start)
    while i < stop:
        if mask[nonneg(i)] != wp.uint8(0):
            state[nonneg(i * (stride >> 1))] = UNREACHED
        i += 1


@wp.kernel
def init_listed_kernel(usable: wp.array(dtype=wp.int32), stride: int, state: wp.array(dtype=wp.uint64)):
    """Mark the listed (usable) padded nodes unreached: :func:`init_state_kernel` for sparse lattices."""
    state[usable[wp.tid()] * (stride >> 1)] = UNREACHED


@wp.kernel
def load_state_kernel(
    dist: wp.array(dtype=float),
    label: wp.array(dtype=wp.int32),
    shape: wp.vec3i,
    pad: wp.vec3i,
    stride: int,
    chunk: int,
    mask: wp.array(dtype=wp.uint8),
    state: wp.array(dtype=wp.uint64),
):
    """Write an earlier search's ``dist``/``label`` (unpadded) back into the records' states.

    The inverse of :func:`records_pass_kernel`'s unpacking: a finite cost becomes the word
    ``pack(dist, label)`` the search had left, an infinite one ``UNREACHED``;
    masked nodes keep their word 0. ``chunk`` nodes per thread.
    """
    start = wp.tid() * chunk
    stop = wp.min(start + chunk, dist.shape[0])
    i = int(start)
    while i < stop:
        p = padded_index(i, shape, pad)
        if mask[p] != wp.uint8(0):
            word = UNREACHED
            if dist[i] < wp.inf:
                word = pack_cost(dist[i], label[i])
            state[p * (stride >> 1)] = word
        i += 1


@wp.kernel
def seed_kernel(
    nodes_in: wp.array(dtype=wp.int32),
    labels_in: wp.array(dtype=wp.int32),
    stride: int,
    n_weights: int,
    far_id: int,
    far_slot: int,
    state: wp.array(dtype=wp.uint64),
    records: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_min: wp.array(dtype=float),
    far_out: wp.array(dtype=wp.int32),
):
    """Give each generator node cost 0 and its row as label; queue it."""
    i = wp.tid()
    node = nodes_in[i]
    word = pack_cost(0.0, labels_in[i])
    if word < state_min(state, stride, node, word):
        push_far(node, 0.0, far_id, -far_id, records, stride, n_weights, far_out, counts, far_slot, far_min)


@wp.func
def queue_ends(
    node: int,
    other: int,
    far_id: int,
    far_slot: int,
    stride: int,
    n_weights: int,
    state: wp.array(dtype=wp.uint64),
    records: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_min: wp.array(dtype=float),
    far_out: wp.array(dtype=wp.int32),
):
    """Queue both ends of a lowered edge that a search has reached, at their costs (warm start)."""
    for end in range(2):
        n = node
        if end == 1:
            n = other
        word = state_at(state, stride, n)
        if word != UNREACHED:
            push_far(n, packed_cost(word), far_id, -far_id, records, stride, n_weights, far_out, counts, far_slot, far_min)


@wp.kernel
def mark_lowered_kernel(
    flat_offsets: wp.array(dtype=wp.int32),
    mask: wp.array(dtype=wp.uint8),
    old_records: wp.array(dtype=wp.int32),
    stride: int,
    n_weights: int,
    far_id: int,
    far_slot: int,
    state: wp.array(dtype=wp.uint64),
    records: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_min: wp.array(dtype=float),
    far_out: wp.array(dtype=wp.int32),
):
    """Queue both ends of every edge whose weight went down from ``old_records`` to ``records`` (warm start).

    Both record arrays have the same layout (the same lattice shape and connectivity).
    """
    node = wp.tid()
    if mask[node] == wp.uint8(0):
        return
    k = int(0)
    while k < flat_offsets.shape[0]:
        e = node * stride + WEIGHT0 + k
        other = node + flat_offsets[k]
        if wp.cast(records[e], wp.float32) < wp.cast(old_records[e], wp.float32) and mask[other] != wp.uint8(0):
            queue_ends(node, other, far_id, far_slot, stride, n_weights, state, records, counts, far_min, far_out)
        k += 1


@wp.kernel
def mark_listed_lowered_kernel(
    nodes: wp.array(dtype=wp.int32),
    dirs: wp.array(dtype=wp.int32),
    values: wp.array(dtype=float),
    write: int,
    flat_offsets: wp.array(dtype=wp.int32),
    mask: wp.array(dtype=wp.uint8),
    stride: int,
    n_weights: int,
    far_id: int,
    far_slot: int,
    state: wp.array(dtype=wp.uint64),
    records: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_min: wp.array(dtype=float),
    far_out: wp.array(dtype=wp.int32),
):
    """Queue both ends of the listed edges, whose weights went down in place (warm start).

    Edge ``i`` leaves padded node ``nodes[i]`` in direction ``dirs[i]``; with
    ``write`` its new weight ``values[i]`` is first stored in these records
    (records other than the host's, which already hold it).
    """
    i = wp.tid()
    node = nodes[i]
    k = dirs[i]
    if write != 0:
        records[node * stride + WEIGHT0 + k] = wp.cast(values[i], wp.int32)
    other = node + flat_offsets[k]
    if mask[node] != wp.uint8(0) and mask[other] != wp.uint8(0):
        queue_ends(node, other, far_id, far_slot, stride, n_weights, state, records, counts, far_min, far_out)


@wp.func
def relax_edge(
    other: int,
    new_cost: float,
    label: int,
    threshold: float,
    limit: float,
    generation: int,
    far_id: int,
    stride: int,
    n_weights: int,
    near_slot: int,
    far_slot: int,
    state: wp.array(dtype=wp.uint64),
    records: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_min: wp.array(dtype=float),
    near_out: wp.array(dtype=wp.int32),
    far_out: wp.array(dtype=wp.int32),
):
    """Offer ``other`` the cost ``new_cost`` from generator ``label``; queue it if it improved.

    ``limit`` is finite (the host caps it at the largest float32), so a cost
    that overflowed float32 is never offered: the node stays unreached.
    """
    if new_cost <= limit:
        candidate = pack_cost(new_cost, label)
        if candidate < state_at(state, stride, other):
            if candidate < state_min(state, stride, other, candidate):
                if new_cost < threshold:
                    push_near(other, generation, records, stride, n_weights, near_out, counts, near_slot)
                else:
                    push_far(other, new_cost, far_id, generation, records, stride, n_weights, far_out, counts, far_slot,
                             far_min)


@wp.func(inline=True)
def relax_node(
    node: int,
    flat_offsets: wp.array(dtype=wp.int32),
    directions: int,
    hashed: HashedWeights,
    stored: bool,
    plain: bool,
    stride: int,
    n_weights: int,
    far_id: int,
    threshold: float,
    limit: float,
    generation: int,
    near_slot: int,
    far_slot: int,
    state: wp.array(dtype=wp.uint64),
    records: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_min: wp.array(dtype=float),
    near_out: wp.array(dtype=wp.int32),
    far_out: wp.array(dtype=wp.int32),
):
    """Relax both edges of every direction at ``node`` (see :func:`relax_kernel`).

    ``stored`` (a constant where the caller knows the weights are stored) skips
    the test of ``hashed.use``, so that the code of hashed weights goes.

    The loop over directions has a constant trip count (13, the most
    half-offsets a lattice has), with a test skipping the directions a
    lattice lacks. The module leaves it rolled (``max_unroll`` 12): unrolled
    in each of the kernels that inline this function it tripled the module's
    compile time, for no run-time gain measured since.
    """
    word = state_at(state, stride, node)
    cost = packed_cost(word)
    label = packed_label(word)
    c = wp.vec3i(0, 0, 0)
    j = int(0)
    if not stored and hashed.use != 0:
        # hashed weights: the node's coordinates once (two divisions), its neighbours' by offsets
        c = node_coords(node, hashed.shape3 + hashed.pad3 + hashed.pad3) - hashed.pad3
        j = node_index(c, hashed.shape3)
    for k in range(13):
        if k < directions:
            step = flat_offsets[k]
            # forward edge stored at this node, backward edge stored at the neighbour
            w_fwd = float(0.0)
            w_bwd = float(0.0)
            if stored or hashed.use == 0:
                w_fwd = wp.cast(records[nonneg(node * stride + WEIGHT0 + k)], wp.float32)
                w_bwd = wp.cast(records[nonneg((node - step) * stride + WEIGHT0 + k)], wp.float32)
            else:
                # only for neighbours that could improve: border nodes have no weights to compute
                if state_at(state, stride, node + step) != wp.uint64(0):
                    w_fwd = hashed_weight(hashed, plain, j, c, k)
                if state_at(state, stride, node - step) != wp.uint64(0):
                    back = c - hashed.offsets[k]
                    w_bwd = hashed_weight(hashed, plain, node_index(back, hashed.shape3), back, k)
            relax_edge(node + step, cost + w_fwd, label, threshold, limit, generation, far_id, stride, n_weights,
                       near_slot, far_slot, state, records, counts, far_min, near_out, far_out)
            relax_edge(node - step, cost + w_bwd, label, threshold, limit, generation, far_id, stride, n_weights,
                       near_slot, far_slot, state, records, counts, far_min, near_out, far_out)


@wp.kernel
def relax_kernel(
    flat_offsets: wp.array(dtype=wp.int32),
    hashed: HashedWeights,
    stride: int,
    n_weights: int,
    far_id: int,
    near_in: wp.array(dtype=wp.int32),
    in_slot: int,
    threads: int,
    fifo: int,
    threshold: float,
    limit: float,
    generation: int,
    near_slot: int,
    far_slot: int,
    state: wp.array(dtype=wp.uint64),
    records: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_min: wp.array(dtype=float),
    near_out: wp.array(dtype=wp.int32),
    far_out: wp.array(dtype=wp.int32),
):
    """Relax every edge of the near frontier's nodes.

    ``threads`` threads stride over the ``counts[in_slot]`` entries of
    ``near_in`` (one thread on the CPU, many on a GPU). With ``fifo`` (one
    thread only), ``near_out`` is ``near_in`` and the list is a work queue:
    nodes queued during the launch are relaxed in the same launch, and a node
    may be queued again once it has been taken out. A neighbour whose
    packed state drops is queued in the next near list when its cost is below
    ``threshold`` and in the far pile otherwise; costs above ``limit`` are
    never written. Record word ``p * stride + 2 + k`` of ``records`` holds the
    weight of the edge ``p <-> p + flat_offsets[k]``, unless ``hashed.use``
    asks for weights recomputed from their hash.
    """
    capacity = near_in.shape[0]
    directions = flat_offsets.shape[0]
    plain = is_plain(hashed.params)
    i = wp.tid()
    at = i  # i modulo the ring's capacity, kept without a division per node
    while i < counts[in_slot]:
        node = near_in[nonneg(at)]
        at += threads
        if at >= capacity:
            at = at % capacity
        if fifo != 0:
            records[stamp_index(node, stride, n_weights)] = 0  # out of the work queue: it may be queued again
        relax_node(node, flat_offsets, directions, hashed, False, plain, stride, n_weights, far_id, threshold, limit,
                   generation, near_slot, far_slot, state, records, counts, far_min, near_out, far_out)
        i += threads


@wp.kernel
def split_far_kernel(
    far_in: wp.array(dtype=wp.int32),
    in_slot: int,
    threads: int,
    previous_threshold: float,
    threshold: float,
    generation: int,
    stride: int,
    n_weights: int,
    near_slot: int,
    far_slot: int,
    state: wp.array(dtype=wp.uint64),
    records: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_min: wp.array(dtype=float),
    near_out: wp.array(dtype=wp.int32),
    far_out: wp.array(dtype=wp.int32),
):
    """Move far nodes below the new ``threshold`` to the near list.

    Nodes that dropped below ``previous_threshold`` while waiting were already
    queued as near nodes at that moment, so they are simply dropped.
    """
    i = wp.tid()
    n = counts[in_slot]
    while i < n:
        node = far_in[nonneg(i)]
        cost = packed_cost(state_at(state, stride, node))
        if cost < threshold:
            if cost >= previous_threshold:
                push_near(node, generation, records, stride, n_weights, near_out, counts, near_slot)
        else:
            far_out[nonneg(wp.atomic_add(counts, far_slot, 1))] = node
            wp.atomic_min(far_min, 0, cost)
        i += threads


FLOAT32_MAX = wp.constant(wp.float64(3.4028234663852886e38))
"""The largest finite float32, as a float64."""


@wp.func
def next_threshold(threshold: float, far_low: float, delta: wp.float64) -> float:
    """The next bucket's upper bound, as the host's ``wdendrite.sssp._next_threshold`` makes it.

    The sum is taken in float64 and rounded once to float32 (inf from the
    largest float32 up); the result is strictly above ``far_low`` (a
    non-negative cost), the next float32 up if the rounding left it equal.
    """
    wanted = wp.max(wp.float64(threshold) + delta, wp.float64(far_low) + delta)
    t = float(wp.inf)
    if wanted < FLOAT32_MAX:
        t = wp.float32(wanted)
    if not (t > far_low):
        t = wp.cast(wp.cast(far_low, wp.uint32) + wp.uint32(1), wp.float32)
    return t


SEARCH_DIRECTIONS = (2, 3, 4, 13)
"""Edge directions (stored weights per record) of the lattices: connectivity 4, 6, 8 and 26."""


def record_stride(n_weights: int) -> int:
    """int32 words per node record with ``n_weights`` stored weights: a 64-bit state, the
    weights and a stamp, rounded up to an even count so that states stay aligned."""
    return (n_weights + 4) // 2 * 2


def _one_launch_search(fixed_weights: int) -> wp.Kernel:
    """The one-thread search kernel, for records of ``fixed_weights`` stored weights
    known when it compiles (one of :data:`SEARCH_DIRECTIONS`, with the stride
    :func:`record_stride` gives), or, with ``fixed_weights = 0``, for any records,
    laid out as the launch's ``stride`` and ``n_weights`` say (hashed weights, or any
    other layout).

    Known at compile time, the record stride and the number of directions let
    the compiler fold the record arithmetic and unroll the directions, and
    the hashed weights' code goes: 0.88x the time of a search through
    run-time values (512^2, 8-connected, on the CPU), 0.83x with the arrays'
    dense views as well (see :mod:`~wdendrite.kernels.indexing`).
    """
    stored = fixed_weights > 0

    @wp.kernel
    def search_kernel(
        flat_offsets: wp.array(dtype=wp.int32),
        hashed: HashedWeights,
        stride: int,
        n_weights: int,
        far_id: int,
        queue: wp.array(dtype=wp.int32),
        far_pile: wp.array(dtype=wp.int32),
        limit: float,
        delta: wp.float64,
        generation: int,
        state: wp.array(dtype=wp.uint64),
        records: wp.array(dtype=wp.int32),
        counts: wp.array(dtype=wp.int32),
        far_min: wp.array(dtype=float),
        stats: wp.array(dtype=wp.int64),
    ):
        """A whole near-far search in one thread: the host's work-queue schedule without a launch per bucket.

        Launched with one thread. Buckets are emptied as in :func:`relax_kernel`
        with ``fifo`` (``queue`` is the work queue, its length ``counts[0]``); when
        one runs dry the threshold moves up (:func:`next_threshold`) and the far
        pile (``far_pile``, ``counts[2]``, where the seeds were queued) is split in
        place: nodes now below the threshold join the queue, unless they dropped
        below the previous one while waiting (then they were queued already), and
        the rest stay in order at the pile's front. The queue's and the pile's
        orders are those of the host's schedule, so costs, labels and the counts
        are the same. ``stats`` receives the buckets emptied and the nodes relaxed.
        A kernel compiled for a fixed count of stored weights ignores ``stride`` and
        ``n_weights`` and uses its own constants. Every array must be contiguous: the kernel
        reads them through views that assume so (:func:`dense_i32`).
        """
        flat_offsets = dense_i32(flat_offsets)
        queue = dense_i32(queue)
        far_pile = dense_i32(far_pile)
        state = dense_u64(state)
        records = dense_i32(records)
        capacity = queue.shape[0]
        directions = flat_offsets.shape[0]
        if wp.static(stored):
            stride = wp.static(record_stride(fixed_weights))
            n_weights = wp.static(fixed_weights)
            directions = wp.static(fixed_weights)
        plain = is_plain(hashed.params)
        threshold = float(-wp.inf)
        rounds = wp.int64(0)
        relaxed = wp.int64(0)
        while True:
            if counts[0] > 0:
                i = int(0)
                at = int(0)  # i modulo the ring's capacity
                while i < counts[0]:
                    node = queue[nonneg(at)]
                    at += 1
                    if at >= capacity:
                        at = 0
                    records[stamp_index(node, stride, n_weights)] = 0  # out of the work queue: it may be queued again
                    relax_node(node, flat_offsets, directions, hashed, wp.static(stored), plain, stride, n_weights, far_id,
                               threshold, limit, generation, 0, 2, state, records, counts, far_min, queue, far_pile)
                    i += 1
                relaxed += wp.int64(counts[0])
                counts[0] = 0
                rounds += wp.int64(1)
            else:
                n_far = counts[2]
                low = far_min[0]
                if n_far == 0 or not (low < wp.inf):
                    break
                previous = threshold
                threshold = next_threshold(threshold, low, delta)
                far_min[0] = wp.inf
                kept = int(0)
                for i in range(n_far):
                    node = far_pile[nonneg(i)]
                    cost = packed_cost(state_at(state, stride, node))
                    if cost < threshold:
                        if cost >= previous:
                            push_near(node, generation, records, stride, n_weights, queue, counts, 0)
                    else:
                        far_pile[nonneg(kept)] = node
                        kept += 1
                        far_min[0] = wp.min(far_min[0], cost)
                counts[2] = kept
        stats[0] = rounds
        stats[1] = relaxed

    return search_kernel


SEARCH_KERNELS = {n_weights: _one_launch_search(n_weights) for n_weights in (0,) + SEARCH_DIRECTIONS}
"""The one-launch search kernels by stored weights per record (0: any records, for hashed weights)."""


@wp.func
def nearest_edge_source(c: wp.vec3i, offset: wp.vec3i, shape: wp.vec3i) -> wp.vec3i:
    """The node whose edge along ``offset`` stands in for ``c``'s: ``c`` itself when the
    neighbour ``c + offset`` is inside, else the nearest node whose neighbour is (edges
    leaving the lattice are never used, but interpolating weights reads them)."""
    out = c
    for a in range(3):
        if shape[a] >= 2:
            if offset[a] > 0:
                out[a] = wp.min(out[a], shape[a] - 2)
            elif offset[a] < 0:
                out[a] = wp.max(out[a], 1)
    return out


@wp.kernel
def fill_records_kernel(
    usable: wp.array(dtype=wp.int32),
    listed: int,
    mask: wp.array(dtype=wp.uint8),
    params: WeightParams,
    shape: wp.vec3i,
    pad: wp.vec3i,
    offsets: wp.array(dtype=wp.vec3i),
    lengths: wp.array(dtype=float),
    stride: int,
    records: wp.array(dtype=wp.int32),
):
    """Write the weights of every usable padded node's record from a distribution.

    Launch dim: P (every padded node), or with ``listed`` the length of
    ``usable``, the padded indices of the usable nodes (sparse lattices).

    An edge into a masked node gets no weight (no search relaxes it), and
    records of masked and border nodes stay untouched, so a sparse lattice
    only touches the memory of its usable nodes. An edge leaving the lattice
    takes the weight of the nearest edge inside, as
    :func:`wdendrite.lattice.fill_outside` gives the stored arrays.
    """
    p = wp.tid()
    if listed != 0:
        p = usable[p]
    elif mask[p] == wp.uint8(0):
        return
    padded = shape + pad + pad
    c = node_coords(p, padded) - pad
    plain = is_plain(params)
    refined = params.kind == REFINED and params.num_terms == 0
    # a refined node's interpolation cells along each axis, for offsets -1, 0 and 1 (shared by its
    # directions), and its hash key: the values refined_base computes per edge
    g = params.grid
    ni = int(params.b)
    inv_n = 1.0 / params.b
    half = float(ni / 2)
    cg = c + params.grid_start
    zero = wp.vec3(0.0, 0.0, 0.0)
    zm, z0, zp, ym, y0, yp, xm, x0, xp = zero, zero, zero, zero, zero, zero, zero, zero, zero
    key = wp.uint32(0)
    if refined:
        zm = cell_of(cg[0], -1, half, inv_n, g[0])
        z0 = cell_of(cg[0], 0, half, inv_n, g[0])
        zp = cell_of(cg[0], 1, half, inv_n, g[0])
        ym = cell_of(cg[1], -1, half, inv_n, g[1])
        y0 = cell_of(cg[1], 0, half, inv_n, g[1])
        yp = cell_of(cg[1], 1, half, inv_n, g[1])
        xm = cell_of(cg[2], -1, half, inv_n, g[2])
        x0 = cell_of(cg[2], 0, half, inv_n, g[2])
        xp = cell_of(cg[2], 1, half, inv_n, g[2])
        key = refined_key(params, cg)
    k = int(0)
    while k < offsets.shape[0]:
        o = offsets[k]
        # an edge into a masked node is never relaxed: its weight is not needed (edges
        # leaving the lattice are kept, for the ``weights`` view of complete records)
        inside = in_bounds(c + o, shape)
        if not inside or mask[p + (o[0] * padded[1] + o[1]) * padded[2] + o[2]] != wp.uint8(0):
            w = float(0.0)
            if refined and inside:
                # edge_weight_of's value for no bias terms: length * (base + 0) * 1 rounds as length * base
                if refined_blocked(params, cg, o):
                    w = wp.inf
                else:
                    cz = z0
                    if o[0] > 0:
                        cz = zp
                    elif o[0] < 0:
                        cz = zm
                    cy = y0
                    if o[1] > 0:
                        cy = yp
                    elif o[1] < 0:
                        cy = ym
                    cx = x0
                    if o[2] > 0:
                        cx = xp
                    elif o[2] < 0:
                        cx = xm
                    w = lengths[k] * refined_value(params, k, cz, cy, cx, key)
            else:
                src = nearest_edge_source(c, o, shape)
                w = weight_of_edge(params, plain, shape, node_index(src, shape), src, k, o, lengths[k])
            records[p * stride + WEIGHT0 + k] = wp.cast(w, wp.int32)
        k += 1


@wp.kernel
def clear_records_kernel(stride: int, n_weights: int, with_state: int, chunk: int, records: wp.array(dtype=wp.int32)):
    """Zero every record's stamp (before the stamp ids would wrap), and with ``with_state``
    its state words too (records copied from another device); ``chunk`` records per thread."""
    start = wp.tid() * chunk
    stop = wp.min(start + chunk, records.shape[0] / stride)
    p = int(start)
    while p < stop:
        if with_state != 0:
            records[p * stride] = 0
            records[p * stride + 1] = 0
        records[stamp_index(p, stride, n_weights)] = 0
        p += 1


@wp.kernel
def set_count_kernel(slot: int, value: int, counts: wp.array(dtype=wp.int32)):
    """Set one frontier length (a one-thread launch)."""
    counts[slot] = value


@wp.func
def unpack_one(word: wp.uint64, limit: float, i: int, dist_out: wp.array(dtype=float), label_out: wp.array(dtype=wp.int32)):
    """Write output ``i`` from a packed state: cost and label, or inf and -1 when
    unreached or above ``limit``."""
    if word != UNREACHED and packed_cost(word) <= limit:
        dist_out[nonneg(i)] = packed_cost(word)
        label_out[nonneg(i)] = packed_label(word)
    else:
        dist_out[nonneg(i)] = wp.inf
        label_out[nonneg(i)] = -1


@wp.func
def row_run(i: int, stop: int, shape: wp.vec3i, pad: wp.vec3i) -> wp.vec2i:
    """The padded index of unpadded node ``i`` and the end (at most ``stop``) of the run
    of nodes from ``i`` along its row, whose padded indices follow each other: passes
    over consecutive nodes take a row at a time, with one division per row."""
    x = i % shape[2]
    return wp.vec2i(padded_index(i, shape, pad), wp.min(stop, i + shape[2] - x))


@wp.func
def in_band(word: wp.uint64, limit: float, low: float, high: float) -> bool:
    """Whether a packed state holds a searched cost ``c`` (within ``limit``) with ``low < c < high``."""
    if word == UNREACHED:
        return False
    c = packed_cost(word)
    return c <= limit and c > low and c < high


@wp.func
def pass_node(
    word: wp.uint64,
    usable: bool,
    j: int,
    band: int,
    limit: float,
    low: float,
    high: float,
    dist_out: wp.array(dtype=float),
    label_out: wp.array(dtype=wp.int32),
    count: wp.array(dtype=wp.int32),
    nodes_out: wp.array(dtype=wp.int32),
):
    """One node of :func:`records_pass_kernel`: unpack its state into output ``j``
    (inf and -1 unless usable), or with ``band`` list ``j`` if its cost is in the band."""
    if band != 0:
        if usable and in_band(word, limit, low, high):
            nodes_out[nonneg(wp.atomic_add(count, 0, 1))] = j
    else:
        if not usable:
            word = UNREACHED
        unpack_one(word, limit, j, dist_out, label_out)


@wp.kernel
def records_pass_kernel(
    usable: wp.array(dtype=wp.int32),
    listed: int,
    state: wp.array(dtype=wp.uint64),
    mask: wp.array(dtype=wp.uint8),
    shape: wp.vec3i,
    pad: wp.vec3i,
    stride: int,
    limit: float,
    band: int,
    low: float,
    high: float,
    chunk: int,
    dist_out: wp.array(dtype=float),
    label_out: wp.array(dtype=wp.int32),
    count: wp.array(dtype=wp.int32),
    nodes_out: wp.array(dtype=wp.int32),
):
    """One pass over the records' packed states, in node order.

    Without ``band``: split them into costs (inf when unreached or above
    ``limit``) and labels (-1), ``dist_out`` and ``label_out`` of the unpadded
    shape. With ``band``: list in ``nodes_out`` the (unpadded) indices of the
    usable nodes whose cost lies in ``(low, high)``, ``count`` of them.

    Launch dim: ``chunk`` consecutive nodes per thread, a row at a time (see
    :func:`row_run`; one thread lists in ascending order), or with ``listed``
    one thread per entry of ``usable``, the padded indices of the usable nodes
    of a sparse lattice (whose outputs already hold inf and -1 elsewhere): a
    sparse lattice's other records are never read.
    """
    if listed != 0:
        p = usable[wp.tid()]
        j = node_index(node_coords(p, shape + pad + pad) - pad, shape)
        pass_node(state_at(state, stride, p), True, j, band, limit, low, high, dist_out, label_out, count, nodes_out)
        return
    start = wp.tid() * chunk
    stop = wp.min(start + chunk, shape[0] * shape[1] * shape[2])
    if start >= stop:
        return
    sstride = stride >> 1
    i = start
    while i < stop:
        run = row_run(i, stop, shape, pad)
        p = run[0] - i
        j = int(i)
        while j < run[1]:
            usable_node = mask[nonneg(p + j)] != wp.uint8(0)
            word = UNREACHED
            if usable_node:
                word = state[nonneg((p + j) * sstride)]
            pass_node(word, usable_node, j, band, limit, low, high, dist_out, label_out, count, nodes_out)
            j += 1
        i = run[1]


@wp.kernel
def read_states_kernel(
    nodes: wp.array(dtype=wp.int32),
    state: wp.array(dtype=wp.uint64),
    stride: int,
    limit: float,
    cost_out: wp.array(dtype=float),
    label_out: wp.array(dtype=wp.int32),
):
    """Costs and labels of the listed padded nodes, as :func:`unpack_one` gives them."""
    i = wp.tid()
    unpack_one(state_at(state, stride, nodes[i]), limit, i, cost_out, label_out)


