"""Terrain files that describe themselves: 16-bit heightmaps and float32 GeoTIFFs.

Game engines and GIS tools take a terrain as a grid of heights:

- *PNG heightmap* (``.png``): 16-bit grey, grey 0 at the low end of a range and 65535 at its
  high end, with text chunks (tEXt) that say how to read it back: ``wdendrite:min`` and
  ``wdendrite:max`` (the range; ``value = min + grey / 65535 * (max - min)``),
  ``wdendrite:field`` (what the values are: elevation, distance, ...) and, when the field
  covers a domain, ``wdendrite:domain`` (``[[x0, y0], [x1, y1]]``) and ``wdendrite:spacing``
  (domain units per pixel; ``"DX,DY"`` when the two differ).
- *Raw heightmap* (``.r16``, ``.raw``): the same levels as little-endian uint16, row 0 first,
  no header: Unreal's ``.r16`` and Unity's Import Raw (Depth 16 bit, Byte Order Windows). A
  raw file holds no size, and both engines read it as a square (Unity's terrain heightmaps
  are square; Unreal infers the side from the file's length), so only square fields are
  written. Unity's terrains further take sides of 2**n + 1 pixels from 33 to 4097 only
  (``TerrainData.heightmapResolution``): a ``.raw`` file, the name Unity's dialog asks for,
  must have one of those; a ``.r16`` file, Unreal's, may have any side (Unreal's landscapes
  are any number of quads + 1 vertices a side).
- *GeoTIFF* (``.tif``, ``.tiff``): the values as float32, through tifffile
  (``pip install 'wdendrite[tiff]'``), with the domain as the raster's transform
  (``ModelTransformationTag``, pixels as areas) and a JSON ``ImageDescription`` of the field.

A range given by the caller is shared: several files (windows of one map, runs of several
seeds) saved with one range have one scale, and their grey levels join without seams. Values
outside it are clipped to 0 or 65535; +inf (a distance with no branch in reach) is 65535.

Pixel ``(row, col)`` of an ``(H, W)`` field over the domain ``((x0, y0), (x1, y1))`` is
centred at ``x = x0 + (col + 0.5) * (x1 - x0) / W``, ``y = y0 + (row + 0.5) * (y1 - y0) / H``
(row 0 at y0, as in :func:`wdendrite.dendry`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

__all__ = ["GEOTIFF_FORMATS", "HEIGHTMAP_FORMATS", "UNITY_SIDES", "check_field", "check_raw_shape", "describe",
           "field_range", "save_geotiff", "save_heightmap", "value_range"]

HEIGHTMAP_FORMATS = ("png", "r16", "raw")
"""Formats of 16-bit heightmaps (:func:`save_heightmap`)."""
GEOTIFF_FORMATS = ("tif", "tiff")
"""Suffixes of float32 GeoTIFFs (:func:`save_geotiff`)."""
UNITY_SIDES = tuple(2**n + 1 for n in range(5, 13))
"""The heightmap sides Unity's terrains take (33, 65, ..., 4097 pixels)."""
_TOP = 65535


def value_range(value, name: str = "'range'") -> tuple[float, float]:
    """``(lo, hi)`` from ``"LO,HI"`` text or a pair of numbers.

    Raises:
        ValueError: anything but two finite numbers with ``lo < hi``; the message names ``name``.
    """
    def refuse() -> ValueError:
        return ValueError(f"{name} expects LO,HI: two finite numbers with LO < HI, but got {value!r}")

    parts = value.split(",") if isinstance(value, str) else value
    if not isinstance(parts, (list, tuple)) or len(parts) != 2:
        raise refuse()
    try:
        if any(isinstance(p, bool) or not isinstance(p, (str, int, float, np.number)) for p in parts):
            raise TypeError
        lo, hi = (float(p) for p in parts)
    except (TypeError, ValueError, OverflowError):
        raise refuse() from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise refuse()
    return lo, hi


def check_field(field, *, nan: bool = False) -> np.ndarray:
    """``field`` as an array once it is a non-empty 2D array of numbers (without NaN unless ``nan``).

    Raises:
        TypeError: not a non-empty 2D array of numbers.
        ValueError: NaN values (unless ``nan``).
    """
    z = np.asarray(field)
    if z.dtype.kind not in "fiu" or z.ndim != 2 or not z.size:
        raise TypeError(f"Expected a non-empty (H, W) array of numbers for 'field', but got {z.dtype} "
                        f"of shape {z.shape}")
    if not nan and z.dtype.kind == "f" and np.isnan(z).any():
        raise ValueError("the field has NaN values, which no grey level stands for")
    return z


