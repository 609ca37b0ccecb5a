"""Regular 2D and 3D lattices with weighted, undirected edges and a node mask."""

from __future__ import annotations

import itertools
import threading
from dataclasses import dataclass, field

import numpy as np
import warp as wp

from . import _checks, _memory
from .kernels import sssp as _ks
from .kernels.sssp import record_stride
from .kernels import weights as _kw

__all__ = ["Lattice", "half_offsets"]

_ALLOWED = {2: (4, 8), 3: (6, 26)}


def half_offsets(ndim: int, connectivity: int) -> np.ndarray:
    """One offset per undirected edge direction, shape ``(K, ndim)`` int64.

    Each direction appears once (the lexicographically positive one of the
    pair ``o``/``-o``): K = 2, 4, 3, 13 for connectivity 4, 8, 6, 26.
    """
    if ndim not in _ALLOWED:
        raise ValueError(f"Expected a lattice rank of 2 or 3, but got {ndim}")
    if _checks.integer("connectivity", connectivity) not in _ALLOWED[ndim]:
        raise ValueError(
            f"Expected 'connectivity' in {_ALLOWED[ndim]} for a {ndim}D lattice, but got {connectivity!r}"
        )
    full = connectivity in (8, 26)
    out = []
    for o in itertools.product((-1, 0, 1), repeat=ndim):
        if not any(o) or o <= tuple([0] * ndim):
            continue
        if full or sum(map(abs, o)) == 1:
            out.append(o)
    # axis directions first, last axis (x) first: matches the papers' 4/6-neighbourhoods
    out.sort(key=lambda o: (sum(map(abs, o)), [-abs(v) for v in reversed(o)], o))
    return np.array(out, dtype=np.int64)


def padded_index_of(coords, shape: tuple) -> np.ndarray:
    """Flat int64 indices, in the kernels' padded lattice of ``shape``, of ``(G, ndim)`` node coordinates."""
    # 2D lattices are padded in y and x only, 3D ones in z too: +1 on every given axis
    return np.ravel_multi_index(tuple((np.asarray(coords) + 1).T), tuple(n + 2 for n in shape)).astype(np.int64)


def coords_of_padded(index, shape: tuple) -> np.ndarray:
    """``(G, ndim)`` int64 node coordinates of flat padded indices (inverse of :func:`padded_index_of`)."""
    return np.stack(np.unravel_index(np.asarray(index), tuple(n + 2 for n in shape)), axis=1).astype(np.int64) - 1


