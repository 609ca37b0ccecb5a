"""Writing results to disk safely (temporary file, then rename)."""

from __future__ import annotations

import contextlib
import contextvars
import json
import math
import os
import re
import warnings
import zipfile
import zlib
from pathlib import Path
from typing import NoReturn

import numpy as np

from . import _checks
from ._staging import Staging, sync_folder

__all__ = [
    "DENDRITE_FORMATS", "MESH_FORMATS", "atomic_write", "load_dendrite", "save_dendrite", "save_mesh", "save_png",
    "save_svg", "svg_polylines",
]


def occupied(path) -> str | None:
    """What stands at ``path`` in words (``"exists"``, ``"is a link to a missing file"``), or None
    when nothing does. A link counts even when it leads nowhere: it is the user's too."""
    if not os.path.lexists(path):
        return None
    return "exists" if os.path.exists(path) else "is a link to a missing file"


def _target(path, overwrite: bool) -> Path:
    """``path`` as a Path, once it is known that a file may be written there."""
    overwrite = _checks.flag("overwrite", overwrite)  # (text such as "no" would have counted as true)
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"'path' {str(path)!r} is a folder; give the name of a file to write in it")
    if not path.parent.is_dir():
        raise ValueError(f"The folder of 'path' does not exist (or is not a folder): {str(path.parent)!r}")
    what = occupied(path)
    if what and not overwrite:
        raise FileExistsError(f"'path' {str(path)!r} {what}; pass overwrite=True to replace it")
    return path


def _umask() -> int:
    # reading it from /proc leaves the process umask alone (setting it is not thread-safe)
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    current = os.umask(0o022)
    os.umask(current)
    return current


_STAGED = contextvars.ContextVar("wdendrite_io_staged", default=False)


@contextlib.contextmanager
def writing_staged():
    """Within this block the ``save_*`` functions write straight to the paths they are given:
    for callers that already write to temporary files of their own and rename them together."""
    token = _STAGED.set(True)
    try:
        yield
    finally:
        _STAGED.reset(token)


def atomic_write(path, write, *, overwrite: bool = False) -> Path:
    """Call ``write(tmp_path)`` on a temporary file beside ``path``, then rename it to ``path``.

    An interrupted write leaves no half-written ``path`` behind. Inside
    :func:`writing_staged`, ``write(path)`` is called on ``path`` itself.

    Args:
        path: the file to write; its folder must exist.
        write: ``write(str_path)`` writes the whole file at the path it is given.
        overwrite: replace an existing file.

    Returns:
        ``path`` as a :class:`~pathlib.Path`.

    Raises:
        ValueError: a missing folder, a ``path`` that is a folder.
        FileExistsError: ``path`` exists (or appears while it is written) and ``overwrite`` is False.
        OSError: the system refused the write; it names ``path`` (the original error is its cause).
    """
    path = _target(path, overwrite)
    if _STAGED.get():
        write(str(path))
        return path
    mode = final_mode(path)
    with Staging() as stage:  # (a kill leaves a temporary the next command's sweep recognises)
        try:
            tmp = str(stage.temporary(path, mode))
        except OSError as exc:
            raise_write_failed(path, exc)
        try:
            write(tmp)
            sync_to_disk(tmp)
            os.chmod(tmp, mode)  # (written while the owner could write it)
            if overwrite:
                os.replace(tmp, path)
            else:
                # a hard link fails if ``path`` appeared meanwhile (the check above is not atomic);
                # file systems without hard links fall back to the rename
                try:
                    os.link(tmp, path)
                except FileExistsError:
                    raise FileExistsError(f"{str(path)!r} appeared while it was written; nothing was replaced "
                                          "(pass overwrite=True to replace it)") from None
                except OSError:
                    os.replace(tmp, path)
        except BaseException as exc:  # (the staging deletes the temporary file)
            if isinstance(exc, OSError) and not isinstance(exc, FileExistsError):
                raise_write_failed(path, exc, tmp)
            raise
    sync_folder(path.parent)
    return path