def field_range(field) -> tuple[float, float]:
    """The finite minimum and maximum of a field, which a heightmap without a range of its own spans.

    Raises:
        ValueError: NaN values (no grey level stands for them) or no finite value at all.
        TypeError: a field that is not a non-empty 2D array of numbers.
    """
    z = check_field(field)
    finite = z[np.isfinite(z)] if z.dtype.kind == "f" else z
    if not finite.size:
        raise ValueError("the field has no finite value (a distance image with no branch in view, say), so "
                         "there is no range to scale")
    return float(finite.min()), float(finite.max())


def check_raw_shape(shape, fmt: str) -> None:
    """Refuse an ``(H, W)`` field that a raw heightmap of format ``fmt`` (``"r16"`` or ``"raw"``)
    cannot hold for the engines that read it (see the module's notes).

    Raises:
        ValueError: a field that is not square; for ``"raw"`` (Unity), a side that is not one of
            :data:`UNITY_SIDES`, with the nearest of them.
    """
    h, w = (int(n) for n in shape)
    if h != w:
        raise ValueError(f"a .{fmt} heightmap must be square (a raw file holds no size, and Unity and Unreal "
                         f"read it as a square), but the field is {h} x {w}; write .png or .tif instead")
    if fmt == "raw" and w not in UNITY_SIDES:
        near = min(UNITY_SIDES, key=lambda s: (abs(s - w), s))
        why = "larger than Unity's largest terrain, 4097 x 4097" if w > UNITY_SIDES[-1] else \
            "not a side Unity's terrains take (2**n + 1 from 33 to 4097)"
        raise ValueError(f"a .raw heightmap is for Unity, and {w} x {w} is {why}: make it {near} x {near}, or "
                         "write .r16 (Unreal takes any square side)")


def _levels(z: np.ndarray, lo: float, hi: float) -> np.ndarray:
    from .io import _quantized

    return _quantized(z, 16, lo=lo, hi=hi)


def _spacing(shape, domain) -> tuple[float, float]:
    (x0, y0), (x1, y1) = domain
    return (x1 - x0) / shape[1], (y1 - y0) / shape[0]


def describe(shape, quantity: str, domain) -> dict:
    """What a terrain file says of an ``(H, W)`` field: ``field`` (``quantity``), and with a
    ``domain`` ``((x0, y0), (x1, y1))`` also ``domain`` and ``spacing`` (see the module's notes)."""
    out = {"field": quantity}
    if domain is not None:
        (x0, y0), (x1, y1) = domain
        dx, dy = _spacing(shape, domain)
        out["domain"] = [[x0, y0], [x1, y1]]
        out["spacing"] = repr(dx) if dx == dy else f"{dx!r},{dy!r}"
    return out


def _domain(domain):
    if domain is None:
        return None
    from .control import rectangle

    return tuple(tuple(float(v) for v in corner) for corner in rectangle("domain", domain))


def save_heightmap(path, field, *, range=None, domain=None, quantity: str = "value", format: str | None = None,
                   overwrite: bool = False) -> dict:
    """Write a 2D field as a 16-bit heightmap: a PNG that carries its range in text chunks, or a
    raw ``.r16``/``.raw`` file for game engines (see the module's notes). The write is atomic.

    Args:
        path: output file; its folder must exist.
        field: ``(H, W)`` numbers (elevations, distances, ...), row 0 at the top; +inf is allowed
            (written as 65535), NaN is not.
        range: ``(lo, hi)`` or ``"LO,HI"``: the values of grey 0 and 65535, shared by every file
            saved with it (values outside are clipped). Default: the field's finite minimum and maximum.
        domain: ``((x0, y0), (x1, y1))`` the field covers, in domain units, recorded in a PNG with the
            spacing it gives (None: not recorded).
        quantity: what the values are (``"elevation"``, ``"distance"``, ...), recorded in a PNG.
        format: ``"png"``, ``"r16"`` or ``"raw"`` (default: from the suffix of ``path``).
        overwrite: replace an existing file.

    Returns:
        ``{"path", "shape": (H, W), "min", "max", "clipped"}``: the range written and the number of
        finite values outside it.

    Raises:
        ValueError: an unknown format, NaN values, no finite value without a ``range``, a bad
            ``range`` or ``domain``, a raw format the field's shape does not fit
            (:func:`check_raw_shape`), a missing folder, a ``path`` that is a folder.
        TypeError: a field that is not a non-empty 2D array of numbers.
        FileExistsError: ``path`` exists and ``overwrite`` is False.
        OSError: the system refused the write; it names ``path``, and no file is left.
    """
    from .io import _format, _target, atomic_write

    _target(path, overwrite)
    fmt = _format(path, format, HEIGHTMAP_FORMATS, "heightmap")
    z = check_field(field)
    lo, hi = field_range(z) if range is None else value_range(range)
    domain = _domain(domain)
    if fmt != "png":
        check_raw_shape(z.shape, fmt)
    if not isinstance(quantity, str) or not quantity.strip():
        raise ValueError(f"Expected a name for 'quantity', such as 'elevation', but got {quantity!r}")
    clipped = int(np.count_nonzero(np.isfinite(z) & ((z < lo) | (z > hi))))
    levels = _levels(z, lo, hi)
    if fmt == "png":
        write = _png_writer(levels, lo, hi, describe(z.shape, quantity, domain))
    else:
        def write(tmp):
            with open(tmp, "wb") as f:
                f.write(memoryview(np.ascontiguousarray(levels, "<u2")).cast("B"))

    atomic_write(path, write, overwrite=overwrite)
    return {"path": Path(path), "shape": tuple(z.shape), "min": lo, "max": hi, "clipped": clipped}


