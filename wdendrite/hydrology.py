"""Hydrology metrics for terrains: depressions, D8 drainage area, noise baselines.

Depressions are the cells a priority-flood fill raises (Barnes et al. 2014): water
poured on the terrain drains to the border except where it is trapped. The fill
is computed as a morphological reconstruction by erosion from the border, which
gives the same surface. Each 8-connected group of raised cells is one depression.

Example::

    from wdendrite import hydrology
    stats = hydrology.depressions(elevation)
    stats.count, stats.percent
    area = hydrology.flow_accumulation(elevation)      # cells draining through each cell
    img = hydrology.drainage_image(area)               # log-scaled, in [0, 1]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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


def flow_accumulation(elevation, *, filled: bool = False) -> np.ndarray:
    """D8 drainage area: how many cells (itself included) drain through each cell.

    Every cell passes its area to the neighbour of steepest descent (diagonals at
    distance sqrt(2)); cells without a lower neighbour (pits, flats, outlets) keep it.
    The areas of those end cells sum to the number of cells.

    Args:
        elevation: (H, W) real array.
        filled: fill the depressions first (flow then reaches the border except on flats).

    Returns:
        (H, W) float64 array of areas in cells.
    """
    z = _elevation("elevation", elevation)
    if filled:
        z = fill(z)
    h, w = z.shape
    pad = np.pad(z, 1, constant_values=np.inf)
    drops = np.stack([(z - pad[1 + dr : 1 + dr + h, 1 + dc : 1 + dc + w]) / ln for (dr, dc), ln in zip(_D8, _D8_LEN)])
    best = np.argmax(drops, axis=0)
    has = np.take_along_axis(drops, best[None], 0)[0] > 0
    rows, cols = np.mgrid[0:h, 0:w]
    receiver = np.where(has, (rows + _D8[best, 0]) * w + cols + _D8[best, 1], -1).ravel()
    order = np.argsort(-z.ravel(), kind="stable")
    area = np.ones(h * w)
    # highest first: a cell's donors are all higher, so its area is complete when it is reached
    rec = receiver[order].tolist()
    acc = area.tolist()
    for i, r in zip(order.tolist(), rec):
        if r >= 0:
            acc[r] += acc[i]
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
    """Fractal (fBm) Perlin noise terrain on [0, 1]^2, a baseline without drainage structure."""
    c = _control.perlin(seed=seed, frequency=frequency, octaves=octaves, domain=((0.0, 0.0), (1.0, 1.0)))
    return c.grid(shape, device=device)


def ridged_terrain(shape, *, seed: int = 0, frequency: float = 4.0, octaves: int = 8, device=None) -> np.ndarray:
    """Ridged multifractal noise terrain on [0, 1]^2, a baseline with sharp crests."""
    c = _control.ridged(seed=seed, frequency=frequency, octaves=octaves, domain=((0.0, 0.0), (1.0, 1.0)))
    return c.grid(shape, device=device)
