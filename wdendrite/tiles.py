"""Images written tile by tile into NPY files, raw heightmaps and Zarr groups, never whole in
memory, resumably.

:func:`write_tiled` computes an image one ``tile`` x ``tile`` window at a time (here, or as
one Dask task per tile whose worker writes it) straight into its outputs: an NPY file, or a
raw 16-bit heightmap (``.r16``/``.raw``, each tile scaled to one range given in advance, see
:mod:`wdendrite.heightmaps`), whose space is allocated before the first tile, written with
ordinary writes (a full disk is an error, never a signal), or a Zarr group
(:func:`new_zarr_group`) that xarray opens with its coordinates. Each output is first a hidden partial file beside it (``.NAME.partial.SUFFIX``)
with a folder of tile records (``.NAME.tiles.SUFFIX``: the image's identity, one marker per
finished tile and, once every tile is in, the identity of every output of the run), so that
a run killed at any step resumes with the tiles it lacks, renames what it had finished, or
recognises outputs it had renamed into place as its own. The outputs are locked while a run
writes them (:func:`wdendrite._staging.locked`).
"""

from __future__ import annotations

import itertools
import json
import os
from pathlib import Path

import numpy as np

from ._staging import _remove, identity

__all__ = ["new_zarr_group", "placed_by_killed_run", "probe_windows", "tile_key", "tile_windows", "tiled_array",
           "write_tiled"]


def _tiling(shape, tile) -> tuple[tuple[int, int], int]:
    """``shape`` as (H, W) positive ints and ``tile`` as a positive int, or an error naming them."""
    from ._checks import integer, lattice_shape

    # (tiles are what lets an image exceed 2**31 pixels: only each size must fit an int32)
    return lattice_shape(shape, ranks=(2,), whole=False), integer("tile", tile, low=1)


def tile_windows(shape, tile: int) -> list[tuple[int, int, int, int]]:
    """``(row0, col0, h, w)`` of the tiles covering an (H, W) image, row by row; edge tiles are smaller."""
    (h, w), tile = _tiling(shape, tile)
    return [(r, c, min(tile, h - r), min(tile, w - c)) for r in range(0, h, tile) for c in range(0, w, tile)]


def _block(tile_fn, block_info=None):
    (r0, r1), (c0, c1) = block_info[None]["array-location"]
    return np.asarray(tile_fn((r0, c0, r1 - r0, c1 - c0)), np.float32)


def tiled_array(tile_fn, shape, tile: int):
    """A lazy Dask array of ``shape`` whose ``tile`` x ``tile`` blocks are ``tile_fn((row0, col0, h, w))``.

    ``tile_fn`` must return the (h, w) values of that window of the whole image and be
    picklable when the array is computed on a cluster.
    """
    import dask.array as da

    shape, tile = _tiling(shape, tile)
    chunks = tuple(tuple(min(tile, n - s) for s in range(0, n, tile)) for n in shape)
    return da.map_blocks(_block, tile_fn, chunks=chunks, dtype=np.float32, meta=np.empty((0, 0), np.float32))


RAW = (".r16", ".raw")
"""Suffixes of raw 16-bit heightmaps, which tiles fill as levels of a range given in advance."""


class _Target:
    """Where finished tiles go: an NPY file or a raw heightmap (written in place with ordinary
    writes, so that a full disk is an error and never a signal) or a Zarr array, plus one marker
    file per finished tile so an interrupted run knows what is left. ``array``: the image's name
    in a Zarr group; ``width``, ``levels``: a raw heightmap's width and ``(lo, hi)``."""

    def __init__(self, path: Path, marks: Path, array: str, width: int, levels=None):
        self.path, self.marks, self.array, self.levels = str(path), str(marks), array, levels
        self.suffix = Path(self.path).suffix.lower()
        if self.suffix == ".npy":
            self.offset, self.width = _npy_layout(path)
        elif self.suffix in RAW:
            self.offset, self.width = 0, width

    def mark(self, window) -> Path:
        return Path(self.marks) / ("%d_%d" % tuple(window[:2]))

    def write(self, window, values) -> None:
        r0, c0, h, w = window
        if self.suffix == ".zarr":
            import zarr

            arr = zarr.open_array(self.path, path=self.array, mode="r+")
            arr[r0:r0 + h, c0:c0 + w] = values
        else:
            from ._staging import write_at

            if self.suffix in RAW:
                from .heightmaps import _levels

                rows = np.ascontiguousarray(_levels(values, *self.levels), "<u2").reshape(h, w)
            else:
                rows = np.ascontiguousarray(values, "<f4").reshape(h, w)
            size = rows.itemsize
            offset, stride = self.offset + size * (r0 * self.width + c0), size * self.width
            if w == self.width:  # whole rows: one piece of the file
                rows, stride = rows.reshape(1, -1), 0
            fd = os.open(self.path, os.O_WRONLY)
            try:
                for row in rows:
                    # (a row written in part, as a full disk may leave it, is written again whole)
                    if not hasattr(os, "pwrite") or os.pwrite(fd, row, offset) != row.nbytes:
                        write_at(fd, row, offset)
                    offset += stride
                getattr(os, "fdatasync", os.fsync)(fd)  # (the tile is on the disk before its marker)
            finally:
                os.close(fd)
        self.mark(window).touch()


