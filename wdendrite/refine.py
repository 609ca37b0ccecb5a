"""Path refinement on sublattices (Xu thesis section 4.4, Figs 4.14-4.16).

Every node of a coarse dendrite becomes an ``n x n`` (``n^3`` in 3D) block of
a finer lattice, with ``n`` odd so the coarse node sits at its block's
centre. Blocks of neighbouring nodes touch, which stitches them into one
graph; everything else is masked out, so the ordinary shortest-path and
backtracking kernels run on it. Fine edge weights are
``W_sub = e * W_int + (1 - e) * W_ran``: ``W_int`` interpolates the coarse
weights linearly, ``W_ran`` is uniform between 1 and ``W_int``; ``0.5 < e < 1``
keeps the coarse path's shape while adding detail.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from . import _checks
from .dendrite import Dendrite, trace
from .lattice import Lattice
from .sssp import shortest_paths

__all__ = ["refine", "refined_lattice"]


def _block_mask(den: Dendrite, lattice: Lattice) -> np.ndarray:
    """Coarse nodes whose blocks make the refined graph: the dendrite, plus for each
    diagonal step the axis neighbours it passes, so consecutive blocks share a face."""
    keep = np.zeros(lattice.shape, bool)
    keep[tuple(den.nodes.T)] = True
    child = np.flatnonzero(den.parent >= 0)
    a, b = den.nodes[child], den.nodes[den.parent[child]]
    step = b - a
    for axis in range(lattice.ndim):
        moved = step[:, axis] != 0
        if np.any(moved & (np.abs(step).sum(axis=1) > 1)):
            c = a[moved].copy()
            c[:, axis] = b[moved, axis]
            keep[tuple(c.T)] = True
    if lattice.mask is not None:
        keep &= lattice.mask
    return keep


def _interpolate(coarse_w: np.ndarray, fine_nodes: np.ndarray, start, n: int) -> np.ndarray:
    """Multilinear interpolation of coarse weights ``(K, *coarse)`` at ``(M, ndim)`` fine nodes -> ``(K, M)``."""
    from scipy.ndimage import map_coordinates

    coords = ((fine_nodes + np.asarray(start)) - n // 2).T / n
    return np.stack([map_coordinates(w, coords, order=1, mode="nearest").astype(np.float32) for w in coarse_w])


def refined_lattice(dendrite: Dendrite, lattice: Lattice, *, n: int, e: float, seed=0):
    """The masked fine lattice :func:`refine` plans on, with its roots and endpoints.

    Returns:
        ``(fine_lattice, roots, endpoints, origin)``: roots and endpoints are
        ``(G, ndim)`` / ``(M, ndim)`` fine coordinates at the centres of the
        coarse ones' blocks; ``origin`` is the world position of fine node 0.
        Parameters are as for :func:`refine` (validated there).
    """
    rng = np.random.default_rng(seed)

    keep = _block_mask(dendrite, lattice)
    lo = np.argwhere(keep).min(axis=0)
    hi = np.argwhere(keep).max(axis=0) + 1
    window = tuple(slice(a, b) for a, b in zip(lo, hi))
    fine_shape = tuple(int(b - a) * n for a, b in zip(lo, hi))
    fine_mask = keep[window]
    for axis in range(lattice.ndim):
        fine_mask = np.repeat(fine_mask, n, axis=axis)
    start = lo * n
    # weights are only needed where the mask keeps nodes; elsewhere they are never read
    kept = np.nonzero(fine_mask)
    per_length = lattice.weights / lattice.lengths.reshape((-1,) + (1,) * lattice.ndim)
    w_int = _interpolate(per_length, np.stack(kept, axis=1), start, n)
    w_ran = 1.0 + (np.maximum(w_int, 1.0) - 1.0) * rng.random(w_int.shape, dtype=np.float32)
    # fine edges are 1/n as long as coarse ones, so costs stay in the coarse units
    w_sub = np.zeros((len(lattice.lengths), *fine_shape), np.float32)
    w_sub[(slice(None),) + kept] = (e * w_int + (1.0 - e) * w_ran) * (lattice.lengths[:, None] / n)
    fine_lat = Lattice(fine_shape, lattice.connectivity, weights=w_sub, mask=fine_mask, _adopt=True)

    centre = lambda rows: (dendrite.nodes[rows] - lo) * n + n // 2  # noqa: E731
    roots = np.unique(centre(dendrite.roots), axis=0)
    ends = np.unique(centre(dendrite.endpoints), axis=0)
    origin = np.asarray(dendrite.origin, float) + dendrite.spacing * (start - n // 2) / n
    return fine_lat, roots, ends, origin


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
        ``origin``/``spacing`` place it over the coarse one) and the masked
        fine lattice, cropped to the dendrite's bounding box. Refine again
        for more detail.

    Raises:
        ValueError: ``n`` even or < 3, ``e`` outside (0.5, 1), or a dendrite
            from another lattice shape.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 3 or n % 2 == 0:
        raise ValueError(f"Expected an odd integer 'n' >= 3, but got {n!r}")
    e = _checks.positive("e", e)
    if not 0.5 < e < 1.0:
        raise ValueError(f"Expected 'e' in the open interval (0.5, 1), but got {e!r}")
    if not isinstance(dendrite, Dendrite) or not isinstance(lattice, Lattice):
        raise TypeError("Expected a Dendrite and the Lattice it was traced on for 'dendrite' and 'lattice'")
    if tuple(dendrite.shape) != lattice.shape:
        raise ValueError(f"'dendrite' has shape {dendrite.shape}, but 'lattice' has shape {lattice.shape}")
    if not len(dendrite):
        raise ValueError("'dendrite' is empty: there is nothing to refine")
    fine_lat, roots, ends, origin = refined_lattice(dendrite, lattice, n=n, e=e, seed=seed)
    cf = shortest_paths(fine_lat, roots, device=device)
    fine = trace(cf, ends)
    return dataclasses.replace(fine, origin=tuple(origin.tolist()), spacing=dendrite.spacing / n), fine_lat
