"""Near-far (delta-stepping) relaxation kernels for lattice shortest paths.

A node's state is one ``uint64`` word: the float32 bits of its cost in the
high half and the row of its generator in the low half. Non-negative float32
values order like their bit patterns, so ``wp.atomic_min`` on the packed word
keeps the least cost and, among equal costs, the lowest generator row. The
minimum does not depend on the order in which threads arrive, so the result
is bit-identical run to run on a device.

Kernels index a *padded* lattice: the lattice with a one-node border (in
x, y and, for 3D, z), so a neighbour is always ``node + flat_offsets[k]``. The
border and masked-out nodes hold the packed word 0, which no candidate can
undercut, so they are never entered and need no test.

Frontiers are flat ``int32`` node lists with their lengths kept in a small
``counts`` array; a node enters a "near" list at most once per generation
(``stamp``) and the "far" pile at most once (``in_far``).
"""

import warp as wp

from .lattice import node_coords, padded_index
from .weights import WeightParams, edge_weight_at

wp.set_module_options({"enable_backward": False, "optimization_level": 3})

UNREACHED = wp.constant(wp.uint64(0xFFFFFFFFFFFFFFFF))
"""Packed state of a node no path has reached."""


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
def edge_cost(weights: wp.array(dtype=float), hashed: HashedWeights, lower: int, k: int) -> float:
    """Weight of the padded lattice's edge ``lower <-> lower + flat_offsets[k]``."""
    if hashed.use == 0:
        return weights[k * (weights.shape[0] / hashed.offsets.shape[0]) + lower]
    padded = hashed.shape3 + hashed.pad3 + hashed.pad3
    coords = node_coords(lower, padded) - hashed.pad3
    return edge_weight_at(hashed.params, hashed.shape3, coords, k, hashed.offsets[k], hashed.lengths[k])


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
    in_far: wp.array(dtype=wp.int32),
    far_out: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_slot: int,
    far_min: wp.array(dtype=float),
):
    """Add ``node`` to the far pile once, and keep the pile's least cost."""
    if wp.atomic_exch(in_far, node, 1) == 0:
        far_out[wp.atomic_add(counts, far_slot, 1)] = node
    wp.atomic_min(far_min, 0, cost)


@wp.func
def push_near(
    node: int,
    generation: int,
    stamp: wp.array(dtype=wp.int32),
    near_out: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    near_slot: int,
):
    """Add ``node`` to the near list of ``generation`` once (the list is a ring of its capacity)."""
    if wp.atomic_exch(stamp, node, generation) != generation:
        near_out[wp.atomic_add(counts, near_slot, 1) % near_out.shape[0]] = node


@wp.kernel
def init_state_kernel(mask: wp.array(dtype=wp.uint8), chunk: int, packed_out: wp.array(dtype=wp.uint64)):
    """Unreached usable nodes, blocked (word 0) masked and border nodes; ``chunk`` nodes per thread."""
    start = wp.tid() * chunk
    for i in range(start, wp.min(start + chunk, mask.shape[0])):
        if mask[i] != wp.uint8(0):
            packed_out[i] = UNREACHED
        else:
            packed_out[i] = wp.uint64(0)


@wp.kernel
def seed_kernel(
    nodes_in: wp.array(dtype=wp.int32),
    labels_in: wp.array(dtype=wp.int32),
    far_slot: int,
    packed: wp.array(dtype=wp.uint64),
    in_far: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_min: wp.array(dtype=float),
    far_out: wp.array(dtype=wp.int32),
):
    """Give each generator node cost 0 and its row as label; queue it."""
    i = wp.tid()
    node = nodes_in[i]
    word = pack_cost(0.0, labels_in[i])
    if word < wp.atomic_min(packed, node, word):
        push_far(node, 0.0, in_far, far_out, counts, far_slot, far_min)


@wp.kernel
def mark_lowered_kernel(
    flat_offsets: wp.array(dtype=wp.int32),
    mask: wp.array(dtype=wp.uint8),
    old_weights: wp.array(dtype=float),
    new_weights: wp.array(dtype=float),
    far_slot: int,
    packed: wp.array(dtype=wp.uint64),
    in_far: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_min: wp.array(dtype=float),
    far_out: wp.array(dtype=wp.int32),
):
    """Queue both ends of every edge whose weight went down (warm start)."""
    node = wp.tid()
    if mask[node] == wp.uint8(0):
        return
    count = mask.shape[0]
    for k in range(flat_offsets.shape[0]):
        e = k * count + node
        other = node + flat_offsets[k]
        if new_weights[e] < old_weights[e] and mask[other] != wp.uint8(0):
            for end in range(2):
                n = node
                if end == 1:
                    n = other
                word = packed[n]
                if word != UNREACHED:
                    push_far(n, packed_cost(word), in_far, far_out, counts, far_slot, far_min)