def _npy_header(shape) -> bytes:
    """The header of an NPY file of a float32 image of ``shape`` (little-endian, rows first)."""
    import io

    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f4", "fortran_order": False, "shape": tuple(shape)})
    return buf.getvalue()


def _npy_layout(path) -> tuple[int, int]:
    """``(offset of the data, image width)`` of a float32 NPY image that :func:`_open_partial` made."""
    with open(path, "rb") as f:
        major, _ = np.lib.format.read_magic(f)
        read = np.lib.format.read_array_header_1_0 if major == 1 else np.lib.format.read_array_header_2_0
        shape, fortran, dtype = read(f)
        if dtype != np.dtype("<f4") or fortran or len(shape) != 2:
            raise ValueError(f"{str(path)!r} is not a partial tiled image (a {dtype} array of shape {shape})")
        return f.tell(), shape[1]


def _tile_into(window, tile_fn, targets) -> tuple:
    """Compute one tile and write it into every target that lacks it; return its window."""
    values = np.asarray(tile_fn(window), np.float32)
    for target in targets:
        if not target.mark(window).exists():
            target.write(window, values)
    return window


def _tiles_here(todo: list, tile_fn, targets, workers: int):
    """:func:`_tile_into` of each window of ``todo``, in order, the tiles computed by ``workers``
    threads a few tiles ahead while this thread writes them one after another; yields each window
    once written. A failing tile stops the writes there (tiles after it are not written); leaving
    early cancels the tiles not started and waits for those running."""
    if workers <= 1:
        yield from (_tile_into(w, tile_fn, targets) for w in todo)
        return
    from collections import deque
    from concurrent.futures import ThreadPoolExecutor

    pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="wdendrite-tile")
    ahead, windows = deque(), iter(todo)
    try:
        for w in itertools.islice(windows, 2 * workers):  # (a few tiles in memory, not the image)
            ahead.append((w, pool.submit(tile_fn, w)))
        while ahead:
            w, computed = ahead.popleft()
            values = computed.result()
            following = next(windows, None)
            if following is not None:
                ahead.append((following, pool.submit(tile_fn, following)))
            yield _tile_into(w, lambda _: values, targets)
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _tile_records(final: Path) -> list[Path]:
    """The hidden partial file and tile records of a tiled output (see :func:`_open_partial`)."""
    return [final.with_name(f".{final.stem}.{what}{final.suffix}") for what in ("partial", "tiles")]


def tile_key(params: dict, kind: str, value_range=None) -> str:
    """What tells one tiled image from another in its tile records: the preset's full
    parameters, the kind of device (``cpu`` or ``cuda``) its tiles were computed on and the
    range of its raw heightmaps' levels, if any."""
    return json.dumps({"params": params, "device": kind, **({"range": list(value_range)} if value_range else {})},
                      sort_keys=True)


def _image_ident(key: str, shape, tile: int, name: str, levels=None) -> str:
    """The image a folder of tile records holds tiles of (its ``image.json``; ``name``: its array's in a
    Zarr group; ``levels``: the range of raw heightmaps' levels, if any)."""
    return json.dumps({"key": key, "shape": list(shape), "tile": tile, "array": name,
                       **({"levels": list(levels)} if levels is not None else {})}, sort_keys=True)


