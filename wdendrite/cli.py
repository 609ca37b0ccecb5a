"""The ``wdendrite`` command: one subcommand per preset, plus ``batch``.

Every preset function (``wdendrite.presets`` and the command's own models
below) is introspected: its keyword parameters become options, with their
defaults, types (from annotations or defaults) and help (from the docstring);
a frozen-dataclass parameter (``LightningParams``, ``DendryParams``) is
flattened into one option per field. New presets therefore appear in the
command without any wiring here.

Exit codes: 0 success, 2 bad usage or input (a message, no traceback),
1 an unexpected failure.
"""

from __future__ import annotations

import argparse
import logging
import os
import re
import sys
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING

from ._spec import (ALIASES, UsageError, all_presets, canonical_name, counted, nearest, parse_config, preset_summaries,
                    progress_bar, resolve)

__all__ = ["MODELS", "UsageError", "build_parser", "dendry_setup", "main", "pick_device", "relief", "run_preset",
           "unit_range", "write_outputs"]

PICTURE, FIELD, SVG = (".png",), (".npy",), (".svg",)
MESH, DENDRITE = (".obj", ".ply", ".stl", ".glb"), (".npz", ".json")
RAW, GEOTIFF = (".r16", ".raw"), (".tif", ".tiff")  # terrain files (wdendrite.heightmaps)
SUFFIXES = PICTURE + FIELD + MESH + DENDRITE + SVG + RAW + GEOTIFF

if TYPE_CHECKING:  # (NumPy is imported where a result is handled: --help and --version need none of it)
    import numpy as np


