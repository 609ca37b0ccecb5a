"""Hydrology metrics for terrains: depressions, D8 and D-infinity drainage area, noise baselines.

Depressions are the cells a priority-flood fill raises (Barnes et al. 2014): water
poured on the terrain drains to the border except where it is trapped. The fill
is computed as a morphological reconstruction by erosion from the border, which
gives the same surface. Each 8-connected group of raised cells is one depression.

Example::

    from wdendrite import hydrology
    stats = hydrology.depressions(elevation)
    stats.count, stats.percent
    area = hydrology.flow_accumulation(elevation)      # D8; method="dinf" for D-infinity
    img = hydrology.drainage_image(area)               # log-scaled, in [0, 1]
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from . import _checks
from . import control as _control

__all__ = ["Depressions", "depressions", "drainage_image", "fbm_terrain", "fill", "flow_accumulation",
           "ridged_terrain"]

# D8 neighbours (row, col offsets) and their distances
_D8 = np.array([(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)])
_D8_LEN = np.hypot(_D8[:, 0], _D8[:, 1])


def _elevation(name: str, value) -> np.ndarray:
    arr = np.asarray(value)
    if arr.dtype.kind not in "fiu" or arr.dtype == np.bool_:
        raise TypeError(f"Expected a real-valued array for '{name}', but got dtype {arr.dtype}")
    if arr.ndim != 2 or min(arr.shape) < 1:
        raise ValueError(f"Expected a non-empty 2D array for '{name}', but got shape {arr.shape}")
    arr = np.ascontiguousarray(arr, dtype=np.float64)
    if not np.isfinite(arr).all():
        raise ValueError(f"'{name}' must be finite, but has {int((~np.isfinite(arr)).sum())} NaN/inf entries")
    return arr


def fill(elevation) -> np.ndarray:
    """The depression-filled surface: the lowest surface >= ``elevation`` that drains to the border.

    Args:
        elevation: (H, W) real array.

    Returns:
        (H, W) float64 array.
    """
    from skimage.morphology import reconstruction

    z = _elevation("elevation", elevation)
    if min(z.shape) <= 2:
        return z.copy()
    seed = z.copy()
    seed[1:-1, 1:-1] = z.max()
    return reconstruction(seed, z, method="erosion", footprint=np.ones((3, 3), bool))


@dataclass(frozen=True)
class Depressions:
    """Depressions of a terrain."""

    count: int
    """Number of 8-connected groups of raised cells."""
    percent: float
    """Raised cells, in percent of all cells."""
    mask: np.ndarray
    """(H, W) bool, True where the fill raised the terrain."""
    depth: np.ndarray
    """(H, W) float64, filled minus original elevation."""


def depressions(elevation) -> Depressions:
    """Count the depressions of ``elevation`` ((H, W) real array) and their share of the surface."""
    from scipy.ndimage import label

    z = _elevation("elevation", elevation)
    depth = fill(z) - z
    mask = depth > 0
    _, count = label(mask, structure=np.ones((3, 3), int))
    return Depressions(int(count), 100.0 * float(mask.mean()), mask, depth)


# D-infinity facets (Tarboton 1997): cardinal neighbour e1 and diagonal neighbour e2, (row, col) offsets
_FACETS = [((0, 1), (-1, 1)), ((-1, 0), (-1, 1)), ((-1, 0), (-1, -1)), ((0, -1), (-1, -1)),
           ((0, -1), (1, -1)), ((1, 0), (1, -1)), ((1, 0), (1, 1)), ((0, 1), (1, 1))]


def _shifted(pad: np.ndarray, off, shape) -> np.ndarray:
    h, w = shape
    return pad[1 + off[0] : 1 + off[0] + h, 1 + off[1] : 1 + off[1] + w]


def _d8_receivers(z: np.ndarray):
    """One receiver per cell (flat index, -1 for none) with weight 1."""
    h, w = z.shape
    pad = np.pad(z, 1, constant_values=np.inf)
    drops = np.stack([(z - _shifted(pad, off, z.shape)) / ln for off, ln in zip(_D8, _D8_LEN)])
    best = np.argmax(drops, axis=0)
    has = np.take_along_axis(drops, best[None], 0)[0] > 0
    rows, cols = np.mgrid[0:h, 0:w]
    rec = np.where(has, (rows + _D8[best, 0]) * w + cols + _D8[best, 1], -1).ravel()
    return rec[None], np.ones((1, h * w))


def _dinf_receivers(z: np.ndarray):
    """Two receivers per cell with the D-infinity split of the steepest facet (-1 for none)."""
    h, w = z.shape
    pad = np.pad(z, 1, constant_values=np.inf)
    quarter = np.pi / 4
    slopes, angles = [], []
    for e1, e2 in _FACETS:
        z1, z2 = _shifted(pad, e1, z.shape), _shifted(pad, e2, z.shape)
        with np.errstate(invalid="ignore"):
            s1 = z - z1
            s2 = z1 - z2
            r = np.arctan2(s2, s1)
            sl = np.hypot(s1, s2)
            sl = np.where(r < 0, s1, sl)
            r = np.where(r < 0, 0.0, r)
            sl = np.where(r > quarter, (z - z2) / np.sqrt(2.0), sl)
            r = np.where(r > quarter, quarter, r)
        # a facet whose cardinal neighbour lies outside the grid does not exist
        slopes.append(np.where(np.isfinite(z1), sl, -np.inf))
        angles.append(np.where(np.isfinite(z1), r, 0.0))
    slopes, angles = np.stack(slopes), np.stack(angles)
    best = np.argmax(slopes, axis=0)
    has = np.take_along_axis(slopes, best[None], 0)[0] > 0
    r = np.take_along_axis(angles, best[None], 0)[0]
    rows, cols = np.mgrid[0:h, 0:w]
    e1 = np.array([f[0] for f in _FACETS])[best]
    e2 = np.array([f[1] for f in _FACETS])[best]
    rec1 = np.where(has, (rows + e1[..., 0]) * w + cols + e1[..., 1], -1).ravel()
    rec2 = np.where(has, (rows + e2[..., 0]) * w + cols + e2[..., 1], -1).ravel()
    frac2 = (r / quarter).ravel()
    # a neighbour that gets nothing may lie outside the grid: point it at the other one
    rec2 = np.where(frac2 > 0.0, rec2, rec1)
    rec1 = np.where(frac2 < 1.0, rec1, rec2)
    return np.stack([rec1, rec2]), np.stack([1.0 - frac2, frac2])


def flow_accumulation(elevation, *, method: Literal["d8", "dinf"] = "d8", filled: bool = False) -> np.ndarray:
    """Drainage area: how many cells (itself included) drain through each cell.

    ``"d8"``: every cell passes its area to the neighbour of steepest descent (diagonals at
    distance sqrt(2)). ``"dinf"``: D-infinity (Tarboton 1997), the steepest of 8 triangular
    facets, with the area split between its two neighbours by angle (the paper's Figure 16).
    Cells without a downslope direction (pits, flats, cells against the border's lowest
    side) keep their area; the areas of those end cells sum to the number of cells.

    Args:
        elevation: (H, W) real array.
        method: ``"d8"`` or ``"dinf"``.
        filled: fill the depressions first (flow then reaches the border except on flats).

    Returns:
        (H, W) float64 array of areas in cells.
    """
    z = _elevation("elevation", elevation)
    if method not in ("d8", "dinf"):
        raise ValueError(f"Expected 'method' in ('d8', 'dinf'), but got {method!r}")
    if filled:
        z = fill(z)
    h, w = z.shape
    rec, frac = _d8_receivers(z) if method == "d8" else _dinf_receivers(z)
    order = np.argsort(-z.ravel(), kind="stable")
    acc = [1.0] * (h * w)
    # highest first: a cell's donors are all higher, so its area is complete when it is reached
    recs = [rec[k][order].tolist() for k in range(rec.shape[0])]
    fracs = [frac[k][order].tolist() for k in range(rec.shape[0])]
    if rec.shape[0] == 1:
        for i, r in zip(order.tolist(), recs[0]):
            if r >= 0:
                acc[r] += acc[i]
    else:
        for i, r1, r2, f1, f2 in zip(order.tolist(), recs[0], recs[1], fracs[0], fracs[1]):
            if r1 >= 0:
                a = acc[i]
                acc[r1] += f1 * a
                acc[r2] += f2 * a
    return np.asarray(acc).reshape(h, w)


def drainage_image(area) -> np.ndarray:
    """Log-scaled drainage area in [0, 1] (float32), ready for :func:`wdendrite.io.save_png`."""
    a = _elevation("area", area)
    if (a <= 0).any():
        raise ValueError("'area' must be positive (areas are counted in cells, at least 1)")
    la = np.log(a)
    span = la.max() - la.min()
    return ((la - la.min()) / span if span > 0 else np.zeros_like(la)).astype(np.float32)


def fbm_terrain(shape, *, seed: int = 0, frequency: float = 4.0, octaves: int = 8, device=None) -> np.ndarray:
    """Fractal (fBm) Perlin noise terrain on [0, 1]^2, a baseline without drainage structure.

    Args:
        shape: ``(H, W)`` positive ints.
        seed, frequency, octaves: as for :func:`wdendrite.control.perlin`.
        device: Warp device (default: Warp's default device).

    Returns:
        ``(H, W)`` float32 elevations.

    Raises:
        ValueError, TypeError: a bad ``shape`` or noise parameter (before any kernel runs).
        MemoryError: the terrain does not fit in the device's free memory.
    """
    device = _checks.device(device)
    _control._grid_shape(shape, device)  # the control's own range search launches kernels: check first
    c = _control.perlin(seed=seed, frequency=frequency, octaves=octaves, domain=((0.0, 0.0), (1.0, 1.0)))
    return c.grid(shape, device=device)


def ridged_terrain(shape, *, seed: int = 0, frequency: float = 4.0, octaves: int = 8, device=None) -> np.ndarray:
    """Ridged multifractal noise terrain on [0, 1]^2, a baseline with sharp crests.

    Arguments, result and errors as for :func:`fbm_terrain` (noise parameters as for
    :func:`wdendrite.control.ridged`).
    """
    device = _checks.device(device)
    _control._grid_shape(shape, device)
    c = _control.ridged(seed=seed, frequency=frequency, octaves=octaves, domain=((0.0, 0.0), (1.0, 1.0)))
    return c.grid(shape, device=device)
