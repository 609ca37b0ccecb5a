"""wdendrite: dendritic shapes grown with NVIDIA Warp kernels.

Path planning (Xu & Mould): a weighted lattice, shortest path costs from
generators, backtracking into dendrites. Dendry (Gaillard et al.): a
per-pixel branching function and terrain.

Start here::

    import wdendrite as wd
    lat = wd.Lattice((256, 256), 8, weights=wd.weights.Uniform(r=10, seed=1))
    cf = wd.shortest_paths(lat, [[128, 128]])               # least path costs (Warp kernels)
    den = wd.trace(cf, wd.endpoints.random(lat, 40, seed=2))  # paths back to the generator
    picture = wd.render.brightness(den, 1.5)                 # (256, 256) float32 in [0, 1]
    terrain = wd.dendry((512, 512), domain=((0, 0), (4, 4)), params=wd.DendryParams(), output="elevation")

Every model of the papers is one call in :mod:`wdendrite.presets` (lightning, trees, coral,
lichen, moss, letters, terrains), also on the command line: ``wdendrite --help``.
Modules: lattice, weights, sssp (searches), endpoints, dendrite (trace), growth (fractal growth),
refine, render, figure (labelled panels), skeleton (smooth centre lines), geometry (meshes), preview
(ray-cast pictures), dendry, control, hydrology, io, heightmaps (terrain files: 16-bit heightmaps
that carry their range, raw .r16/.raw, GeoTIFF), presets, batch (``import wdendrite.batch``: job
files, Dask) and tiles (``import wdendrite.tiles``: images written tile by tile, resumably).
Kernels run on the CPU or CUDA: ``device=``. Warp compiles each kernel module on its first use
and caches it; ``wd.load_kernels()`` (``wdendrite warmup``) compiles them all up front.
``import wdendrite`` itself imports neither Warp nor NumPy: each name loads its module when first
used.
"""


def _find_source_kernels() -> None:
    """Give a source checkout imported as ``wdendrite`` its ``wdendrite.kernels``.

    An installation maps the checkout's top-level ``kernels/`` folder into the package (a
    wheel copies it, an editable install adds a finder). Python started in the checkout's
    root (``python -c``, ``python -m``) puts the root first on ``sys.path``, so the checkout's
    ``wdendrite/`` shadows any installed copy, and it holds no ``kernels/``: when nothing else
    finds the kernels, load them from the checkout, so host code and kernels come from one tree.
    """
    import importlib.util
    import sys
    from pathlib import Path

    name = f"{__name__}.kernels"
    if importlib.util.find_spec(name) is not None:
        return
    folder = Path(__file__).resolve().parent.parent / "kernels"
    if not (folder / "__init__.py").is_file():
        return  # (the import below then names what is missing)
    spec = importlib.util.spec_from_file_location(name, folder / "__init__.py",
                                                  submodule_search_locations=[str(folder)])
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)


_find_source_kernels()

import sys as _sys  # noqa: E402
import types as _types  # noqa: E402

_NAMES = {
    "CostField": "sssp", "Dendrite": "dendrite", "DendryParams": "dendry", "FractalParams": "growth",
    "Lattice": "lattice", "default_control": "dendry", "dendry": "dendry", "dendry_points": "dendry",
    "grow": "growth", "load_kernels": "warmup", "refine": "refine", "shortest_paths": "sssp", "trace": "dendrite",
}
"""Public names and the module each comes from: imported when first asked for (``wd.Lattice``), so
``import wdendrite`` does not import Warp, and a command or a script loads only what it uses."""

_MODULES = ("batch", "control", "dendrite", "endpoints", "figure", "geometry", "growth", "heightmaps", "hydrology",
            "io", "lattice", "lightning", "presets", "preview", "refine", "render", "skeleton", "sssp", "tiles",
            "warmup", "weights")
"""Submodules reachable as attributes (``wd.render``), imported when first asked for."""


def __getattr__(name: str):
    import importlib

    if name in _NAMES:
        value = getattr(importlib.import_module(f"{__name__}.{_NAMES[name]}"), name)
    elif name in _MODULES:
        value = importlib.import_module(f"{__name__}.{name}")
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return value


def __dir__():
    return sorted({*globals(), *__all__, *_MODULES})


class _Package(_types.ModuleType):
    """The package's module type: importing the submodule ``wdendrite.dendry`` (or ``.refine``)
    binds the package's name ``dendry`` to it, but the public ``wd.dendry`` is that module's function."""

    def __setattr__(self, name, value):
        if _NAMES.get(name) == name and isinstance(value, _types.ModuleType):
            value = getattr(value, name)
        super().__setattr__(name, value)


_sys.modules[__name__].__class__ = _Package


def _installed_version() -> str:
    """The version of the installed distribution (pyproject.toml is its only source)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("wdendrite")
    except PackageNotFoundError:  # a source tree on the path that was never installed
        return "0+unknown"


__version__ = _installed_version()

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
    "figure",
    "geometry",
    "grow",
    "heightmaps",
    "hydrology",
    "io",
    "load_kernels",
    "presets",
    "preview",
    "refine",
    "render",
    "shortest_paths",
    "skeleton",
    "trace",
    "weights",
    "__version__",
]
