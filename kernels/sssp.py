"""Near-far (delta-stepping) relaxation kernels for lattice shortest paths.

A node's state is one ``uint64`` word: the float32 bits of its cost in the
high half and the row of its generator in the low half. Non-negative float32
values order like their bit patterns, so ``wp.atomic_min`` on the packed word
keeps the least cost and, among equal costs, the lowest generator row. The
minimum does not depend on the order in which threads arrive, so the result
is bit-identical run to run on a device.

Frontiers are flat ``int32`` node lists with their lengths kept in a small
``counts`` array; a node enters a "near" list at most once per generation
(``stamp``) and the "far" pile at most once (``in_far``).
"""

import warp as wp

from .lattice import in_bounds, node_coords, node_index

wp.set_module_options({"enable_backward": False})

UNREACHED = wp.constant(wp.uint64(0xFFFFFFFFFFFFFFFF))
"""Packed state of a node no path has reached."""


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
    """Add ``node`` to the near list of ``generation`` once."""
    if wp.atomic_exch(stamp, node, generation) != generation:
        near_out[wp.atomic_add(counts, near_slot, 1)] = node


@wp.kernel
def seed_kernel(
    nodes_in: wp.array(dtype=wp.int32),
    labels_in: wp.array(dtype=wp.int32),
    packed: wp.array(dtype=wp.uint64),
    in_far: wp.array(dtype=wp.int32),
    far_out: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_slot: int,
    far_min: wp.array(dtype=float),
):
    """Give each generator node cost 0 and its row as label; queue it."""
    i = wp.tid()
    node = nodes_in[i]
    word = pack_cost(0.0, labels_in[i])
    if word < wp.atomic_min(packed, node, word):
        push_far(node, 0.0, in_far, far_out, counts, far_slot, far_min)


@wp.kernel
def mark_lowered_kernel(
    shape: wp.vec3i,
    offsets: wp.array(dtype=wp.vec3i),
    mask: wp.array(dtype=wp.uint8),
    old_weights: wp.array(dtype=float),
    new_weights: wp.array(dtype=float),
    packed: wp.array(dtype=wp.uint64),
    in_far: wp.array(dtype=wp.int32),
    far_out: wp.array(dtype=wp.int32),
    counts: wp.array(dtype=wp.int32),
    far_slot: int,
    far_min: wp.array(dtype=float),
):
    """Queue both ends of every edge whose weight went down (warm start)."""
    node = wp.tid()
    if mask[node] == wp.uint8(0):
        return
    count = shape[0] * shape[1] * shape[2]
    here = node_coords(node, shape)
    for k in range(offsets.shape[0]):
        e = k * count + node
        if new_weights[e] < old_weights[e]:
            there = here + offsets[k]
            if in_bounds(there, shape):
                other = node_index(there, shape)
                if mask[other] != wp.uint8(0):
                    for end in range(2):
                        n = node
                        if end == 1:
                            n = other
                        word = packed[n]
                        if word != UNREACHED:
                            push_far(n, packed_cost(word), in_far, far_out, counts, far_slot, far_min)


@wp.kernel
def relax_kernel(
    shape: wp.vec3i,
    offsets: wp.array(dtype=wp.vec3i),
    weights: wp.array(dtype=float),
    mask: wp.array(dtype=wp.uint8),
    near_in: wp.array(dtype=wp.int32),
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

    A neighbour whose packed state drops is queued in the next near list when
    its cost is below ``threshold`` and in the far pile otherwise; costs above
    ``limit`` are never written.
    """
    node = near_in[wp.tid()]
    word = packed[node]
    cost = packed_cost(word)
    label = packed_label(word)
    count = shape[0] * shape[1] * shape[2]
    here = node_coords(node, shape)
    for k in range(offsets.shape[0]):
        for side in range(2):
            there = here + offsets[k]
            if side == 1:
                there = here - offsets[k]
            if in_bounds(there, shape):
                other = node_index(there, shape)
                if mask[other] != wp.uint8(0):
                    # the weight of an undirected edge is stored at its lower end
                    e = k * count + node
                    if side == 1:
                        e = k * count + other
                    new_cost = cost + weights[e]
                    if new_cost <= limit:
                        candidate = pack_cost(new_cost, label)
                        if candidate < wp.atomic_min(packed, other, candidate):
                            if new_cost < threshold:
                                push_near(other, generation, stamp, near_out, counts, near_slot)
                            else:
                                push_far(other, new_cost, in_far, far_out, counts, far_slot, far_min)


@wp.kernel
def split_far_kernel(
    far_in: wp.array(dtype=wp.int32),
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
    node = far_in[wp.tid()]
    cost = packed_cost(packed[node])
    if cost < threshold:
        in_far[node] = 0
        if cost >= previous_threshold:
            push_near(node, generation, stamp, near_out, counts, near_slot)
    else:
        far_out[wp.atomic_add(counts, far_slot, 1)] = node
        wp.atomic_min(far_min, 0, cost)


@wp.kernel
def set_count_kernel(slot: int, value: int, counts: wp.array(dtype=wp.int32)):
    """Set one frontier length (a one-thread launch)."""
    counts[slot] = value


@wp.kernel
def unpack_kernel(
    packed: wp.array(dtype=wp.uint64),
    dist_out: wp.array(dtype=float),
    label_out: wp.array(dtype=wp.int32),
):
    """Split packed states into costs (inf when unreached) and labels (-1)."""
    i = wp.tid()
    word = packed[i]
    if word == UNREACHED:
        dist_out[i] = wp.inf
        label_out[i] = -1
    else:
        dist_out[i] = packed_cost(word)
        label_out[i] = packed_label(word)
