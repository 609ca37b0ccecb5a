"""wdendrite: dendritic shapes grown with NVIDIA Warp kernels.

Path planning (Xu & Mould): a weighted lattice, shortest path costs from
generators, backtracking into dendrites. Dendry (Gaillard et al.): a
per-pixel branching function and terrain.
"""

from . import weights
from .lattice import Lattice
from .sssp import CostField, shortest_paths

__version__ = "0.1.0"

__all__ = ["CostField", "Lattice", "shortest_paths", "weights", "__version__"]