def _whole_image(marks: Path) -> dict | None:
    """What a folder of tile records says of the whole image a run renamed into place (its
    ``whole`` file: the file's identity, the image's, and ``set``, the identities of every output
    of that run by absolute path), or None."""
    try:
        whole = json.loads((marks / "whole").read_text())
    except (OSError, ValueError):
        return None
    return whole if isinstance(whole, dict) and isinstance(whole.get("image"), str) else None


def _renamed_by_killed_run(final: Path, same_image, outputs=()) -> bool:
    """Whether the file at ``final`` is a whole image that a run killed before the end of its
    clean-up renamed there, untouched since: so say its own records, or those of another of
    ``outputs`` written by that run (each output's records leave in one rename, one after
    another). ``same_image(ident)`` tells whether a record's image is the one wanted."""
    if not os.path.lexists(final):
        return False
    now, where = identity(final), os.path.abspath(final)
    for other in dict.fromkeys([Path(final), *map(Path, outputs)]):
        whole = _whole_image(_tile_records(other)[1])
        if whole is None or not same_image(whole["image"]):
            continue
        listed = whole.get("set") if isinstance(whole.get("set"), dict) else {}
        if (other == Path(final) and whole.get("file") == now) or listed.get(where) == now:
            return True
    return False


def placed_by_killed_run(final: Path, key: str, outputs=()) -> bool:
    """Whether the file at ``final`` is the whole image of tile key ``key`` that a run of the
    ``outputs`` (``final`` among them) killed before the end of its clean-up renamed there, untouched
    since: a re-run of that run may take it (:func:`write_tiled` then keeps it) rather than refuse it
    as a file of the user's."""
    def same_key(image: str) -> bool:
        try:
            return json.loads(image).get("key") == key
        except (ValueError, AttributeError):
            return False

    return _renamed_by_killed_run(final, same_key, outputs)


def _partial_state(final: Path, ident: str, outputs=()) -> str:
    """What the records beside ``final`` (or, for an image already renamed, those of the other
    ``outputs`` of its run) hold of the image ``ident`` (:func:`_image_ident`): ``"placed"`` (the
    whole image, renamed to ``final`` by a run killed before it had cleared every output's
    records), ``"resume"`` (a partial file with some of its tiles) or ``"new"`` (nothing of it)."""
    partial, marks = _tile_records(final)
    if not os.path.lexists(partial) and _renamed_by_killed_run(final, lambda image: image == ident, outputs):
        return "placed"
    try:
        same = (marks / "image.json").read_text() == ident
    except OSError:
        same = False
    return "resume" if partial.exists() and same else "new"


def _npy_bytes(shape) -> int:
    """The size of the NPY file of a float32 image of ``shape``, in bytes."""
    return len(_npy_header(shape)) + 4 * shape[0] * shape[1]


def _file_bytes(final: Path, shape) -> int | None:
    """The size of the file a tiled output ``final`` becomes, in bytes (None: a Zarr store, sized by its chunks)."""
    suffix = final.suffix.lower()
    return _npy_bytes(shape) if suffix == ".npy" else 2 * shape[0] * shape[1] if suffix in RAW else None


def _open_partial(final: Path, shape, tile: int, ident: str, state: str, described: tuple) -> tuple[Path, Path, bool]:
    """The partial file and the folder of tile markers beside ``final``, made afresh when ``state``
    (:func:`_partial_state`) is ``"new"`` (an NPY file with its whole size allocated on the disk:
    a full disk fails here, and the file is deleted; a Zarr group as :func:`new_zarr_group` makes
    it of ``described``, ``(name, attrs, domain)``; a raw heightmap with its size allocated as an
    NPY file's); and whether the image is ``"placed"``."""
    # ".{stem}.partial{suffix}" keeps the suffix that names the format
    partial, marks = _tile_records(final)
    if state == "new":
        _remove(marks)
        _remove(partial)
        if final.suffix.lower() == ".zarr":
            name, attrs, domain = described
            new_zarr_group(partial, shape, tile, name=name, attrs=attrs, domain=domain)
        else:
            from ._staging import reserve, write_at

            fd = os.open(partial, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o666)
            try:
                reserve(fd, _file_bytes(final, shape), final)  # (first: a full disk fails here, naming the file)
                if final.suffix.lower() == ".npy":
                    write_at(fd, _npy_header(shape), 0)
            except BaseException:
                os.close(fd)
                partial.unlink(missing_ok=True)
                raise
            os.close(fd)
        marks.mkdir()
        (marks / "image.json").write_text(ident)
    return partial, marks, state == "placed"


