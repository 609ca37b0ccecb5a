"""Greedy backtracking from endpoints to generators on a packed cost field.

The packed states are those a search leaves in the lattice's node records
(``state``, see :mod:`wdendrite.kernels.sssp`).

A node's predecessor is the first neighbour ``u`` (half-offset order, the
``+offset`` neighbour before the ``-offset`` one) whose packed word, extended
by the edge ``u -> node``, reproduces the node's packed word exactly:
``pack(cost[u] + w, label[u]) == packed[node]`` (see :func:`predecessor` for
weights that vanish in float32 rounding). The choice depends only on the cost
field: paths that meet share the rest of the way, so the union of all walks is
a forest.

The search set every word as such a minimum, but a neighbour's word may have
dropped since: when ``u`` first offered ``(c, 0)`` from a costlier path and
later reached a lower cost from generator 1 whose extension rounds to the same
``c``, the node keeps ``(c, 0)`` (the lower label wins the tie) while no
neighbour reproduces it any more. The walk then takes the first neighbour that
reproduces the cost alone, from a strictly lower cost, and leaves the path in
generator 1's region; the host relabels such paths by the generator they reach.
"""

import warp as wp

from . import OPTIONS
from .indexing import nonneg
from .sssp import UNREACHED, HashedWeights, edge_cost, pack_cost, packed_cost, packed_label, stamp_index, state_at

wp.set_module_options({**OPTIONS, "optimization_level": 3})

TRACE_OK = wp.constant(0)
TRACE_UNREACHABLE = wp.constant(1)
TRACE_STUCK = wp.constant(2)


@wp.func
def predecessor(
    node: int,
    flat_offsets: wp.array(dtype=wp.int32),
    records: wp.array(dtype=wp.int32),
    stride: int,
    hashed: HashedWeights,
    mask: wp.array(dtype=wp.uint8),
    state: wp.array(dtype=wp.uint64),
    hops: wp.array(dtype=wp.int32),
    use_hops: int,
) -> int:
    """The neighbour a least-cost path to ``node`` comes from (-1 if none).

    A neighbour qualifies when its word plus the edge reproduces ``node``'s
    word. Normally its own word is smaller; when an edge weight vanishes in
    float32 rounding next to a large cost, a neighbour with the *same* word
    qualifies too (a *plateau* of equal words), and to keep walks from
    circling such neighbours are taken only after strictly smaller ones, and
    only toward a lower node index or, with ``use_hops``, toward a node one
    step nearer the plateau's way out (``hops``, counted by the host when a
    walk found no lower index to go to; 0 where a plateau is left).
    When no neighbour reproduces the word (a tie the search's label kept, see
    the module docstring), the first one reproducing the cost from a lower
    cost is taken.
    """
    word = state_at(state, stride, node)
    level_match = int(-1)
    cost_match = int(-1)
    k = int(0)
    while k < flat_offsets.shape[0]:
        for side in range(2):
            other = node + flat_offsets[k]
            lower = node
            if side == 1:
                other = node - flat_offsets[k]
                lower = other
            # a word above this node's never matches (adding a weight only raises the cost), and
            # unreached neighbours hold the largest word: only lower or equal words are tested
            src = state_at(state, stride, other)
            if src <= word:
                if mask[nonneg(other)] != wp.uint8(0):
                    offer = pack_cost(packed_cost(src) + edge_cost(records, stride, hashed, lower, k), packed_label(src))
                    if offer == word:
                        if src < word:
                            return other
                        if level_match < 0:
                            if use_hops == 0:
                                if other < node:
                                    level_match = other
                            elif hops[node] > 0 and hops[other] == hops[node] - 1:
                                level_match = other
                    elif cost_match < 0 and (offer >> wp.uint64(32)) == (word >> wp.uint64(32)):
                        # the cost alone, from a strictly lower cost (so walks cannot circle)
                        if packed_cost(src) < packed_cost(word):
                            cost_match = other
        k += 1
    if level_match >= 0:
        return level_match
    return cost_match


@wp.kernel
def trace_kernel(
    starts: wp.array(dtype=wp.int32),
    flat_offsets: wp.array(dtype=wp.int32),
    stride: int,
    n_weights: int,
    hashed: HashedWeights,
    mask: wp.array(dtype=wp.uint8),
    state: wp.array(dtype=wp.uint64),
    root_id: int,
    visit_id: int,
    zero_claimed: int,
    max_steps: int,
    hops: wp.array(dtype=wp.int32),
    use_hops: int,
    records: wp.array(dtype=wp.int32),
    new_nodes_out: wp.array(dtype=wp.int32),
    new_pred_out: wp.array(dtype=wp.int32),
    new_count: wp.array(dtype=wp.int32),
    status_out: wp.array(dtype=wp.int32),
    new_cost_out: wp.array(dtype=float),
    new_label_out: wp.array(dtype=wp.int32),
):
    """Walk from each start to a root, listing each new node with its predecessor.

    The walk marks live in the records' stamp words (word ``n_weights + 2``, which
    searches only compare with their own, newer ids): ``visit_id`` on nodes
    a walk has claimed (or the dendrite being extended already holds),
    ``root_id`` on unclaimed generators. A walk stops at a root (a new node
    with predecessor -1) or at a claimed node, from where the path is
    shared. With ``zero_claimed`` (the dendrite's nodes are generators, which
    the host then leaves unmarked), a node of cost 0 not marked a root counts
    as claimed. New node ``j`` is ``new_nodes_out[j]``, its predecessor
    ``new_pred_out[j]``, its cost and label ``new_cost_out[j]``, ``new_label_out[j]``
    (walks start at nodes within the search's limit and only descend).
    """
    i = wp.tid()
    node = starts[i]
    status_out[i] = TRACE_OK
    step = int(0)
    while step < max_steps:
        seen = wp.atomic_exch(records, stamp_index(node, stride, n_weights), visit_id)
        if seen == visit_id:
            return
        word = state_at(state, stride, node)
        if zero_claimed != 0 and seen != root_id and packed_cost(word) == 0.0:
            return
        at = nonneg(wp.atomic_add(new_count, 0, 1))
        new_nodes_out[at] = node
        new_cost_out[at] = packed_cost(word)
        new_label_out[at] = packed_label(word)
        if seen == root_id:
            new_pred_out[at] = -1
            return
        if word == UNREACHED:
            new_pred_out[at] = -1
            status_out[i] = TRACE_UNREACHABLE
            return
        prev = predecessor(node, flat_offsets, records, stride, hashed, mask, state, hops, use_hops)
        new_pred_out[at] = prev
        if prev < 0:
            status_out[i] = TRACE_STUCK
            return
        node = prev
        step += 1
    status_out[i] = TRACE_STUCK


@wp.kernel
def stamp_kernel(nodes_in: wp.array(dtype=wp.int32), stride: int, n_weights: int, value: int,
                 records: wp.array(dtype=wp.int32)):
    """Set the record stamp of each listed padded node to ``value``."""
    records[stamp_index(nodes_in[wp.tid()], stride, n_weights)] = value
