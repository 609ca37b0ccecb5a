"""Path refinement on sublattices (Xu thesis section 4.4, Figs 4.14-4.16).

Every node of a coarse dendrite becomes an ``n x n`` (``n^3`` in 3D) block of
a finer lattice, with ``n`` odd so the coarse node sits at its block's
centre; everything else is masked out, so the ordinary shortest-path and
backtracking kernels run on it. As in the thesis (Fig 4.15), blocks are
stitched along the dendrite's steps only: fine edges between the blocks of a
node and its parent (and, for a diagonal step, the blocks it passes on the
way) are usable, while edges into the block of any other node lying beside
it weigh inf. Each refined path thus keeps to the blocks of its own coarse
path, and competing dendrites keep their endpoints, while the result is still
one tree, traced in one search. Fine edge weights are
``W_sub = e * W_int + (1 - e) * W_ran`` (see :class:`Refined`): ``W_int``
interpolates the coarse weights linearly, ``W_ran`` is uniform between 1 and
``W_int``; ``0.5 < e < 1`` keeps the coarse path's shape while adding detail.
A kernel computes the fine weights of the usable nodes only, straight into
the fine lattice's records; the rest of the bounding box is never touched
(boxes too large for stored records recompute weights in the kernels).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

import warp as wp

from . import _checks
from .dendrite import Dendrite, trace
from .kernels import weights as _kw
from .lattice import Lattice, record_words
from .sssp import shortest_paths
from .weights import Distribution

__all__ = ["Refined", "refine", "refined_lattice"]


def _check_n_e(n, e, *, n_name: str = "n") -> tuple[int, float]:
    """The sublattice size ``n`` (odd, >= 3) and interpolation share ``e`` (in (0.5, 1)), validated;
    ``n_name`` is what the caller calls ``n``."""
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 3 or n % 2 == 0:
        raise ValueError(f"Expected an odd integer '{n_name}' >= 3, but got {n!r}")
    e = _checks.positive("e", e)
    if not 0.5 < e < 1.0:
        raise ValueError(f"Expected 'e' in the open interval (0.5, 1), but got {e!r}")
    return int(n), e


@dataclasses.dataclass(frozen=True, eq=False)
class Refined(Distribution):
    """Sublattice weights ``W_sub = (e * W_int + (1 - e) * W_ran) * length / n`` (thesis 4.4).

    ``W_int`` interpolates the coarse weights per unit length of the same direction linearly
    at each fine edge's midpoint, where the coarse edges' weights sit at theirs (coarse node
    ``c`` sits at fine index ``c * n + n // 2``);
    ``W_ran`` is uniform between 1 and ``W_int``, from the hash of ``seed``.
    Computed in the kernels, so a refined lattice holds no ``(K, *shape)`` weight array.
    """

    coarse: np.ndarray
    """``(K, *block)`` float32 coarse weights divided by their edge lengths, of the block of
    coarse nodes starting at ``lo`` (the whole coarse lattice by default)."""
    n: int
    """Fine nodes per coarse node along each axis (odd, >= 3)."""
    e: float
    """Share of the interpolated weight, in (0.5, 1)."""
    start: tuple
    """Fine index, in the whole fine lattice, of the window's node (0, ...)."""
    seed: int = 0
    """Hash seed of ``W_ran``."""
    lo: tuple | None = None
    """Coarse index of ``coarse``'s first node in the whole coarse lattice (default: the origin).
    The block must hold every coarse node the window's fine nodes interpolate between."""
    grid: tuple | None = None
    """Shape of the whole coarse lattice, where interpolation stops (default: ``lo`` plus the block's)."""
    links: np.ndarray | None = None
    """``block``-shaped int32: per coarse node, bit ``9 (dz + 1) + 3 (dy + 1) + dx + 1`` (dz = 0 in
    2D) set where fine edges may cross from its block into the block of the coarse node at
    offset ``(dz, dy, dx)``; crossings not set weigh inf. Default: every crossing allowed."""

    def __post_init__(self):
        _check_n_e(self.n, self.e)
        coarse = np.asarray(self.coarse)
        if coarse.ndim not in (3, 4):
            raise ValueError(f"Expected 'coarse' of shape (K, H, W) or (K, D, H, W), but got shape {coarse.shape}")
        ndim = coarse.ndim - 1
        for name in ("start", "lo", "grid"):
            value = getattr(self, name)
            if value is not None and len(value) != ndim:
                raise ValueError(f"Expected {ndim} entries in '{name}', but got {value!r}")
        object.__setattr__(self, "start", tuple(int(v) for v in self.start))
        lo = (0,) * ndim if self.lo is None else tuple(int(v) for v in self.lo)
        grid = tuple(a + b for a, b in zip(lo, coarse.shape[1:])) if self.grid is None else tuple(int(v) for v in self.grid)
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "grid", grid)
        if min(lo) < 0 or any(a + b > g for a, b, g in zip(lo, coarse.shape[1:], grid)):
            raise ValueError(f"The block of 'coarse' (shape {coarse.shape[1:]} at 'lo' {lo}) does not lie "
                             f"inside 'grid' {grid}")
        if self.links is not None:
            links = np.asarray(self.links)
            if links.shape != coarse.shape[1:] or links.dtype.kind not in "iu":
                raise ValueError(f"Expected integer 'links' of shape {coarse.shape[1:]} (the block of 'coarse'), "
                                 f"but got {links.dtype} {links.shape}")

    def _needed(self, shape) -> tuple[tuple[int, ...], tuple[int, ...]]:
        """First and last coarse index a fine window of ``shape`` interpolates between, per axis,
        found as the kernels find them (float32 arithmetic; interpolation cells grow with the index)."""
        n = np.float32(self.n)
        inv_n = np.float32(1.0) / n
        half = np.float32(self.n // 2)
        first, last = [], []
        for c0, size, g in zip(self.start, shape, self.grid):
            cells = []
            for c in (c0, c0 + size - 1):
                for o in (-1, 0, 1):  # an edge's offset along the axis (see kernels.weights.cell_of)
                    x = (np.float32(c) + np.float32(0.5) * np.float32(o) - half) * inv_n - np.float32(0.5) * np.float32(o)
                    x = np.clip(x, np.float32(0.0), np.float32(g - 1))
                    i = min(int(np.floor(x)), max(g - 2, 0))
                    cells += [i, min(i + 1, g - 1)]
            first.append(min(cells))
            last.append(max(cells))
        return tuple(first), tuple(last)

    def _base(self):
        return _kw.REFINED, self.e, float(self.n), self.seed

    def _bound(self) -> float:
        if "_top" not in self.__dict__:
            self.__dict__["_top"] = float(np.max(self.coarse, initial=1.0))
        return self.__dict__["_top"] / self.n + 1.0

    def kernel_params(self, shape, device=None):
        """As for :class:`~wdendrite.weights.Distribution`, for a fine window of ``shape``
        starting at ``start``; raises ValueError when the window interpolates between coarse
        nodes the block does not hold (the kernels would read outside it)."""
        ndim = self.coarse.ndim - 1
        shape = _checks.lattice_shape(shape)
        if len(shape) != ndim:
            raise ValueError(f"Expected a {ndim}D 'shape' for these refined weights, but got {shape}")
        first, last = self._needed(shape)
        end = tuple(a + b - 1 for a, b in zip(self.lo, self.coarse.shape[1:]))
        if any(f < a for f, a in zip(first, self.lo)) or any(l_ > e for l_, e in zip(last, end)):
            raise ValueError(
                f"A fine window of shape {shape} at 'start' {self.start} interpolates between coarse nodes {first} to "
                f"{last}, but 'coarse' holds {self.lo} to {end} only"
            )
        params = super().kernel_params(shape, device)
        pad = (1,) * (3 - ndim)
        params.maps, params.links = self._arrays(wp.get_device(device))
        params.grid = wp.vec3i(*(pad + self.grid))
        params.grid_k = int(self.coarse.shape[0])
        params.grid_start = wp.vec3i(*((0,) * (3 - ndim) + self.start))
        params.grid_lo = wp.vec3i(*((0,) * (3 - ndim) + self.lo))
        params.grid_span = wp.vec3i(*(pad + self.coarse.shape[1:]))
        return params

    def __getstate__(self):
        # the per-device caches hold Warp arrays, which neither pickle nor deep-copy
        return {k: v for k, v in self.__dict__.items() if k not in ("_on_device", "_top")}

    def _arrays(self, device) -> tuple[wp.array, wp.array]:
        """The coarse weights (node-major, so that one fine node's directions read neighbouring
        words) and the links on ``device``, made once per device: searches and traces ask again."""
        cache = self.__dict__.setdefault("_on_device", {})
        key = str(device)
        if key not in cache:
            links = np.full(1, -1, np.int32) if self.links is None else np.asarray(self.links).astype(np.int32).ravel()
            node_major = np.ascontiguousarray(np.moveaxis(self.coarse, 0, -1), np.float32).ravel()
            cache[key] = (wp.array(node_major, dtype=float, device=device, copy=not device.is_cpu),  # (a new array)
                          wp.array(links, dtype=int, device=device))
        return cache[key]


def _check_pair(dendrite, lattice) -> None:
    if not isinstance(dendrite, Dendrite):
        raise TypeError(f"Expected a wdendrite.Dendrite for 'dendrite', but got {type(dendrite).__name__}")
    if not isinstance(lattice, Lattice):
        raise TypeError(f"Expected the wdendrite.Lattice the dendrite was traced on for 'lattice', but got "
                        f"{type(lattice).__name__}")
    if tuple(dendrite.shape) != lattice.shape:
        raise ValueError(f"'dendrite' has shape {dendrite.shape}, but 'lattice' has shape {lattice.shape}")
    if not len(dendrite):
        raise ValueError("'dendrite' is empty: there is nothing to refine")
    if lattice.mask is not None:
        off = np.flatnonzero(~lattice.mask[tuple(dendrite.nodes.T)])
        if off.size:
            raise ValueError(f"'dendrite' row {off[0]} = {tuple(dendrite.nodes[off[0]].tolist())} is a masked-out node "
                             f"of 'lattice' ({off.size} such rows): refine needs the lattice it was traced on")


def _coarse_block(lattice: Lattice, block: tuple, need: np.ndarray) -> np.ndarray:
    """``(K, *block)`` float32 weights per unit length of the coarse nodes in ``block`` (slices)
    for the nodes ``need`` marks (bool, block-shaped: those a fine node interpolates between);
    other entries are 1.

    Read from the records, or computed for the needed nodes and their neighbours only when the
    lattice holds none. An entry no usable edge stands behind (an end masked out or beyond the
    lattice, except along an axis of size 1, whose entries the lattice keeps; or a weight of
    inf, an edge never taken) takes the mean of the usable entries of its direction at the
    node's neighbours, else of the node's other directions, else of its neighbours' other
    directions, else 1: the fine weights next to walls and borders look like their
    surroundings whatever the lattice holds there, and depend on the lattice alone."""
    offsets = lattice.offsets
    nd, nk = lattice.ndim, len(offsets)
    shape = np.asarray(lattice.shape)
    # an axis of size 1 has no edge inside: its entries are the lattice's own, kept
    reach = np.where(shape >= 2, offsets, 0)
    lengths = lattice.lengths.astype(np.float64)
    full = lattice.weights if lattice._weights is not None else None

    def entries(k: np.ndarray, c: np.ndarray, inside: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Values per unit length of entries (direction ``k``, node ``c``: global coordinates
        inside the lattice), and whether a usable edge stands behind each (``inside``: whether
        each edge's far end lies in the lattice, when the caller knows)."""
        if full is not None:
            v = full[(k,) + tuple(c.T)].astype(np.float64)
        else:
            v = lattice.distribution.evaluate(lattice.shape, lattice.lengths, np.ravel_multi_index(tuple(c.T), lattice.shape),
                                              k, offsets=offsets).astype(np.float64)
        v /= lengths[k]
        if inside is None:
            other = c + reach[k]
            inside = ((other >= 0) & (other < shape)).all(axis=1)
        with np.errstate(invalid="ignore"):
            ok = np.isfinite(v) & (v > 0) & inside
        if lattice.mask is not None:
            ok &= lattice.mask[tuple(c.T)]
            ok[ok] &= lattice.mask[tuple((c[ok] + reach[k[ok]]).T)]
        return v, ok

    corner = np.array([b.start for b in block])
    if full is not None and lattice.mask is None:
        # stored weights, every node usable: the block at once, then its few entries without an
        # edge (leaving the lattice, or inf) found by position and value
        per = full[(slice(None),) + block] / lengths.reshape((-1,) + (1,) * nd).astype(np.float32)
        faces = []  # (direction, axis, index) of entries whose edge leaves the lattice
        for k in range(nk):
            for axis in range(nd):
                if reach[k, axis] == 1 and block[axis].stop == shape[axis]:
                    faces.append((k, axis, need.shape[axis] - 1))
                elif reach[k, axis] == -1 and block[axis].start == 0:
                    faces.append((k, axis, 0))
        if float(per.min()) > 0 and float(per.max()) < np.inf:  # the usual case: only the faces
            picks = []
            for k, axis, i in faces:
                on = np.argwhere(np.take(need, i, axis=axis))
                picks.append(np.concatenate([np.full((len(on), 1), k), np.insert(on, axis, i, axis=1)], axis=1))
            picked = np.unique(np.concatenate(picks), axis=0) if picks else np.zeros((0, nd + 1), np.int64)
            bk, bc = picked[:, 0], picked[:, 1:]
        else:
            with np.errstate(invalid="ignore"):
                bad = ~((per > 0) & (per < np.inf))  # (NaN fails both)
            for k, axis, i in faces:
                face = [slice(None)] * nd
                face[axis] = i
                bad[(k,) + tuple(face)] = True
            bk, *bc = np.unravel_index(np.flatnonzero(bad & need[None]), bad.shape)
            bc = np.stack(bc, axis=1)
            per[bad & ~need[None]] = 1.0  # (never read; keeps the weights' bound finite)
        if len(bk):
            per[(bk,) + tuple(bc.T)] = _fill(entries, bk, bc + corner, shape, nd, nk)
        return per
    mine = np.argwhere(need) + corner
    # an edge leaves the lattice where its node lies on a side it moves across (offsets are -1, 0, 1)
    leaves = ((mine == shape - 1).astype(np.int64) @ (reach == 1).T.astype(np.int64)
              + (mine == 0).astype(np.int64) @ (reach == -1).T.astype(np.int64))
    vals, ok = np.empty((nk, len(mine))), np.empty((nk, len(mine)), bool)
    for k in range(nk):
        vals[k], ok[k] = entries(np.full(len(mine), k), mine, inside=leaves[:, k] == 0)
    vals, ok = vals.ravel(), ok.ravel()
    bad = np.flatnonzero(~ok)
    if len(bad):
        vals[bad] = _fill(entries, bad // len(mine), mine[bad % len(mine)], shape, nd, nk)
    per = np.ones((nk,) + need.shape, np.float32)
    per[:, need] = vals.reshape(nk, len(mine)).astype(np.float32)
    return per


def _fill(entries, bk: np.ndarray, bc: np.ndarray, shape: np.ndarray, nd: int, nk: int) -> np.ndarray:
    """Values for entries (directions ``bk``, global nodes ``bc``) no usable edge stands behind:
    see :func:`_coarse_block` (``entries`` reads and judges entries)."""
    rings = [np.array(d) - 1 for d in np.ndindex(*(3,) * nd) if any(v != 1 for v in d)]
    total, count = np.zeros(len(bk)), np.zeros(len(bk))
    for d in rings:  # the same direction at the neighbours
        nc = bc + d
        inb = np.flatnonzero(((nc >= 0) & (nc < shape)).all(axis=1))
        v, good = entries(bk[inb], nc[inb])
        total[inb[good]] += v[good]
        count[inb[good]] += 1
    fill = np.where(count > 0, total / np.maximum(count, 1), np.nan)
    left = np.flatnonzero(count == 0)
    for where in ([np.zeros(nd, int)], rings):  # the node's other directions, then its neighbours'
        if not len(left):
            break
        total, count = np.zeros(len(left)), np.zeros(len(left))
        for d in where:
            nc = bc[left] + d
            inb = np.flatnonzero(((nc >= 0) & (nc < shape)).all(axis=1))
            for k in range(nk):
                v, good = entries(np.full(len(inb), k), nc[inb])
                total[inb[good]] += v[good]
                count[inb[good]] += 1
        fill[left[count > 0]] = total[count > 0] / count[count > 0]
        left = left[count == 0]
    fill[left] = 1.0
    return fill


def _block_rows(den: Dendrite, lattice: Lattice) -> np.ndarray:
    """Coarse nodes whose blocks make the refined graph, as the dendrite row each stands for
    (-1 elsewhere): the dendrite's nodes, plus for each diagonal step the nodes it passes
    along its first axes (standing for the step's child), so consecutive blocks touch along
    a face in 2D and at least an edge in 3D (connected for every connectivity in use)."""
    rows = np.full(lattice.shape, -1, np.int64)
    child = np.flatnonzero(den.parent >= 0)
    a, b = den.nodes[child], den.nodes[den.parent[child]]
    step = b - a
    for axis in range(lattice.ndim):
        moved = step[:, axis] != 0
        if np.any(moved & (np.abs(step).sum(axis=1) > 1)):
            c = a[moved].copy()
            c[:, axis] = b[moved, axis]
            rows[tuple(c.T)] = child[moved]
    rows[tuple(den.nodes.T)] = np.arange(len(den))  # a dendrite node stands for itself
    if lattice.mask is not None:
        rows[~lattice.mask] = -1
    return rows


def _block_links(rows: np.ndarray, parent: np.ndarray) -> np.ndarray:
    """:attr:`Refined.links` for coarse nodes standing for dendrite ``rows`` (-1: none): blocks
    join where they stand for one row or for a parent and its child, so a refined path keeps
    to the blocks of its own coarse path (thesis Fig 4.15 stitches consecutive blocks only)."""
    nd = rows.ndim
    r3 = rows.reshape((1,) * (3 - nd) + rows.shape)
    links = np.zeros(r3.shape, np.int32)
    at = np.argwhere(r3 >= 0)  # only blocks' nodes: the rest of the box stays 0
    mine = r3[tuple(at.T)]
    up = parent[mine]
    for dz in ((-1, 0, 1) if nd == 3 else (0,)):
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                nb = at + (dz, dy, dx)
                inside = ((nb >= 0) & (nb < r3.shape)).all(axis=1)
                there = np.full(len(at), -1, rows.dtype)
                there[inside] = r3[tuple(nb[inside].T)]
                joined = (there >= 0) & ((there == mine) | (up == there) | (parent[np.maximum(there, 0)] == mine))
                links[tuple(at[joined].T)] |= np.int32(1 << (9 * (dz + 1) + 3 * (dy + 1) + dx + 1))
    return links.reshape(rows.shape)


def refined_lattice(dendrite: Dendrite, lattice: Lattice, *, n: int, e: float, seed=0):
    """The masked fine lattice :func:`refine` plans on, with its roots and endpoints.

    Args:
        dendrite, lattice, n, e, seed: as for :func:`refine`.

    Returns:
        ``(fine_lattice, roots, endpoints, origin)``: roots and endpoints are
        ``(G, ndim)`` / ``(M, ndim)`` fine coordinates at the centres of the
        coarse ones' blocks; ``origin`` is the world position of fine node 0.

    Raises:
        ValueError, TypeError: as for :func:`refine`.
    """
    return _refined(dendrite, lattice, n, e, seed)[:4]


def _refined(dendrite: Dendrite, lattice: Lattice, n, e, seed):
    """:func:`refined_lattice`, plus the window's first coarse node and the dendrite row each
    coarse node of the window stands for (see :func:`_block_rows`)."""
    n, e = _check_n_e(n, e)
    _check_pair(dendrite, lattice)
    rng = _checks.rng(seed)

    rows = _block_rows(dendrite, lattice)
    keep = rows >= 0
    lo = np.argwhere(keep).min(axis=0)
    hi = np.argwhere(keep).max(axis=0) + 1
    window = tuple(slice(a, b) for a, b in zip(lo, hi))
    fine_shape = tuple(int(b - a) * n for a, b in zip(lo, hi))
    # before any fine array: the box must fit the kernels' int32 indices, and its masks memory
    nodes = math.prod(fine_shape)
    if nodes >= 2**31 or record_words(fine_shape, 0) >= 2**31:
        raise ValueError(f"'n' = {n} makes a fine lattice of shape {fine_shape} around the dendrite ({nodes} nodes in "
                         f"its box), beyond the kernels' int32 indices (2**31); lower 'n' or refine a part of the dendrite")
    _checks.fits_in_memory(3 * nodes, "cpu", f"the fine mask of refine with 'n' = {n} (box {fine_shape})")
    fine_mask = keep[window]
    for axis in range(lattice.ndim):
        fine_mask = np.repeat(fine_mask, n, axis=axis)
    start = lo * n
    # the window's fine nodes interpolate between coarse nodes at most one beyond the window
    near_lo = np.maximum(lo - 1, 0)
    near_hi = np.minimum(hi + 1, lattice.shape)
    near = tuple(slice(int(a), int(b)) for a, b in zip(near_lo, near_hi))
    # the coarse nodes a fine node interpolates between: within one of a block's node
    need = keep[near].copy()
    for axis in range(lattice.ndim):
        grown = need.copy()
        lo_s = [slice(None)] * lattice.ndim
        hi_s = [slice(None)] * lattice.ndim
        lo_s[axis], hi_s[axis] = slice(1, None), slice(None, -1)
        grown[tuple(lo_s)] |= need[tuple(hi_s)]
        grown[tuple(hi_s)] |= need[tuple(lo_s)]
        need = grown
    per_length = _coarse_block(lattice, near, need)
    # a kernel writes the usable nodes' fine weights into the records: no (K, *fine_shape) array.
    # Boxes whose stored records would pass the kernels' int32 indices recompute the weights
    # in the kernels instead (smaller records, each weight computed when relaxed)
    dist = Refined(per_length, n, float(e), tuple(int(v) for v in start), int(rng.integers(0, 2**32)),
                   lo=tuple(int(v) for v in near_lo), grid=tuple(lattice.shape),
                   links=_block_links(rows[near], dendrite.parent))
    store = record_words(fine_shape, len(lattice.offsets)) < 2**31
    fine_lat = Lattice(fine_shape, lattice.connectivity, weights=dist, mask=fine_mask, store_weights=store)

    centre = lambda r: (dendrite.nodes[r] - lo) * n + n // 2  # noqa: E731
    roots = np.unique(centre(dendrite.roots), axis=0)
    ends = np.unique(centre(dendrite.endpoints), axis=0)
    origin = np.asarray(dendrite.origin, float) + dendrite.spacing * (start - n // 2) / n
    return fine_lat, roots, ends, origin, lo, rows[window]


def refine(
    dendrite: Dendrite,
    lattice: Lattice,
    *,
    n: int = 7,
    e: float = 0.75,
    seed: int | np.random.Generator = 0,
    device=None,
) -> tuple[Dendrite, Lattice]:
    """Recompute a dendrite's paths on an ``n`` times finer lattice around it.

    Args:
        dendrite: the coarse dendrite (from :func:`trace` or :func:`grow`).
        lattice: the lattice it was traced on (its weights and connectivity
            are reused).
        n: sublattice size per coarse node, odd and >= 3 (the thesis shows 7, 9, 15).
        e: weight of the interpolated coarse weights, in (0.5, 1).
        seed: int or ``np.random.Generator`` for the random part of the weights.
        device: Warp device (default: Warp's default device).

    Returns:
        ``(fine, fine_lattice)``: the refined :class:`Dendrite` (its roots and
        endpoints sit at the centres of the coarse ones' blocks; its
        ``origin``/``spacing`` place it over the coarse one; every node keeps
        the ``generation`` of the coarse node whose block it lies in and the
        ``label`` of the coarse root its path leads to) and the masked fine
        lattice, cropped to the dendrite's bounding box. Refine again for more
        detail.

    Raises:
        ValueError: ``n`` even or < 3, ``e`` outside (0.5, 1), an empty dendrite,
            a dendrite from another lattice shape or on its masked-out nodes, an ``n``
            whose fine box passes the kernels' int32 indices, a negative ``seed``, or an
            unknown or absent ``device``.
        MemoryError: the fine box's masks would not fit in free memory.
        TypeError: ``dendrite`` or ``lattice`` of the wrong type, a ``seed`` that is
            neither an int nor a ``np.random.Generator``.
    """
    device = _checks.device(device)
    fine_lat, roots, ends, origin, lo, rows = _refined(dendrite, lattice, n, e, seed)
    cf = shortest_paths(fine_lat, roots, device=device)
    fine = trace(cf, ends)
    # each fine node keeps the generation of the coarse row its block stands for, and the
    # label of the coarse root its path ends at
    block = rows[tuple((fine.nodes // n).T)]
    coarse_root = rows[tuple((roots // n).T)]
    return dataclasses.replace(fine, origin=tuple(origin.tolist()), spacing=dendrite.spacing / n,
                               generation=dendrite.generation[block].astype(np.int32),
                               label=dendrite.label[coarse_root][fine.label].astype(np.int32)), fine_lat
