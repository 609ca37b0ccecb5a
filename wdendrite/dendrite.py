"""Dendrites: forests of least-cost paths traced back from endpoints to generators."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import warp as wp

from . import _checks, _memory
from .kernels import dendrite as _kd
from .lattice import coords_of_padded, edge_slices, padded_index_of
from .sssp import CostField, load_state, read_states

__all__ = ["Dendrite", "trace"]


@dataclass(frozen=True, eq=False)
class Dendrite:
    """A forest of lattice paths, each node pointing toward its generator.

    Nodes are listed in the order they were added (one block per :func:`trace`
    call, sorted by lattice index within a block), so a dendrite grown further
    keeps the rows it had.

    Paths that meet at a node share the rest of the way down, so branches never
    cross at a node. On 8- and 26-connected lattices two diagonal edges of
    different branches can still cross inside one lattice cell without a node
    in common (shortest paths on such lattices allow it; the papers' lattices do too).

    Attributes:
        shape: the lattice shape.
        nodes: ``(N, ndim)`` int64 node coordinates, (row, col) = (y, x) in 2D and (z, y, x) in 3D,
            as numpy indexes (``image[tuple(nodes.T)]``).
        parent: ``(N,)`` int64 row of the next node toward the root; -1 at roots
            (generator nodes).
        cost: ``(N,)`` float32 path cost from the node's generator along the
            dendrite: the cost field's ``dist`` for a traced dendrite; for a grown
            one each new branch continues the cost of the node it joins.
        label: ``(N,)`` int32 row of the generator (in the cost field's
            generator list) the node's path leads to: the cost field's
            ``label`` there, except where a float32 tie let the search keep
            another generator's row (the path then shows which one it reaches).
            Branches traced onto a dendrite (``trace(extend=...)``) take the
            label of the node they join.
        generation: ``(N,)`` int32 growth iteration that added the node (0 first).
        endpoints: ``(M,)`` int64 rows of the nodes paths were traced from.
        origin, spacing: place nodes in the world (see :attr:`positions`).
    """

    shape: tuple
    nodes: np.ndarray
    parent: np.ndarray
    cost: np.ndarray
    label: np.ndarray
    generation: np.ndarray
    endpoints: np.ndarray
    _padded: np.ndarray = field(repr=False)
    origin: tuple = None
    """World position of node (0, ...) (default: the origin)."""
    spacing: float = 1.0
    """World distance between neighbouring nodes (refined dendrites use 1/n of their source's)."""

    def __post_init__(self):
        if self.origin is None:
            object.__setattr__(self, "origin", (0.0,) * len(self.shape))
        self._check_index()
        self._freeze()

    def _check_index(self) -> None:
        """Refuse a node index (``_padded``) made for other nodes or another shape: what
        :func:`dataclasses.replace` with new ``nodes`` or ``shape`` would give, which walks that
        extend the dendrite read (they had stopped at the old positions). Up to 257 evenly spaced
        rows are compared, so the check costs the same for any dendrite."""
        n = len(self.nodes)
        rows = np.unique(np.linspace(0, n - 1, min(n, 257)).astype(np.int64)) if n else np.zeros(0, np.int64)
        some = np.asarray(self.nodes)[rows]
        inside = np.all((some >= 0) & (some < np.asarray(self.shape)))
        if len(self._padded) != n or not inside or not np.array_equal(self._padded[rows],
                                                                      padded_index_of(some, self.shape)):
            raise ValueError("this dendrite's node index does not match its 'nodes' and 'shape' (dataclasses.replace "
                             "cannot move a dendrite: its rows, parents and checks go with them); make the moved one "
                             "with Dendrite.from_arrays")

    def __setstate__(self, state):
        # unpickled and deep-copied dendrites get fresh, writeable arrays: freeze them again
        self.__dict__.update(state)
        self._freeze()

    def _freeze(self) -> None:
        """Make every array read-only views, as a Lattice's and a CostField's arrays are: a write
        would leave the cached properties (depth, ...) describing another dendrite, or a write to
        one of those would change what later uses of it see (the caller's arrays stay writeable)."""
        for name, value in list(self.__dict__.items()):
            if isinstance(value, np.ndarray) and value.flags.writeable:
                self.__dict__[name] = _read_only(value)

    @property
    def positions(self) -> np.ndarray:
        """``(N, ndim)`` float64 world positions ``origin + nodes * spacing``."""
        return np.asarray(self.origin, np.float64) + self.nodes * float(self.spacing)

    @classmethod
    def from_arrays(
        cls, shape, nodes, parent, *, cost=None, label=None, generation=None, endpoints=None, origin=None,
        spacing: float = 1.0,
    ) -> Dendrite:
        """A dendrite from plain arrays (e.g. read from a file), validated.

        Args:
            shape: the lattice shape.
            nodes: ``(N, ndim)`` int coordinates, distinct and inside ``shape``.
            parent: ``(N,)`` int rows, -1 at roots; must form a forest.
            cost, label, generation: ``(N,)`` per-node values (default 0).
            endpoints: rows paths were traced from (default: the leaves).
            origin, spacing: placement in the world.
        """
        shape = _checks.lattice_shape(shape)
        nodes = _checks.integer_array("nodes", nodes, "coordinates")
        if nodes.ndim != 2 or nodes.shape[1] != len(shape):
            raise ValueError(f"Expected 'nodes' of shape (N, {len(shape)}), but got shape {nodes.shape}")
        n = len(nodes)
        outside = np.any((nodes < 0) | (nodes >= np.asarray(shape)), axis=1)
        if outside.any():
            row = int(np.argmax(outside))
            raise ValueError(f"'nodes' row {row} = {tuple(nodes[row].tolist())} lies outside the lattice of shape {shape}")
        parent = _checks.integer_array("parent", parent, "rows").reshape(-1)
        if parent.shape != (n,):
            raise ValueError(f"Expected 'parent' of shape ({n},), but got shape {parent.shape}")
        wrong = (parent < -1) | (parent >= n)
        if wrong.any():
            row = int(np.argmax(wrong))
            raise ValueError(f"'parent' row {row} = {int(parent[row])} is not a row in [-1, {n})")
        padded = padded_index_of(nodes, shape)
        if len(np.unique(padded)) != n:
            raise ValueError("'nodes' lists a node twice")

        def per_node(name, value, dtype, low=None):
            if value is None:
                return np.zeros(n, dtype)
            if np.dtype(dtype).kind == "i":
                arr = _checks.integer_array(name, value).reshape(-1)
                info = np.iinfo(dtype)
                low = info.min if low is None else low
                if arr.size and (arr.min() < low or arr.max() > info.max):
                    raise ValueError(f"'{name}' must lie in [{low}, {info.max}], but ranges over "
                                     f"[{arr.min()}, {arr.max()}]")
                arr = arr.astype(dtype)
            elif np.size(value) == 0:
                arr = np.zeros(0, dtype)
            else:
                # a copy: finite_array hands back the caller's own array when it is already float32
                arr = np.array(_checks.finite_array(name, value, "1D (N,)", lambda s: True, dtype=dtype).reshape(-1))
            if arr.shape != (n,):
                raise ValueError(f"Expected '{name}' of shape ({n},), but got shape {arr.shape}")
            return arr

        child = np.flatnonzero(parent >= 0)
        steps = np.abs(nodes[parent[child]] - nodes[child]).max(axis=1) if len(child) else np.zeros(0)
        if np.any(steps != 1):
            row = int(child[np.argmax(steps != 1)])
            raise ValueError(f"'parent' row {row} is not a lattice neighbour of node {tuple(nodes[row].tolist())}")
        if endpoints is None:
            has_child = np.zeros(n, bool)
            has_child[parent[child]] = True
            endpoints = np.flatnonzero(~has_child)
        endpoints = _checks.integer_array("endpoints", endpoints, "rows").reshape(-1)
        if endpoints.size and (endpoints.min() < 0 or endpoints.max() >= n):
            raise ValueError(f"'endpoints' must be rows in [0, {n}), but range over [{endpoints.min()}, {endpoints.max()}]")
        _, first, seen = np.unique(endpoints, return_index=True, return_counts=True)
        if (seen > 1).any():  # (downstream would count it twice; trace keeps each endpoint once)
            row = int(endpoints[np.sort(first[seen > 1])[0]])
            raise ValueError(f"'endpoints' lists row {row} more than once; give each endpoint once")
        if origin is not None:
            origin = tuple(_checks.finite_array("origin", origin, f"({len(shape)},)", lambda s: s == (len(shape),),
                                                dtype=np.float64).tolist())
        den = cls(shape, nodes, parent, per_node("cost", cost, np.float32), per_node("label", label, np.int32, 0),
                  per_node("generation", generation, np.int32, 0), endpoints,
                  padded, origin, _checks.positive("spacing", spacing))
        den.depth  # raises on a cycle
        return den

    def __len__(self) -> int:
        return len(self.nodes)

    def __repr__(self) -> str:
        gens = int(self.generation.max()) + 1 if len(self) else 0
        return (f"Dendrite(shape={self.shape}, nodes={len(self)}, roots={len(self.roots)}, "
                f"endpoints={len(self.endpoints)}, generations={gens})")

    @property
    def ndim(self) -> int:
        return len(self.shape)

    @property
    def roots(self) -> np.ndarray:
        """Rows of the root nodes (generators reached by some path)."""
        return np.flatnonzero(self.parent < 0)

    @cached_property
    def depth(self) -> np.ndarray:
        """``(N,)`` int64 number of edges between each node and its root."""
        depth = (self.parent >= 0).astype(np.int64)
        anc = self.parent.copy()
        # pointer jumping: depth[i] counts the edges up to anc[i]; each round doubles the jump
        for _ in range(2 + int(np.log2(max(len(self), 1)))):
            live = np.flatnonzero(anc >= 0)
            if not len(live):
                return _read_only(depth)
            up = anc[live]
            depth[live] = depth[live] + depth[up]
            anc[live] = anc[up]
        raise ValueError("'parent' has a cycle: the dendrite is not a forest")

    @cached_property
    def order(self) -> np.ndarray:
        """Rows sorted from the roots outward (every parent before its children)."""
        return _read_only(np.argsort(self.depth, kind="stable"))

    @cached_property
    def downstream(self) -> np.ndarray:
        """``(N,)`` int64 number of endpoints whose path passes through each node (itself included)."""
        count = np.zeros(len(self), np.int64)
        np.add.at(count, self.endpoints, 1)
        depth = self.depth
        rows = self.order[::-1]
        # accumulate level by level, deepest first, so children are complete before parents
        bounds = np.flatnonzero(np.diff(depth[rows])) + 1
        for level in np.split(rows, bounds):
            p = self.parent[level]
            ok = p >= 0
            np.add.at(count, p[ok], count[level[ok]])
        return _read_only(count)

    def path(self, row: int) -> np.ndarray:
        """``(L,)`` int64 rows from node ``row`` to its root (both included).

        Raises:
            TypeError, ValueError: ``row`` not an integer in ``[0, len(self))``.
        """
        n = len(self)
        if _checks.integer("row", row) < 0 or row >= n:  # (a negative row would count from the end)
            raise ValueError(f"Expected 'row' in [0, {n}), the dendrite's rows, but got {row!r}")
        out = [int(row)]
        while self.parent[out[-1]] >= 0:
            out.append(int(self.parent[out[-1]]))
        return np.asarray(out, dtype=np.int64)

    def paths(self) -> list[np.ndarray]:
        """The path of every endpoint, in ``endpoints`` order: a list of ``(L,)`` int64 rows from the
        endpoint to its root (a new list each call; ``len(den.paths()) == len(den.endpoints)``)."""
        return [self.path(e) for e in self.endpoints]


def _read_only(arr: np.ndarray) -> np.ndarray:
    """A read-only view of ``arr`` (the array itself stays as it was)."""
    view = arr.view()
    view.flags.writeable = False
    return view


def _endpoint_rows(extend: Dendrite | None, rows: np.ndarray, n: int) -> np.ndarray:
    """Sorted distinct endpoint rows of a dendrite of ``n`` rows: ``extend``'s and ``rows``."""
    flag = np.zeros(n, bool)
    if extend is not None:
        flag[extend.endpoints] = True
    flag[rows] = True
    return np.flatnonzero(flag)


def _path_labels(label: np.ndarray, parent: np.ndarray, old_label: np.ndarray) -> np.ndarray:
    """The new nodes' labels as the generator their paths reach: each takes the label of the
    last new node on its way down, which is its own (a root) or, where it joins the dendrite
    being extended, the label of the node it joins.

    ``parent`` numbers rows with the ``len(old_label)`` old rows first. Walks keep a label along
    exact steps, so only joins and steps by cost alone (a float32 tie, see
    :mod:`wdendrite.kernels.dendrite`) can change anything; the rest is worked out by pointer
    jumping (a few passes, however long the paths).
    """
    n_old = len(old_label)
    own = label.copy()
    joins = (parent >= 0) & (parent < n_old)
    own[joins] = old_label[parent[joins]]
    up = np.where(parent >= n_old, parent - n_old, np.arange(len(label)))
    if np.array_equal(own[up], own):
        return own
    while True:
        nxt = up[up]
        if np.array_equal(nxt, up):
            return own[up]
        up = nxt


def _plateau_hops(costfield: CostField, old: np.ndarray, padded_shape) -> np.ndarray:
    """Steps from every node of a plateau to its nearest way out, as int32 over the padded lattice.

    A plateau is a connected set of nodes with one packed word (cost and
    label) joined by edges whose weight vanishes in float32 next to that
    cost. Its ways out are its nodes that a neighbour of lower cost reaches
    at their cost (what the walk's predecessor rule takes first), nodes of
    cost 0 and nodes of ``old`` (the dendrite being extended), all 0. Other
    nodes hold -10 (never one step from anything).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    lattice = costfield.lattice
    dist, label, shape = costfield.dist, costfield.label, lattice.shape
    n = lattice.num_nodes
    flat = np.arange(n, dtype=np.int64).reshape(shape)
    out = dist == 0
    if len(old):
        out[tuple(coords_of_padded(old, shape).T)] = True
    tails, heads = [], []
    # the weights the search and the walks add on their device (sampled there, once, for a
    # lattice that stores none), so that the sums below equal theirs
    weights = lattice._kernel_weights(costfield.device)
    for k, off in enumerate(lattice.offsets):
        a, b = edge_slices(off, shape)  # edge a -> b = a + off, its weight stored at a
        da, db, w = dist[a], dist[b], weights[k][a]
        with np.errstate(invalid="ignore", over="ignore"):
            reach_b, reach_a = da + w, db + w  # float32 sums, as the kernels make them
        out[b] |= (da < db) & (reach_b == db)
        out[a] |= (db < da) & (reach_a == da)
        flat_equal = (da == db) & (label[a] == label[b]) & (reach_b == da) & np.isfinite(da)
        tails.append(flat[a][flat_equal])
        heads.append(flat[b][flat_equal])
    hops = np.full(n, -10, np.int64)
    tails, heads = np.concatenate(tails), np.concatenate(heads)
    sources = np.flatnonzero(out.ravel())
    if len(tails) and len(sources):
        graph = coo_matrix((np.ones(len(tails)), (tails, heads)), shape=(n, n)).tocsr()
        steps = dijkstra(graph, directed=False, indices=sources, min_only=True, unweighted=True)
        hops = np.where(np.isfinite(steps), steps, -10).astype(np.int64)
    padded = np.full(tuple(padded_shape), -10, np.int32)
    pad = [(p - n) // 2 for p, n in zip(padded_shape, (1,) * (3 - lattice.ndim) + shape)]
    inner = tuple(slice(p, n - p) for p, n in zip(pad, padded_shape))
    padded[inner] = hops.reshape((1,) * (3 - lattice.ndim) + shape)
    return padded.ravel()


def trace(
    costfield: CostField,
    endpoints,
    *,
    extend: Dendrite | None = None,
    generation: int | None = None,
) -> Dendrite:
    """Backtrack least-cost paths from ``endpoints`` to their generators (greedy descent).

    Every endpoint walks, in parallel, to the neighbour its least cost came
    from until it reaches a generator or a node already on the dendrite;
    paths that meet share the rest of the way. The predecessor rule is fixed
    (see :mod:`wdendrite.kernels.dendrite`), so the result depends only on
    the cost field and the endpoints.

    Args:
        costfield: from :func:`wdendrite.shortest_paths`.
        endpoints: ``(M, ndim)`` integer node coordinates with finite cost, (row, col) = (y, x) in
            2D and (z, y, x) in 3D.
        extend: a dendrite to grow: walks stop when they reach one of its
            nodes, and the new nodes are appended after its rows; a new
            branch takes the label of the node it joins.
        generation: value stored in ``Dendrite.generation`` for the new nodes
            (default: one more than ``extend``'s largest, else 0).

    Returns:
        A :class:`Dendrite` holding ``extend``'s nodes followed by the new ones.

    Raises:
        ValueError: endpoints out of bounds, on masked nodes or unreachable
            (the message names the row), ``extend`` from another lattice shape or on
            nodes its mask forbids, a negative ``generation``.
        TypeError: a ``costfield`` that is not a :class:`CostField`, a ``generation``
            that is not an integer.
    """
    return _trace(costfield, endpoints, extend=extend, generation=generation)


def _trace(costfield: CostField, endpoints, *, extend: Dendrite | None = None, generation: int | None = None,
           drawn: bool = False) -> Dendrite:
    """:func:`trace`; ``drawn=True`` (growth) says the endpoints are an int64 ``(M, ndim)`` array drawn
    from this cost field's band (in bounds, usable, of finite cost), so they are not checked again."""
    if not isinstance(costfield, CostField):
        raise TypeError(f"Expected a CostField for 'costfield', but got {type(costfield).__name__}")
    lattice = costfield.lattice
    pts = endpoints if drawn else _checks.node_coordinates("endpoints", endpoints, lattice.shape, lattice.mask)
    if extend is not None:
        if not isinstance(extend, Dendrite):
            raise TypeError(f"Expected a Dendrite for 'extend', but got {type(extend).__name__}")
        if tuple(extend.shape) != lattice.shape:
            raise ValueError(f"'extend' has shape {extend.shape}, but the cost field's lattice has {lattice.shape}")
        if lattice.mask is not None and len(extend):
            blocked = ~lattice.mask[tuple(extend.nodes.T)]
            if blocked.any():
                row = int(np.argmax(blocked))
                raise ValueError(f"'extend' row {row} = {tuple(extend.nodes[row].tolist())} is a masked-out node "
                                 "of the cost field's lattice")
    if generation is None:
        generation = 0 if extend is None or not len(extend) else int(extend.generation.max()) + 1
    else:
        generation = _checks.integer("generation", generation, low=0, high=np.iinfo(np.int32).max)

    device = costfield.device
    arrays = lattice.device_arrays(device)
    starts = lattice.padded_indices(pts)
    old = np.zeros(0, np.int64) if extend is None else extend._padded
    with wp.ScopedDevice(device), arrays.stamps.lock:
        load_state(costfield, arrays)
        # costs are read from the records: the cost field's dist array is not needed
        bad = None if drawn else ~np.isfinite(read_states(arrays, starts, costfield.limit)[0])
        if bad is not None and bad.any():
            row = int(np.argmax(bad))
            why = "above the cost field's limit" if np.isfinite(costfield.limit) else "unreachable from every generator"
            raise ValueError(
                f"'endpoints' row {row} = {tuple(pts[row].tolist())} is {why} ({int(bad.sum())} such endpoints)"
            )
        gen_rows = costfield.generators
        # the generators end with the dendrite's nodes (growth with new generators): those are the nodes
        # of cost 0 apart from the first generators, so walks may take a node of cost 0 as one on the
        # dendrite (unless it is marked a root) instead of marking the dendrite's nodes first
        claim_zero = bool(len(old) and len(gen_rows) >= len(old)
                          and np.array_equal(gen_rows[len(gen_rows) - len(old):], extend.nodes))
        size = arrays.mask.shape[0]
        hops = None  # plateau steps, counted only once a walk finds no lower index to go to
        while True:
            # walks mark the records' stamps: generators first, then the nodes already on the dendrite
            root_id = arrays.fresh_ids(2)
            visit_id = root_id + 1
            if claim_zero:
                # only first generators on none of the dendrite's nodes are marked roots
                roots = lattice.padded_indices(gen_rows[: len(gen_rows) - len(old)])
                on = _memory.sparse_table(size, bool)
                on[old] = True
                marks = ((roots[~on[roots]], root_id),)
            else:
                marks = ((lattice.padded_indices(gen_rows), root_id), (old.astype(np.int32), visit_id))
            for nodes, mark in marks:
                if len(nodes):
                    wp.launch(_kd.stamp_kernel, dim=len(nodes), inputs=[wp.array(nodes, dtype=wp.int32),
                                                                        arrays.stride, arrays.n_weights, mark],
                              outputs=[arrays.records])
            room = max(1, lattice.num_usable)
            new_nodes = wp.empty(room, dtype=wp.int32)
            new_pred = wp.empty(room, dtype=wp.int32)
            new_count = wp.zeros(1, dtype=wp.int32)
            status = wp.empty(len(starts), dtype=wp.int32)
            new_cost = wp.empty(room, dtype=float)
            new_label = wp.empty(room, dtype=wp.int32)
            wp.launch(
                _kd.trace_kernel,
                dim=len(starts),
                inputs=[wp.array(starts, dtype=wp.int32), arrays.flat_offsets, arrays.stride, arrays.n_weights,
                        arrays.hashed, arrays.mask, arrays.state, root_id, visit_id, int(claim_zero), size,
                        wp.zeros(1, dtype=wp.int32) if hops is None else hops, int(hops is not None)],
                outputs=[arrays.records, new_nodes, new_pred, new_count, status, new_cost, new_label],
            )
            n_new = int(new_count.numpy()[0])
            listed = new_nodes[:n_new].numpy()
            # new rows in ascending node order, whatever order the walks listed them in. A lattice-sized
            # table maps padded nodes to positions; only the entries written are read, so the records
            # keep it for the next trace when small (a fresh one costs a page fault per page its
            # scattered writes touch): first each new node's place in the list, which orders the walks'
            # outputs as a sort of the nodes (cheaper than an argsort) ...
            rows = arrays.kept("rows", lambda: _memory.sparse_table(size, np.int32), 4 * size)
            rows[listed] = np.arange(n_new, dtype=np.int32)
            fresh = np.sort(listed)
            order = rows[fresh]
            fresh = fresh.astype(np.int64)
            fresh_pred = new_pred[:n_new].numpy()[order]
            all_padded = np.concatenate([old, fresh])
            # ... then the dendrite row of every node on it
            rows[all_padded] = np.arange(len(all_padded), dtype=np.int32)
            if claim_zero:
                # a node of cost 0 is on the dendrite: lattices refuse weights of 0, so only generators
                # cost 0. Should a node of cost 0 off it appear all the same, the table does not hold
                # some node a walk stopped at, and the walks are made again with the dendrite marked
                linked = np.concatenate([fresh_pred[fresh_pred >= 0], starts])
                at = rows[linked]
                held = (at >= 0) & (at < len(all_padded))
                if not (held.all() and np.array_equal(all_padded[at], linked)):
                    claim_zero = False
                    continue
            stuck = np.flatnonzero(status.numpy() != 0)
            if hops is None and len(stuck):
                # walks stuck on a plateau of equal words whose way out lies toward higher indices:
                # walk again, stepping across plateaus toward their ways out
                hops = wp.array(_plateau_hops(costfield, old, arrays.padded_shape), dtype=wp.int32)
                continue
            break
        new_parent = np.where(fresh_pred >= 0, rows[np.maximum(fresh_pred, 0)], -1).astype(np.int64)
        end_rows = rows[starts].astype(np.int64)
        cost = new_cost[:n_new].numpy()[order]
        label = _path_labels(new_label[:n_new].numpy()[order], new_parent,
                             np.zeros(0, np.int32) if extend is None else extend.label)
    if len(stuck):
        row = int(stuck[0])
        dist = costfield.dist
        raise ValueError(
            f"backtracking from 'endpoints' row {row} = {tuple(pts[row].tolist())} found no way down: path costs "
            f"reach {float(np.nanmax(np.where(np.isfinite(dist), dist, np.nan))):.3g}, where float32 cannot add the "
            "lattice's smallest weights any more, and no neighbour leads to a lower cost; is the cost field "
            "from this lattice?"
        )
    coords = coords_of_padded(fresh, lattice.shape)
    def _cat(name, new, dtype):
        new = new.astype(dtype, copy=False)
        return new if extend is None else np.concatenate([getattr(extend, name), new]).astype(dtype, copy=False)
    return Dendrite(
        shape=lattice.shape,
        nodes=_cat("nodes", coords, np.int64).reshape(-1, lattice.ndim),
        parent=_cat("parent", new_parent, np.int64),
        cost=_cat("cost", cost, np.float32),
        label=_cat("label", label, np.int32),
        generation=_cat("generation", np.full(len(fresh), generation, np.int32), np.int32),
        endpoints=_endpoint_rows(extend, end_rows, len(all_padded)),
        _padded=all_padded,
        origin=None if extend is None else extend.origin,
        spacing=1.0 if extend is None else extend.spacing,
    )