@contextlib.contextmanager
def interrupts_held():
    """Hold Ctrl-C (SIGINT) back while the block runs, then deliver it: renames that must all
    happen or none are not cut between a step and the record of it. Only the main thread receives
    SIGINT, so elsewhere (and where another handler than Python's is set) the block runs as it is."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        yield
        return
    held = []
    signal.signal(signal.SIGINT, lambda signum, frame: held.append(signum))
    try:
        yield
    except BaseException as exc:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        if held and not isinstance(exc, KeyboardInterrupt):
            raise KeyboardInterrupt from exc  # (the Ctrl-C is not lost to the block's own error)
        raise
    signal.signal(signal.SIGINT, signal.default_int_handler)
    if held:
        raise KeyboardInterrupt


def raise_write_failed(path, exc: OSError, tmp=None) -> NoReturn:
    """Raise ``exc``, caught while ``path`` was staged in the temporary file ``tmp`` beside it
    (None: while that file was made), as an error of the same kind (``errno``) that names
    ``path``: the temporary file is gone, and its hidden name would only puzzle (the original
    stays as the cause). An error about another file (one the writer reads, say) is raised as it is."""
    if exc.filename is not None and tmp is not None and str(exc.filename) != str(tmp):
        raise exc
    why = exc.strerror or str(exc)
    message = f"could not write {str(path)!r}: {why}"
    raise (OSError(exc.errno, message) if exc.errno is not None else OSError(message)) from exc


def sync_to_disk(path) -> None:
    """Flush the file at ``path`` to the disk before it is renamed over an older one: after a crash
    the name then holds the old content or the new, never a file the system had not yet written."""
    fd = os.open(path, os.O_RDWR if os.name == "nt" else os.O_RDONLY)  # (Windows flushes writable files only)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def final_mode(path) -> int:
    """Permissions a file written to ``path`` ends with: those of the regular file it replaces
    (or that a link there leads to), without set-id or sticky bits; else (nothing there, a device,
    a pipe, a socket, a folder) what a plain ``open()`` gives a new file."""
    import stat

    try:
        st = os.stat(path)
    except OSError:  # nothing there yet (or nothing readable)
        st = None
    if st is not None and stat.S_ISREG(st.st_mode):
        return st.st_mode & 0o777
    return 0o666 & ~_umask()  # (a device's mode, /dev/null's 0o666 say, says nothing of a file's)


def _png_filtered(rows: np.ndarray, bpp: int) -> np.ndarray:
    """PNG scanlines of the (H, N) uint8 ``rows``: each row's filter type byte, then its filtered bytes.

    Every row takes the one of the five filters (none, sub, up, average, Paeth; ``bpp`` bytes per
    pixel) whose bytes, read as signed, sum to the least magnitude: the heuristic of the PNG
    specification, which lets zlib find the runs of a smooth image. A band of rows at a time.
    """
    h, n = rows.shape
    out = np.empty((h, n + 1), np.uint8)
    band = max(1, (1 << 18) // n)  # rows per band: a few MB of candidates
    above = np.zeros(n, np.uint8)
    for r0 in range(0, h, band):
        x = rows[r0:r0 + band]
        m = len(x)
        up = np.empty_like(x)
        up[0], up[1:] = above, x[:-1]
        left = np.zeros_like(x)
        left[:, bpp:] = x[:, :-bpp]
        corner = np.zeros_like(x)
        corner[:, bpp:] = up[:, :-bpp]
        # Paeth's predictor: the one of left, up and corner nearest left + up - corner (ties in that order)
        a, b, c = left.astype(np.int16), up.astype(np.int16), corner.astype(np.int16)
        pa, pb, pc = np.abs(b - c), np.abs(a - c), np.abs(a + b - 2 * c)
        paeth = np.where((pa <= pb) & (pa <= pc), left, np.where(pb <= pc, up, corner))
        average = (left >> 1) + (up >> 1) + (left & up & 1)  # floor((left + up) / 2) without overflow
        cands = np.stack([x, x - left, x - up, x - average, x - paeth])  # uint8: differences modulo 256
        choice = np.minimum(cands, 0 - cands).sum(axis=2, dtype=np.uint32).argmin(axis=0)
        out[r0:r0 + m, 0] = choice
        out[r0:r0 + m, 1:] = cands[choice, np.arange(m)]
        above = x[-1]
    return out


_PNG_LEVEL = 3  # zlib's level for 16-bit colour: near level 6's size on filtered rows, in less time (BENCHMARKS.md)


def _png16_rgb(path, rgb: np.ndarray, *, level: int = _PNG_LEVEL, filtered: bool = True) -> None:
    """Write an (H, W, 3|4) uint16 image as a 16-bit PNG (Pillow cannot write 16-bit colour).

    ``level``: zlib's compression level; ``filtered``: False writes every row unfiltered (filter
    type 0; for comparisons)."""
    import struct
    import zlib

    h, w, c = rgb.shape
    rows = np.ascontiguousarray(rgb.astype(">u2")).view(np.uint8).reshape(h, w * c * 2)
    if filtered:
        raw = _png_filtered(rows, bpp=2 * c)
    else:
        raw = np.concatenate([np.zeros((h, 1), np.uint8), rows], axis=1)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", w, h, 16, 2 if c == 3 else 6, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw.tobytes(), level))
                + chunk(b"IEND", b""))


def save_png(path, image: np.ndarray, *, bits: int = 8, overwrite: bool = False) -> Path:
    """Save a grey (H, W) or colour (H, W, 3|4) image as an 8- or 16-bit PNG.

    Grey images and 8-bit colour go through Pillow; 16-bit colour is encoded here
    (Pillow has no 16-bit RGB mode), each row with the PNG filter that suits it.
    The write is atomic.

    Args:
        path: output ``.png`` file; its folder must exist.
        image: ``(H, W)`` grey or ``(H, W, 3|4)`` RGB(A) array, row 0 at the top. uint8 and
            uint16 images are levels of their dtype's range (0-255, 0-65535), kept as they are at
            their own depth and rescaled (rounded) to the other. Floats are values in [0, 1],
            clipped to it (light that saturates; a UserWarning when most of them lie above 1, as
            0-255 levels do); bool and other integer arrays must hold 0 and 1 only.
        bits: 8 or 16 bits per channel.
        overwrite: replace an existing file.

    Raises:
        ValueError: a ``path`` not ending in ``.png`` (any case), an empty image, a bad shape, NaN
            or inf values, values outside [0, 1] in an integer image other than uint8 and uint16
            (0-255 levels as int64, say), ``bits`` not 8 or 16, a missing folder, a ``path`` that
            is a folder.
        TypeError: an image that is not numbers (bool images are fine), ``bits`` not an int.
        FileExistsError: ``path`` exists and ``overwrite`` is False.
        OSError: the system refused the write (a full disk, say); it names ``path``, and no file is left.
    """
    from PIL import Image

    _target(path, overwrite)  # (a folder is named as one, whatever its suffix)
    _format(path, None, ("png",), "image")  # (PNG data under another name misleads what opens it)
    img = _checks.finite_array("image", image, "(H, W), (H, W, 3) or (H, W, 4)",
                               lambda s: len(s) == 2 or (len(s) == 3 and s[2] in (3, 4)), kinds="biuf", dtype=None)
    if _checks.integer("bits", bits) not in (8, 16):
        raise ValueError(f"Expected 'bits' in (8, 16), but got {bits!r}")
    levels = img.dtype.kind == "u" and img.dtype.itemsize in (1, 2)
    if img.dtype.kind in "iu" and not levels and (img.min() < 0 or img.max() > 1):
        # float values beyond [0, 1] are clipped (light that saturates); integer ones are levels
        raise ValueError(f"Expected 'image' values in [0, 1], but this {img.dtype} image spans [{img.min()}, "
                         f"{img.max()}]; pass 8-bit levels as uint8 (16-bit as uint16), or divide them by 255 "
                         "(65535) first")
    if img.dtype.kind == "f" and np.count_nonzero(img > 1) > img.size // 2:
        warnings.warn(f"'image' has most of its values above 1 (up to {float(img.max()):.6g}); floats are clipped to "
                      "[0, 1], so it saves mostly white: divide 8-bit levels by 255 first", UserWarning, stacklevel=2)
    data = _levels(img, bits) if levels else _quantized(img, bits)
    if bits == 16 and img.ndim == 3:
        return atomic_write(path, lambda tmp: _png16_rgb(tmp, data), overwrite=overwrite)
    pil = Image.fromarray(data)
    return atomic_write(path, lambda tmp: pil.save(tmp, format="PNG"), overwrite=overwrite)


def _levels(img: np.ndarray, bits: int) -> np.ndarray:
    """uint8 / uint16 levels at ``bits`` per sample: the same levels at their own depth, else
    ``round(x * (2^bits - 1) / (2^depth - 1))`` (exact in integers: 257 = 65535 / 255)."""
    img = img.astype(img.dtype.newbyteorder("="), copy=False)  # (Pillow takes native byte order)
    if img.dtype == (np.uint8 if bits == 8 else np.uint16):
        return img
    if bits == 16:
        return img.astype(np.uint16) * np.uint16(257)
    return ((img.astype(np.uint32) + 128) // 257).astype(np.uint8)  # (x / 257 is never halfway: 257 is odd)


def _quantized(img: np.ndarray, bits: int, *, lo: float = 0.0, hi: float = 1.0) -> np.ndarray:
    """``round(clip((img - lo) / (hi - lo), 0, 1) * (2^bits - 1))`` as uint8 / uint16 (when
    ``hi <= lo``, a constant field's range: 0, and the top level above ``lo``), computed in
    float64 a band of rows at a time (a whole-image float64 copy of a large picture costs
    seconds in page faults)."""
    top = 255 if bits == 8 else 65535
    half = not np.isfinite(hi - lo)  # a span float64 cannot hold: halve everything first
    lo, hi = (lo / 2.0, hi / 2.0) if half else (lo, hi)
    span = hi - lo if hi > lo else math.inf
    out = np.empty(img.shape, np.uint8 if bits == 8 else np.uint16)
    rows = max(1, (1 << 20) // max(1, img[0].size))  # about 8 MB of float64 per band
    for r in range(0, img.shape[0], rows):
        band = img[r:r + rows].astype(np.float64)
        if half:
            band /= 2.0
        if lo != 0.0 or span != 1.0:
            band = (band - lo) / span if span != math.inf else np.where(band > lo, 1.0, 0.0)
        out[r:r + rows] = np.clip(band, 0.0, 1.0) * top + 0.5
    return out


MESH_FORMATS = ("obj", "ply", "stl", "glb")
"""Mesh file formats :func:`save_mesh` writes (through trimesh)."""
DENDRITE_FORMATS = ("npz", "json")
"""Dendrite graph formats :func:`save_dendrite` writes."""


def _format(path, format, allowed: tuple[str, ...], what: str) -> str:
    fmt = Path(path).suffix.lower().lstrip(".") if format is None else str(format).lower().lstrip(".")
    if fmt not in allowed:
        source = f"'format' {format!r}" if format is not None else f"the suffix of 'path' {str(path)!r}"
        raise ValueError(f"Unknown {what} format from {source}; allowed formats: {', '.join(allowed)}")
    return fmt


def save_mesh(path, mesh, *, format: str | None = None, overwrite: bool = False) -> Path:
    """Write a :class:`trimesh.Trimesh` as OBJ, PLY, STL or GLB (atomically).

    Meshes are ``z``-up (lattice axis 0). OBJ, PLY and STL keep their
    coordinates; GLB follows glTF 2.0, which is ``y``-up, so it holds
    ``(x, z, -y)``: a tree stands upright in glTF viewers.

    Args:
        path: output file; its folder must exist.
        mesh: the mesh.
        format: one of :data:`MESH_FORMATS` (default: from the suffix of ``path``).
        overwrite: replace an existing file.

    Raises:
        ValueError: an unknown format (the message lists the allowed ones), a mesh without faces,
            with NaN/inf vertices or vertices too large for float32, faces that are not ``(F, 3)``
            or index no vertex, a missing folder, a ``path`` that is a folder.
        TypeError: ``mesh`` is not a mesh, faces that are not integers.
        FileExistsError: ``path`` exists and ``overwrite`` is False.
    """
    fmt = _format(path, format, MESH_FORMATS, "mesh")
    _target(path, overwrite)
    if not all(hasattr(mesh, a) for a in ("export", "vertices", "faces")):
        raise TypeError(f"Expected a trimesh.Trimesh for 'mesh', but got {type(mesh).__name__}")
    if not len(mesh.faces):
        raise ValueError("Expected a trimesh.Trimesh with at least one face for 'mesh', but it has none")
    verts = _checks.finite_array("mesh.vertices", mesh.vertices, "(V, 3)", lambda s: len(s) == 2 and s[1] == 3)
    _checks.face_indices("mesh.faces", mesh.faces, len(verts))
    if fmt == "glb":
        mesh = mesh.copy()
        mesh.apply_transform(_Z_UP_TO_Y_UP)
    return atomic_write(path, lambda tmp: mesh.export(tmp, file_type=fmt), overwrite=overwrite)


# (x, y, z) -> (x, z, -y): a rotation by -90 degrees about x, keeping the faces' orientation
_Z_UP_TO_Y_UP = np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]])


def _widths_for(dendrite, width) -> np.ndarray:
    from .render import node_widths

    return np.ones(len(dendrite), np.float32) if width is None else node_widths(dendrite, width)


def save_dendrite(path, dendrite, *, width=None, format: str | None = None, overwrite: bool = False) -> Path:
    """Write a dendrite graph as NPZ or JSON (atomically).

    The file holds ``shape``, ``nodes`` (N, ndim), ``parent`` (N,), ``cost``,
    ``label``, ``generation``, ``endpoints``, ``origin``, ``spacing`` and
    ``width`` (N,): the node widths from ``width`` (a constant, a
    :class:`~wdendrite.render.Taper` or an array; default 1).

    Args:
        path: output file; its folder must exist.
        dendrite: a non-empty :class:`~wdendrite.Dendrite` (2D or 3D).
        width: node widths as in :func:`wdendrite.render.node_widths` (default: 1 everywhere).
        format: ``"npz"`` or ``"json"`` (default: from the suffix of ``path``).
        overwrite: replace an existing file.

    Raises:
        ValueError: unknown format (allowed: npz, json), an empty dendrite, a missing folder,
            a ``path`` that is a folder.
        FileExistsError: ``path`` exists and ``overwrite`` is False.
    """
    from .dendrite import Dendrite

    fmt = _format(path, format, DENDRITE_FORMATS, "dendrite")
    _target(path, overwrite)
    if not isinstance(dendrite, Dendrite):
        raise TypeError(f"Expected a wdendrite.Dendrite for 'dendrite', but got {type(dendrite).__name__}")
    if not len(dendrite):
        raise ValueError("'dendrite' is empty (no nodes): there is nothing to save")
    data = {
        "shape": np.asarray(dendrite.shape, np.int64),
        "nodes": dendrite.nodes.astype(np.int64),
        "parent": dendrite.parent.astype(np.int64),
        "cost": dendrite.cost.astype(np.float32),
        "label": dendrite.label.astype(np.int32),
        "generation": dendrite.generation.astype(np.int32),
        "endpoints": dendrite.endpoints.astype(np.int64),
        "origin": np.asarray(dendrite.origin, np.float64),
        "spacing": np.float64(dendrite.spacing),
        "width": _widths_for(dendrite, width).astype(np.float32),
    }

    def write(tmp):
        if fmt == "npz":
            with open(tmp, "wb") as f:
                np.savez_compressed(f, **data)
        else:
            with open(tmp, "w") as f:
                json.dump({k: np.asarray(v).tolist() for k, v in data.items()}, f)

    return atomic_write(path, write, overwrite=overwrite)


_DENDRITE_KEYS = ("shape", "nodes", "parent", "cost", "label", "generation", "endpoints", "origin", "spacing",
                  "width")


def _read_arrays(path: Path, fmt: str) -> dict:
    """The named arrays of an existing dendrite file; ``ValueError`` naming the file when they cannot be read."""
    def refuse(why: str) -> ValueError:
        return ValueError(f"'path' {str(path)!r} is not a dendrite file: {why}")

    # np.load reads anything that does not start like a zip archive as a pickle, and refuses it
    # with advice on pickles: check both ends (is_zipfile reads the end)
    if fmt == "npz":
        with open(path, "rb") as f:
            head = f.read(4)
        if head != b"PK\x03\x04" or not zipfile.is_zipfile(path):
            raise refuse("it is not an .npz (zip) archive")
    try:
        if fmt == "npz":
            with np.load(path, allow_pickle=False) as z:
                return {k: z[k] for k in z.files}
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
        if isinstance(data, dict):
            return {k: np.asarray(v) for k, v in data.items()}
    except (PermissionError, IsADirectoryError, FileNotFoundError):
        raise  # the file system's answer, not the file's content
    except RecursionError:  # JSON nested deeper than the parser goes (before RuntimeError, its base)
        raise refuse("its JSON is nested too deeply") from None
    # ValueError: JSON, text, ragged lists; RuntimeError, NotImplementedError, OSError: damaged
    # zip headers (a member flagged encrypted, an unknown compression method, a bad offset)
    except (ValueError, EOFError, zipfile.BadZipFile, zlib.error, RuntimeError, NotImplementedError, OSError) as err:
        raise refuse(f"{type(err).__name__}: {err}") from None
    raise refuse(f"expected a JSON object, but it holds a {type(data).__name__}")


def load_dendrite(path, *, format: str | None = None):
    """Read a file written by :func:`save_dendrite`.

    Args:
        path: the file.
        format: ``"npz"`` or ``"json"``; None takes it from the suffix (give it for a file
            saved under another suffix with ``save_dendrite(..., format=...)``).

    Returns:
        ``(dendrite, width)``: the :class:`~wdendrite.Dendrite` and its ``(N,)`` float32 widths.

    Raises:
        ValueError: an unknown suffix, or a file that is not a dendrite file (unreadable,
            missing arrays, arrays that do not make a dendrite, integers beyond int64, widths
            that are not positive); the message names the file.
        FileNotFoundError: ``path`` does not exist.
    """
    from .dendrite import Dendrite

    path = Path(path)
    fmt = _format(path, format, DENDRITE_FORMATS, "dendrite")
    if not path.exists():
        raise FileNotFoundError(f"'path' {str(path)!r} does not exist")
    if path.is_dir():
        raise ValueError(f"'path' {str(path)!r} is a folder, not a dendrite file")
    raw = _read_arrays(path, fmt)
    missing = [k for k in _DENDRITE_KEYS if k not in raw]
    if missing:
        raise ValueError(f"'path' {str(path)!r} is not a dendrite file: missing {', '.join(map(repr, missing))}")
    try:
        den = Dendrite.from_arrays(
            tuple(_checks.integer_array("shape", raw["shape"], "sizes").reshape(-1).tolist()),
            raw["nodes"],
            raw["parent"],
            cost=raw["cost"],
            label=raw["label"],
            generation=raw["generation"],
            endpoints=raw["endpoints"],
            origin=np.asarray(raw["origin"]).reshape(-1),
            spacing=raw["spacing"].item() if np.ndim(raw["spacing"]) == 0 else raw["spacing"],
        )
        width = _checks.finite_array("width", raw["width"], "1D (N,)", lambda s: len(s) == 1).reshape(-1)
        if (width <= 0).any():  # (save_dendrite writes node_widths, which are > 0)
            raise ValueError(f"'width' must be positive, but its minimum is {width.min()}")
    except (TypeError, ValueError) as err:
        raise ValueError(f"'path' {str(path)!r} is not a dendrite file: {err}") from None
    if width.shape != (len(den),):
        raise ValueError(f"'path' {str(path)!r} holds {len(width)} widths for {len(den)} nodes")
    return den, width


def svg_polylines(dendrite, *, width=1.0, side=None) -> list[tuple[np.ndarray, float]]:
    """The branches of a 2D dendrite as ``(points (P, 2) as (x, y), stroke width)`` pairs.

    Each branch (see :func:`wdendrite.render.branch_order`) runs from where it
    leaves its parent branch to its tip; its stroke is twice its mean width. A node
    alone (a root no path reached) is its point twice, a zero-length polyline that
    round caps draw as a dot of its width.

    Args:
        dendrite: a non-empty 2D dendrite.
        width, side: node widths and the optional side-branch width, as in
            :func:`wdendrite.render.node_widths`, in world units.
    """
    from .render import branch_order, node_widths

    br = branch_order(dendrite)
    w = node_widths(dendrite, width, side=side)
    pos = dendrite.positions[:, ::-1]
    out = []
    rows = dendrite.order  # roots first, so every branch lists its nodes from its start to its tip
    rows = rows[np.argsort(br.start[rows], kind="stable")]
    cuts = np.flatnonzero(np.diff(br.start[rows])) + 1
    for chain in np.split(rows, cuts):
        s = chain[0]
        if dendrite.parent[s] >= 0:
            chain = np.concatenate([[dendrite.parent[s]], chain])
        if len(chain) == 1:
            chain = np.concatenate([chain, chain])
        out.append((pos[chain], 2.0 * float(w[chain].mean())))
    return out


_SVG_COLOUR = re.compile(r"[#A-Za-z0-9(),.%+/ -]+")


def _svg_colour(name: str, value) -> None:
    """An SVG paint (a name, ``#rgb``, ``rgb(...)``, ...): nothing that could end its attribute."""
    if not isinstance(value, str):
        raise TypeError(f"Expected an SVG colour string for '{name}', but got {type(value).__name__}")
    if not value.strip() or not _SVG_COLOUR.fullmatch(value):
        raise ValueError(f"Expected an SVG colour for '{name}' (a name such as 'black', '#1a2b3c' or "
                         f"'rgb(10, 20, 30)'), but got {value!r}")


def save_svg(path, dendrite, *, width=1.0, side=None, color: str = "black", background: str | None = "white",
             overwrite: bool = False) -> Path:
    """Write a 2D dendrite as SVG polylines, one per branch, in world units (its
    ``positions``: lattice nodes for a traced dendrite, ``spacing`` apart for a refined one).

    Args:
        path: output ``.svg`` file; its folder must exist.
        dendrite: a non-empty 2D dendrite.
        width: node widths as in :func:`wdendrite.render.node_widths` (stroke = 2 x mean width of a
            branch), in the same world units: scale pixel widths by the dendrite's ``spacing``.
        side: optional side-branch width.
        color: stroke colour: an SVG colour name, ``#rgb``/``#rrggbb`` or a function such as
            ``rgb(10, 20, 30)``.
        background: fill of a background rectangle, or None for none.
        overwrite: replace an existing file.

    Raises:
        ValueError: a ``path`` not ending in ``.svg`` (any case), a 3D or empty dendrite, a colour
            holding characters that cannot appear in an SVG paint value (the name itself is not
            checked: viewers skip strokes of an unknown colour), a missing folder, a ``path`` that
            is a folder.
        TypeError: a colour that is not a string.
        FileExistsError: ``path`` exists and ``overwrite`` is False.
    """
    from .dendrite import Dendrite

    _target(path, overwrite)  # (a folder is named as one, whatever its suffix)
    _format(path, None, ("svg",), "drawing")
    if not isinstance(dendrite, Dendrite):
        raise TypeError(f"Expected a wdendrite.Dendrite for 'dendrite', but got {type(dendrite).__name__}")
    _svg_colour("color", color)
    if background is not None:
        _svg_colour("background", background)
    if not len(dendrite):
        raise ValueError("'dendrite' is empty (no nodes): there is nothing to draw")
    if dendrite.ndim != 2:
        raise ValueError(f"SVG export needs a 2D dendrite, but the dendrite has shape {tuple(dendrite.shape)}; "
                         "use save_mesh for 3D geometry")
    h, w = (np.asarray(dendrite.shape) * float(dendrite.spacing)).tolist()
    ox, oy = float(dendrite.origin[1]), float(dendrite.origin[0])
    lines = [f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="{ox:g} {oy:g} {w:g} {h:g}" '
             f'width="{w:g}" height="{h:g}">']
    if background is not None:
        lines.append(f'<rect x="{ox:g}" y="{oy:g}" width="{w:g}" height="{h:g}" fill="{background}"/>')
    for pts, stroke in svg_polylines(dendrite, width=width, side=side):
        coords = " ".join(f"{x:g},{y:g}" for x, y in pts)
        lines.append(f'<polyline points="{coords}" fill="none" stroke="{color}" stroke-width="{stroke:.3g}" '
                     'stroke-linecap="round" stroke-linejoin="round"/>')
    lines.append("</svg>")
    text = "\n".join(lines) + "\n"

    def write(tmp):
        with open(tmp, "w") as f:
            f.write(text)

    return atomic_write(path, write, overwrite=overwrite)