def _png_writer(levels: np.ndarray, lo: float, hi: float, described: dict):
    """``write(tmp)`` of a 16-bit grey PNG of ``levels`` with the text chunks that read it back."""
    from PIL import Image, PngImagePlugin

    from . import __version__

    info = PngImagePlugin.PngInfo()
    text = {"wdendrite:min": repr(lo), "wdendrite:max": repr(hi),
            **{f"wdendrite:{k}": v if isinstance(v, str) else json.dumps(v) for k, v in described.items()},
            "Software": f"wdendrite {__version__}",
            "Description": "16-bit heightmap: value = wdendrite:min + grey / 65535 * (wdendrite:max - wdendrite:min); "
                           "pixel (row, col) is centred at x = x0 + (col + 0.5) * dx, y = y0 + (row + 0.5) * dy, "
                           "row 0 at y0 (wdendrite:domain, wdendrite:spacing)"}
    for key, value in text.items():
        info.add_text(key, value)
    image = Image.fromarray(levels)  # (uint16: Pillow's "I;16", a 16-bit grey PNG)

    return lambda tmp: image.save(tmp, format="PNG", pnginfo=info)


def _tifffile():
    try:
        import tifffile
    except ImportError:
        raise ImportError("GeoTIFF output needs tifffile: pip install 'wdendrite[tiff]'") from None
    return tifffile


def save_geotiff(path, field, *, domain=None, quantity: str = "value", overwrite: bool = False) -> Path:
    """Write a 2D field as a float32 GeoTIFF (see the module's notes). The write is atomic.

    Args:
        path: output ``.tif`` or ``.tiff`` file; its folder must exist.
        field: ``(H, W)`` numbers, row 0 at the top (non-finite values are kept as they are).
        domain: ``((x0, y0), (x1, y1))`` the field covers: the raster's transform maps pixel corner
            ``(col, row)`` to ``(x0 + col * dx, y0 + row * dy)`` (y grows with the rows, as in the
            domain; GIS viewers that draw y upwards show row 0 at the bottom). None: no transform.
        quantity: what the values are, recorded in the ``ImageDescription`` (JSON) with the domain
            and the spacing.
        overwrite: replace an existing file.

    Raises:
        ImportError: tifffile is not installed (nothing is written).
        ValueError: a suffix other than ``.tif``/``.tiff``, a bad ``domain``, a missing folder, a
            ``path`` that is a folder.
        TypeError: a field that is not a non-empty 2D array of numbers.
        FileExistsError: ``path`` exists and ``overwrite`` is False.
        OSError: the system refused the write; it names ``path``, and no file is left.
    """
    from .io import _format, _target, atomic_write

    tifffile = _tifffile()
    _target(path, overwrite)
    _format(path, None, GEOTIFF_FORMATS, "GeoTIFF")
    z = check_field(field, nan=True)
    domain = _domain(domain)
    if not isinstance(quantity, str) or not quantity.strip():
        raise ValueError(f"Expected a name for 'quantity', such as 'elevation', but got {quantity!r}")
    values = np.ascontiguousarray(z, np.float32)
    tags = []
    if domain is not None:
        (x0, y0), _ = domain
        dx, dy = _spacing(z.shape, domain)
        affine = [dx, 0.0, 0.0, x0, 0.0, dy, 0.0, y0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]
        # (ModelPixelScale takes positive scales with y falling down the rows: ours rises, so a transform)
        tags = [(34264, 12, 16, affine, True),  # ModelTransformationTag, doubles
                (34735, 3, 8, [1, 1, 0, 1, 1025, 0, 1, 1], True)]  # GeoKeyDirectory: GTRasterTypeGeoKey = PixelIsArea
    from . import __version__

    text = json.dumps({"wdendrite": __version__, **describe(z.shape, quantity, domain)})
    atomic_write(path, lambda tmp: tifffile.imwrite(tmp, values, photometric="minisblack", description=text,
                                                    metadata=None, software="wdendrite", extratags=tags),
                 overwrite=overwrite)
    return Path(path)
