"""The command's own models: ``fractal`` and ``costs`` (path planning), ``dendry`` and ``terrain`` (Dendry).

They follow the presets' conventions (keyword parameters with documented
defaults, a seed, a result with ``image``/``dendrite``/``mesh``/``parts``) so the
command introspects them like :mod:`wdendrite.presets`; a preset of the same
name there takes precedence.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from dataclasses import dataclass
from dataclasses import field as dataclass_field
from typing import Literal

import numpy as np

from . import _checks, _parallel
from .dendry import DendryParams, coordinate_limit
from .render import dendry_lines, relief, strokes, unit_range

__all__ = ["MODELS", "TABLE1", "TERRAIN", "Made", "costs", "dendry", "dendry_setup", "fractal", "relief", "terrain", "unit_range"]


@dataclass(frozen=True)
class Made:
    """What one of the command's own models made (the shape of :class:`wdendrite.presets.Result`)."""

    picture: object
    """``(H, W, 3)`` or ``(H, W)`` float picture in [0, 1], or a function of no arguments that makes it
    when :attr:`image` is first read (so that a run writing only ``.npy`` skips it)."""
    dendrite: object = None
    """The dendrite, if any."""
    mesh: object = None
    """A mesh, if any."""
    parts: dict = dataclass_field(default_factory=dict)
    """Further data; ``"field"`` or ``"elevation"`` is what ``.npy`` and ``--heightmap`` write."""
    quantity: str | None = None
    """What the field's values are (``"elevation"``, ``"distance"``, ``"cost"``...), as terrain files record it."""
    domain: tuple | None = None
    """``((x0, y0), (x1, y1))`` the field covers, in domain units (Dendry models), else None."""

    @property
    def image(self) -> np.ndarray:
        """The picture, made now if it was deferred."""
        if callable(self.picture):
            object.__setattr__(self, "picture", self.picture())  # made once, then kept
        return self.picture


