"""wdendrite: dendritic shapes grown with NVIDIA Warp kernels.

Path planning (Xu & Mould): a weighted lattice, shortest path costs from
generators, backtracking into dendrites. Dendry (Gaillard et al.): a
per-pixel branching function and terrain.
"""

from . import control, endpoints, geometry, hydrology, io, presets, render, weights
from .dendrite import Dendrite, trace
from .dendry import DendryParams, default_control, dendry, dendry_points
from .growth import FractalParams, grow
from .lattice import Lattice
from .refine import refine
from .sssp import CostField, shortest_paths

__version__ = "0.1.0"


def _document_fields() -> None:
    """Show each public dataclass's field docstrings in ``help()`` (see ``_spec.document_fields``)."""
    import importlib

    from . import _spec

    for part in ("dendry", "growth", "hydrology", "presets", "render", "sssp", "weights"):
        _spec.document_fields(importlib.import_module(f"{__name__}.{part}"))  # (wdendrite.dendry is also a function)


_document_fields()

__all__ = [
    "CostField",
    "Dendrite",
    "DendryParams",
    "FractalParams",
    "Lattice",
    "control",
    "default_control",
    "dendry",
    "dendry_points",
    "endpoints",
    "geometry",
    "grow",
    "hydrology",
    "io",
    "presets",
    "refine",
    "render",
    "shortest_paths",
    "trace",
    "weights",
    "__version__",
]
