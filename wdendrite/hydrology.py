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

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import warp as wp

from . import _checks
from . import control as _control
from .kernels import hydrology as _k

__all__ = ["Depressions", "depressions", "drainage_image", "fbm_terrain", "fill", "flow_accumulation",
           "ridged_terrain"]


def _elevation(name: str, value) -> np.ndarray:
    """``value`` as a finite, non-empty (H, W) float64 array (integers only where float64 holds them)."""
    _checks.unmasked(name, value)  # (before the conversion below drops a mask)
    try:
        raw = np.asarray(value)
    except ValueError:  # ragged nested lists: finite_array names them
        return _checks.finite_array(name, value, "2D (H, W)", lambda s: len(s) == 2, dtype=np.float64)
    top = max(abs(int(raw.min())), abs(int(raw.max()))) if raw.dtype.kind in "iu" and raw.size else 0
    if top > 2**53:
        raise ValueError(f"'{name}' holds integers beyond 2**53 (magnitudes up to {top}), which float64 cannot "
                         f"tell apart; scale them down or pass floats")
    return _checks.finite_array(name, raw, "2D (H, W)", lambda s: len(s) == 2, dtype=np.float64)


def fill(elevation) -> np.ndarray:
    """The depression-filled surface: the lowest surface >= ``elevation`` that drains to the border.

    Args:
        elevation: (H, W) real array.

    Returns:
        (H, W) float64 array.

    Raises:
        ValueError: an elevation that is not a non-empty 2D array, holds NaN/inf or masked cells,
            or integers beyond 2**53.
        TypeError: an elevation that is not real-valued.
    """
    from skimage.morphology import reconstruction

    z = _elevation("elevation", elevation)
    if min(z.shape) <= 2:
        return z.copy()
    # the reconstruction only compares and copies values: elevations that are float32 numbers
    # (Dendry's and the noise terrains') give the same surface in float32, in about 0.6x the time
    with np.errstate(over="ignore"):  # values beyond float32 become inf, unequal to z: float64 it is
        narrow = z.astype(np.float32)
    work = narrow if np.array_equal(narrow, z) else z
    seed = work.copy()
    seed[1:-1, 1:-1] = work.max()
    return reconstruction(seed, work, method="erosion", footprint=np.ones((3, 3), bool)).astype(np.float64, copy=False)


@dataclass(frozen=True, eq=False)
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

    def __repr__(self) -> str:
        return f"Depressions(count={self.count}, percent={self.percent:.4g}, shape={self.mask.shape})"


def depressions(elevation) -> Depressions:
    """Count the depressions of ``elevation`` ((H, W) real array) and their share of the surface.

    Cells the priority-flood :func:`fill` raises are depressed; 8-connected groups of them are
    counted. Errors as for :func:`fill`.
    """
    from scipy.ndimage import label

    z = _elevation("elevation", elevation)
    depth = fill(z) - z
    mask = depth > 0
    _, count = label(mask, structure=np.ones((3, 3), int))
    return Depressions(int(count), 100.0 * float(mask.mean()), mask, depth)