def new_zarr_group(path, shape, tile: int, *, name: str = "field", attrs: dict | None = None, domain=None,
                   _zarr_format: int | None = None):
    """Make a Zarr group at ``path`` that xarray opens as a dataset with coordinates.

    It holds the float32 array ``name`` of ``shape`` (H, W), empty, in ``tile`` x ``tile`` chunks
    (one per tile, none larger than the image: workers writing different tiles never touch the
    same chunk), with dimensions ``("y", "x")``; with ``domain`` ``((x0, y0), (x1, y1))`` also the
    float64 pixel centres ``y`` (H,) and ``x`` (W,) (row 0 at y0, as :func:`wdendrite.dendry`
    places them); ``attrs`` (JSON-ready) as the group's attributes; and consolidated metadata, so
    ``xarray.open_zarr`` reads the whole layout at once. Dimension names are the Zarr v3 arrays'
    ``dimension_names``, or in a Zarr v2 store xarray's ``_ARRAY_DIMENSIONS`` attributes.
    ``_zarr_format`` (2 or 3; default: zarr's own) is for the tests.

    Returns:
        The group.
    """
    import warnings

    import zarr

    group = zarr.open_group(str(path), mode="w", **({} if _zarr_format is None else {"zarr_format": _zarr_format}))
    _zarr_array(group, name, tuple(shape), tuple(min(tile, n) for n in shape), ("y", "x"), "f4")
    if domain is not None:
        (x0, y0), (x1, y1) = domain
        for dim, n, lo, hi in (("y", shape[0], y0, y1), ("x", shape[1], x0, x1)):
            _zarr_array(group, dim, (n,), (n,), (dim,), "f8")[:] = lo + (np.arange(n) + 0.5) * ((hi - lo) / n)
    group.attrs.update(attrs or {})
    with warnings.catch_warnings():  # (zarr 3 warns that v3 stores have no consolidated metadata in the spec yet)
        warnings.simplefilter("ignore")
        zarr.consolidate_metadata(str(path))
    return group


def _zarr_array(group, name: str, shape, chunks, dims, dtype):
    """A new array of ``group`` with dimension names ``dims`` in the form its Zarr format has, and NaN
    for the chunks not yet written (xarray reads a v2 array's fill value as missing data: the
    default, 0, would make every 0 of the field NaN)."""
    v3 = getattr(getattr(group, "metadata", None), "zarr_format", 2) >= 3
    make = getattr(group, "create_array", None) or group.create_dataset  # (zarr 3, zarr 2)
    arr = make(name, shape=shape, chunks=chunks, dtype=dtype, fill_value=np.nan,
               **({"dimension_names": dims} if v3 else {}))
    if not v3:
        arr.attrs["_ARRAY_DIMENSIONS"] = list(dims)
    return arr


def probe_windows(shape) -> list[tuple[int, int, int, int]]:
    """The one-pixel windows at the image's corners, which :func:`write_tiled` computes first to check
    the setup before it makes any file (a domain's largest coordinates lie at its corners)."""
    h, w = shape
    return sorted({(r, c, 1, 1) for r in (0, h - 1) for c in (0, w - 1)})