def fractal(size: int = 256, *, count: int = 6, d: float | None = None, alpha: float = 1.8, beta: float = 2.5,
            epsilon: float | None = None, cheap: float = 0.0, seed: int = 0, progress: bool = False) -> Made:
    """A fractal dendrite grown from the centre of a size x size lattice (thesis Fig 3.12).

    Args:
        size: lattice side in nodes (>= 8).
        count: endpoints of the first iteration (m of the thesis).
        d: path cost of the first iteration's endpoints (default: 1.2 x size).
        alpha: each iteration divides d by it (> 1).
        beta: each iteration multiplies the endpoint count by it (>= 1).
        epsilon: growth stops once d falls to it (default: 0.12 x size).
        cheap: weight factor D of the dendrite's edges in later iterations; 0: its nodes become generators.
        seed: seed of the weights and the endpoints.
    """
    from . import FractalParams, Lattice, grow, weights

    size = _checks.integer("size", size, low=8)
    # no least path costs more than one costliest edge (a diagonal, sqrt(2) (1 + r)) per node: a first band
    # (0.9 d, 1.1 d) above that holds nothing, and so many empty iterations would overflow the endpoint counts
    most = (size * size - 1) * math.sqrt(2.0) * 11.0
    if d is not None and _checks.positive("d", d) * 0.9 > most:
        raise ValueError(f"Expected 'd' <= {most / 0.9:.6g} on a {size} x {size} lattice (no path on it costs more "
                         f"than {most:.6g}), but got {d!r}")
    # defaults: a sparse, readable fractal whose first branches reach most of the way out
    params = FractalParams(count=count, d=1.2 * size if d is None else d, alpha=alpha, beta=beta,
                           epsilon=0.12 * size if epsilon is None else epsilon, cheap=cheap)
    lat = Lattice((size, size), connectivity=8, weights=weights.Uniform(r=10.0, seed=seed))
    den = grow(lat, [[size // 2, size // 2]], params, seed=seed, progress=progress)
    # strokes grow brighter and wider with the number of endpoints a node carries (thicker trunks)
    carried = np.log1p(den.downstream) / np.log1p(den.downstream.max())
    img = strokes(den, 0.9 + 1.6 * carried, ink=0.35 + 0.65 * carried)
    return Made(img, den, parts={"field": img}, quantity="brightness")


def costs(size: int = 256, *, generators: int = 5, seed: int = 0) -> Made:
    """Shortest-path costs of a random 8-connected lattice from random generators, in bands tinted by region.

    Args:
        size: lattice side in nodes (>= 8).
        generators: number of random generators (>= 1).
        seed: seed of the weights and the generators.
    """
    from . import Lattice, shortest_paths, weights

    _checks.integer("size", size, low=8)
    _checks.integer("generators", generators, low=1)
    if generators > size * size:  # no lattice holds more distinct generators (refused before the search)
        raise ValueError(f"Expected 'generators' <= {size * size} (the node count of the {size} x {size} lattice), "
                         f"but got {generators!r}")
    lat = Lattice((size, size), connectivity=8, weights=weights.Uniform(r=10.0, seed=seed))
    gens = _checks.rng(seed).integers(0, size, size=(generators, 2))
    cf = shortest_paths(lat, gens)
    d = cf.dist
    # banded costs show the wavefronts; the label field tints each generator's region
    top = float(d[np.isfinite(d)].max())  # 0 when every node is a generator: one flat band
    bands = 0.5 + 0.5 * np.cos(d / (top / 12.0 if top > 0 else 1.0) * 2 * np.pi)
    tint = (cf.label * 0.61803) % 1.0
    rgb = np.stack([bands * (0.4 + 0.6 * tint), bands * 0.7, bands * (1.0 - 0.6 * tint)], axis=-1)
    return Made(rgb, parts={"field": d}, quantity="cost")


Control = Literal["perlin", "ridged", "radial", "plane", "lichtenberg"]


_CONTROL_DOMAINS = {"perlin": ((-0.2, -0.4), (1.4, 0.7)), "ridged": ((-0.2, -0.4), (1.4, 0.7)),
                    "radial": ((0.0, 0.0), (1.0, 1.0)), "plane": ((0.0, 0.0), (1.0, 1.0)),
                    "lichtenberg": ((-1.0, -1.0), (1.0, 1.0))}


def dendry_setup(size: int, params, *, extent: float, control: str, frequency: float, drained: bool,
                 seed: int, output: str = "distance") -> dict:
    """Keyword arguments of :func:`wdendrite.dendry` (``shape``, ``domain``, ``params``, ``control``) for a model.

    The image covers ``[0, extent]^2`` domain units; the control spans the paper's
    Table 1 rectangle (noise) or its own domain (ramps, Lichtenberg bowl). Every argument,
    and the image :func:`wdendrite.dendry` would make of them with ``output``, is checked
    before the control is made (a noise control's range is found by sampling it with kernels).
    """
    from . import control as ctl
    from .dendry import dendry as _dendry

    size = _checks.integer("size", size, low=1)
    _checks.positive("extent", extent)  # in domain units
    if not isinstance(control, str) or control not in _CONTROL_DOMAINS:
        raise ValueError(f"Expected 'control' in {typing.get_args(Control)}, but got {control!r}")
    _checks.positive("frequency", frequency)  # (read by the noise controls only, but never left unchecked)
    drained = _checks.flag("drained", drained)
    seed = _checks.seed32(seed)
    if not isinstance(params, DendryParams):
        raise TypeError(f"Expected a DendryParams for 'params', but got {type(params).__name__}")
    params = dataclasses.replace(params, seed=seed)
    # the image's own check of its last pixel centre, which would name its 'domain' (never written by a model's user)
    reach = coordinate_limit(params, output)
    if not (size - 0.5) * (extent / size) < reach:
        raise ValueError(
            f"'extent' = {extent!r} takes the image's pixel centres beyond the coordinates float32 key points "
            f"resolve at these params' finest level (an extent below about {reach * size / (size - 0.5):.6g} "
            f"domain units at size {size}); lower 'extent', the resolution or the levels")
    shape, domain = (size, size), ((0.0, 0.0), (extent, extent))
    try:  # the image's own checks (output, params, coordinate reach), which stop before any kernel runs
        with _checks.checking_only():
            _dendry(shape, domain=domain, params=params, control_domain=_CONTROL_DOMAINS[control], output=output)
    except _checks.Checked:
        pass
    except ValueError as e:  # the square the model made of 'extent' (too small for float32, ...): name it
        if "'domain'" not in str(e):
            raise
        raise ValueError(f"'extent' = {extent!r} makes a 'domain' {domain!r} the image refuses: {e}") from None
    _checks.stop_if_checking()  # (a batch checking its tasks stops here, before the control's kernels)
    if control in ("perlin", "ridged"):
        c = getattr(ctl, control)(seed=seed, frequency=frequency, domain=_CONTROL_DOMAINS[control])
    elif control == "radial":
        c = ctl.radial((0.5, 0.5), radius=0.75)
    elif control == "plane":
        c = ctl.plane((0.0, 1.0))
    else:
        c = ctl.lichtenberg(scale=0.2)  # [0, 1], as terrains take it; the values keep their order
    if drained:
        c = ctl.drained(c)
    return {"shape": shape, "domain": domain, "params": params, "control": c}



TABLE1 = DendryParams.table1()
"""The paper's Table 1 Dendry parameters, as published."""

TERRAIN = DendryParams.terrain()
"""The default of the ``dendry`` and ``terrain`` models: :meth:`wdendrite.DendryParams.terrain`."""


def dendry(size: int = 512, *, params: DendryParams = TERRAIN,
           output: Literal["distance", "elevation", "level"] = "distance", extent: float = 4.0,
           control: Control = "perlin", frequency: float = 1.0, drained: bool = False, seed: int = 0,
           workers: int | None = None) -> Made:
    """Dendry (Gaillard et al. 2019): the distance to an implicit branching tree, its level, or an elevation.

    The picture of the distance draws the tree's branches dark on paper, antialiased, each level
    wider than the next finer one (:func:`wdendrite.render.dendry_lines`, which evaluates the tree
    once per level). The level and the elevation are drawn as grey from their lowest
    value (black) to their highest (white).

    Args:
        size: image side in pixels.
        output: distance (domain units), elevation (control units) or level (1..n of the nearest branch).
        extent: side of the square the image covers, in domain units.
        control: control function steering the branches (noise, radial ramp, plane, Lichtenberg bowl).
        frequency: noise features per control unit (perlin, ridged).
        drained: fill the control's interior minima so water reaches the border.
        seed: seed of the tree and of the noise control.
        workers: CPU threads (None: every core); the result does not depend on it.
    """
    workers = _parallel.workers(workers)
    setup = dendry_setup(size, params, extent=extent, control=control, frequency=frequency, drained=drained,
                         seed=seed, output=output)
    from .dendry import dendry as _dendry

    z = _dendry(**setup, output=output, workers=workers)

    def lines() -> np.ndarray:  # (the other levels are evaluated only for a picture)
        return _grey(1.0 - dendry_lines(**setup, distance=z, workers=workers))

    return Made(lines if output == "distance" else _grey(unit_range(z)), parts={"field": z}, quantity=output,
                domain=setup["domain"])


def _grey(value: np.ndarray) -> np.ndarray:
    return np.repeat(value[..., None].astype(np.float32), 3, axis=2)


def terrain(size: int = 512, *, params: DendryParams = TERRAIN, extent: float = 4.0, control: Control = "perlin",
            frequency: float = 1.0, drained: bool = True, rivers: bool = True, seed: int = 0,
            workers: int | None = None) -> Made:
    """A Dendry terrain (paper Table 1 setup): shaded relief, with its drainage network drawn in blue.

    Args:
        size: image side in pixels.
        extent: side of the square the image covers, in domain units.
        control: control function steering the main valleys.
        frequency: noise features per control unit (perlin, ridged).
        drained: fill the control's interior minima so water reaches the border.
        rivers: draw the D8 drainage network (cells draining more than 0.1 % of the image).
        seed: seed of the tree, the terrain noise and the noise control.
        workers: CPU threads for the elevation and the shading (None: every core); the drainage
            is one thread (its fill and flow cross any split). The result does not depend on it.
    """
    from . import hydrology
    from .dendry import dendry as _dendry

    rivers = _checks.flag("rivers", rivers)
    workers = _parallel.workers(workers)
    _checks.integer("size", size, low=2)  # (the shaded relief takes slopes between pixels)
    setup = dendry_setup(size, params, extent=extent, control=control, frequency=frequency, drained=drained,
                         seed=seed, output="elevation")
    z = _dendry(**setup, output="elevation", workers=workers)
    parts = {"elevation": z}

    def picture() -> np.ndarray:
        # shading and drainage take longer than the terrain itself: only for a picture
        area = None
        if rivers:
            area = hydrology.flow_accumulation(z, filled=True)
            parts["drainage"] = area
        return relief(z, extent / size, area, workers=workers)

    return Made(picture, parts=parts, quantity="elevation", domain=setup["domain"])


MODELS = {"fractal": fractal, "costs": costs, "dendry": dendry, "terrain": terrain}
"""The command's own models by name (used when :mod:`wdendrite.presets` has none of that name)."""


costs.makes_dendrite = dendry.makes_dendrite = terrain.makes_dendrite = False  # (checked before they run)
dendry.units = terrain.units = {"size": "pixels"}  # (shown in --help; the table says nodes)