@wp.func
def relax_edge(
    other: int,
    new_cost: float,
    label: int,
    threshold: float,
    limit: float,
    generation: int,
    near_slot: int,
    far_slot: int,
    packed: wp.array(dtype=wp.uint64),
    stamp: wp.array(dtype=wp.int32),
    in_far: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_min: wp.array(dtype=float),
    near_out: wp.array(dtype=wp.int32),
    far_out: wp.array(dtype=wp.int32),
):
    """Offer ``other`` the cost ``new_cost`` from generator ``label``; queue it if it improved."""
    if new_cost <= limit:
        candidate = pack_cost(new_cost, label)
        if candidate < packed[other]:
            if candidate < wp.atomic_min(packed, other, candidate):
                if new_cost < threshold:
                    push_near(other, generation, stamp, near_out, counts, near_slot)
                else:
                    push_far(other, new_cost, in_far, far_out, counts, far_slot, far_min)


@wp.kernel
def relax_kernel(
    flat_offsets: wp.array(dtype=wp.int32),
    weights: wp.array(dtype=float),
    hashed: HashedWeights,
    near_in: wp.array(dtype=wp.int32),
    in_slot: int,
    threads: int,
    fifo: int,
    threshold: float,
    limit: float,
    generation: int,
    near_slot: int,
    far_slot: int,
    packed: wp.array(dtype=wp.uint64),
    stamp: wp.array(dtype=wp.int32),
    in_far: wp.array(dtype=wp.int32),
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
    never written. ``weights[k * P + p]`` is the edge ``p <-> p + flat_offsets[k]``
    of the padded lattice of P nodes, unless ``hashed.use`` asks for weights
    recomputed from their hash.
    """
    count = packed.shape[0]
    capacity = near_in.shape[0]
    i = wp.tid()
    while i < counts[in_slot]:
        node = near_in[i % capacity]
        if fifo != 0:
            stamp[node] = 0
        word = packed[node]
        cost = packed_cost(word)
        label = packed_label(word)
        for k in range(flat_offsets.shape[0]):
            step = flat_offsets[k]
            # forward edge stored at this node, backward edge stored at the neighbour
            w_fwd = float(0.0)
            w_bwd = float(0.0)
            if hashed.use == 0:
                w_fwd = weights[k * count + node]
                w_bwd = weights[k * count + node - step]
            else:
                w_fwd = edge_cost(weights, hashed, node, k)
                w_bwd = edge_cost(weights, hashed, node - step, k)
            relax_edge(node + step, cost + w_fwd, label, threshold, limit, generation,
                       near_slot, far_slot, packed, stamp, in_far, counts, far_min, near_out, far_out)
            relax_edge(node - step, cost + w_bwd, label, threshold, limit, generation,
                       near_slot, far_slot, packed, stamp, in_far, counts, far_min, near_out, far_out)
        i += threads


@wp.kernel
def split_far_kernel(
    far_in: wp.array(dtype=wp.int32),
    in_slot: int,
    threads: int,
    previous_threshold: float,
    threshold: float,
    generation: int,
    near_slot: int,
    far_slot: int,
    packed: wp.array(dtype=wp.uint64),
    stamp: wp.array(dtype=wp.int32),
    in_far: wp.array(dtype=wp.int32),
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
        node = far_in[i]
        cost = packed_cost(packed[node])
        if cost < threshold:
            in_far[node] = 0
            if cost >= previous_threshold:
                push_near(node, generation, stamp, near_out, counts, near_slot)
        else:
            far_out[wp.atomic_add(counts, far_slot, 1)] = node
            wp.atomic_min(far_min, 0, cost)
        i += threads


@wp.kernel
def set_count_kernel(slot: int, value: int, counts: wp.array(dtype=wp.int32)):
    """Set one frontier length (a one-thread launch)."""
    counts[slot] = value


@wp.kernel
def unpack_kernel(
    packed: wp.array(dtype=wp.uint64),
    mask: wp.array(dtype=wp.uint8),
    shape: wp.vec3i,
    pad: wp.vec3i,
    limit: float,
    chunk: int,
    dist_out: wp.array(dtype=float),
    label_out: wp.array(dtype=wp.int32),
):
    """Split the padded packed states into costs (inf when unreached or above ``limit``) and labels (-1).

    Each thread handles ``chunk`` consecutive nodes.
    """
    start = wp.tid() * chunk
    for i in range(start, wp.min(start + chunk, dist_out.shape[0])):
        p = padded_index(i, shape, pad)
        word = packed[p]
        if word == UNREACHED or mask[p] == wp.uint8(0) or packed_cost(word) > limit:
            dist_out[i] = wp.inf
            label_out[i] = -1
        else:
            dist_out[i] = packed_cost(word)
            label_out[i] = packed_label(word)