def write_tiled(tile_fn, shape, tile: int, path, *, client=None, progress=None, key: str = "", placed_all=None,
                name: str = "field", attrs: dict | None = None, domain=None, value_range=None,
                workers: int | None = 1):
    """Compute an image tile by tile and write it to ``path`` (``.npy``, ``.zarr``, ``.r16`` or
    ``.raw``) without holding it whole.

    ``path`` may be a list of files (say one ``.npy`` and one ``.zarr``): each tile is
    computed once and written to all of them, and they are renamed into place one after
    another once every tile is in every file. Finished tiles are recorded; calling again after an
    interruption computes only the missing ones. On a Dask ``client`` each tile is one
    task of the workers, which write it straight into the files (they must share the
    file system). Every finished file replaces its path by a rename.

    Args:
        tile_fn: ``(row0, col0, h, w) -> (h, w)`` array, the window of the whole image
            (picklable when a ``client`` computes it).
        shape: (H, W) of the whole image.
        tile: tile side in pixels.
        path: the output file, or a list of them.
        client: a ``distributed.Client`` (None: compute here, one tile after another).
        progress: a callable told ``(done, total)`` after every tile.
        key: names the image (e.g. its parameters): tiles recorded under another key are not reused.
        placed_all: called with no arguments once every file has its final name, before the
            tile records and any old stores moved aside are deleted.
        name, attrs, domain: a ``.zarr`` output is a group (:func:`new_zarr_group`) holding the
            image as the array ``name`` (dimensions ``y``, ``x``), ``attrs`` as its attributes and,
            with ``domain`` ``((x0, y0), (x1, y1))``, the pixel centres as coordinates.
        value_range: ``(lo, hi)``, needed by ``.r16``/``.raw`` outputs: every tile is written as
            16-bit levels of it (:func:`wdendrite.heightmaps.save_heightmap`'s; values outside are
            clipped). Tiles recorded under another range are not reused.
        workers: without a ``client``, threads that compute tiles at once (``tile_fn`` must then
            be safe to call from several threads) while this thread writes them in order; None:
            every core. The files do not depend on it.

    Returns:
        The written path (a list of them when ``path`` is a list).

    Raises:
        ValueError, TypeError: a bad ``shape`` or ``tile``; an empty list of paths, one path given
        twice, a path not ending in ``.npy``, ``.zarr``, ``.r16`` or ``.raw``, a ``.npy`` or raw path
        that is a folder (an existing file or Zarr store at a path is replaced: the caller decides
        whether it may be), a raw output without a ``value_range`` (or with a bad one), or of a
        shape its engine cannot take (:func:`wdendrite.heightmaps.check_raw_shape`);
        whatever ``tile_fn`` raises; computed here, it is first tried on the image's corner
        pixels (:func:`probe_windows`), so that a setup it refuses fails before the partial files
        are made.
        FileExistsError: another process is writing one of the paths (each is locked while this
        runs, see :func:`wdendrite._staging.locked`); nothing was touched.
        OSError: a ``.npy`` or raw file does not fit the free space of its disk (checked before any file
        is made, then its space is allocated before its first tile: a full disk is never met
        part way), or exceeds the largest file this process may write; the message names the
        file and the space needed. The records kept so far stay: a call after space is freed resumes.
    """
    shape, tile = _tiling(shape, tile)
    from ._parallel import workers as _workers

    workers = _workers(workers)
    finals = [Path(p) for p in path] if isinstance(path, (list, tuple)) else [Path(path)]
    if not finals or len({f.resolve() for f in finals}) != len(finals):
        raise ValueError(f"Expected one or more distinct output paths for 'path', but got {path!r}")
    raw = [f for f in finals if f.suffix.lower() in RAW]
    if raw or value_range is not None:
        from .heightmaps import check_raw_shape, value_range as checked_range

        if value_range is None:
            raise ValueError(f"'value_range' (LO, HI) is needed for the raw heightmap {str(raw[0])!r}: its levels "
                             "must be known before the first tile")
        value_range = checked_range(value_range, "'value_range'")
        for final in raw:
            check_raw_shape(shape, final.suffix.lower()[1:])
    for final in finals:
        if final.suffix.lower() not in (".npy", ".zarr", *RAW):
            raise ValueError(f"Expected '.npy', '.zarr', '.r16' or '.raw' output paths for 'path', but got "
                             f"{str(final)!r}")
        if final.suffix.lower() != ".zarr" and final.is_dir() and not final.is_symlink():
            raise ValueError(f"'path' {str(final)!r} is a folder, not a file: it would be replaced with its contents")
        if not final.parent.is_dir():  # (before the first tile is computed)
            raise ValueError(f"'path' {str(final)!r}: the folder {str(final.parent)!r} does not exist or is not "
                             "a folder")
    if client is None:
        for window in probe_windows(shape):  # a setup the tiles refuse leaves no partial file behind
            tile_fn(window)
    from ._staging import Staging, locked

    # (Dask workers write their tiles under the locks this process holds)
    with locked(finals), Staging() as stage:
        _write_locked(tile_fn, shape, tile, finals, stage, client=client, progress=progress, key=key,
                      placed_all=placed_all, described=(name, attrs, domain), levels=value_range, workers=workers)
    return finals if isinstance(path, (list, tuple)) else finals[0]


