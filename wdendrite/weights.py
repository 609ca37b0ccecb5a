"""Edge-weight distributions for lattices (seeded and reproducible).

A distribution turns a lattice's shape and edge directions into the
``(K, *shape)`` float32 weight array of :class:`wdendrite.Lattice`. Weights are
computed by a Warp kernel from a counter-based hash of ``(seed, node,
direction)``, so the same seed gives the same weights on every device, and a
kernel can recompute any single weight without the array.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from . import _checks
from .kernels import weights as _kw

__all__ = ["Uniform"]


def _seed32(seed) -> int:
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"Expected an integer 'seed', but got {seed!r}")
    if not 0 <= int(seed) < 2**32:
        raise ValueError(f"Expected 'seed' in [0, 2**32), but got {seed!r}")
    return int(seed)


@dataclass(frozen=True)
class Uniform:
    """Xu & Mould's uniform weights ``W = length * (1 + r * R)``, R uniform in (0, 1).

    ``length`` is the edge's Euclidean length (1 for axis edges, sqrt(2) and
    sqrt(3) for diagonals), so diagonal moves cost what their length says.
    """

    r: float = 10.0
    """Spread of the random part (the papers use about 10; the thesis 10 to 100). Must be >= 0."""
    seed: int = 0
    """Seed of the hash; the same seed gives the same weights on every device."""

    def __post_init__(self):
        _checks.nonnegative("r", self.r, allow_none=False)
        _seed32(self.seed)

    def sample(self, shape: tuple[int, ...], lengths: np.ndarray, *, device=None) -> np.ndarray:
        """Return the ``(K, *shape)`` float32 weights for edge directions of ``lengths`` (K,)."""
        count = int(np.prod(shape))
        lengths = np.asarray(lengths, dtype=np.float32)
        with wp.ScopedDevice(device if device is not None else "cpu"):
            out = wp.empty(len(lengths) * count, dtype=float)
            wp.launch(
                _kw.uniform_weights_kernel,
                dim=out.shape[0],
                inputs=[wp.uint32(self.seed), float(self.r), wp.array(lengths, dtype=float), count],
                outputs=[out],
            )
            return out.numpy().reshape((len(lengths), *shape))