def __getattr__(name: str):
    # the models, NumPy and Warp are imported when a preset runs, not for --help or --version
    if name in ("MODELS", "dendry_setup", "relief", "unit_range"):  # (dendry_setup for batch jobs; the others
        from . import _models                                        # kept importable from here)

        return getattr(_models, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# --------------------------------------------------------------------------- devices and outputs


def check_device_name(name) -> None:
    """Raise :class:`UsageError` unless ``name`` spells a device (``cpu``, ``cuda``, ``cuda:N``)."""
    if not re.fullmatch(r"cpu|cuda(:\d+)?", str(name)):
        raise UsageError(f"--device must be cpu, cuda or cuda:N, but got {name!r}")


def pick_device(name: str | None) -> str:
    """The Warp device for ``name`` (``cpu``, ``cuda``, ``cuda:N``; None: CUDA if present, else the CPU)."""
    import warp as wp

    wp.config.log_level = logging.WARNING  # no start-up banner
    wp.init()
    if name is None:
        return "cuda:0" if wp.get_cuda_device_count() > 0 else "cpu"
    check_device_name(name)
    found = [str(d) for d in wp.get_devices()]
    want = "cuda:0" if name == "cuda" else name
    if want not in found:
        raise UsageError(f"--device {name!r} is not available on this machine; available: {', '.join(found)}")
    return want


def probe_folder(folder) -> None:
    """Raise ``OSError`` unless a file can be created in ``folder``.

    ``os.access`` says yes to root even on read-only file systems, so a file is really
    made: an unnamed one where the system allows it (Linux), so that a run killed
    meanwhile leaves nothing behind in the user's folder.
    """
    with tempfile.TemporaryFile(dir=folder):
        pass


def check_outputs(paths, *, force: bool, suffixes: tuple[str, ...] = SUFFIXES, ours=None,
                  writes: tuple[str, ...] | None = None) -> list[Path]:
    """Validate output paths before any work: known suffix, existing writable folder, no clobbering
    (``ours(path)``: True for a file this very run may replace, one a killed run of it left;
    ``writes``: the suffixes an unknown one's message lists, default ``suffixes``)."""
    out = []
    for p in paths:
        try:
            out.append(_checked_output(Path(p), out, force, suffixes, ours, writes or suffixes))
        except OSError as exc:  # a name the file system refuses (too long, say)
            raise UsageError(f"-o/--out {str(p)!r}: {exc.strerror or exc}") from None
    return out


def _checked_output(p: Path, out: list, force: bool, suffixes, ours=None, writes=SUFFIXES) -> Path:
    """``p`` if it may be written (see :func:`check_outputs`); ``out``: the paths checked before it."""
    if p.resolve() in [q.resolve() for q in out]:
        raise UsageError(f"-o/--out {str(p)!r} is given twice")
    suffix = p.suffix.lower()
    if suffix not in suffixes:
        if suffix == ".zarr":
            raise UsageError(f"-o/--out {str(p)!r}: a .zarr field is written tile by tile: add --tile N")
        if suffix in SUFFIXES:  # a known format this run does not write (tiles write fields only)
            raise UsageError(f"-o/--out {str(p)!r}: {suffix!r} is not written tile by tile; "
                             f"use one of {', '.join(suffixes)}")
        raise UsageError(f"-o/--out {str(p)!r}: unknown suffix {p.suffix or '(none)'!r}; "
                         f"use one of {', '.join(writes)}")
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir():
        raise UsageError(f"-o/--out {str(p)!r}: the folder {str(folder)!r} does not exist or is not a folder")
    try:
        probe_folder(folder)
    except OSError as exc:
        raise UsageError(f"-o/--out {str(p)!r}: the folder {str(folder)!r} is not writable "
                         f"({exc.strerror})") from None
    if p.is_dir() and p.suffix.lower() != ".zarr":  # a Zarr store is a folder; nothing else is
        raise UsageError(f"-o/--out {str(p)!r} is a folder; name a file")
    from .io import occupied

    what = occupied(p)
    if what and not force and not (ours is not None and ours(p)):
        raise UsageError(f"-o/--out {str(p)!r} {what}; pass --force to overwrite it")
    return p


def write_outputs(result, paths, *, force: bool, heightmap: bool = False, preset: str = "",
                  value_range=None) -> list[str]:
    """Write what a preset returned to each path, the format taken from the suffix.

    ``.png``: the picture (8-bit RGB), or with ``heightmap`` the 2D field as a 16-bit grey PNG
    scaled from ``value_range`` (default: its finite minimum to its maximum; +inf as white; a
    field with NaN or, without a range, without a finite value is refused), which records the
    range in its text chunks; ``.r16/.raw``: the same levels as raw little-endian uint16;
    ``.tif/.tiff``: the field as a float32 GeoTIFF (see :mod:`wdendrite.heightmaps`); ``.npy``: the
    field (float32; without one, as for the 3D presets, the picture's luminance); ``.obj/.ply/.stl/.glb``:
    the mesh; ``.npz/.json``: the dendrite graph; ``.svg``: a 2D dendrite as polylines.

    All or nothing: every output is first written to a temporary file beside its path, and
    only when all are written are they renamed into place; a failure, in the writing or in
    the renames, removes them and leaves every path as it was. A kill during the renames
    leaves them recorded: the next command run on the folder completes them
    (:func:`wdendrite._staging.sweep`), and a kill before them leaves temporary files it deletes.
    """
    from . import io

    paths = [Path(p) for p in paths]
    for p in paths:  # every output must be possible before the first is written
        suf = p.suffix.lower()
        if suf in MESH:
            _need(result, "mesh", preset)
        elif suf in DENDRITE + SVG:
            _need(result, "dendrite", preset)
    from ._staging import Staging

    with Staging() as stage:  # (what a failure or a kill leaves staged is deleted, here or by the next sweep)
        staged = []
        for p in paths:
            tmp = None
            try:
                mode = io.final_mode(p)
                tmp = stage.temporary(p, mode)
                staged.append((tmp, p))
                with io.writing_staged():  # the writers write to tmp itself: it is already a temporary file
                    _write_one(io, result, tmp, p.suffix.lower(), heightmap, preset, value_range)
                io.sync_to_disk(tmp)
                os.chmod(tmp, mode)
            except OSError as exc:
                io.raise_write_failed(p, exc, tmp)
        for _, p in staged:  # a file that appeared meanwhile is not clobbered without --force
            what = io.occupied(p)
            if what and not force:
                raise UsageError(f"-o/--out {str(p)!r} {what}; pass --force to overwrite it")
        # a Ctrl-C between two renames would break all or nothing: it waits for the end
        with io.interrupts_held():
            stage.commit(staged)
    return [str(p) for p in paths]


def _save_npy(path, array: np.ndarray) -> None:
    """``np.save`` to exactly ``path`` (given a name, NumPy appends ``.npy`` unless it ends so, as
    ``f.NPY`` does not)."""
    import numpy as np

    with open(path, "wb") as f:
        np.save(f, array)


def _sixteen_bit(paths, heightmap: bool) -> list[Path]:
    """The outputs among ``paths`` that are 16-bit heightmaps (.r16, .raw; .png with ``heightmap``)."""
    return [Path(p) for p in paths
            if Path(p).suffix.lower() in RAW or (heightmap and Path(p).suffix.lower() == ".png")]


def _heightmap(field, value_range=None, option: str = "--heightmap") -> tuple[float, float, int]:
    """``(lo, hi, clipped)``: the values grey 0 and 65535 stand for in heightmaps of ``field``
    (``value_range``, else its finite minimum and maximum) and how many finite values lie outside
    them; a field with NaN, or without a finite value and a range, is refused naming ``option``."""
    import numpy as np

    from . import heightmaps

    try:
        lo, hi = heightmaps.field_range(field) if value_range is None else value_range
        if value_range is not None:
            heightmaps.check_field(field)
    except ValueError as exc:
        raise UsageError(f"{option}: {exc}; nothing was written") from None
    z = np.asarray(field)
    return lo, hi, int(np.count_nonzero(np.isfinite(z) & ((z < lo) | (z > hi))))


def _grid(result) -> dict:
    """``{"quantity", "domain"}`` of a result's field, as terrain files record them."""
    import numpy as np

    quantity = getattr(result, "quantity", None)
    parts = getattr(result, "parts", {}) or {}
    if quantity is None:
        found = [k for k in ("elevation", "field", "value", "values")
                 if isinstance(parts.get(k), np.ndarray) and parts[k].ndim == 2]
        quantity = found[0] if found else "luminance"
    return {"quantity": quantity, "domain": getattr(result, "domain", None)}


def _write_one(io, result, path: Path, suf: str, heightmap: bool, preset: str, value_range=None) -> None:
    """Write one output of ``result`` to ``path`` (an existing temporary file) as ``suf`` says."""
    from . import heightmaps

    if suf in RAW or (suf == ".png" and heightmap):
        heightmaps.save_heightmap(path, _field(result, preset), range=value_range, **_grid(result), overwrite=True)
    elif suf in GEOTIFF:
        heightmaps.save_geotiff(path, _field(result, preset), **_grid(result), overwrite=True)
    elif suf == ".png":
        io.save_png(path, _picture(result), overwrite=True)
    elif suf == ".npy":
        import numpy as np

        field = np.asarray(_field(result, preset), np.float32)
        io.atomic_write(path, lambda tmp: _save_npy(tmp, field), overwrite=True)
    elif suf in MESH:
        io.save_mesh(path, _need(result, "mesh", preset), overwrite=True)
    elif suf in DENDRITE:
        io.save_dendrite(path, _need(result, "dendrite", preset), overwrite=True)
    else:
        io.save_svg(path, _need(result, "dendrite", preset), overwrite=True)


def _need(result, attr: str, preset: str):
    value = getattr(result, attr, None)
    if value is None:
        raise _makes_no(preset, attr, getattr(result, "mesh", None) is not None)
    return value


def _formats(preset) -> tuple[str, ...]:
    """The output suffixes ``preset`` writes: its picture and field always, then meshes, dendrite
    graphs and (for a 2D dendrite) SVG polylines as it makes them."""
    out = PICTURE + FIELD + GEOTIFF[:1] + RAW + (MESH if preset.meshes else ())
    if preset.dendrite:
        out += DENDRITE + (() if preset.meshes else SVG)
    return out


def _listed(suffixes) -> str:
    """``.a, .b or .c``."""
    return ", ".join(suffixes[:-1]) + " or " + suffixes[-1] if len(suffixes) > 1 else suffixes[0]


def _makes_no(preset: str, what: str, meshes: bool) -> UsageError:
    """The error for an output a preset cannot make, naming the outputs it can."""
    return UsageError(f"preset {preset!r} makes no {what}; write .png or .npy"
                      + (", or a mesh (.obj, .ply, .stl, .glb)" if meshes else "") + " instead")


def _picture(result) -> np.ndarray:
    import numpy as np

    from ._models import unit_range

    if isinstance(result, np.ndarray):
        return unit_range(result)
    return result.image


def _field(result, preset: str) -> np.ndarray:
    import numpy as np

    if isinstance(result, np.ndarray):
        return result
    parts = getattr(result, "parts", {}) or {}
    for key in ("elevation", "field", "value", "values"):
        v = parts.get(key)
        if isinstance(v, np.ndarray) and v.ndim == 2:
            return v
    img = np.asarray(result.image)
    return img if img.ndim == 2 else img @ np.array([0.299, 0.587, 0.114], np.float32)


# --------------------------------------------------------------------------- running one preset


class _Ticker:
    """A tqdm line, ``desc`` and the time so far, whose clock keeps moving while one long call
    runs (a call has no steps to count: ``set_description_str`` names the stage)."""

    def __init__(self, desc: str, quiet: bool):
        # shown only for work that takes more than a moment
        self.bar = progress_bar(desc, quiet=quiet, leave=False, delay=0.5, bar_format="{desc} {elapsed}")
        self._stop, self._drawn = None, False

    def __enter__(self):
        import threading

        if not self.bar.disable:
            self._stop = threading.Event()

            def tick():
                while not self._stop.wait(0.5):
                    self.bar.refresh()
                    self._drawn = True

            self._thread = threading.Thread(target=tick, daemon=True)
            self._thread.start()
        return self.bar

    def __exit__(self, *exc):
        if self._stop is not None:
            self._stop.set()
            self._thread.join()  # (no refresh after the clearing)
        if self._drawn:  # (tqdm's close clears only a line it drew itself: these refreshes it does not count)
            self.bar.clear()
        self.bar.close()


def run_preset(name: str, values: dict, outputs, *, device: str | None = None, force: bool = False,
               quiet: bool = True, heightmap: bool = False, value_range=None, workers: int | None = None) -> dict:
    """Run preset ``name`` with parameter ``values`` (already typed) and write ``outputs``.

    ``workers``: CPU threads of a preset that takes them (``dendry``, ``terrain``; None: every core).

    Everything is validated before the preset runs: parameter names and values, the
    output suffixes and folders, the device, ``value_range`` (``(lo, hi)`` of the 16-bit
    heightmaps among the outputs; refused when there are none). What only the field can tell
    (NaN, a shape a raw heightmap cannot hold) is refused after the preset ran, before any
    write. The outputs are locked while it runs (:func:`wdendrite._staging.locked`): a second
    run writing one of them at the same time stops at once with ``FileExistsError``. Returns a
    record of what was done: ``preset``, ``params`` (every parameter, defaults included),
    ``device``, ``outputs``, ``seconds`` (compute) and ``write_seconds``; with 16-bit heightmaps
    also ``heightmap_range`` (the values of grey 0 and 65535), ``clipped`` (finite values outside
    it) and ``raw`` (``[path, H, W]`` of each raw file, whose size the file does not hold).
    """
    import warp as wp

    name = canonical_name(name)
    preset = all_presets().get(name)
    if preset is None:
        raise UsageError(f"unknown preset {name!r}{nearest(name, all_presets())}")
    paths = check_outputs(outputs, force=force, writes=_formats(preset))
    for p in paths:
        if p.suffix.lower() in MESH and not preset.meshes:
            raise UsageError(f"preset {name!r} makes no mesh (it is 2D); write {_listed(_formats(preset))}")
        if p.suffix.lower() in DENDRITE + SVG and not preset.dendrite:
            raise _makes_no(name, "dendrite", preset.meshes)
        if p.suffix.lower() in SVG and preset.meshes:
            raise UsageError(f"preset {name!r} makes a 3D dendrite, which SVG cannot draw; "
                             f"write {_listed(_formats(preset))}")
    sixteen = _sixteen_bit(paths, heightmap)
    if value_range is not None and not sixteen:
        raise UsageError("--range scales 16-bit heightmaps (.png with --heightmap, .r16, .raw), and this run "
                         "writes none")
    need_tifffile(paths)
    dev = pick_device(device)
    kwargs, full = resolve(preset, values)
    if preset.func.__module__ == "wdendrite._models" and preset.name in ("dendry", "terrain"):
        size = kwargs.get("size", preset.params["size"].default)
        _check_raw(paths, (size, size))  # (their field is size x size: known before they run)
    if takes_workers(preset):  # (not a parameter of the result: its bytes do not depend on it)
        kwargs["workers"] = workers
    from ._staging import locked

    with locked(paths), _Ticker(f"{name}: making", quiet) as bar:  # (a second run writing them stops at once)
        t0 = time.perf_counter()
        with wp.ScopedDevice(dev):
            result = preset.func(**kwargs)
            if not heightmap and any(p.suffix.lower() == ".png" for p in paths):
                _picture(result)  # a deferred picture is made here: it counts as making, and fails before any write
            if sixteen:  # (refused before any write too)
                field = _field(result, name)
                option = "--heightmap" if heightmap and any(p.suffix.lower() == ".png" for p in paths) else \
                    f"-o/--out {str(sixteen[0])!r}"
                lo, hi, clipped = _heightmap(field, value_range, option)
                _check_raw(paths, field.shape)
        seconds = time.perf_counter() - t0
        # (shown by the ticker's next refresh: drawing it now would show a line for an instant write)
        bar.set_description_str(f"{name}: writing {counted(len(paths), 'file')}", refresh=False)
        t1 = time.perf_counter()
        written = write_outputs(result, paths, force=force, heightmap=heightmap, preset=name,
                                value_range=(lo, hi) if sixteen else None)
    rec = {"preset": name, "params": full, "device": dev, "outputs": written, "seconds": round(seconds, 4),
           "write_seconds": round(time.perf_counter() - t1, 4), "made": _made(result)}
    if sixteen:
        # grey 0 and 65535 stand for these values: what it takes to read the heightmap back
        rec.update(heightmap_range=[lo, hi], clipped=clipped,
                   raw=[[str(p), *field.shape] for p in paths if p.suffix.lower() in RAW])
    return rec


def _check_raw(paths, shape) -> None:
    """Refuse a raw heightmap among ``paths`` that an ``(H, W)`` field cannot fill for its engine."""
    from .heightmaps import check_raw_shape

    for p in paths:
        if p.suffix.lower() in RAW:
            try:
                check_raw_shape(shape, p.suffix.lower()[1:])
            except ValueError as exc:
                raise UsageError(f"-o/--out {str(p)!r}: {exc}; nothing was written") from None


def need_tifffile(paths, where: str = "-o/--out") -> None:
    """Raise :class:`UsageError` when a GeoTIFF output is asked for and tifffile is not installed."""
    tifs = [p for p in paths if Path(p).suffix.lower() in GEOTIFF]
    if tifs:
        try:
            import tifffile  # noqa: F401
        except ImportError:
            raise UsageError(f"{where} {str(tifs[0])!r}: GeoTIFF output needs tifffile: pip install "
                             "'wdendrite[tiff]' (or write .npy); nothing was written") from None


# --------------------------------------------------------------------------- the parser


class _Parser(argparse.ArgumentParser):
    """argparse that suggests the nearest name for an unknown subcommand or choice, in one line
    (the usage block is left to ``--help``), and takes options by their whole names only (a
    shortened one such as ``--devic`` would be read as ``--device`` without a word)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message):
        m = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
        if m:
            choices = re.findall(r"'([^']*)'", m.group(2))
            message += nearest(m.group(1), choices)
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _add_common(p, preset) -> None:
    g = p.add_argument_group("common options")
    if preset.size_param:
        sp = preset.params[preset.size_param]
        # a shape's largest side, or the one length the preset is sized by (a panel's side, a height)
        what = "largest side" if preset.size_param in ("shape", "size") else sp.doc.rstrip(".")
        g.add_argument("--size", type=int, default=argparse.SUPPRESS, metavar="N",
                       help=f"{what}; sets '{preset.size_param}' "
                            f"(default: {preset.default_size}) [{sp.unit}]" if sp else "")
    if "seed" in preset.params:
        g.add_argument("--seed", type=int, default=argparse.SUPPRESS, metavar="INT",
                       help=f"random seed (default: {preset.params['seed'].default})")
    g.add_argument("--device", default=argparse.SUPPRESS, metavar="DEV",
                   help="Warp device: cpu, cuda, cuda:N (default: CUDA if present, else cpu)")
    g.add_argument("-o", "--out", action="append", default=argparse.SUPPRESS, metavar="FILE",
                   help=f"output file, repeatable; format from the suffix: {', '.join(_formats(preset))} "
                        f"(default: {preset.name}.png)")
    g.add_argument("--heightmap", action="store_true", default=argparse.SUPPRESS,
                   help="write .png outputs as a 16-bit grey heightmap of the field instead of the picture "
                        "(its finite minimum to its maximum; +inf, such as no branch in reach, as white)")
    g.add_argument("--range", default=argparse.SUPPRESS, metavar="LO,HI",
                   help="16-bit heightmaps (.png with --heightmap, .r16, .raw) put grey 0 at LO and 65535 at HI "
                        "instead of the field's minimum and maximum, so that several runs share one scale "
                        "(values outside are clipped)")
    if preset.name in ("dendry", "terrain") and preset.func.__module__ == "wdendrite._models":
        g.add_argument("--tile", type=int, default=argparse.SUPPRESS, metavar="N",
                       help="compute the field in N x N tiles (N at least 8) straight into .npy (or .zarr) "
                            "outputs, never the whole image in memory; a killed run resumes (default: whole "
                            "image) [pixels]")
    if takes_workers(preset):
        g.add_argument("--workers", type=int, default=argparse.SUPPRESS, metavar="N",
                       help="CPU threads (default: every core this process may use; more are capped at that); "
                            "the output does not depend on it")
    g.add_argument("--config", metavar="FILE.toml", default=argparse.SUPPRESS,
                   help="TOML file whose keys are this preset's parameters (options given here override it)")
    g.add_argument("--force", action="store_true", default=argparse.SUPPRESS, help="overwrite existing outputs")
    g.add_argument("--quiet", action="store_true", default=argparse.SUPPRESS, help="no progress bar")


def _add_params(p, preset) -> None:
    groups = {}
    for prm in preset.params.values():
        if prm.name in ("seed", "size"):  # common options
            continue
        title = f"{prm.group} fields" if prm.group else "parameters"
        g = groups.setdefault(title, p.add_argument_group(title))
        flag = "--" + prm.name.replace("_", "-")
        if prm.kind == "bool":
            g.add_argument(flag, dest=prm.name, action=argparse.BooleanOptionalAction, default=argparse.SUPPRESS,
                           help=prm.help_text())
        else:
            g.add_argument(flag, dest=prm.name, default=argparse.SUPPRESS, metavar=prm.metavar(),
                           help=prm.help_text())
    if preset.fixed:
        p.epilog = ("Not settable from the command line (Python only): " + ", ".join(preset.fixed) + ".")


_COMMON_HELP = """\
options of every preset:
  --size N              largest side [nodes or pixels] (default: the preset's, e.g. 600 for lightning)
  --seed INT            random seed (default: 0); same seed, same output
  --device DEV          cpu, cuda or cuda:N (default: CUDA if present, else cpu)
  -o, --out FILE        repeatable; format from the suffix: .png picture, .npy field (float32),
                        .tif GeoTIFF (float32), .r16/.raw 16-bit heightmap (Unreal/Unity),
                        .obj/.ply/.stl/.glb mesh (3D presets), .npz/.json dendrite graph, .svg polylines
                        (default: PRESET.png)
  --heightmap           .png outputs hold the field as a 16-bit grey heightmap
  --range LO,HI         16-bit heightmaps span LO to HI (default: the field's minimum to maximum)
  --config FILE.toml    parameter values from a TOML file (options given here override it)
  --force               overwrite existing outputs
  --quiet               no progress bar

exit codes: 0 success, 2 bad usage or input (nothing written), 1 unexpected failure"""


def build_parser(*, listing: bool = False) -> argparse.ArgumentParser:
    """The full parser: one subparser per preset, plus ``batch`` and ``warmup``. With ``listing``, the
    presets' subparsers only name them (with their summaries, read from the sources, so that
    ``wdendrite --help`` and ``--version`` import neither the presets nor Warp): enough to print the
    command's help or version, or to refuse a command line that names no preset."""
    summaries = preset_summaries() if listing else None
    p = _Parser(prog="wdendrite", formatter_class=argparse.RawDescriptionHelpFormatter,
                description="Dendritic shapes grown with NVIDIA Warp kernels.\n\n"
                            "Run 'wdendrite PRESET --help' for a preset's parameters, defaults and units.\n"
                            "Example: wdendrite fractal --size 256 -o fractal.png --force",
                epilog=_COMMON_HELP)
    from . import __version__

    p.add_argument("--version", action="version", version=f"wdendrite {__version__}")
    sub = p.add_subparsers(dest="command", metavar="PRESET", required=True, parser_class=_Parser)
    for name, preset in (summaries or all_presets()).items():
        # a preset named after its model (tree) also answers to its function's name (elm-tree)
        aliases = [f.replace("_", "-") for f, a in ALIASES.items() if a == name]
        if summaries is not None:
            sub.add_parser(name, aliases=aliases, help=preset)
            continue
        s = sub.add_parser(name, aliases=aliases, help=preset.summary, description=preset.doc,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        _add_params(s, preset)
        _add_common(s, preset)
        s.set_defaults(_preset=name)
    b = sub.add_parser("batch", help="run a TOML job file: presets with parameter sweeps, resumable, "
                                     "optionally on Dask")
    b.add_argument("jobs", metavar="JOBS.toml", help="the job file (see 'Batch jobs' in the README)")
    b.add_argument("--scheduler", default=None, metavar="local|ADDRESS",
                   help="run on Dask: 'local' starts a LocalCluster, else a scheduler address "
                        "such as tcp://host:8786 (default: one process, no Dask)")
    b.add_argument("--workers", type=int, default=None, metavar="N", help="LocalCluster workers (default: 1)")
    b.add_argument("--device", default=None, metavar="DEV", help="Warp device for every job (default: the file's, "
                                                                 "else CUDA if present, else cpu)")
    b.add_argument("--timeout", type=float, default=10.0, metavar="SECONDS",
                   help="how long to wait for a scheduler at an address (default: 10) [s]")
    b.add_argument("--quiet", action="store_true", help="no progress bar")
    b.add_argument("--force", action="store_true",
                   help="overwrite files in the output folder that an earlier batch did not make")
    b.add_argument("--dry-run", action="store_true", help="list the tasks and whether they are done, run nothing")
    b.set_defaults(_preset=None)
    w = sub.add_parser("warmup", help="compile every kernel module now (for later runs, notebooks, CI images), "
                                      "printing the seconds each took")
    w.add_argument("--device", default=None, metavar="DEV", help="Warp device (default: CUDA if present, else cpu)")
    w.add_argument("--workers", type=int, default=None, metavar="N",
                   help="modules compiled at the same time (default: the number of CPUs)")
    w.add_argument("--quiet", action="store_true", help="no progress bar")
    w.set_defaults(_preset=None, _warmup=True)
    return p


def _warmup(args) -> int:
    """``wdendrite warmup``: every kernel module compiled (or found in Warp's cache) for the device."""
    from .warmup import load_kernels

    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers must be at least 1, got {args.workers}")
    dev = pick_device(args.device)
    t = time.perf_counter()
    seconds = load_kernels(dev, workers=args.workers, progress=not args.quiet)
    for name, s in seconds.items():
        print(f"{name:<16}{s:8.2f} s")
    print(f"{len(seconds)} kernel modules ready on {dev} in {time.perf_counter() - t:.2f} s")
    return 0


def _unknown(argv, parser, extras) -> UsageError:
    name = next((a for a in argv if not a.startswith("-")), None)
    sub = parser._subparsers._group_actions[0].choices.get(name) if name else None
    options = [s for a in (sub._actions if sub else []) for s in a.option_strings]
    bad = [e for e in extras if e.startswith("-")] or extras
    flag = bad[0].split("=")[0]
    return UsageError(f"unrecognized option {flag!r} for '{name}'{nearest(flag, options)}")


def _values_from(args, preset, sources: dict | None = None) -> dict:
    """Typed parameter values from the config file and the options (which win); ``sources`` is told
    ``{parameter: where}`` for the values the config file gave."""
    given = {k: v for k, v in vars(args).items() if k in preset.params and k != "size"}
    values = {}
    if "config" in args:
        values.update(parse_config(args.config, preset))
        overridden = {*given, *([preset.size_param] if "size" in args else [])}
        if sources is not None:
            sources.update({k: f"config file {str(args.config)!r}" for k in values if k not in overridden})
    for k, v in given.items():
        values[k] = preset.params[k].convert(v, source=f"--{k.replace('_', '-')}")
    if "size" in args:
        if args.size is not None and preset.size_param in given:
            raise UsageError(f"give --size or --{preset.size_param.replace('_', '-')}, not both")
        values[preset.size_param] = preset.sized(args.size)
    return values


def _negative_range_glued(argv: list) -> list:
    """``argv`` with ``--range -1,2`` written ``--range=-1,2``: argparse takes a word that starts with
    a dash for an option (and then says --range lacks its value)."""
    out = []
    for i, a in enumerate(argv):
        if i and argv[i - 1] == "--range" and out[-1] == "--range" and re.match(r"-\.?\d", a):
            out[-1] = f"--range={a}"
        else:
            out.append(a)
    return out


def main(argv=None) -> int:
    """Entry point of the ``wdendrite`` console script; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    argv = _negative_range_glued(argv)
    size_note = ""  # how --size became the preset's shape, for errors about that shape
    preset = None
    sources = {}  # parameters the config file set
    try:
        if not any(not a.startswith("-") for a in argv):  # no preset named: --help, --version or a usage error
            build_parser(listing=True).parse_known_args(argv)
        import warp as wp

        wp.config.log_level = logging.WARNING  # no start-up banner, whatever initializes Warp first
        parser = build_parser()
        args, extras = parser.parse_known_args(argv)
        if extras:
            raise _unknown(argv, parser, extras)
        if getattr(args, "_warmup", False):
            return _warmup(args)
        if args._preset is None:
            from .batch import run_file

            return run_file(args.jobs, scheduler=args.scheduler, device=args.device, workers=args.workers,
                            quiet=args.quiet, dry_run=args.dry_run, timeout=args.timeout, force=args.force)
        preset = all_presets()[args._preset]
        values = _values_from(args, preset, sources)
        if getattr(args, "size", None) is not None and isinstance(values[preset.size_param], tuple):
            size_note = f" (--size {args.size} gives {preset.size_param}={values[preset.size_param]})"
        outs = getattr(args, "out", None) or [f"{preset.name}.png"]
        from ._staging import sweep

        for folder in dict.fromkeys(Path(o).parent for o in outs):
            sweep(folder)  # what killed runs left there: renames completed, temporary files deleted
        workers = _workers(args)
        if "tile" in args:
            return _tiled(preset, values, outs, args, workers)
        value_range = None
        if "range" in args:
            from .heightmaps import value_range as _range

            value_range = _range(args.range, "--range")
        rec = run_preset(preset.name, values, outs, device=getattr(args, "device", None),
                         force=getattr(args, "force", False), quiet=getattr(args, "quiet", False),
                         heightmap=getattr(args, "heightmap", False), value_range=value_range, workers=workers)
        made = f": {rec['made']}" if rec["made"] else ""
        print(f"{preset.name} ({_brief(rec['params'], preset)}){made} in {rec['seconds']:.3f} s on {rec['device']} "
              f"-> {', '.join(rec['outputs'])}")
        _tell_heightmaps(rec)
        return 0
    except (UsageError, ValueError, TypeError, FileExistsError) as exc:
        if size_note and f"'{preset.size_param}'" not in str(exc):
            size_note = ""
        print(f"wdendrite: error: {exc}{size_note}{_options_named(exc, preset, sources)}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader of our report went away (``| head``): the outputs are written, the report is not needed
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except KeyboardInterrupt:
        print("wdendrite: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        from ._checks import memory_error

        memory = memory_error(exc)  # (also an allocation beyond the checks' estimates: ulimit -v, a cgroup)
        if memory is not None:
            print(f"wdendrite: error: not enough memory: {memory}", file=sys.stderr)
            return 2
        if isinstance(exc, OSError):  # the system refused a write (disk full, file too large, permissions): no bug
            print(f"wdendrite: error: {exc}", file=sys.stderr)
            return 1
        import traceback  # a bug, not the user's input: show where

        traceback.print_exc()
        print("wdendrite: unexpected failure (please report it with the traceback above)", file=sys.stderr)
        return 1


def _options_named(exc, preset, sources=None) -> str:
    """`` (--a, --b)``: the options behind the parameters a library error names in quotes
    (the preset's checks speak of its Python parameters), or nothing; a value the config file
    gave is said to come from it (``sources``: ``{parameter: where}``)."""
    if preset is None or isinstance(exc, UsageError):
        return ""
    named = dict.fromkeys(n for n in re.findall(r"'(\w+)'", str(exc)) if n in preset.params)
    sources = sources or {}
    where = [f"'{n}' from {sources[n]}" if n in sources else "--" + n.replace("_", "-") for n in named]
    return f" ({', '.join(where)})" if named else ""


def _tell_heightmaps(rec: dict) -> None:
    """Print what it takes to read a run's 16-bit heightmaps back: their range, and raw files' sizes."""
    if "heightmap_range" in rec:
        clipped = f" ({counted(rec['clipped'], 'value')} outside, clipped)" if rec.get("clipped") else ""
        print("heightmap: grey 0 = {:.6g}, 65535 = {:.6g}".format(*rec["heightmap_range"]) + clipped)
    for path, h, w in rec.get("raw", []):  # (engines ask for the size: the file does not hold it)
        print(f"{path}: {w} x {h} pixels, 16-bit little-endian, row 0 first, no header")


def takes_workers(preset) -> bool:
    """Whether ``preset``'s function takes ``workers`` (CPU threads), which ``--workers`` sets."""
    import inspect

    return "workers" in inspect.signature(preset.func).parameters


def _workers(args) -> int | None:
    """``--workers`` checked before any work (None when not given: every core); more than the
    cores this process may use are capped at them, with a line on stderr saying so."""
    if "workers" not in args:
        return None
    from ._parallel import cores

    if args.workers < 1:
        raise UsageError(f"--workers must be a positive integer, but got {args.workers}")
    if args.workers > cores():
        print(f"wdendrite: --workers {args.workers} is more than the {cores()} cores this process may use: "
              f"using {cores()}", file=sys.stderr)
        return cores()
    return args.workers


def _tiled(preset, values: dict, outs: list, args, workers: int | None = None) -> int:
    """``dendry``/``terrain`` with ``--tile``: the field written tile by tile (:func:`wdendrite.tiles.write_tiled`)."""
    from .batch import Task, need_zarr, run_tiled
    from .heightmaps import value_range
    from .tiles import _tile_records, placed_by_killed_run, tile_key
    from ._staging import NAME_BYTES as _NAME_BYTES

    if isinstance(args.tile, bool) or args.tile < 8:
        raise UsageError(f"--tile must be at least 8 pixels, got {args.tile}")
    if getattr(args, "heightmap", False):
        raise UsageError("--heightmap makes .png outputs, which --tile does not write (it writes .npy, .zarr, and "
                         "with --range .r16 and .raw)")
    levels = value_range(args.range, "--range") if "range" in args else None
    _, full = resolve(preset, values)
    # an output a killed run of this very command renamed into place is its own, not the user's
    key = tile_key(full, pick_device(getattr(args, "device", None)).split(":")[0], levels)
    # tiles go straight into the field's file: no picture, which would need the whole image
    paths = check_outputs(outs, force=getattr(args, "force", False), suffixes=(".npy", ".zarr") + RAW,
                          ours=lambda p: placed_by_killed_run(p, key, outs))
    raw = [p for p in paths if p.suffix.lower() in RAW]
    if levels is None and raw:
        raise UsageError(f"-o/--out {str(raw[0])!r}: a tiled raw heightmap needs --range LO,HI: its levels are fixed "
                         "before the first tile, when the field's range is not known yet")
    if levels is not None and not raw:
        raise UsageError("--range scales 16-bit heightmaps; with --tile those are .r16 and .raw outputs, and this run "
                         "writes none")
    _check_raw(paths, (full["size"], full["size"]))
    for p in paths:  # tiles go to a hidden partial file beside it, and their records to a hidden folder
        longest = max(len(os.fsencode(q.name)) for q in _tile_records(p))
        if longest > _NAME_BYTES:
            raise UsageError(f"-o/--out {str(p)!r}: the name is {longest - _NAME_BYTES} bytes too long for the file "
                             f"the tiles are written to before the rename ({_NAME_BYTES} at most); shorten it")
    need_zarr(paths)
    task = Task(paths[0].stem, preset.name, values, [str(p) for p in paths], full, args.tile,
                {"range": list(levels)} if levels else {})
    with progress_bar(f"{preset.name} tiles", quiet=getattr(args, "quiet", False), leave=False) as bar:
        def tick(done, total):
            bar.total, bar.n = total, done
            bar.refresh()

        rec = run_tiled(task, getattr(args, "device", None), progress=tick, manifest=False, workers=workers)
    print(f"{preset.name} ({_brief(full, preset)}) in {args.tile}-pixel tiles: {rec['seconds']:.3f} s on "
          f"{rec['device']} -> {', '.join(task.outputs)}")
    _tell_heightmaps(rec)
    return 0


def _made(result) -> str:
    """What a result holds, in a few words: dendrite and mesh sizes, else the size and finite range
    of its field (a terrain's elevation, a Dendry image)."""
    import numpy as np

    bits = []
    den, mesh = getattr(result, "dendrite", None), getattr(result, "mesh", None)
    if den is not None:
        bits.append(f"{counted(len(den), 'node')}, {counted(len(den.endpoints), 'endpoint')}")
    if mesh is not None and hasattr(mesh, "faces"):
        bits.append(f"{len(mesh.faces)} faces")
    parts = getattr(result, "parts", None) or {}
    field = next((parts[k] for k in ("elevation", "field") if isinstance(parts.get(k), np.ndarray)), None)
    if not bits and field is not None and field.ndim == 2:
        finite = field[np.isfinite(field)]
        span = f" from {finite.min():.6g} to {finite.max():.6g}" if finite.size else ", no finite value"
        bits.append(f"{field.shape[0]} x {field.shape[1]} {'elevation' if 'elevation' in parts else 'field'}{span}")
    return ", ".join(bits)


def _brief(params: dict, preset) -> str:
    keys = [k for k in (preset.size_param, "seed") if k]
    return ", ".join(f"{k}={params[k]}" for k in keys if k in params)


if __name__ == "__main__":
    sys.exit(main())