def flow_accumulation(elevation, *, method: Literal["d8", "dinf"] = "d8", filled: bool = False) -> np.ndarray:
    """Drainage area: how many cells (itself included) drain through each cell.

    ``"d8"``: every cell passes its area to the neighbour of steepest descent (diagonals at
    distance sqrt(2)). ``"dinf"``: D-infinity (Tarboton 1997), the steepest of 8 triangular
    facets, with the area split between its two neighbours by angle (the paper's Figure 16).
    Among equally steep directions the first wins (D8: in row-major order of the neighbours;
    D-infinity: of the facets from east anticlockwise, its ties decided exactly for integer
    elevations, whose squared slopes float64 holds). Cells without a downslope direction
    (pits, flats, cells against the border's lowest side) keep their area; the areas of those
    end cells sum to the number of cells.

    With ``filled=True`` the depressions are filled first and the flats (those the fill makes
    and any others) are then drained: every interior cell of a flat passes its area to a
    neighbour of the same height one step nearer to where the flat drains (a neighbour of it
    that has a way down, or the border), distances in steps of 2 (sides) and 3 (diagonals),
    the first in row-major order among equals; one receiver each, for D-infinity too. All the
    area then ends on the border.

    Runs on Warp's CPU device whatever the default device: the receivers are found one
    thread per cell, then one thread walks the flow graph, visiting each cell once after all
    its donors (about 0.1 s per million cells for D8; no sort; with ``filled``, the fill and
    the flats add about 0.5 s per million).

    Args:
        elevation: (H, W) real array.
        method: ``"d8"`` or ``"dinf"``.
        filled: fill the depressions first and drain the flats (flow then reaches the border).

    Returns:
        (H, W) float64 array of areas in cells.

    Raises:
        ValueError, TypeError: an elevation that is not a finite, non-empty 2D real array, or
            has 2**31 cells or more; a method other than ``"d8"`` or ``"dinf"``.
        MemoryError: when the arrays (about 36 bytes per cell for D8, 56 for D-infinity)
            would not fit in free memory.
    """
    if not isinstance(method, str) or method not in ("d8", "dinf"):
        raise ValueError(f"Expected 'method' in ('d8', 'dinf'), but got {method!r}")
    filled = _checks.flag("filled", filled)
    try:
        cells = math.prod(np.shape(elevation))
    except ValueError:  # ragged nested lists: the elevation check names them
        cells = 0
    if cells >= 2**31:
        raise ValueError(f"'elevation' has {cells} cells; flow accumulation numbers cells with 32-bit integers, "
                         f"so at most 2**31 - 1")
    two = method == "dinf"
    # bytes per cell: the float64 elevations (read in place), receivers (and shares),
    # donors, stack, areas and the returned array
    # (and with ``filled``, the fill's copies and the flats' distances)
    _checks.fits_in_memory(cells * (8 + 4 + 4 + 4 + 8 + 8 + (4 + 16 if two else 0) + (24 if filled else 0)), "cpu",
                           f"flow_accumulation of {cells} cells")
    z = _elevation("elevation", elevation)
    if filled:
        z = fill(z)
    # every array names the CPU device: a scope would change Warp's default device for every
    # thread of the process while it lasts
    cpu = "cpu"
    zw = wp.array(z, dtype=wp.float64, copy=False, device=cpu)  # the receiver kernels only read it: no copy
    rec = wp.empty((2 if two else 1, z.size), dtype=int, device=cpu)
    frac = wp.empty(rec.shape if two else (1, 1), dtype=wp.float64, device=cpu)
    donors = wp.zeros(z.size, dtype=int, device=cpu)
    if two:
        wp.launch(_k.dinf_kernel, dim=z.shape, inputs=[zw], outputs=[rec, frac, donors], device=cpu)
    else:
        wp.launch(_k.d8_kernel, dim=z.shape, inputs=[zw], outputs=[rec, donors], device=cpu)
    if filled:  # arrays on the CPU device: their NumPy views write through
        _drain_flats(z, rec.numpy(), frac.numpy() if two else None, donors.numpy())
    area = wp.full(z.size, wp.float64(1.0), dtype=wp.float64, device=cpu)
    wp.launch(_k.accumulate_kernel, dim=1, inputs=[rec, frac, donors, wp.empty(z.size, dtype=int, device=cpu)],
              outputs=[area], device=cpu)
    return area.numpy().reshape(z.shape)


_STEPS = [(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc]  # row-major, as the kernels


def _drain_flats(z: np.ndarray, rec: np.ndarray, frac: np.ndarray | None, donors: np.ndarray) -> None:
    """Give every interior cell without a receiver, on a flat that drains, the neighbour of its
    height one step nearer the flat's way out (see :func:`flow_accumulation`); in place.

    ``rec``: (k, N) receivers (-1: none), ``frac``: (k, N) shares or None, ``donors``: (N,) counts.
    The distances are integers (steps 2 and 3), so one thread finds them all in one pass over
    the flats' cells (:func:`wdendrite.kernels.hydrology.flat_distance_kernel`); runs on Warp's
    CPU device, as the accumulation does.
    """
    h, w = z.shape
    lost = rec[0] < 0
    lost.reshape(h, w)[[0, -1], :] = False  # the border is where water leaves
    lost.reshape(h, w)[:, [0, -1]] = False
    cells = np.flatnonzero(lost)
    if cells.size == 0:
        return
    far = np.iinfo(np.int64).max
    dist = wp.full(z.size, far, dtype=wp.int64, device="cpu")
    wp.launch(_k.flat_distance_kernel, dim=1, device="cpu",
              inputs=[wp.array(z.ravel(), dtype=wp.float64, copy=False, device="cpu"),
                      wp.array(lost.view(np.uint8), dtype=wp.uint8, copy=False, device="cpu"), w,
                      wp.empty(z.size, dtype=int, device="cpu"), wp.empty(4, dtype=int, device="cpu")],
              outputs=[dist])
    dist = dist.numpy()
    zf = z.ravel()
    cells = cells[dist[cells] < far]
    to = np.full(cells.size, -1, dtype=rec.dtype)
    for dr, dc in _STEPS:  # the first neighbour in row-major order one step nearer
        nb = cells + (dr * w + dc)
        pick = (to < 0) & (zf[nb] == zf[cells]) & (dist[nb] == dist[cells] - (3 if dr and dc else 2))
        to[pick] = nb[pick]
    rec[:, cells] = to
    if frac is not None:
        frac[0, cells] = 1.0
        frac[1, cells] = 0.0
    np.add.at(donors, to, 1)


def drainage_image(area) -> np.ndarray:
    """Log-scaled drainage area in [0, 1] (float32), ready for :func:`wdendrite.io.save_png`."""
    a = _elevation("area", area)
    low = a < 1.0
    if low.any():  # (every cell drains at least itself)
        first = tuple(int(i) for i in np.argwhere(low)[0])
        raise ValueError(f"'area' counts cells, each its own, so at least 1, but has {int(low.sum())} entries "
                         f"below 1 (first at {first}: {float(a[first])!r})")
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