def fill_outside(weights: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Give the entries whose neighbour lies outside the lattice (never used) their nearest used value, in place.

    Edges leaving the lattice carry no cost, but interpolating the weights
    (refinement) reads them; copying the nearest real edge keeps them harmless.
    """
    for k, off in enumerate(offsets):
        w = weights[k]
        for axis, o in enumerate(off):
            n = w.shape[axis]
            if o == 0 or n < 2:
                continue
            take = [slice(None)] * w.ndim
            put = [slice(None)] * w.ndim
            if o > 0:
                put[axis], take[axis] = slice(n - 1, n), slice(n - 2, n - 1)
            else:
                put[axis], take[axis] = slice(0, 1), slice(1, 2)
            w[tuple(put)] = w[tuple(take)]
    return weights


def edge_slices(offset, shape: tuple) -> tuple[tuple, tuple]:
    """Index slices ``(src, dst)`` pairing each node with its neighbour at ``offset``, both inside ``shape``."""
    src = tuple(slice(max(0, -o), n - max(0, o)) for o, n in zip(offset, shape))
    dst = tuple(slice(max(0, o), n - max(0, -o)) for o, n in zip(offset, shape))
    return src, dst


def _check_weight_values(weights: np.ndarray, offsets: np.ndarray, mask, raw=None) -> None:
    """Require weights that are not NaN or -inf, positive on every usable edge (``raw``: the
    caller's array before its conversion to float32, quoted in the messages). ``+inf`` marks an
    edge no path takes (refined lattices hold such edges between unrelated blocks).

    Entries whose neighbour lies outside the lattice are ignored (the records
    take the nearest edge inside instead), except along an axis of size 1,
    where there is no edge inside to take: those entries are kept (refinement
    interpolates them), so they must be finite and positive on usable nodes.
    """
    shape = weights.shape[1:]

    def checked(off):
        if any(o != 0 and n < 2 for o, n in zip(off, shape)):
            return tuple(slice(None) for _ in shape), None
        return edge_slices(off, shape)

    slices = [checked(off) for off in offsets]
    inside = [weights[k][src] for k, (src, _) in enumerate(slices)]
    # the common case: two reductions per direction over views
    # (a NaN makes the minimum NaN; an inf is checked against the caller's value below)
    if all(v.size == 0 or (0 < float(v.min()) and float(v.max()) < np.inf) for v in inside):
        return
    for k, (v, (src, _)) in enumerate(zip(inside, slices)):
        bad = np.isnan(v) | np.isneginf(v)
        if raw is not None and np.isposinf(v).any():  # a finite value float32 cannot hold is no +inf
            with np.errstate(invalid="ignore"):
                bad |= np.isposinf(v) & np.isfinite(np.asarray(raw[k][src], np.float64))
        if bad.any():
            where = (k, *(int(i) + (s.start or 0) for i, s in zip(np.argwhere(bad)[0], src)))
            given = weights[where] if raw is None else raw[where]
            raise ValueError(
                f"'weights' must be float32 numbers (+inf for an edge never taken), but has {int(bad.sum())} NaN, "
                f"-inf or too large entries in direction {k} (first at {where}: {given.item()!r}"
                f"{_checks.float32_note(given)})"
            )
    for k, (v, (src, dst)) in enumerate(zip(inside, slices)):
        low = v <= 0
        if mask is not None:
            # an edge touching a masked-out node is never used, whatever it costs
            low &= mask[src] & (mask[dst] if dst is not None else True)
        if low.any():
            where = (k, *(int(i) + (s.start or 0) for i, s in zip(np.argwhere(low)[0], src)))
            given = weights[where] if raw is None else raw[where]
            kept = "" if dst is not None else (
                f"; direction {k} {tuple(offsets[k].tolist())} leaves a lattice of shape {shape} along an axis of "
                "size 1, whose entries are kept (refinement interpolates them), so they must be positive too")
            raise ValueError(
                f"'weights' must be positive on usable edges, but has value {given.item()!r}"
                f"{_checks.float32_note(given)} at index {where} ({int(low.sum())} such entries in direction {k})"
                + kept
            )


@dataclass(frozen=True)
class LatticeArrays:
    """A lattice's arrays on one Warp device, as the shortest-path kernels take them.

    Kernels see the lattice *padded* with a one-node border of blocked nodes
    (in x and y, and in z for 3D lattices), so every neighbour of a usable
    node is ``p + flat_offsets[k]`` or ``p - flat_offsets[k]`` with no bounds
    test. ``P`` below is the padded node count.
    """

    shape3: wp.vec3i
    """Unpadded shape as ``(D, H, W)``; D = 1 for 2D lattices."""
    pad3: wp.vec3i
    """Border width per axis ``(z, y, x)``: (0, 1, 1) in 2D, (1, 1, 1) in 3D."""
    padded_shape: tuple
    """Padded shape ``(D + 2 pz, H + 2, W + 2)``."""
    offsets: wp.array
    """Half-offsets as ``wp.vec3i`` ``(dz, dy, dx)``, shape (K,)."""
    flat_offsets: wp.array
    """int32 flat index step of each half-offset in the padded lattice, shape (K,)."""
    records: wp.array
    """int32 node records, shape (P * stride,): record ``p`` holds the packed search
    state (words 0-1), the float32 bits of the ``n_weights`` stored weights (word ``2 + k``: the
    edge ``p <-> p + flat_offsets[k]``), then the search stamp (see
    :mod:`wdendrite.kernels.sssp`)."""
    state: wp.array
    """uint64 view of ``records``, shape (P * stride / 2,): node ``p``'s packed state is
    ``state[p * stride / 2]``."""
    stride: int
    """Words per record: ``n_weights + 3`` rounded up to an even number."""
    n_weights: int
    """Stored weights per record: K, or 0 when weights are recomputed in kernels."""
    mask: wp.array
    """uint8 usable-node flags of the padded lattice, shape (P,) (0 on the border)."""
    usable: object
    """For sparse lattices (fewer than a quarter of the nodes usable): int32 padded
    indices of the usable nodes, so that passes over the lattice visit those only; else None."""
    hashed: object
    """:class:`~wdendrite.kernels.sssp.HashedWeights`: ``use == 1`` when weights are
    recomputed in kernels."""
    stamps: "_Stamps"
    """Issues the ever-growing generation and search ids the record stamps use."""
    scratch: dict = field(default_factory=dict, compare=False, repr=False)
    """Buffers searches on these records keep for the next one (frontier lists and
    recorded launches, see :mod:`wdendrite.sssp`); used under ``stamps.lock``."""

    SCRATCH_LIMIT = 64 * 2**20
    """Bytes up to which a buffer is kept in :attr:`scratch`: a small lattice searched
    many times (growth) saves the allocations; a big one does not hold more memory
    between searches than it needs."""

    def kept(self, key: str, make, nbytes: int):
        """``scratch[key]``, made by ``make()`` when missing and kept when it takes at most
        :attr:`SCRATCH_LIMIT` bytes (the caller holds ``stamps.lock``)."""
        found = self.scratch.get(key)
        if found is None:
            found = make()
            if nbytes <= self.SCRATCH_LIMIT:
                self.scratch[key] = found
        return found

    def fresh_ids(self, count: int) -> int:
        """The first of ``count`` new stamp ids (the caller holds ``stamps.lock``).

        Stamps are int32 and ids only grow; before they would wrap, every
        record's stamp is cleared and numbering starts again.
        """
        if not self.stamps.room(max(count, 2**24)):
            clear_records(self.records, self.stride, self.n_weights, with_state=False)
            self.stamps.last = 0
        first = self.stamps.last + 1
        self.stamps.last += count
        return first


def _record_weights(records: wp.array, padded: tuple, stride: int, n_weights: int) -> np.ndarray:
    """Writable ``(K, *shape)`` float32 view of the weights in the host's node ``records``."""
    words = records.numpy().view(np.float32).reshape(tuple(padded) + (stride,))
    inner = words[1:-1, 1:-1, 1:-1] if padded[0] > 1 else words[0, 1:-1, 1:-1]
    return np.moveaxis(inner[..., _ks.WEIGHT0 : _ks.WEIGHT0 + n_weights], -1, 0)


def pass_chunk(device) -> int:
    """Nodes per thread for whole-lattice passes: many on the CPU, where each thread
    of a launch is a function call, one on GPUs, where neighbouring threads coalesce."""
    return 4096 if wp.get_device(device).is_cpu else 1


def pass_threads(count: int, chunk: int) -> int:
    """Threads of a whole-lattice pass over ``count`` nodes, ``chunk`` per thread."""
    return max(1, -(-count // chunk))


def clear_records(records: wp.array, stride: int, n_weights: int, *, with_state: bool) -> None:
    """Zero every record's queue stamp, and with ``with_state`` its search state too."""
    chunk = pass_chunk(records.device)
    wp.launch(_ks.clear_records_kernel, dim=pass_threads(records.shape[0] // stride, chunk),
              inputs=[stride, n_weights, int(with_state), chunk], outputs=[records], device=records.device)


def record_words(shape: tuple, n_weights: int) -> int:
    """int32 words of the padded node records of a lattice of ``shape`` with ``n_weights`` stored weights."""
    return int(np.prod([n + 2 for n in shape])) * record_stride(n_weights)


class _Stamps:
    """Ids for the stamps in a lattice's records, never repeated, a lock so that
    one search at a time uses the records, and which cost field's states the
    records hold."""

    LIMIT = 2**31 - 2**24

    def __init__(self):
        self.last = 0
        self.lock = threading.RLock()
        self.owner = None
        """Weak reference to the CostField whose packed states the records hold (or None)."""

    def next(self) -> int:
        self.last += 1
        return self.last

    def room(self, needed: int) -> bool:
        """True when ``needed`` more ids fit before the int32 stamps would wrap."""
        return self.last + needed < self.LIMIT


def _rebuild(shape, connectivity, weights, mask, store_weights) -> "Lattice":
    """Unpickle a :class:`Lattice`."""
    return Lattice(shape, connectivity, weights=weights, mask=mask, store_weights=store_weights)


class Lattice:
    """A 2D or 3D lattice of nodes joined by weighted, undirected edges.

    Args:
        shape: ``(H, W)`` or ``(D, H, W)``, positive ints.
        connectivity: 4 or 8 in 2D, 6 or 26 in 3D (default: 4 in 2D, 6 in 3D).
        weights: a ``(K, *shape)`` array of edge costs, positive on every usable edge,
            ``+inf`` for an edge never taken (``weights[k][idx]`` is the edge ``idx <-> idx + offsets[k]``;
            entries whose neighbour lies outside are ignored, except along an axis
            of size 1, where they are kept for refinement and checked), or a
            distribution from :mod:`wdendrite.weights` such as
            ``wd.weights.Uniform(r=10, seed=0)``. Default: each edge costs its
            length (1, sqrt(2), sqrt(3)), giving plain lattice distances.
        mask: bool array of ``shape``; ``True`` marks usable nodes. Masked-out
            nodes are never entered. Default: every node usable.
        store_weights: with a distribution as ``weights``, False stores no
            weight array: kernels recompute each weight from its hash, so a
            lattice too large for stored weights still works. The values equal
            the stored ones bit for bit on the CPU; on a GPU, ``pow`` (CUDA's
            own: in ``Power``, ``Polynomial``, and bias terms with an exponent
            other than 1) may differ from the CPU's by a unit in the last place.

    Attributes:
        shape, ndim, connectivity: as given.
        offsets: ``(K, ndim)`` int64 half-offsets, one per undirected edge direction.
        lengths: ``(K,)`` float32 Euclidean length of each direction.
        weights: ``(K, *shape)`` float32, read-only: the lattice's own copy
            (the caller's array may change afterwards). Entries whose neighbour
            falls outside the lattice hold the nearest edge inside.
        mask: ``shape`` bool, read-only, or ``None``.

    The weights are kept in the node records the search kernels read (built
    with the lattice on the host; copied to other devices when first used).
    With fewer than a quarter of its nodes usable, a lattice is *sparse*: its
    records are touched near usable nodes only, and whole-lattice passes
    visit a list of the usable nodes.

    Raises:
        ValueError, TypeError: for a bad shape, connectivity, weights or mask;
            the message names the parameter and the value it got.
        MemoryError: when the node records would not fit in host memory.
    """

    def __init__(
        self, shape, connectivity: int | None = None, weights=None, mask=None, *, store_weights: bool = True,
    ):
        self.shape = _checks.lattice_shape(shape)
        self.ndim = len(self.shape)
        if connectivity is None:
            connectivity = _ALLOWED[self.ndim][0]
        self.offsets = half_offsets(self.ndim, connectivity)
        self.connectivity = int(connectivity)
        self.offsets.flags.writeable = False
        self.lengths = np.sqrt((self.offsets**2).sum(axis=1)).astype(np.float32)
        self.lengths.flags.writeable = False
        self.mask = None if mask is None else _checks.bool_array("mask", mask, self.shape).copy()
        if self.mask is not None:
            self.mask.flags.writeable = False
        wshape = (len(self.offsets), *self.shape)
        if isinstance(weights, type):
            raise TypeError(f"Expected a weight distribution instance or an array for 'weights', but got the class "
                            f"{weights.__name__} (call it: {weights.__name__}())")
        self.distribution = weights if hasattr(weights, "kernel_params") else None
        """The weight distribution when weights came from one, else None."""
        self._weights = None
        self._device_arrays: dict[str, LatticeArrays] = {}
        # one build of a device's arrays, however many threads ask (a lock per device, so that a
        # slow build on one does not hold up the others; the first lock guards the dict of them)
        self._arrays_lock = threading.Lock()
        self._device_locks: dict[str, threading.Lock] = {}
        self._default_delta: float | None = None  # bucket width cached by shortest_paths
        self._num_usable: int | None = None
        self._stored = _checks.flag("store_weights", store_weights)
        source = None
        if not store_weights:
            if self.distribution is None:
                raise ValueError(
                    "'store_weights=False' needs 'weights' from a wdendrite.weights distribution, "
                    f"but got {type(weights).__name__}"
                )
            self.distribution.kernel_params(self.shape, "cpu")  # validates the distribution for this shape
        elif weights is None:
            source = np.broadcast_to(self.lengths.reshape((-1,) + (1,) * self.ndim), wshape)
        elif self.distribution is not None:
            self.distribution.kernel_params(self.shape, "cpu")  # validates it before any work
        else:
            k = len(self.offsets)
            source = _checks.float_array(
                "weights", weights, wshape, check_values=False,
                shape_note=f" (K = {k}: one plane per undirected edge direction, connectivity {self.connectivity} / 2, "
                           "in the order of Lattice.offsets)")
            _check_weight_values(source, self.offsets, self.mask, raw=np.asarray(weights))
        n_weights = len(self.offsets) if self._stored else 0
        words = record_words(self.shape, n_weights)
        if words >= 2**31:
            # the largest side of a square (cube) lattice whose records fit, for the message
            side = int(((2**31 - 1) // record_stride(n_weights)) ** (1 / self.ndim)) - 2
            while record_words((side + 1,) * self.ndim, n_weights) < 2**31:
                side += 1
            while record_words((side,) * self.ndim, n_weights) >= 2**31:
                side -= 1
            raise ValueError(
                f"'shape' {self.shape} with connectivity {self.connectivity} needs {words} words of node records, "
                f"beyond the kernels' int32 indices (2**31): the largest {'square' if self.ndim == 2 else 'cube'} "
                f"lattice that fits has {side} nodes a side"
                + ("; store_weights=False (weights from a distribution) takes larger ones" if self._stored else "")
            )
        # every argument is checked: a check of a whole model stops here (the memory it needs is
        # for the machine that runs it to judge)
        _checks.stop_if_checking()
        if self._stored:
            _checks.fits_in_memory(self._records_bytes(wp.get_device("cpu")), "cpu",
                                   f"node records of a lattice of shape {self.shape}")
            # the host records are the lattice's own copy of the weights (see ``weights``)
            arrays = self._make_arrays(wp.get_device("cpu"), None if source is None else np.asarray(source, np.float32))
            self._device_arrays["cpu"] = arrays
            if source is not None or self.mask is None:
                # complete records: ``weights`` is a view of them (a masked distribution
                # fills usable nodes only, so its ``weights`` are computed on access)
                self._weights = _record_weights(arrays.records, arrays.padded_shape, arrays.stride, len(self.offsets))
                self._weights.flags.writeable = False

    @property
    def stores_weights(self) -> bool:
        """False when kernels recompute every weight from the distribution's hash."""
        return self._stored

    @property
    def weights(self) -> np.ndarray:
        """``(K, *shape)`` float32 edge weights, read-only.

        For a lattice made with ``store_weights=False``, and for a masked one
        whose weights come from a distribution (its records hold the usable
        nodes' weights only), the array is computed on each access (the same
        values the kernels use).
        """
        if self._weights is not None:
            return self._weights
        sampled = self._sampled("cpu")
        if self.stores_weights:
            self._weights = sampled  # a masked distribution: computed once asked for, then kept
        return sampled

    def _sampled(self, device) -> np.ndarray:
        """The distribution's weights computed on ``device`` (read-only, outside entries filled)."""
        sampled = np.asarray(self.distribution.sample(self.shape, self.lengths, offsets=self.offsets, device=device),
                             np.float32)
        sampled = fill_outside(sampled, self.offsets)
        sampled.flags.writeable = False
        return sampled

    def _kernel_weights(self, device) -> np.ndarray:
        """``(K, *shape)`` float32 weights as the kernels on ``device`` use them: :attr:`weights`,
        except that a lattice storing none recomputes them there (on a GPU, CUDA's ``pow`` may
        differ from the CPU's by a unit in the last place)."""
        if self._stored:
            return self.weights  # records come from the host's weights, whatever the device
        return self._sampled(device)

    @property
    def num_nodes(self) -> int:
        """Number of nodes, usable or not."""
        return int(np.prod(self.shape))

    @property
    def num_usable(self) -> int:
        """Number of usable (unmasked) nodes."""
        if self._num_usable is None:
            self._num_usable = self.num_nodes if self.mask is None else int(np.count_nonzero(self.mask))
        return self._num_usable

    def __repr__(self) -> str:
        masked = "" if self.mask is None else f", {int(self.mask.sum())} usable nodes"
        return f"Lattice(shape={self.shape}, connectivity={self.connectivity}{masked})"

    def with_weights(self, weights) -> Lattice:
        """A lattice of the same shape, connectivity and mask with other ``weights``."""
        return Lattice(self.shape, self.connectivity, weights=weights, mask=self.mask)

    def __reduce__(self):
        # device arrays do not pickle: a copy is rebuilt from the definition
        weights = self.distribution if self.distribution is not None else np.array(self.weights)
        return _rebuild, (self.shape, self.connectivity, weights, self.mask, self.stores_weights)

    def nbytes_per_node(self) -> int:
        """Bytes per lattice node of a dense lattice's records, mask, outputs and frontier lists (estimate)."""
        return 4 * record_stride(len(self.offsets) if self.stores_weights else 0) + 1 + 8 + 16

    def _records_bytes(self, device) -> int:
        """Bytes the node records occupy on ``device`` (estimate). On the CPU a sparse
        lattice's records are zero pages touched near its usable nodes only: counted
        as 16 times the usable share of the box (the refinement boxes measured touch
        4 to 8 times that share), at most the whole box."""
        dense = 4 * record_words(self.shape, len(self.offsets) if self.stores_weights else 0)
        if not wp.get_device(device).is_cpu:
            return dense
        return int(dense * min(1.0, 16.0 * self.num_usable / self.num_nodes))

    def search_bytes(self, device) -> int:
        """Bytes a shortest-path search allocates on ``device`` beyond the arrays it already has:
        the records and mask (the first search on a device), the frontier lists, and room
        for the cost field's ``dist``/``label`` (made when first read). Lattices small
        enough to keep their lists (:attr:`LatticeArrays.SCRATCH_LIMIT`) allocate nothing
        lattice-sized in later searches: 0."""
        arrays = self._device_arrays.get(str(_checks.device(device)))
        if arrays is not None and "search" in arrays.scratch:
            return 0
        need = 8 * self.num_nodes + 16 * self.num_usable
        if arrays is None:
            need += self._records_bytes(device) + int(np.prod([n + 2 for n in self.shape]))
        return need

    def device_arrays(self, device=None) -> LatticeArrays:
        """The lattice's padded arrays on ``device`` (built once, then reused).

        Stored weights: the host records made with the lattice are copied
        (with cleared search state), so every device uses the same float32
        values. Unstored: records without weights are built.
        """
        device = _checks.device(device)
        key = str(device)
        arrays = self._device_arrays.get(key)
        if arrays is None:
            with self._arrays_lock:
                lock = self._device_locks.setdefault(key, threading.Lock())
            with lock:
                arrays = self._device_arrays.get(key)
                if arrays is None:
                    arrays = self._copied_arrays(device) if self.stores_weights else self._make_arrays(device, None)
                    self._device_arrays[key] = arrays
        return arrays

    def _copied_arrays(self, device) -> LatticeArrays:
        """Arrays on ``device`` whose records copy the host records, search state and stamps cleared."""
        host = self._device_arrays["cpu"]
        with host.stamps.lock:
            records = _memory.empty(host.records.shape[0], wp.int32, device)
            wp.copy(records, host.records)
        clear_records(records, host.stride, host.n_weights, with_state=True)
        return self._make_arrays(device, None, records=records)

    def _make_arrays(self, device, weights: np.ndarray | None, records: wp.array | None = None) -> LatticeArrays:
        """Padded arrays on ``device``, with records built from ``weights`` ((K, *shape) float32
        on the host), taken from ``records`` (already filled), filled from the distribution
        (stored weights), or without weights (unstored)."""
        pad3 = (0, 1, 1) if self.ndim == 2 else (1, 1, 1)
        shape3 = (1,) * (3 - self.ndim) + self.shape
        padded = tuple(n + 2 * p for n, p in zip(shape3, pad3))
        inner = tuple(slice(p, p + n) for n, p in zip(shape3, pad3))
        off3 = np.zeros((len(self.offsets), 3), dtype=np.int32)
        off3[:, 3 - self.ndim :] = self.offsets
        flat = (off3 * np.array([padded[1] * padded[2], padded[2], 1])).sum(axis=1).astype(np.int32)
        offsets = wp.array(off3, dtype=wp.vec3i, device=device)
        lengths = wp.array(self.lengths, dtype=float, device=device)
        hashed = _ks.HashedWeights()
        hashed.shape3, hashed.pad3 = wp.vec3i(*shape3), wp.vec3i(*pad3)
        hashed.offsets = offsets
        hashed.lengths = lengths
        n_weights = len(self.offsets) if self.stores_weights else 0
        hashed.use = 0 if self.stores_weights else 1
        if self.distribution is not None:
            hashed.params = self.distribution.kernel_params(self.shape, device)
        else:
            hashed.params = _kw.WeightParams()
        mask = np.zeros(padded, np.uint8)
        mask[inner] = 1 if self.mask is None else self.mask.reshape(shape3)
        # (on the CPU the array is the kernels' own: no copy; nothing writes to it)
        mask_wp = wp.array(mask.ravel(), dtype=wp.uint8, device=device, copy=not wp.get_device(device).is_cpu)
        sparse = self.num_usable * 4 < self.num_nodes
        # (read as bool, the 0/1 bytes are searched about 10x faster than as uint8)
        usable = wp.array(np.flatnonzero(mask.ravel().view(bool)).astype(np.int32), dtype=wp.int32,
                          device=device) if sparse else None
        stride = record_stride(n_weights)
        if records is None:
            # node-major records: a node's state, weights and stamp share its cache line;
            # state 0 blocks border and masked nodes until a search marks the usable ones.
            # Zero pages cost nothing until touched, so a sparse lattice (few usable nodes
            # in its box, as refinement makes) pays for the records it uses only.
            records = _memory.zeros(int(np.prod(padded)) * stride, wp.int32, device, huge=not sparse)
            if weights is not None:  # host records (other devices copy them)
                view = _record_weights(records, padded, stride, n_weights)
                for k in range(n_weights):  # a plane per direction: 0.75x the time of one strided copy
                    view[k] = weights[k]
                fill_outside(view, self.offsets)
            elif self.stores_weights:
                listed = usable if sparse else wp.zeros(1, dtype=wp.int32, device=device)
                wp.launch(_ks.fill_records_kernel, dim=usable.shape[0] if sparse else mask.size,
                          inputs=[listed, int(sparse), mask_wp, hashed.params, hashed.shape3, hashed.pad3, offsets,
                                  lengths, stride],
                          outputs=[records], device=device)
        return LatticeArrays(
            shape3=wp.vec3i(*shape3),
            pad3=wp.vec3i(*pad3),
            padded_shape=padded,
            offsets=offsets,
            flat_offsets=wp.array(flat, dtype=wp.int32, device=device),
            records=records,
            state=wp.array(ptr=records.ptr, dtype=wp.uint64, shape=(records.shape[0] // 2,), device=device),
            stride=stride,
            n_weights=n_weights,
            mask=mask_wp,
            usable=usable,
            hashed=hashed,
            stamps=_Stamps(),
        )

    def _lower_in_place(self, dirs: np.ndarray, coords: np.ndarray, factor: float, device) -> tuple:
        """Multiply the weights of edges ``(dirs[i], coords[i])`` by ``factor``, in place.

        For growth's own copy of a lattice only (lattices are otherwise never
        changed). The host records change here; records on ``device`` get the
        new values from the next warm search (``lowered`` of
        :func:`wdendrite.sssp._search`), and records on any other device are dropped. Returns
        ``(padded nodes, dirs, new weights, the records that hold them)`` for that search.
        """
        if self._weights is None or not self._stored:
            raise ValueError("only a lattice whose host records hold every weight is lowered in place")
        keep = str(wp.get_device(device))
        for key in [k for k in self._device_arrays if k not in ("cpu", keep)]:
            del self._device_arrays[key]
        idx = (np.asarray(dirs),) + tuple(np.asarray(coords).T)
        values = self._weights[idx] * np.float32(factor)
        self._weights.flags.writeable = True
        try:
            self._weights[idx] = values
        finally:
            self._weights.flags.writeable = False
        return (self.padded_indices(coords), np.asarray(dirs, np.int32), values.astype(np.float32),
                self._device_arrays["cpu"])

    def padded_indices(self, coords: np.ndarray) -> np.ndarray:
        """Flat indices in the kernels' padded lattice of ``(G, ndim)`` node coordinates (int32)."""
        return padded_index_of(coords, self.shape).astype(np.int32)

    def edges(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every usable undirected edge as flat node indices ``(u, v)`` int64 and weights float32.

        An edge is usable when both ends are inside the lattice and unmasked.
        Weights the host records do not hold (unstored, or a masked
        distribution) are evaluated for these edges only.
        """
        us, vs, ks = [], [], []
        index = np.arange(self.num_nodes, dtype=np.int64).reshape(self.shape)
        mask = np.ones(self.shape, bool) if self.mask is None else self.mask
        for k, off in enumerate(self.offsets):
            src, dst = edge_slices(off, self.shape)
            ok = mask[src] & mask[dst]
            us.append(index[src][ok])
            vs.append(index[dst][ok])
            ks.append(np.full(len(us[-1]), k, np.int64))
        u, v, k = np.concatenate(us), np.concatenate(vs), np.concatenate(ks)
        return u, v, self._edge_weights(k, u)

    def _edge_weights(self, dirs, nodes, device="cpu") -> np.ndarray:
        """float32 weights of the edges ``weights[dirs[i]]`` at flat node ``nodes[i]`` (C order;
        rows of ``offsets`` and each edge's lower end, both valid: not checked here), as the
        kernels on ``device`` use them: read from the host records, else evaluated for these
        edges only, on ``device`` (see :meth:`_kernel_weights`)."""
        if self._weights is not None:
            return self._weights[(dirs, *np.unravel_index(nodes, self.shape))]
        return self.distribution.evaluate(self.shape, self.lengths, nodes, dirs, offsets=self.offsets, device=device)

    def to_csgraph(self):
        """The lattice as a symmetric ``scipy.sparse.csr_matrix`` of shape (N, N) (needs SciPy).

        Zero-weight edges are stored explicitly, so SciPy's graph routines see them.
        """
        from scipy import sparse

        u, v, w = self.edges()
        n = self.num_nodes
        g = sparse.csr_matrix(
            (np.concatenate([w, w]).astype(np.float64), (np.concatenate([u, v]), np.concatenate([v, u]))),
            shape=(n, n),
        )
        return g
