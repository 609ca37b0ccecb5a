"""Shortest path costs from generator nodes over a lattice (near-far delta-stepping).

The search keeps a *near* frontier of nodes whose cost is below a moving
threshold and a *far* pile of the rest. Each round relaxes the near frontier;
when it runs dry the threshold moves up by ``delta`` and the far pile is
split. Work stays close to the number of nodes reached, instead of a
whole-lattice sweep per hop as in plain Bellman-Ford. On a GPU the host drives
the rounds, one launch each; on the CPU (one thread per launch) a single
launch runs them all, each bucket emptied as a work queue, by a kernel
compiled for the lattice's record layout (stored weights of 2, 3, 4 or 13
directions) or, for hashed weights, by the general one.

Ties are broken by a fixed rule: among generators at the same least cost a
node takes the lowest generator row (see :class:`CostField`).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, field

import numpy as np
import warp as wp

from . import _checks, _memory
from .kernels import sssp as _k
from .lattice import Lattice, pass_chunk, pass_threads

__all__ = ["CostField", "shortest_paths"]


class _Fields:
    """Where a :class:`CostField`'s costs live: in the records of ``arrays`` until they
    are first asked for or the records are needed by another search, then in
    arrays of its own."""

    __slots__ = ("arrays", "dist", "label", "spent", "host", "holder")

    def __init__(self, arrays):
        self.arrays = arrays  # None for an unpickled field, whose own arrays are made at once
        self.dist: wp.array | None = None
        self.label: wp.array | None = None
        self.spent = False
        self.host: dict = {}  # read-only host copies of dist and label, once asked for
        self.holder = None  # weak reference to the one CostField these costs belong to


@dataclass(frozen=True, eq=False)
class CostField:
    """Least path costs from a set of generators, and which generator is nearest.

    ``dist`` and ``label`` are NumPy views of the device arrays
    ``dist_array`` / ``label_array`` (no copy on the CPU); kernels that follow
    can take the device arrays directly. A search leaves its costs packed in
    the lattice's node records: backtracking and endpoint draws read them
    there, and the two arrays are only made when first asked for (or when
    another search on the lattice is about to reuse the records).

    Tie rule: when several generators reach a node at the same least cost
    (to float32 rounding of the sums along the paths), ``label`` is the lowest
    of their rows. This is what an order-independent ``atomic_min`` on the
    packed word ``(cost bits << 32) | row`` gives. Which paths' sums are offered
    depends on the order of relaxations, though: where a costlier path from one
    generator and the least one from another round to the same sum, the first
    may be offered or not, so such a node's label can differ with ``delta`` and,
    on a GPU, from run to run (costs never do).

    A cost field pickles and deep-copies (with a copy of its lattice): its
    costs travel as host arrays and come back on the device they were on, or on
    the CPU in a process without that device.
    """

    lattice: Lattice
    """The lattice the costs were computed on."""
    generators: np.ndarray
    """``(G, ndim)`` int64 generator coordinates; ``label`` indexes its rows."""
    limit: float
    """Costs above this bound were not searched (inf: no bound)."""
    _fields: _Fields = field(repr=False)
    rounds: int = 0
    """Relaxation rounds the search took: cost buckets emptied on the CPU (all within one launch),
    frontier generations on GPUs (one launch each; their number may differ from run to run there)."""
    relaxed: int = 0
    """Node relaxations the search did; close to the number of reached nodes when ``delta`` suits the
    weights (on GPUs it may differ from run to run; the costs never do)."""

    def __post_init__(self):
        f = self._fields
        if f.holder is not None and f.holder() is not None:
            raise TypeError("a CostField cannot be remade with dataclasses.replace: its costs belong to the search "
                            "that made them (their records, limit and generators); search again, or copy.copy it")
        f.holder = weakref.ref(self)
        # a read-only copy: walks and warm starts trust these rows, checked once by the search
        gens = np.array(self.generators, dtype=np.int64)
        gens.flags.writeable = False
        object.__setattr__(self, "generators", gens)

    @property
    def device(self):
        """The Warp device holding the arrays."""
        f = self._fields
        return f.dist.device if f.dist is not None else f.arrays.records.device

    @property
    def dist_array(self) -> wp.array:
        """float32 device array of the lattice shape."""
        return self._materialized().dist

    @property
    def label_array(self) -> wp.array:
        """int32 device array of the lattice shape."""
        return self._materialized().label

    @property
    def dist(self) -> np.ndarray:
        """float32 array of the lattice shape: least cost to any generator (inf where unreachable or above ``limit``)."""
        return self._host("dist")

    @property
    def label(self) -> np.ndarray:
        """int32 array of the lattice shape: row of the nearest generator (-1 where ``dist`` is inf)."""
        return self._host("label")

    def __reduce__(self):
        # device arrays do not pickle: the costs travel as host arrays, and the lattice rebuilds itself
        return _rebuild, (self.lattice, self.generators, self.limit, np.array(self.dist), np.array(self.label),
                          self.rounds, self.relaxed, str(self.device))

    def _host(self, name: str) -> np.ndarray:
        """The read-only host array of field ``name``: a view on the CPU; copied from a GPU once,
        then kept (the device arrays never change once made)."""
        f = self._materialized()
        kept = f.host.get(name)
        if kept is None:
            kept = getattr(f, name).numpy()
            kept.flags.writeable = False
            f.host[name] = kept
        return kept

    def _materialized(self) -> _Fields:
        f = self._fields
        if f.dist is None:
            with f.arrays.stamps.lock:
                if f.dist is None:
                    _unpack(self)
        return f


def _rebuild(lattice: Lattice, generators, limit, dist, label, rounds, relaxed, device) -> CostField:
    """Unpickle a :class:`CostField`: its arrays go back to the device they were on when
    this process has it, else to the CPU."""
    device = wp.get_device(device if device in [str(d) for d in wp.get_devices()] else "cpu")
    fields = _Fields(None)  # its records are made when a search or walk needs them
    fields.dist = wp.array(dist, dtype=float, device=device)
    fields.label = wp.array(label, dtype=wp.int32, device=device)
    return CostField(lattice, generators, limit, fields, rounds, relaxed)


def _unpack(costfield: CostField) -> None:
    """Give ``costfield`` its own ``dist``/``label`` arrays from the records that hold it
    (the caller holds the records' lock)."""
    f = costfield._fields
    if f.spent:
        raise RuntimeError(
            "this CostField was handed to a later search as a warm start that reused its memory; "
            "its costs are gone (ask for 'dist' before that search to keep them)"
        )
    arrays = f.arrays
    owner = arrays.stamps.owner
    if owner is None or owner() is not costfield:
        raise RuntimeError("internal error: a cost field's records were reused before its costs were unpacked")
    lattice = costfield.lattice
    device = arrays.records.device
    dist = _memory.empty(lattice.shape, float, device)
    label = _memory.empty(lattice.shape, wp.int32, device)
    if arrays.usable is not None:
        # sparse: fill the outputs, then visit the usable nodes only
        dist.fill_(math.inf)
        label.fill_(-1)
    _records_pass(arrays, lattice, costfield.limit, dist=dist.flatten(), label=label.flatten())
    f.dist, f.label = dist, label


def _records_pass(arrays, lattice: Lattice, limit: float, *, dist=None, label=None, band=None, count=None,
                  nodes=None) -> None:
    """Launch :func:`~wdendrite.kernels.sssp.records_pass_kernel` over the usable nodes:
    unpack into flat ``dist`` / ``label``, or list the nodes with cost in ``band = (low, high)``
    into ``nodes`` (``count`` of them). Unused outputs get a one-element stand-in."""
    device = arrays.records.device
    with wp.ScopedDevice(device):
        spare_f, spare_i = wp.empty(1, dtype=float), wp.empty(1, dtype=wp.int32)
        listed = arrays.usable is not None
        chunk = pass_chunk(device)
        low, high = (0.0, 0.0) if band is None else band
        wp.launch(
            _k.records_pass_kernel,
            dim=arrays.usable.shape[0] if listed else pass_threads(lattice.num_nodes, chunk),
            inputs=[arrays.usable if listed else spare_i, int(listed), arrays.state, arrays.mask, arrays.shape3,
                    arrays.pad3, arrays.stride, kernel_limit(limit), int(band is not None), low, high, chunk],
            outputs=[spare_f if dist is None else dist, spare_i if label is None else label,
                     spare_i if count is None else count, spare_i if nodes is None else nodes],
        )


def release_records(arrays, consumed: CostField | None = None) -> None:
    """Free ``arrays``' records for new search states (the caller holds their lock).

    The cost field they hold, if any is still alive, first gets its own arrays,
    unless it is ``consumed``: a warm start whose caller will not read it again
    (fractal growth), which is marked spent instead of unpacked.
    """
    ref = arrays.stamps.owner
    owner = None if ref is None else ref()
    if owner is not None and owner._fields.dist is None:
        if owner is consumed:
            owner._fields.spent = True
        else:
            _unpack(owner)
    arrays.stamps.owner = None


class _Frontiers:
    """Near lists (slots 0, 1) and far piles (slots 2, 3) with their lengths."""

    def __init__(self, n: int, device, capacity: int | None = None):
        # a node sits in a list at most once, so lists need room for the usable nodes only
        cap = n if capacity is None else max(1, capacity)
        # read in order: plain pages do (huge pages go to the randomly read records and state)
        self.lists = [wp.empty(cap, dtype=wp.int32, device=device) for _ in range(4)]
        self.counts = wp.zeros(4, dtype=wp.int32, device=device)
        self.far_min = wp.full(1, math.inf, dtype=float, device=device)
        self.stats = wp.zeros(2, dtype=wp.int64, device=device)
        """Buckets emptied and nodes relaxed by a one-launch search."""
        self._cpu = device.is_cpu
        self.max_threads: int | None = None
        # on the CPU the NumPy views share memory with the device arrays
        self._counts_view = self.counts.numpy() if self._cpu else None
        self._min_view = self.far_min.numpy() if self._cpu else None

    def reset(self) -> None:
        """Empty lists and an infinite far minimum, as a search starts."""
        if self._cpu:
            self._counts_view[:] = 0
            self._min_view[0] = math.inf
        else:
            self.counts.zero_()
            self.far_min.fill_(math.inf)

    def threads(self, work: int) -> int:
        """Threads for a launch over ``work`` list entries: one on the CPU, where a
        single thread striding over the list avoids per-thread launch costs."""
        if self.max_threads is not None:
            return max(1, min(work, self.max_threads))
        return 1 if self._cpu else min(work, 1 << 16)

    def read(self) -> np.ndarray:
        return self._counts_view if self._cpu else self.counts.numpy()

    def far_minimum(self) -> float:
        return float(self._min_view[0] if self._cpu else self.far_min.numpy()[0])

    def set_count(self, slot: int, value: int) -> None:
        if self._cpu:
            self._counts_view[slot] = value
        else:
            wp.launch(_k.set_count_kernel, dim=1, inputs=[slot, value], outputs=[self.counts], device=self.counts.device)

    def reset_far_min(self) -> None:
        if self._cpu:
            self._min_view[0] = math.inf
        else:
            self.far_min.fill_(math.inf)


def _default_delta(lattice: Lattice) -> float:
    """The bucket width of a search on ``lattice``: 16 times the 10th percentile of its weights.

    Least-cost paths run along cheap edges, so the width follows the cheap end of the weights
    (the mean misleads for skewed weights such as R^3); BENCHMARKS.md ("Shortest paths") has the
    widths tried."""
    if lattice._weights is not None:
        # whole rows (along x) spread over the weights held in the host records, read in place: cheap, and they
        # still see weights that vary across the lattice (tropisms, maps)
        w = lattice.weights
        rows = int(np.prod(w.shape[:-1]))
        picks = np.linspace(0, rows - 1, min(rows, max(32, 16384 // w.shape[-1]))).astype(np.int64)
        sample = w[np.unravel_index(picks, w.shape[:-1])][:, :2048].reshape(-1)
    else:
        # weights of edges spread over the real lattice (fields such as maps need its shape)
        k = len(lattice.offsets)
        nodes = np.linspace(0, lattice.num_nodes - 1, min(lattice.num_nodes, 2048)).astype(np.int64)
        sample = lattice.distribution.evaluate(lattice.shape, lattice.lengths, np.repeat(nodes, k),
                                               np.tile(np.arange(k), len(nodes)), offsets=lattice.offsets)
    sample = sample[(sample > 0) & np.isfinite(sample)]  # (+inf: edges never taken)
    if not sample.size:
        return 1.0
    return max(float(np.percentile(sample, 10)), 1e-6) * 16.0


def _generator_rows(generators, lattice: Lattice, warm_start) -> np.ndarray:
    """``generators`` validated as ``(G, ndim)`` int64 coordinates.

    A warm start's generators were validated when it was made: when ``generators``
    begins with them (as growth passes them), only the rows after them are checked.
    """
    if isinstance(warm_start, CostField) and isinstance(generators, np.ndarray) and generators.dtype == np.int64:
        old = warm_start.generators
        if (generators.ndim == 2 and generators.shape[1] == lattice.ndim and len(generators) > len(old)
                and warm_start.lattice.shape == lattice.shape and np.array_equal(generators[: len(old)], old)):
            try:
                tail = _checks.node_coordinates("generators", generators[len(old):], lattice.shape, lattice.mask)
            except (TypeError, ValueError):
                pass  # the whole check below names the bad row in the whole list
            else:
                return np.concatenate([old, tail])
    return _checks.node_coordinates("generators", generators, lattice.shape, lattice.mask)


def _check_warm_start(warm: CostField, lattice: Lattice, gens: np.ndarray, limit: float, rows_checked=False) -> None:
    old = warm.lattice
    if old.shape != lattice.shape or old.connectivity != lattice.connectivity:
        raise ValueError(
            f"'warm_start' was computed on {old!r}, which does not match 'lattice' {lattice!r}"
        )
    same_mask = (old.mask is None and lattice.mask is None) or (
        old.mask is not None and lattice.mask is not None and np.array_equal(old.mask, lattice.mask)
    )
    if not same_mask:
        raise ValueError("'warm_start' was computed with a different 'mask'; a warm start needs the same mask")
    if old.stores_weights != lattice.stores_weights or (
        not lattice.stores_weights and old.distribution != lattice.distribution
    ):
        raise ValueError("'warm_start' was computed with other unstored weights; a warm start needs the same weights")
    if lattice.stores_weights and old is not lattice and old.weights is not lattice.weights:
        raised = int(np.count_nonzero(lattice.weights > old.weights))
        if raised:
            raise ValueError(
                f"'lattice' raises {raised} edge weights over 'warm_start'; a warm start only allows lowered weights"
            )
    g_old = warm.generators
    if len(gens) < len(g_old) or not (rows_checked or np.array_equal(gens[: len(g_old)], g_old)):
        raise ValueError(
            "'generators' must begin with the generators of 'warm_start' (same rows, same order) "
            f"so that labels stay valid; 'warm_start' has {len(g_old)} generators"
        )
    if limit > warm.limit:
        raise ValueError(
            f"'limit' {limit} exceeds the warm start's limit {warm.limit}; costs beyond it were never searched"
        )


def shortest_paths(
    lattice: Lattice,
    generators,
    *,
    device=None,
    limit: float | None = None,
    warm_start: CostField | None = None,
    delta: float | None = None,
) -> CostField:
    """Least path cost from the nearest generator to every lattice node.

    Args:
        lattice: the weighted lattice.
        generators: ``(G, ndim)`` integer node coordinates in the lattice's axis order, (row, col) =
            (y, x) in 2D and (z, y, x) in 3D, as numpy indexes (rows may repeat).
        device: Warp device to run on (default: the warm start's device, else
            Warp's default device).
        limit: search only costs up to this bound; nodes beyond it get
            ``dist = inf`` and ``label = -1`` (costs, float32, are compared with the
            largest float32 at or below it: none above it is kept). Default: no bound. With a warm
            start it may be lower than the warm start's limit, not higher.
        warm_start: a :class:`CostField` computed earlier on the same lattice
            shape, connectivity and mask, with a ``limit`` at least this one, whose
            generators are the first rows of ``generators`` and whose weights
            were all >= those of ``lattice``. Only the nodes next to what
            changed are relaxed; the result is the same as a cold start.
        delta: bucket width of the near-far threshold, in cost units. Larger
            means fewer, bigger rounds (better for GPUs); smaller means less
            repeated work. Default: 16 times the 10th percentile of the edge weights.

    Returns:
        A :class:`CostField` with ``dist`` (float32) and ``label`` (int32) of
        the lattice shape.

    Raises:
        ValueError, TypeError: bad generators (empty, not integer, out of
            bounds, on a masked node), limit, delta or warm start.
        MemoryError: when the search would not fit in the device's memory.
    """
    return _search(lattice, generators, device=device, limit=limit, warm_start=warm_start, delta=delta)


def _search(
    lattice: Lattice,
    generators,
    *,
    device=None,
    limit: float | None = None,
    warm_start: CostField | None = None,
    delta: float | None = None,
    fifo: bool | None = None,
    host_rounds: bool = False,
    max_threads: int | None = None,
    consume_warm_start: bool = False,
    walked: np.ndarray | None = None,
    lowered: tuple | None = None,
) -> CostField:
    """:func:`shortest_paths` with the choices growth and the tests make explicitly.

    Args:
        fifo: the schedule: a work queue per bucket (``True``) or generation rounds
            (``False``); default: the work queue on single-threaded CPU devices, rounds on GPUs.
        host_rounds: with the work queue, drive the buckets from the host, one launch each,
            instead of in one launch (the same costs, labels and counts).
        max_threads: threads per generation-round launch (a GPU's striding, exercised on the CPU).
        consume_warm_start: the caller will not read ``warm_start`` again, so its costs need not
            be kept when the search reuses their memory.
        walked: padded node indices of the generator rows after the warm start's, from growth,
            whose generators are the warm start's followed by nodes its walks just added on this
            lattice: those rows are not checked again.
        lowered: ``(padded nodes, dirs, new weights, records)`` from growth's
            ``Lattice._lower_in_place`` on ``warm_start``'s own lattice: only these edges went
            down since the warm start (the search's records take the new weights unless they are
            ``records``, which hold them).

    The other arguments, the result and the errors are those of :func:`shortest_paths`.
    """
    if not isinstance(lattice, Lattice):
        raise TypeError(f"Expected a wdendrite.Lattice for 'lattice', but got {type(lattice).__name__}")
    trusted = walked is not None and isinstance(warm_start, CostField)
    gens = np.asarray(generators) if trusted else _generator_rows(generators, lattice, warm_start)
    if len(gens) >= 2**31:
        raise ValueError(f"'generators' has {len(gens)} rows; at most 2**31 - 1 are supported")
    limit_f = _checks.nonnegative("limit", limit, allow_inf=True)
    limit_f = math.inf if limit_f is None else limit_f
    if delta is None:
        if lattice._default_delta is None:
            lattice._default_delta = _default_delta(lattice)
        delta_f = lattice._default_delta
    else:
        delta_f = _checks.positive("delta", delta)
    if warm_start is not None:
        if not isinstance(warm_start, CostField):
            raise TypeError(f"Expected a CostField for 'warm_start', but got {type(warm_start).__name__}")
        _check_warm_start(warm_start, lattice, gens, limit_f, rows_checked=trusted)
        if device is None:
            device = warm_start.device
    device = _checks.device(device)
    need = lattice.search_bytes(device)
    if need:
        _checks.fits_in_memory(need, device, f"shortest_paths on a lattice of shape {lattice.shape}")

    arrays = lattice.device_arrays(device)
    if warm_start is not None and warm_start._fields.arrays is not arrays:
        # a warm start held by other records (another lattice or device) is unpacked under their own lock,
        # before this search takes its lock: no search ever holds two
        warm_start.dist_array
    with wp.ScopedDevice(device), arrays.stamps.lock:
        chunk = pass_chunk(device)
        size = arrays.mask.shape[0]
        far_id = arrays.fresh_ids(1)
        frontier, launches = _scratch(arrays, lattice, device)
        if warm_start is None:
            release_records(arrays)
            if arrays.usable is not None:
                wp.launch(_k.init_listed_kernel, dim=arrays.usable.shape[0], inputs=[arrays.usable, arrays.stride],
                          outputs=[arrays.state])
            else:
                wp.launch(_k.init_state_kernel, dim=pass_threads(size, chunk), inputs=[arrays.mask, arrays.stride, chunk],
                          outputs=[arrays.state])
            new_rows = np.arange(len(gens))
        else:
            load_state(warm_start, arrays)
            release_records(arrays, consumed=warm_start if consume_warm_start else None)
            new_rows = np.arange(len(warm_start.generators), len(gens))
            old_arrays = warm_start.lattice.device_arrays(device)
            if lowered is not None:
                if warm_start.lattice is not lattice:
                    raise ValueError("'lowered' edges belong to the warm start's own lattice")
                nodes, dirs, values, held = lowered
                if len(nodes):
                    wp.launch(
                        _k.mark_listed_lowered_kernel,
                        dim=len(nodes),
                        inputs=[wp.array(nodes, dtype=wp.int32), wp.array(dirs, dtype=wp.int32),
                                wp.array(values, dtype=float), int(arrays is not held), arrays.flat_offsets, arrays.mask,
                                arrays.stride, arrays.n_weights, far_id, 2],
                        outputs=[arrays.state, arrays.records, frontier.counts, frontier.far_min, frontier.lists[2]],
                    )
            elif lattice.stores_weights and old_arrays.records is not arrays.records:
                wp.launch(
                    _k.mark_lowered_kernel,
                    dim=size,
                    inputs=[arrays.flat_offsets, arrays.mask, old_arrays.records, arrays.stride, arrays.n_weights, far_id, 2],
                    outputs=[arrays.state, arrays.records, frontier.counts, frontier.far_min, frontier.lists[2]],
                )
        if len(new_rows):
            flat = walked.astype(np.int32) if trusted else lattice.padded_indices(gens[new_rows])
            wp.launch(
                _k.seed_kernel,
                dim=len(flat),
                inputs=[wp.array(flat, dtype=wp.int32), wp.array(new_rows.astype(np.int32), dtype=wp.int32),
                        arrays.stride, arrays.n_weights, far_id, 2],
                outputs=[arrays.state, arrays.records, frontier.counts, frontier.far_min, frontier.lists[2]],
            )
        fifo = device.is_cpu if fifo is None else bool(fifo)
        frontier.max_threads = max_threads
        launches.begin(kernel_limit(limit_f), fifo, far_id, one_launch=fifo and not host_rounds)
        rounds, relaxed = _run(arrays, frontier, launches, delta_f)
        result = CostField(lattice, gens, limit_f, _Fields(arrays), rounds, relaxed)
        arrays.stamps.owner = weakref.ref(result)
    return result


def load_state(costfield: CostField, arrays) -> None:
    """Make ``arrays``' records hold ``costfield``'s packed states (the caller holds their lock).

    Nothing to do when the last search on these records made ``costfield``;
    otherwise its ``dist`` and ``label`` are packed back into the records: the
    words a cold search with its limit leaves (a warm start that lowered the
    limit may have left words above it, which no search or walk within the
    limit can use).
    """
    owner = arrays.stamps.owner
    if owner is not None and owner() is costfield:
        return
    dist, label = costfield.dist_array, costfield.label_array  # from the records that hold it, if any
    release_records(arrays)
    device = arrays.records.device
    chunk = pass_chunk(device)
    n = costfield.lattice.num_nodes
    wp.launch(
        _k.load_state_kernel,
        dim=pass_threads(n, chunk),
        inputs=[dist.to(device).flatten(), label.to(device).flatten(),
                arrays.shape3, arrays.pad3, arrays.stride, chunk, arrays.mask],
        outputs=[arrays.state],
        device=device,
    )
    arrays.stamps.owner = weakref.ref(costfield)


def kernel_limit(limit: float) -> float:
    """The bound the kernels compare float32 costs with for ``limit``: the largest float32 at or
    below it (Warp would round a float64 to the nearest float32, which may lie above it and keep
    a cost above ``limit``), and at most the largest finite float32 (which also keeps costs that
    overflowed float32 out: inf <= max is false)."""
    top = float(np.finfo(np.float32).max)
    f = np.float32(min(limit, top))
    if float(f) > limit:
        f = np.nextafter(f, np.float32(-np.inf))
    return float(f)


def read_states(arrays, nodes: np.ndarray, limit: float) -> tuple[np.ndarray, np.ndarray]:
    """Costs (float32) and labels (int32) of padded ``nodes`` from the records' states, as
    ``dist``/``label`` would give them (inf and -1 when unreached or above ``limit``);
    the caller holds the records' lock and the records hold the wanted cost field."""
    count = len(nodes)
    device = arrays.records.device
    cost = wp.empty(max(count, 1), dtype=float, device=device)
    label = wp.empty(max(count, 1), dtype=wp.int32, device=device)
    if count:
        wp.launch(_k.read_states_kernel, dim=count,
                  inputs=[wp.array(np.asarray(nodes, dtype=np.int32), dtype=wp.int32, device=device), arrays.state,
                          arrays.stride, kernel_limit(limit)],
                  outputs=[cost, label], device=device)
    return cost.numpy()[:count], label.numpy()[:count]


def band_nodes(costfield: CostField, low: float, high: float) -> np.ndarray:
    """Flat int32 node indices, ascending, of the usable nodes whose cost ``c`` has
    ``low < c < high``, read from the records (no ``dist`` array is made)."""
    lattice = costfield.lattice
    arrays = lattice.device_arrays(costfield.device)
    device = arrays.records.device
    with wp.ScopedDevice(device), arrays.stamps.lock:
        load_state(costfield, arrays)
        # the list's room (every usable node) is kept for the next band when small: growth asks for
        # one per iteration
        room = max(1, lattice.num_usable)
        out, count = arrays.kept("band", lambda: (wp.empty(room, dtype=wp.int32), wp.zeros(1, dtype=wp.int32)),
                                 4 * room)
        count.zero_()
        _records_pass(arrays, lattice, costfield.limit, band=(low, high), count=count, nodes=out)
        found = out[: int(count.numpy()[0])].numpy().copy()  # only the listed part leaves a GPU
    # GPU threads append in any order (one CPU thread appends in index order)
    return found if device.is_cpu and arrays.usable is None else np.sort(found)


def _cost_per_node(lat: Lattice, centre, radius: float, dist=None) -> float:
    """Least path cost per node of straight-line distance from ``centre``: the median over the
    nodes between 0.8 and 1 times ``radius`` away (it is well below the mean weight, since least
    paths pick cheap edges). ``dist``: the costs from ``centre`` when already searched."""
    if dist is None:
        dist = shortest_paths(lat, [centre]).dist
    grid = np.indices(lat.shape, dtype=np.float64)
    r = np.sqrt(sum((g - c) ** 2 for g, c in zip(grid, centre)))
    ring = (r >= 0.8 * radius) & (r <= radius) & np.isfinite(dist)
    return float(np.median(dist[ring] / r[ring])) if ring.any() else float(lat.weights[0].mean())


def _scratch(arrays, lattice: Lattice, device) -> tuple[_Frontiers, "_Launches"]:
    """The frontier lists and recorded launches of searches on ``arrays`` (the caller holds
    their lock): made by the first search, emptied and reused by the next ones (kept only
    for lattices whose lists fit :attr:`LatticeArrays.SCRATCH_LIMIT`)."""
    def make():
        frontier = _Frontiers(arrays.mask.shape[0], device, capacity=lattice.num_usable)
        return frontier, _Launches(arrays, frontier)

    kept = arrays.kept("search", make, 16 * max(1, lattice.num_usable))
    kept[0].reset()
    return kept


class _Recorded:
    """A recorded launch that sets a parameter only when its value changed since the last
    replay: most replays change one or two of them (a bucket's threshold), and each set
    costs a few microseconds."""

    __slots__ = ("cmd", "_index", "_last", "search")

    def __init__(self, cmd: wp.Launch, search: int):
        self.cmd = cmd
        self._index = {arg.label: i for i, arg in enumerate(cmd.kernel.adj.args)}
        self._last: dict[str, object] = {}
        self.search = search
        """The search that last set the per-search parameters."""

    def set(self, **params) -> None:
        last, cmd = self._last, self.cmd
        for name, value in params.items():
            if last.get(name, _UNSET) != value:
                cmd.set_param_at_index(self._index[name], value)
                last[name] = value

    def launch(self, threads: int, **params) -> None:
        if self._last.get("dim") != threads:
            self.cmd.set_dim(threads)
            self._last["dim"] = threads
        self.set(threads=threads, **params)
        self.cmd.launch()


_UNSET = object()


class _Launches:
    """Relax and split launches recorded once per buffer arrangement, then replayed.

    Replaying a recorded launch costs a few microseconds instead of about
    twenty for a fresh ``wp.launch``, which matters over thousands of rounds.
    The records keep them for later searches (see :func:`_scratch`), which
    give them their own limit and search id (:meth:`begin`).
    """

    def __init__(self, arrays, frontier: _Frontiers):
        # the records keep this object: a weak reference back keeps them freed by reference counting
        self._arrays, self._fr = weakref.ref(arrays), frontier
        self._relax: dict[tuple[bool, int, int], _Recorded] = {}
        self._split: dict[tuple[int, int], _Recorded] = {}
        self._search = 0

    def begin(self, limit: float, fifo: bool, far_id: int, one_launch: bool = False) -> None:
        """Start a search with these bounds and schedule (``one_launch``: a work queue whose
        buckets are all emptied in one launch, see :meth:`whole`)."""
        self._limit, self.fifo, self._far_id, self.one_launch = limit, fifo, far_id, fifo and one_launch
        self._search += 1

    def whole(self, delta: float, generation: int) -> tuple[int, int]:
        """Run the whole search in one single-threaded launch; returns (buckets, relaxed nodes).

        The work-queue schedule of :func:`_run` without a launch and a read-back
        per bucket. (A narrower ``delta`` saves relaxations but, measured with this
        launch, no time: see :func:`_default_delta`.)
        """
        frontier, a = self._fr, self._arrays()
        # stored weights of a known count in records of the usual stride have a kernel compiled
        # for that layout; other records (hashed weights) the general one, which reads the layout
        fixed = a.hashed.use == 0 and a.n_weights in _k.SEARCH_KERNELS and a.stride == _k.record_stride(a.n_weights)
        kernel = _k.SEARCH_KERNELS[a.n_weights if fixed else 0]
        wp.launch(
            kernel,
            dim=1,
            inputs=[a.flat_offsets, a.hashed, a.stride, a.n_weights, self._far_id, frontier.lists[0], frontier.lists[2], self._limit,
                    delta, generation],
            outputs=[a.state, a.records, frontier.counts, frontier.far_min, frontier.stats],
        )
        rounds, relaxed = (int(v) for v in frontier.stats.numpy())
        return rounds, relaxed

    def relax(self, near: int, far: int, threads: int, threshold: float, generation: int) -> None:
        rec = self._relax.get((self.fifo, near, far))
        if rec is None:
            frontier, a = self._fr, self._arrays()
            nxt = near if self.fifo else 1 - near
            rec = self._relax[(self.fifo, near, far)] = _Recorded(wp.launch(
                _k.relax_kernel,
                dim=threads,
                inputs=[a.flat_offsets, a.hashed, a.stride, a.n_weights, self._far_id, frontier.lists[near], near, threads,
                        int(self.fifo), threshold, self._limit, generation, nxt, 2 + far],
                outputs=[a.state, a.records, frontier.counts, frontier.far_min, frontier.lists[nxt], frontier.lists[2 + far]],
                record_cmd=True,
            ), self._search)
        if rec.search != self._search:  # recorded by an earlier search
            rec.set(limit=self._limit, far_id=self._far_id)
            rec.search = self._search
        rec.launch(threads, threshold=threshold, generation=generation)

    def split(self, near: int, far: int, threads: int, previous: float, threshold: float, generation: int) -> None:
        rec = self._split.get((near, far))
        if rec is None:
            frontier, a, other = self._fr, self._arrays(), 1 - far
            rec = self._split[(near, far)] = _Recorded(wp.launch(
                _k.split_far_kernel,
                dim=threads,
                inputs=[frontier.lists[2 + far], 2 + far, threads, previous, threshold, generation,
                        a.stride, a.n_weights, near, 2 + other],
                outputs=[a.state, a.records, frontier.counts, frontier.far_min, frontier.lists[near], frontier.lists[2 + other]],
                record_cmd=True,
            ), self._search)
        rec.launch(threads, previous_threshold=previous, threshold=threshold, generation=generation)


def _next_threshold(threshold: float, far_min: float, delta: float) -> float:
    """The next bucket's upper bound, as the float32 the kernels compare with.

    It is strictly above ``far_min``, so at least the far pile's cheapest node
    moves to the near list even when ``delta`` vanishes next to large costs.
    """
    wanted = max(threshold + delta, far_min + delta)
    t = np.float32(wanted) if wanted < float(np.finfo(np.float32).max) else np.float32(np.inf)
    low = np.float32(far_min)
    if not t > low:
        t = np.nextafter(low, np.float32(np.inf))
    return float(t)


def _run(arrays, frontier: _Frontiers, launches: _Launches, delta: float) -> tuple[int, int]:
    """Drive near-far rounds until both the near list and the far pile are empty.

    With ``fifo`` (single-threaded devices), one launch empties the near list
    as a work queue, so a round is a whole bucket; otherwise a round relaxes
    one generation of the near list into the other.

    A node's near stamp equals ``generation`` while it waits in the list being
    filled. The work queue keeps one generation throughout (taking a node out
    clears its stamp), so a node is queued at most once and the ring never
    holds more than the usable nodes; generation rounds number each list they
    fill. Generations come from the lattice's ever-growing stamp ids.
    """
    fifo = launches.fifo
    queue_generation = arrays.stamps.next() if fifo else 0
    if launches.one_launch:
        return launches.whole(delta, queue_generation)
    near, far = 0, 0  # which near list (slot 0/1) and far pile (slot 2/3) are current
    threshold = -math.inf

    rounds = relaxed = 0
    while True:
        counts = frontier.read()
        n_near = int(counts[near])
        if n_near:
            generation = queue_generation if fifo else arrays.stamps.next()
            if fifo:
                launches.relax(near, far, 1, threshold, generation)
                relaxed += int(frontier.read()[near])
                frontier.set_count(near, 0)
            else:
                frontier.set_count(1 - near, 0)
                launches.relax(near, far, frontier.threads(n_near), threshold, generation)
                relaxed += n_near
                frontier.set_count(near, 0)
                near = 1 - near
            rounds += 1
            continue
        n_far = int(counts[2 + far])
        if n_far == 0:
            return rounds, relaxed
        far_min = frontier.far_minimum()
        if not math.isfinite(far_min):
            return rounds, relaxed
        previous = threshold
        threshold = _next_threshold(threshold, far_min, delta)
        frontier.reset_far_min()
        generation = queue_generation if fifo else arrays.stamps.next()
        frontier.set_count(3 - far, 0)
        launches.split(near, far, frontier.threads(n_far), previous, threshold, generation)
        frontier.set_count(2 + far, 0)
        far = 1 - far


from ._spec import document_fields as _document_fields  # noqa: E402  (the classes above are complete)

_document_fields(__name__)  # help() shows what each dataclass field means
