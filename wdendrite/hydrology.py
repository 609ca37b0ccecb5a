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
    and any others) are then drained the way of Garbrecht & Martz (1997) and Barnes, Lehman &
    Mulla (2014): on each flat (8-connected interior cells of one height without a lower
    neighbour) two distances are taken over the flat's cells, in steps of 2 (sides) and 3
    (diagonals): towards lower terrain (from the flat's ways out: its neighbours of its
    height that have a way down, or lie on the border) and away from higher terrain (from
    the flat's cells next to a higher cell). A flat cell next to a way out passes its area
    to the nearest one (a side before a diagonal); any other, to the neighbour on its flat
    of lowest ``2 * towards - away`` (the first in row-major order among equals), which is
    lower than its own. So flow leaves the walls, gathers along the flat's middle and runs
    to its outlet, one line down a filled valley. One receiver each, for D-infinity too.
    All the area then ends on the border.

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
        MemoryError: when the arrays (about 36 bytes per cell for D8, 56 for D-infinity; 32
            more with ``filled``) would not fit in free memory.
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
    # (and with ``filled``, the fill's copies and the flats' two distances)
    _checks.fits_in_memory(cells * (8 + 4 + 4 + 4 + 8 + 8 + (4 + 16 if two else 0) + (32 if filled else 0)), "cpu",
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
    if filled:
        _drain_flats(z, rec, frac, donors)
    area = wp.full(z.size, wp.float64(1.0), dtype=wp.float64, device=cpu)
    wp.launch(_k.accumulate_kernel, dim=1, inputs=[rec, frac, donors, wp.empty(z.size, dtype=int, device=cpu)],
              outputs=[area], device=cpu)
    return area.numpy().reshape(z.shape)


def _drain_flats(z: np.ndarray, rec: wp.array, frac: wp.array, donors: wp.array) -> None:
    """Give every interior cell without a receiver, on a flat that drains, a neighbour of its
    height (see :func:`flow_accumulation`); in place.

    ``rec``: (k, N) receivers (-1: none), ``frac``: (k, N) shares (k = 2) or a placeholder,
    ``donors``: (N,) counts; Warp arrays on the CPU device.

    Why every such cell finds a receiver of strictly lower mask ``2 * lower - higher``, so
    that the receivers form no cycle and all the area reaches a way out: both distances are
    shortest paths over the same graph (the flat's cells, steps 2 and 3), so across one
    step of length s they differ by at most s (the triangle inequality; ``higher`` is 0 on
    a whole flat that touches no higher cell). A cell at ``lower`` d > 0 has a neighbour on
    its shortest path at d - s: a way out (which it then takes), or a flat cell whose mask
    is lower by 2s - (higher difference) >= s > 0. Masks fall along the receivers, so every
    path over the flat ends at a way out, and each way out drains on (or is on the border).
    """
    h, w = z.shape
    lost = rec.numpy()[0] < 0
    lost.reshape(h, w)[[0, -1], :] = False  # the border is where water leaves
    lost.reshape(h, w)[:, [0, -1]] = False
    cells = np.flatnonzero(lost).astype(np.int32)
    if cells.size == 0:
        return
    lower, higher = _flat_distances(z, lost)
    wp.launch(_k.flat_receiver_kernel, dim=cells.size, device="cpu",
              inputs=[_cpu(z.ravel(), wp.float64), _cpu(lost.view(np.uint8), wp.uint8), _cpu(cells, int), lower,
                      higher, w],
              outputs=[rec, frac, donors])


def _cpu(a: np.ndarray, dtype) -> wp.array:
    return wp.array(a, dtype=dtype, copy=False, device="cpu")


def _flat_distances(z: np.ndarray, lost: np.ndarray) -> tuple[wp.array, wp.array]:
    """Distances over the flats of ``z`` ((H, W) float64) in steps of 2 (sides) and 3
    (diagonals), through the ``lost`` cells ((H, W) or (N,) bool: interior cells without a
    lower neighbour) of one height: towards lower terrain (from the cells that are not lost
    next to a lost cell of their height, the flats' ways out) and away from higher terrain
    (from the lost cells next to a higher cell).

    Returns two (N,) int64 CPU Warp arrays, in that order; cells no source reaches hold the
    largest int64. One thread each (:func:`wdendrite.kernels.hydrology.flat_distance_kernel`).
    """
    zf, lf = _cpu(z.ravel(), wp.float64), _cpu(np.ravel(lost).view(np.uint8), wp.uint8)
    nxt, heads = wp.empty(z.size, dtype=int, device="cpu"), wp.empty(4, dtype=int, device="cpu")
    out = []
    for from_higher in (0, 1):
        dist = wp.empty(z.size, dtype=wp.int64, device="cpu")
        wp.launch(_k.flat_distance_kernel, dim=1, inputs=[zf, lf, z.shape[1], from_higher, nxt, heads],
                  outputs=[dist], device="cpu")
        out.append(dist)
    return out[0], out[1]


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


from ._spec import document_fields as _document_fields  # noqa: E402  (the classes above are complete)

_document_fields(__name__)  # help() shows what each dataclass field means
