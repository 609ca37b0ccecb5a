"""Batch jobs: presets with parameter sweeps from a TOML file, resumable, optionally on Dask.

A job file::

    out = "runs"                  # output folder, relative to the job file (created if missing)
    device = "cpu"                # optional; default CUDA if present, else the CPU
    formats = ["png"]             # default output formats of every job

    [[job]]
    preset = "lightning"
    seeds = [0, 1, 2]             # or: seed = 0
    sizes = [128, 256]            # or: size = 128
    formats = ["png", "npz"]
    params = { forks = 5 }        # fixed parameter values
    grid = { alpha = [2.0, 3.0] } # swept parameters (every combination)

    [[job]]
    preset = "terrain"            # "dendry" or "terrain" with a tile size: the field is
    size = 8192                   # computed tile by tile (a Dask array on a cluster) and
    tile = 1024                   # written to an NPY file or a Zarr store, never whole in memory
    formats = ["npy"]

Every task (one combination) writes its outputs atomically (a temporary name,
then a rename) and then its manifest ``<name>.manifest.json`` with the
parameters, seed, device, package version and timing. A task is complete when
its manifest matches its parameters and every output exists; re-running the file
skips complete tasks and redoes the rest. Tiled fields record each finished tile,
so a killed run resumes with the tiles it had not written.

Every task that is not complete is checked before any runs: values its preset
would refuse (each preset runs in :func:`wdendrite._checks.checking_only` mode,
which stops it where its first lattice would be filled or its Dendry image
computed), file names too long, two tasks writing one file. Files in the way of
a task's outputs that no manifest of the task lists (files the batch did not
make) stop the run before it starts unless it is forced.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import json
import os
import re
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ._spec import UsageError, all_presets, canonical_name, counted, nearest, progress_bar, read_toml, resolve
from ._staging import NAME_BYTES as _NAME_BYTES, identity

__all__ = ["TILED_PRESETS", "Task", "dendry_array", "load_jobs", "need_zarr", "probe_windows", "run_file", "run_task",
           "run_tiled", "tile_windows", "tiled_array", "worker_device", "write_tiled"]

_TOP_KEYS = ("out", "device", "formats", "job")
_JOB_KEYS = ("preset", "name", "seed", "seeds", "size", "sizes", "formats", "params", "grid", "tile")
TILED_PRESETS = ("dendry", "terrain")
_TILED_FORMATS = ("npy", "zarr")


@dataclass
class Task:
    """One output set of a job: a preset, its parameter values and the files it writes."""

    name: str
    """File stem, unique in the output folder."""
    preset: str
    values: dict
    """Typed parameter values given by the job (the rest are the preset's defaults)."""
    outputs: list
    """Output paths (str)."""
    params: dict = field(default_factory=dict)
    """Every parameter's value (JSON-ready): what the manifest records and compares."""
    tile: int | None = None
    """Tile side in pixels for a tiled Dendry field (None: the preset runs whole)."""

    @property
    def manifest(self) -> Path:
        """Path of the task's manifest."""
        return Path(self.outputs[0]).with_name(self.name + ".manifest.json")

    def _record(self) -> dict:
        try:
            rec = json.loads(self.manifest.read_text())
        except (OSError, ValueError):
            return {}
        return rec if isinstance(rec, dict) else {}

    def complete(self) -> bool:
        """True when the manifest records these parameters and every output exists."""
        return self._record().get("params") == self.params and all(Path(p).exists() for p in self.outputs)

    def foreign(self) -> list[str]:
        """Outputs that exist but that no manifest of this task lists: files a batch did not make.

        Outputs sit beside the manifest, so they are compared by file name (a project moved or
        reached through another path keeps its files).
        """
        rec = self._record()
        listed = rec.get("outputs", [])
        ours = {Path(p).name for p in listed if isinstance(p, str)} if isinstance(listed, list) else set()
        theirs = [p for p in self.outputs if Path(p).name not in ours and os.path.lexists(p)]
        if os.path.lexists(self.manifest) and rec.get("name") != self.name:  # not a manifest of this task
            theirs.append(str(self.manifest))
        return theirs

    def blocked(self) -> list[str]:
        """Folders where the task writes a file (an output that is no Zarr store, or its manifest)."""
        paths = [*self.outputs, str(self.manifest)]
        return [p for p in paths if Path(p).is_dir() and Path(p).suffix.lower() != ".zarr"]


# --------------------------------------------------------------------------- job files


def _keys(table: dict, allowed, where: str) -> None:
    for k in table:
        if k not in allowed:
            raise UsageError(f"{where}: unknown key {k!r}{nearest(k, allowed)}; allowed keys: {', '.join(allowed)}")


def _list(job: dict, one: str, many: str, where: str, default):
    if one in job and many in job:
        raise UsageError(f"{where}: give {one!r} or {many!r}, not both")
    if many in job:
        v = job[many]
        if not isinstance(v, list) or not v:
            raise UsageError(f"{where}: {many!r} must be a non-empty list, but got {v!r}")
        _no_repeats(v, repr(many), where)
        return v
    return [job.get(one, default)]


def _no_repeats(values: list, what: str, where: str) -> None:
    """Refuse a list that names one value twice (its tasks would write one file twice)."""
    for i, v in enumerate(values):
        if v in values[:i]:
            raise UsageError(f"{where}: {what} lists {v!r} twice")


def _formats(value, where: str, preset) -> list[str]:
    """The job's ``formats``, checked: known to the command; an unknown one's message lists ``preset``'s."""
    from .cli import SUFFIXES, _formats as writes

    fmts = [value] if isinstance(value, str) else value
    if not isinstance(fmts, list) or not fmts:
        raise UsageError(f"{where}: 'formats' must be a format or a list of them, but got {value!r}")
    out = []
    for f in fmts:
        f = str(f).lower().lstrip(".")
        if "." + f not in SUFFIXES and f != "zarr":
            allowed = [s[1:] for s in writes(preset)] + (["zarr"] if preset.name in TILED_PRESETS else [])
            raise UsageError(f"{where}: unknown format {f!r}{nearest(f, allowed)}; preset {preset.name!r} writes: "
                             f"{', '.join(allowed)}")
        if f in out:
            raise UsageError(f"{where}: format {f!r} is listed twice in 'formats' {value!r}")
        out.append(f)
    return out


def _slug(v) -> str:
    s = ",".join(_slug(x) for x in v) if isinstance(v, (list, tuple)) else str(v)
    return re.sub(r"[^\w.,+-]", "-", s)  # letters of any script, digits, _ . , + -


def _job_tasks(job: dict, k: int, folder: Path, top_formats) -> list[Task]:
    where = f"job {k + 1}"
    if not isinstance(job, dict):
        raise UsageError(f"{where}: expected a [[job]] table, but got {job!r}")
    if not isinstance(job.get("preset"), str):
        raise UsageError(f"{where}: needs a 'preset' name, e.g. preset = \"lightning\"" +
                         (f", but got {job['preset']!r}" if "preset" in job else ""))
    name, presets = canonical_name(job["preset"]), all_presets()
    where = f"job {k + 1} ({name})" if name in presets else where
    _keys(job, _JOB_KEYS, where)
    if "name" in job and (not isinstance(job["name"], str) or not job["name"].strip()):
        raise UsageError(f"{where}: 'name' must be a non-empty text (a file stem), but got {job['name']!r}")
    if name not in presets:
        raise UsageError(f"{where}: unknown preset {name!r}{nearest(name, presets)}")
    preset = presets[name]
    fixed, grid = job.get("params", {}), job.get("grid", {})
    for t, what in ((fixed, "params"), (grid, "grid")):
        if not isinstance(t, dict):
            raise UsageError(f"{where}: {what!r} must be a table, but got {t!r}")
        _keys(t, list(preset.params), f"{where} {what}")
    for key, vals in grid.items():
        if not isinstance(vals, list) or not vals:
            raise UsageError(f"{where}: grid {key!r} must be a non-empty list of values, but got {vals!r}")
        _no_repeats(vals, f"grid {key!r}", where)
    seeds = _list(job, "seed", "seeds", where, None)
    if seeds != [None] and "seed" not in preset.params:
        raise UsageError(f"{where}: preset {name!r} has no seed")
    sizes = _list(job, "size", "sizes", where, None)
    if sizes != [None] and not preset.size_param:
        raise UsageError(f"{where}: preset {name!r} has no size parameter")
    # one place per value: a seed or size given twice would be overwritten, and file names would lie
    for given, param, keys in ((seeds, "seed", "'seed'/'seeds'"), (sizes, preset.size_param, "'size'/'sizes'")):
        for t, what in ((fixed, "params"), (grid, "grid")):
            if given != [None] and param in t:
                raise UsageError(f"{where}: {what} {param!r} and {keys} both set it; give it in one place")
    both = [p for p in grid if p in fixed]  # (the grid's value had silently won)
    if both:
        raise UsageError(f"{where}: params {both[0]!r} and grid {both[0]!r} both set it; give it in one place")
    sized = {}
    for size in sizes:
        if size is not None:
            try:
                sized[size] = preset.sized(size)
            except UsageError:
                raise UsageError(f"{where}: 'size'/'sizes' expects positive integers, but got {size!r}") from None
    fmts = _formats(job.get("formats", top_formats), where, preset)
    if not preset.meshes and {"obj", "ply", "stl", "glb"} & set(fmts):
        raise UsageError(f"{where}: preset {name!r} makes no mesh (it is 2D); drop the mesh formats")
    if not preset.dendrite and {"npz", "json", "svg"} & set(fmts):
        raise UsageError(f"{where}: preset {name!r} makes no dendrite; drop the formats "
                         f"{', '.join(repr(f) for f in fmts if f in ('npz', 'json', 'svg'))}")
    if preset.meshes and "svg" in fmts:
        raise UsageError(f"{where}: preset {name!r} makes a 3D dendrite, which SVG cannot draw; drop 'svg'")
    tile = _tile(job.get("tile"), name, fmts, where)
    tasks = []
    checked = set()  # the values checked already (seeds aside)
    for size, seed, combo in itertools.product(sizes, seeds, itertools.product(*grid.values())):
        values = {p: preset.params[p].convert(v, source=f"{where} params {p!r}", typed=True) for p, v in fixed.items()}
        values.update({p: preset.params[p].convert(v, source=f"{where} grid {p!r}", typed=True)
                       for p, v in zip(grid, combo)})
        if seed is not None:
            values["seed"] = preset.params["seed"].convert(seed, source=f"{where} seed", typed=True)
            if not 0 <= values["seed"] < 2**32:
                raise UsageError(f"{where}: 'seed'/'seeds' must be in [0, 2**32), but got {seed!r}")
        if size is not None:
            values[preset.size_param] = sized[size]
        try:
            kwargs, full = resolve(preset, values)
        except (ValueError, TypeError) as exc:  # a parameter dataclass refused a value: say which job
            raise UsageError(f"{where}: {exc}") from None
        stem = _task_name(job.get("name", name), preset, full, dict(zip(grid, combo)))
        longest = len(os.fsencode(stem)) + len(".manifest.json")  # as long as ".{stem}.partial.zarr"
        if longest > _NAME_BYTES:
            raise UsageError(f"{where}: the task name {stem[:40]!r}... makes file names of {longest} bytes, "
                             f"more than the {_NAME_BYTES} file systems allow; give the job a shorter 'name'")
        task = Task(stem, name, values, [str(folder / f"{stem}.{f}") for f in fmts], full, tile)
        if not task.complete():  # (a re-run checks only what it will run)
            try:
                _check_values(preset, kwargs, checked)
            except (ValueError, TypeError, OverflowError) as exc:  # the preset refused a value: say which job
                raise UsageError(f"{where}: {exc}") from None
            except MemoryError as exc:
                raise UsageError(f"{where}: checking the values ran out of memory ({exc})") from None
        tasks.append(task)
    return tasks


def _check_values(preset, kwargs: dict, checked: set) -> None:
    """Raise what ``preset`` would raise for ``kwargs`` as soon as it ran, without its work.

    The preset runs in :func:`wdendrite._checks.checking_only` mode, which stops it where its
    first lattice would be filled or its Dendry image computed. Values that differ only in
    their seed are checked once.
    """
    from . import _checks

    key = repr(sorted((k, v) for k, v in kwargs.items() if k != "seed"))
    if key in checked:
        return
    try:
        with _checks.checking_only():
            preset.func(**kwargs)
    except _checks.Checked:
        pass
    checked.add(key)


def need_zarr(paths) -> None:
    """Raise :class:`UsageError` when a ``.zarr`` output is asked for and zarr is not installed."""
    import importlib.util

    if any(str(p).lower().endswith(".zarr") for p in paths) and importlib.util.find_spec("zarr") is None:
        raise UsageError("Zarr outputs need zarr: pip install 'wdendrite[zarr]' (or write .npy)")


def _tile(tile, name: str, fmts: list[str], where: str) -> int | None:
    """The tile size of a job (None: untiled), checked against its preset and formats."""
    if tile is None:
        if "zarr" in fmts:
            raise UsageError(f"{where}: 'zarr' output needs a tiled job (set 'tile')")
        return None
    if name not in TILED_PRESETS or all_presets()[name].func.__module__ != "wdendrite._models":
        raise UsageError(f"{where}: 'tile' is for {' and '.join(TILED_PRESETS)} only")
    if isinstance(tile, bool) or not isinstance(tile, int) or tile < 8:
        raise UsageError(f"{where}: 'tile' must be an integer >= 8 pixels, but got {tile!r}")
    bad = [f for f in fmts if f not in _TILED_FORMATS]
    if bad:
        raise UsageError(f"{where}: a tiled job writes {' or '.join(_TILED_FORMATS)} only, not {bad[0]!r}")
    need_zarr([f".{f}" for f in fmts])
    return tile


def _task_name(stem: str, preset, full: dict, swept: dict) -> str:
    """``stem_size..._seed..._param value...``: what varies in a sweep, readable in the file name."""
    sz = full[preset.size_param] if preset.size_param else None
    bits = [f"{preset.size_param}{'x'.join(map(str, sz)) if isinstance(sz, list) else sz}"] if sz else []
    bits += [f"seed{full['seed']}"] if "seed" in full else []
    bits += [f"{p}{_slug(v)}" for p, v in swept.items()]
    return "_".join([_slug(stem)] + bits)


def load_jobs(path) -> tuple[list[Task], dict]:
    """Parse and validate a job file: ``(tasks, settings)`` with ``settings["out"]`` and ``["device"]``.

    Raises:
        UsageError: a file that does not parse (with its line), an unknown key, preset,
            parameter or format, a bad value, duplicate task names, an unwritable folder.
    """
    path = Path(path)
    raw = read_toml(path, "job file")
    _keys(raw, _TOP_KEYS, f"job file {str(path)!r}")
    if "out" not in raw or not isinstance(raw["out"], str):
        raise UsageError(f"job file {str(path)!r}: needs an output folder, e.g. out = \"runs\"")
    jobs = raw.get("job", [])
    if not isinstance(jobs, list) or not jobs:
        raise UsageError(f"job file {str(path)!r}: lists no [[job]] tables")
    folder = (path.parent / raw["out"]).resolve()
    top_formats = raw.get("formats", ["png"])
    tasks = [t for k, job in enumerate(jobs) for t in _job_tasks(job, k, folder, top_formats)]
    seen, written = {}, {}
    for t in tasks:
        if t.name in seen:
            raise UsageError(f"two tasks would write {t.name!r}; give the jobs different 'name's")
        seen[t.name] = t
        for p in [*t.outputs, str(t.manifest)]:
            if p in written:
                raise UsageError(f"tasks {written[p]!r} and {t.name!r} would both write {p!r}; give the jobs "
                                 "different 'name's")
            written[p] = t.name
    return tasks, {"out": folder, "device": raw.get("device")}


def _remove(path: Path) -> None:
    """Delete a file, a link (not what it points at) or a folder, if there is one at ``path``."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    elif os.path.lexists(path):
        path.unlink()


def _sweep_leftovers(task: Task) -> None:
    """Remove what a run killed after a complete task's manifest left behind: the tile records
    of its outputs (a complete task is not run again to clear them), unless a run writing that
    output now holds its lock (the records are that run's)."""
    from ._staging import locked

    for path in map(Path, task.outputs):
        records = [r for r in _tile_records(path) if os.path.lexists(r)]
        if records:
            with contextlib.suppress(FileExistsError), locked([path]):
                for old in records:
                    _remove(old)


def _prepare_folder(folder: Path) -> None:
    from .cli import probe_folder

    if folder.exists() and not folder.is_dir():
        raise UsageError(f"output folder {str(folder)!r} is a file; name a folder for 'out'")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe_folder(folder)
    except OSError as exc:
        raise UsageError(f"output folder {str(folder)!r} is not writable ({exc.strerror or exc})") from None


# --------------------------------------------------------------------------- one task


def _manifest(task: Task, rec: dict, started: float) -> dict:
    from . import __version__

    return {"name": task.name, "preset": task.preset, "params": task.params, "seed": task.params.get("seed"),
            "device": rec["device"], "version": __version__, "outputs": task.outputs,
            "made": rec.get("made", ""), "seconds": rec["seconds"], "write_seconds": rec.get("write_seconds"),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z", time.localtime(started)),
            "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z")}


def _write_manifest(task: Task, rec: dict) -> None:
    from .io import atomic_write

    text = json.dumps(rec, indent=2)
    atomic_write(task.manifest, lambda tmp: Path(tmp).write_text(text), overwrite=True)


def worker_device(device: str | None) -> str | None:
    """On a Dask worker, plain ``"cuda"`` means one GPU per worker: the workers on one machine, in the
    order of their addresses, take its GPUs in turn (``cuda:(k mod GPUs)`` for the k-th of them).

    Anywhere else (or for any other device) ``device`` is returned as it is.
    """
    if device != "cuda":
        return device
    try:
        from distributed import get_worker

        worker = get_worker()
    except (ImportError, ValueError):  # not on a worker
        return device
    import warp as wp

    count = wp.get_cuda_device_count()
    if not count:
        return device
    return f"cuda:{_rank_on_host(worker) % count}"


def _rank_on_host(worker) -> int:
    """The place of ``worker`` among the scheduler's workers on its host now, ordered by address
    (asked for each task: workers that restart or join change the order)."""
    host = worker.address.rsplit(":", 1)[0]
    try:
        info = worker.client.scheduler_info(n_workers=-1)["workers"]
    except TypeError:  # distributed before n_workers=: every worker is listed
        info = worker.client.scheduler_info()["workers"]
    port = lambda a: int(a.rsplit(":", 1)[1]) if a.rsplit(":", 1)[1].isdigit() else -1  # noqa: E731
    peers = sorted((a for a in info if a.rsplit(":", 1)[0] == host), key=lambda a: (port(a), a))
    if worker.address in peers:
        return peers.index(worker.address)
    return worker.name if isinstance(worker.name, int) else 0


@contextlib.contextmanager
def _claimed(task: Task):
    """While a task runs, its manifest lists its outputs but vouches for no parameters: an old
    manifest must not vouch for new outputs, and files written before a kill stay known as the
    batch's (the task is complete once its new manifest is written). A task that fails with
    none of its outputs in place leaves no manifest."""
    _write_manifest(task, {"name": task.name, "preset": task.preset, "params": None,
                           "outputs": task.outputs, "running": True})
    try:
        yield
    except BaseException:
        if not any(os.path.lexists(p) for p in task.outputs):
            task.manifest.unlink(missing_ok=True)
        raise


def run_task(task: Task, device: str | None = None, *, quiet: bool = True) -> dict:
    """Run one (untiled) task, write its outputs and then its manifest; return the manifest.

    ``quiet=False`` shows a bar whose clock runs while a task takes more than half a second.

    Outputs that exist are overwritten: :func:`run_file` refuses, before any task runs, files
    that no manifest lists unless it is forced.
    """
    from .cli import run_preset

    started = time.time()
    with _claimed(task):
        rec = run_preset(task.preset, task.values, task.outputs, device=worker_device(device), force=True,
                         quiet=quiet)
    man = _manifest(task, rec, started)
    _write_manifest(task, man)
    return man


# --------------------------------------------------------------------------- tiled fields


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


def _dendry_tile(window, *, setup: dict, output: str, device):
    from .cli import pick_device
    from .dendry import dendry

    # one thread a tile: the tiles are what runs in parallel (threads here, Dask's workers there)
    return dendry(**setup, output=output, window=window, device=pick_device(worker_device(device)), workers=1)


def _tiled_setup(task: Task):
    from .cli import dendry_setup

    preset = all_presets()[task.preset]
    kwargs, _ = resolve(preset, task.values)
    p = {n: preset.params[n].default for n in ("extent", "control", "frequency", "drained", "seed")}
    p.update({k: v for k, v in kwargs.items() if k in p})
    params = kwargs.get("params", preset.groups["params"][0])
    size = kwargs.get("size", preset.params["size"].default)
    output = "elevation" if task.preset == "terrain" else kwargs.get("output", preset.params["output"].default)
    return dendry_setup(size, params, **p, output=output), output


def dendry_array(task_or_setup, *, tile: int = 512, output: str = "elevation", device=None):
    """A lazy Dask array of a Dendry image, one block per tile: ``task_or_setup`` is a dict of
    :func:`wdendrite.dendry`'s keywords (``shape``, ``domain``, ``params``, ``control``) or a tiled task."""
    if isinstance(task_or_setup, Task):
        setup, output = _tiled_setup(task_or_setup)
    else:
        setup = task_or_setup
    fn = functools.partial(_dendry_tile, setup=setup, output=output, device=device)
    return tiled_array(fn, setup["shape"], tile)


class _Target:
    """Where finished tiles go: an NPY file (written in place with ordinary writes, so that a full
    disk is an error and never a signal) or a Zarr array, plus one marker file per finished tile
    so an interrupted run knows what is left."""

    def __init__(self, path: Path, marks: Path):
        self.path, self.marks = str(path), str(marks)
        if not self.path.lower().endswith(".zarr"):
            self.offset, self.width = _npy_layout(path)

    def mark(self, window) -> Path:
        return Path(self.marks) / ("%d_%d" % tuple(window[:2]))

    def write(self, window, values) -> None:
        r0, c0, h, w = window
        if self.path.lower().endswith(".zarr"):
            import zarr

            arr = zarr.open_array(self.path, mode="r+")
            arr[r0:r0 + h, c0:c0 + w] = values
        else:
            from ._staging import write_at

            rows = np.ascontiguousarray(values, "<f4").reshape(h, w)
            offset, stride = self.offset + 4 * (r0 * self.width + c0), 4 * self.width
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


def tile_key(params: dict, kind: str) -> str:
    """What tells one tiled image from another in its tile records: the preset's full
    parameters and the kind of device (``cpu`` or ``cuda``) its tiles were computed on."""
    return json.dumps({"params": params, "device": kind}, sort_keys=True)


def _image_ident(key: str, shape, tile: int) -> str:
    """The image a folder of tile records holds tiles of (its ``image.json``)."""
    return json.dumps({"key": key, "shape": list(shape), "tile": tile}, sort_keys=True)


def _whole_image(marks: Path) -> dict | None:
    """What a folder of tile records says of the whole image a run renamed into place (its
    ``whole`` file: the file's identity and the image's), or None."""
    try:
        whole = json.loads((marks / "whole").read_text())
    except (OSError, ValueError):
        return None
    return whole if isinstance(whole, dict) and isinstance(whole.get("image"), str) else None


def placed_by_killed_run(final: Path, key: str) -> bool:
    """Whether the file at ``final`` is the whole image of tile key ``key`` that a run killed
    before its clean-up renamed there, untouched since: a re-run of that run may take it
    (:func:`write_tiled` then keeps it) rather than refuse it as a file of the user's."""
    _, marks = _tile_records(final)
    whole = _whole_image(marks)
    try:
        same = whole is not None and json.loads(whole["image"]).get("key") == key
    except (ValueError, AttributeError):
        return False
    return same and os.path.lexists(final) and whole.get("file") == identity(final)


def _clear_records(marks: Path) -> None:
    """Delete a folder of tile records, its ``whole`` file last: a kill part way leaves records
    a re-run still recognises (:func:`placed_by_killed_run`, :func:`_open_partial`)."""
    if marks.is_dir() and not marks.is_symlink():
        for entry in sorted(marks.iterdir(), key=lambda e: e.name == "whole"):
            _remove(entry)
    _remove(marks)


def _partial_state(final: Path, ident: str) -> str:
    """What the records beside ``final`` hold of the image ``ident`` (:func:`_image_ident`):
    ``"placed"`` (the whole image, renamed to ``final`` by a run killed before it could clear
    them), ``"resume"`` (a partial file with some of its tiles) or ``"new"`` (nothing of it)."""
    partial, marks = _tile_records(final)
    if not os.path.lexists(partial) and os.path.lexists(final):
        # the very file a run renamed there, untouched since (its ``whole`` record outlives the others)
        if _whole_image(marks) == {"file": identity(final), "image": ident}:
            return "placed"
    try:
        same = (marks / "image.json").read_text() == ident
    except OSError:
        same = False
    return "resume" if partial.exists() and same else "new"


def _npy_bytes(shape) -> int:
    """The size of the NPY file of a float32 image of ``shape``, in bytes."""
    return len(_npy_header(shape)) + 4 * shape[0] * shape[1]


def _open_partial(final: Path, shape, tile: int, ident: str, state: str) -> tuple[Path, Path, bool]:
    """The partial file and the folder of tile markers beside ``final``, made afresh when ``state``
    (:func:`_partial_state`) is ``"new"`` (an NPY file with its whole size allocated on the disk:
    a full disk fails here, and the file is deleted); and whether the image is ``"placed"``."""
    # ".{stem}.partial{suffix}" keeps the suffix that names the format
    partial, marks = _tile_records(final)
    if state == "new":
        _remove(marks)
        _remove(partial)
        if final.suffix.lower() == ".zarr":
            import zarr

            # one chunk per tile (none larger than the image): workers writing different tiles never
            # touch the same chunk
            zarr.open_array(str(partial), mode="w", shape=tuple(shape), chunks=tuple(min(tile, n) for n in shape),
                            dtype="f4")
        else:
            from ._staging import reserve, write_at

            fd = os.open(partial, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o666)
            try:
                write_at(fd, _npy_header(shape), 0)
                reserve(fd, _npy_bytes(shape), final)
            except BaseException:
                os.close(fd)
                partial.unlink(missing_ok=True)
                raise
            os.close(fd)
        marks.mkdir()
        (marks / "image.json").write_text(ident)
    return partial, marks, state == "placed"


def probe_windows(shape) -> list[tuple[int, int, int, int]]:
    """The one-pixel windows at the image's corners, which :func:`write_tiled` computes first to check
    the setup before it makes any file (a domain's largest coordinates lie at its corners)."""
    h, w = shape
    return sorted({(r, c, 1, 1) for r in (0, h - 1) for c in (0, w - 1)})


def write_tiled(tile_fn, shape, tile: int, path, *, client=None, progress=None, key: str = "", placed_all=None,
                workers: int | None = 1):
    """Compute an image tile by tile and write it to ``path`` (``.npy`` or ``.zarr``) without holding it whole.

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
        workers: without a ``client``, threads that compute tiles at once (``tile_fn`` must then
            be safe to call from several threads) while this thread writes them in order; None:
            every core. The files do not depend on it.

    Returns:
        The written path (a list of them when ``path`` is a list).

    Raises:
        ValueError, TypeError: a bad ``shape`` or ``tile``; an empty list of paths, one path given
        twice, a path not ending in ``.npy`` or ``.zarr``, or a ``.npy`` path that is a folder
        (an existing file or Zarr store at a path is replaced: the caller decides whether it may be);
        whatever ``tile_fn`` raises; computed here, it is first tried on the image's corner
        pixels (:func:`probe_windows`), so that a setup it refuses fails before the partial files
        are made.
        FileExistsError: another process is writing one of the paths (each is locked while this
        runs, see :func:`wdendrite._staging.locked`); nothing was touched.
        OSError: a ``.npy`` file does not fit the free space of its disk (checked before any file
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
    for final in finals:
        if final.suffix.lower() not in (".npy", ".zarr"):
            raise ValueError(f"Expected '.npy' or '.zarr' output paths for 'path', but got {str(final)!r}")
        if final.suffix.lower() == ".npy" and final.is_dir() and not final.is_symlink():
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
                      placed_all=placed_all, workers=workers)
    return finals if isinstance(path, (list, tuple)) else finals[0]


def _write_locked(tile_fn, shape, tile: int, finals: list, stage, *, client, progress, key: str, placed_all,
                  workers: int = 1) -> None:
    """The work of :func:`write_tiled` once its outputs are locked; ``stage`` names old outputs moved aside."""
    from ._staging import check_space, sync_folder
    from .io import sync_to_disk

    ident = _image_ident(key, shape, tile)
    states = [_partial_state(final, ident) for final in finals]
    # the space is counted before any file is made (a 2000000-pixel square would be a 16 TB file)
    check_space({final: _npy_bytes(shape) for final, state in zip(finals, states)
                 if state == "new" and final.suffix.lower() == ".npy"})
    opened = [_open_partial(final, shape, tile, ident, state) for final, state in zip(finals, states)]
    # (an image a killed run had renamed into place already needs no tile)
    targets = [_Target(partial, marks) for partial, marks, placed in opened if not placed]
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
    for partial, marks, placed in opened:
        if not placed:
            if partial.is_file():
                sync_to_disk(partial)
            # a kill from here on leaves a whole image: a re-run renames it, or keeps it once renamed
            (marks / "whole").write_text(json.dumps({"file": identity(partial), "image": ident}))
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
        _clear_records(marks)


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


def _default_device_kind() -> str:
    """The kind of device (``cpu`` or ``cuda``) this process would run on without ``--device``."""
    from .cli import pick_device

    return pick_device(None).split(":")[0]


def _workers_device_kind(client) -> str:
    """The one kind of default device of every Dask worker (refused when they differ)."""
    kinds = client.run(_default_device_kind)
    if len(set(kinds.values())) > 1:
        seen = ", ".join(f"{k}: {n}" for k, n in sorted(kinds.items()))
        raise UsageError(f"the Dask workers' default devices differ ({seen}); a tiled file must be "
                         "computed on one kind of device: pass --device cpu or --device cuda")
    return next(iter(kinds.values()), "cpu")


def run_tiled(task: Task, device=None, *, client=None, progress=None, manifest: bool = True,
              workers: int | None = None) -> dict:
    """Run a tiled Dendry task: every output written tile by tile, then (``manifest``) the manifest;
    without a ``client``, ``workers`` threads compute tiles at once (None: every core)."""
    from .cli import pick_device

    started = time.time()
    setup, output = _tiled_setup(task)
    dev = device if client is not None else pick_device(device)
    fn = functools.partial(_dendry_tile, setup=setup, output=output, device=dev)
    t0 = time.perf_counter()
    # tiles from another kind of device are not reused: CUDA's pow and exp may round differently
    kind = _workers_device_kind(client) if dev is None else str(dev).split(":")[0]
    made = {}

    def placed_all():
        rec = {"device": dev or f"{kind} (default of each worker)", "seconds": round(time.perf_counter() - t0, 4)}
        h, w = setup["shape"]
        rec["made"] = f"{h} x {w} {output} in {counted(len(tile_windows(setup['shape'], task.tile)), 'tile')}"
        made.update(_manifest(task, rec, started), tile=task.tile, output=output)
        if manifest:
            _write_manifest(task, made)

    with _claimed(task) if manifest else contextlib.nullcontext():
        write_tiled(fn, setup["shape"], task.tile, list(task.outputs), client=client, progress=progress,
                    key=tile_key(task.params, kind), placed_all=placed_all, workers=workers)
    return made


# --------------------------------------------------------------------------- running a file


def _client(scheduler: str, workers: int | None, processes: bool, timeout: float):
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise UsageError("--scheduler needs Dask: pip install 'wdendrite[distributed]'") from None
    if scheduler == "local":
        cluster = LocalCluster(n_workers=workers or 1, threads_per_worker=1, processes=processes,
                               dashboard_address=None)
        return Client(cluster), cluster
    try:
        return Client(scheduler, timeout=f"{timeout}s"), None
    except (OSError, TimeoutError) as exc:
        raise UsageError(f"cannot reach the Dask scheduler at {scheduler!r}: {exc}") from None


def run_file(path, *, scheduler: str | None = None, device: str | None = None, workers: int | None = None,
             quiet: bool = False, dry_run: bool = False, processes: bool = True, timeout: float = 10.0,
             force: bool = False) -> int:
    """Run every task of a job file that is not complete; return the exit code.

    0: every task is complete; 2: some tasks were rejected by their presets (values out of
    range), nothing written for them; 1: some tasks failed otherwise. Failed tasks do not
    stop the others and are redone by the next run.

    Args:
        path: the TOML job file.
        scheduler: None (run here, one task after another), ``"local"`` (a Dask
            ``LocalCluster`` of ``workers`` workers) or a Dask scheduler address.
        device: Warp device for every task (default: the file's ``device``, else CUDA if present, else the CPU).
        workers: LocalCluster workers (default 1).
        quiet: no progress bar.
        dry_run: only list the tasks and whether each is complete.
        processes: LocalCluster workers as processes (False: threads of this process).
        timeout: seconds to wait for a scheduler at an address.
        force: overwrite files in the output folder that no manifest of the batch lists
            (without it they are refused before any task runs).

    Raises:
        UsageError: a bad job file, an unwritable folder, files the batch did not make in the
            way of its outputs (without ``force``), an unreachable scheduler (before any task runs).
        FileExistsError: another batch is running in the same output folder (nothing was changed).
    """
    from .cli import check_device_name, pick_device

    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise UsageError(f"--workers must be a positive integer, but got {workers!r}")
    if not timeout > 0:
        raise UsageError(f"--timeout must be a positive number of seconds, but got {timeout!r}")
    if scheduler not in (None, "local") and not re.fullmatch(r"([a-z]+://)?[\w.\-\[\]:]+:\d+", scheduler):
        raise UsageError(f"--scheduler must be 'local' or an address like tcp://host:8786, but got {scheduler!r}")
    if workers is not None and scheduler != "local":
        raise UsageError("--workers sets the size of a LocalCluster: use it with --scheduler local")
    tasks, settings = load_jobs(path)
    from_file = device is None and settings["device"] is not None
    device = device or settings["device"]
    # validated here, before any work
    try:
        if scheduler is None:
            device = pick_device(device)
        elif device is not None:
            check_device_name(device)
            if scheduler == "local":
                pick_device(device)  # the workers run on this machine: the device must be here
            # a plain "cuda" stays as it is: each worker takes a GPU of its own (worker_device)
    except UsageError as exc:
        if from_file:  # the messages speak of the option; the value came from the file
            raise UsageError(str(exc).replace("--device", f"job file {str(path)!r}: 'device'", 1)) from None
        raise
    if dry_run:
        for t in tasks:
            state = "done" if t.complete() else "todo"
            note = ""
            blocked = t.blocked()
            if state == "todo" and blocked:
                note = f"  (a folder is in the way: move {Path(blocked[0]).name!r})"
            elif state == "todo" and t.foreign():
                note = "  (overwrites files the batch did not make)" if force else \
                    "  (overwrites files the batch did not make: needs --force)"
            print(f"{state}  {t.name}  -> {', '.join(t.outputs)}{note}")
        return 0
    todo = [t for t in tasks if not t.complete()]
    # a folder where a file goes (not a Zarr store) cannot be overwritten, forced or not
    folders = [p for t in todo for p in t.blocked()]
    if folders:
        raise UsageError(f"{folders[0]!r} is a folder where the batch writes a file; move it away")
    foreign = [p for t in todo for p in t.foreign()]
    if foreign and not force:
        more = f" and {len(foreign) - 1} more" if len(foreign) > 1 else ""
        raise UsageError(f"{foreign[0]!r}{more} exist but no manifest of this batch lists them: the batch "
                         "did not make them. Move them away, or pass --force to overwrite them")
    from ._staging import locked, sweep

    created = not settings["out"].exists()
    _prepare_folder(settings["out"])
    busy = f"another batch is running in {str(settings['out'])!r} ({{holder}}); wait until it has finished"
    with locked([settings["out"] / "batch"], busy=busy):  # (a second batch stops here, before any change)
        sweep(settings["out"])  # what killed runs left: renames completed, temporary files deleted
        running = {id(t) for t in todo}
        for t in tasks:
            if id(t) not in running:
                _sweep_leftovers(t)
        failed = _run_todo(todo, settings["out"], created, device, scheduler=scheduler, workers=workers,
                           processes=processes, timeout=timeout, quiet=quiet)
    done = len(tasks) - len(todo)
    print(f"batch: {counted(len(tasks), 'task')}, {len(todo) - len(failed)} run, {done} already complete, "
          f"{len(failed)} failed -> {settings['out']}")
    if not failed:
        return 0
    # a preset that rejects its values is bad input (2); anything else is a failure (1)
    return 2 if all(isinstance(exc, _BAD_INPUT) for _, exc in failed) else 1


def _run_todo(todo: list, out: Path, created: bool, device, *, scheduler, workers, processes, timeout,
              quiet) -> list:
    """Run the tasks of :func:`run_file` that are not complete; ``[(name, error)]`` of those that failed."""
    client = cluster = None
    if scheduler is not None and todo:
        try:
            client, cluster = _client(scheduler, workers, processes, timeout)
        except UsageError:
            if created:  # leave no trace of a run that never started
                shutil.rmtree(out, ignore_errors=True)
            raise
    failed = []
    bar = progress_bar("batch", quiet=quiet, total=len(todo))
    try:
        plain = [t for t in todo if t.tile is None]
        if client is None:
            for t in plain:
                _attempt(lambda: run_task(t, device, quiet=quiet), t, failed)
                bar.update(1)
        else:
            from distributed import as_completed

            futures = {client.submit(run_task, t, device, pure=False): t for t in plain}
            for fut in as_completed(futures):
                _attempt(fut.result, futures[fut], failed)
                bar.update(1)
        for t in (t for t in todo if t.tile is not None):
            with progress_bar(f"{t.name} tiles", quiet=quiet, leave=False) as tiles:
                def tick(done, total, tiles=tiles):
                    tiles.total = total
                    tiles.n = done
                    tiles.refresh()

                _attempt(lambda: run_tiled(t, device, client=client, progress=tick), t, failed)
            bar.update(1)
    finally:
        bar.close()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    return failed


_BAD_INPUT = (ValueError, TypeError, FileExistsError, MemoryError)


def _attempt(call, task: Task, failed: list) -> None:
    from ._checks import memory_error

    try:
        call()
    except Exception as exc:  # one bad task must not stop the others; it is redone next time
        exc = memory_error(exc) or exc  # (an allocation that failed under another name: out of memory)
        failed.append((task.name, exc))
        print(f"batch: task {task.name} failed: {type(exc).__name__}: {exc}", file=sys.stderr)