def _write_locked(tile_fn, shape, tile: int, finals: list, stage, *, client, progress, key: str, placed_all,
                  described: tuple, levels, workers: int = 1) -> None:
    """The work of :func:`write_tiled` once its outputs are locked; ``stage`` names old outputs moved aside;
    ``described``: ``(name, attrs, domain)`` of a Zarr group; ``levels``: the range of raw heightmaps."""
    from ._staging import check_space, sync_folder
    from .io import sync_to_disk

    ident = _image_ident(key, shape, tile, described[0], levels)
    states = [_partial_state(final, ident, finals) for final in finals]
    # the space is counted before any file is made (a 2000000-pixel square would be a 16 TB file)
    check_space({final: _file_bytes(final, shape) for final, state in zip(finals, states)
                 if state == "new" and _file_bytes(final, shape) is not None})
    opened = [_open_partial(final, shape, tile, ident, state, described) for final, state in zip(finals, states)]
    # (an image a killed run had renamed into place already needs no tile)
    targets = [_Target(partial, marks, described[0], shape[1], levels) for partial, marks, placed in opened
               if not placed]
    windows = tile_windows(shape, tile)
    todo = [w for w in windows if not all(t.mark(w).exists() for t in targets)]
    done = len(windows) - len(todo)
    if client is None:
        finished = _tiles_here(todo, tile_fn, targets, workers)
    else:
        from distributed import as_completed

        # one task per tile (not one graph per tile of a Dask array, whose cost grows with the tiles)
        finished = (f.result() for f in as_completed(client.map(_tile_into, todo, tile_fn=tile_fn,
                                                                targets=targets, pure=False)))
    try:
        for _ in finished:
            done += 1
            if progress:
                progress(done, len(windows))
    except OSError as exc:  # (a Zarr store meeting a full disk, say: its records stay for a re-run)
        raise _naming_output(exc, finals, opened) from exc
    for partial, _, placed in opened:
        if not placed and partial.is_file():
            sync_to_disk(partial)
    # a kill from here on leaves a whole image: a re-run renames it, or keeps it once renamed; each
    # output's records name every output of the run, so that a re-run still knows them all once the
    # records of some have gone
    whole = {os.path.abspath(final): identity(final if placed else partial)
             for final, (partial, _, placed) in zip(finals, opened)}
    for final, (partial, marks, placed) in zip(finals, opened):
        if not placed:
            (marks / "whole").write_text(json.dumps({"file": whole[os.path.abspath(final)], "image": ident,
                                                     "set": whole}))
    # one rename each, one after another, once every tile is in every file: an old Zarr store (a
    # folder, which a rename cannot replace), a link or a file where a store goes is moved aside
    # first (under a staged name: a kill leaves it to the next sweep), and deleted after, so a
    # final name never holds a half-deleted store
    moved = []
    for final, (partial, _, placed) in zip(finals, opened):
        if placed:
            continue
        if final.is_symlink() or final.is_dir() or (partial.is_dir() and os.path.lexists(final)):
            moved.append(stage.name(final))
            os.replace(final, moved[-1])
        os.replace(partial, final)
    for folder in dict.fromkeys(f.parent for f in finals):
        sync_folder(folder)
    if placed_all is not None:
        placed_all()  # (a batch writes its manifest here: a kill during the clean-up below redoes nothing)
    for old in moved:
        _remove(old)
    for _, marks, _ in opened:
        # each folder of records leaves in one rename, to a staged name that this run (or, after a
        # kill, the next sweep) deletes: a kill leaves an output's records whole or none of them
        if os.path.lexists(marks):
            os.replace(marks, stage.name(marks))


def _naming_output(exc: OSError, finals: list, opened: list) -> OSError:
    """``exc``, met while tiles were written, as an error of its kind that names the output whose
    partial file or records it concerns (the only output when it names none of them)."""
    where = os.path.abspath(exc.filename) if isinstance(exc.filename, (str, os.PathLike)) else ""
    ours = [final for final, (partial, marks, _) in zip(finals, opened)
            if where and any(where == os.path.abspath(r) or where.startswith(os.path.abspath(r) + os.sep)
                             for r in (partial, marks))]
    if not ours and len(finals) == 1 and exc.errno is not None:
        ours = finals
    if not ours:
        return exc
    return OSError(exc.errno, f"could not write {str(ours[0])!r}: {exc.strerror or exc}")
