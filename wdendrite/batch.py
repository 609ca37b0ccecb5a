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

from ._spec import UsageError, all_presets, canonical_name, counted, nearest, progress_bar, read_toml, resolve
from ._staging import NAME_BYTES as _NAME_BYTES
# tiled images are written by wdendrite.tiles (its public functions stay importable from here)
from .tiles import _remove, _tile_records, probe_windows, tile_key, tile_windows, tiled_array, write_tiled

__all__ = ["TILED_PRESETS", "Task", "dendry_array", "load_jobs", "need_zarr", "probe_windows", "run_file", "run_task",
           "run_tiled", "tile_windows", "tiled_array", "worker_device", "write_tiled"]

_TOP_KEYS = ("out", "device", "formats", "job")
_JOB_KEYS = ("preset", "name", "seed", "seeds", "size", "sizes", "formats", "params", "grid", "tile", "heightmap",
             "range")
TILED_PRESETS = ("dendry", "terrain")
_TILED_FORMATS = ("npy", "zarr", "r16", "raw")


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
    writing: dict = field(default_factory=dict)
    """How the outputs are written, where not by default: ``heightmap`` (True: ``png`` outputs are
    16-bit heightmaps) and ``range`` (``[lo, hi]`` of the 16-bit heightmaps). The manifest records
    it, and a task whose manifest records another is not complete."""

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
        """True when the manifest records these parameters and ways of writing, and every output exists."""
        rec = self._record()
        return rec.get("params") == self.params and rec.get("writing", {}) == self.writing and \
            all(Path(p).exists() for p in self.outputs)

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
    writing = _writing(job, fmts, where)
    if tile and {"r16", "raw"} & set(fmts) and "range" not in writing:
        raise UsageError(f"{where}: a tiled job's raw heightmaps ('r16', 'raw') need 'range' = [LO, HI]: their "
                         "levels are fixed before the first tile, when the field's range is not known yet")
    tasks = []
    checked = set()  # the values checked already (seeds aside)
    for size, seed, combo in itertools.product(sizes, seeds, itertools.product(*grid.values())):
        values = {p: preset.params[p].convert(v, source=f"{where} params {p!r}", typed=True) for p, v in fixed.items()}
        values.update({p: preset.params[p].convert(v, source=f"{where} grid {p!r}", typed=True)
                       for p, v in zip(grid, combo)})
        if seed is not None:
            values["seed"] = preset.params["seed"].convert(seed, source=f"{where}: 'seed'/'seeds'", typed=True)
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
        task = Task(stem, name, values, [str(folder / f"{stem}.{f}") for f in fmts], full, tile, writing)
        if not task.complete():  # (a re-run checks only what it will run)
            try:
                _check_raw_sizes(preset, kwargs, fmts)
                _check_values(preset, kwargs, checked)
            except (ValueError, TypeError, OverflowError) as exc:  # the preset refused a value: say which job
                raise UsageError(f"{where}: {exc}") from None
            except MemoryError as exc:
                raise UsageError(f"{where}: checking the values ran out of memory ({exc})") from None
        tasks.append(task)
    return tasks


def _writing(job: dict, fmts: list[str], where: str) -> dict:
    """A job's ways of writing (:attr:`Task.writing`) from its ``heightmap`` and ``range`` keys."""
    from .cli import need_tifffile
    from .heightmaps import value_range

    need_tifffile([f".{f}" for f in fmts], f"{where}: format")
    out = {}
    if "heightmap" in job:
        if not isinstance(job["heightmap"], bool):
            raise UsageError(f"{where}: 'heightmap' must be true or false, but got {job['heightmap']!r}")
        if job["heightmap"]:
            out["heightmap"] = True
    if "range" in job:
        try:
            out["range"] = list(value_range(job["range"], f"{where}: 'range'"))
        except ValueError as exc:
            raise UsageError(str(exc)) from None
        if not ({"r16", "raw"} & set(fmts) or (out.get("heightmap") and "png" in fmts)):
            raise UsageError(f"{where}: 'range' scales 16-bit heightmaps (formats 'r16' and 'raw', 'png' with "
                             "heightmap = true), and the job writes none")
    return out


def _check_raw_sizes(preset, kwargs: dict, fmts: list[str]) -> None:
    """Refuse raw heightmap formats that the Dendry models' size x size field cannot fill (other
    presets' fields are known only once they ran: their tasks fail then, before any write)."""
    from .heightmaps import check_raw_shape

    if preset.func.__module__ == "wdendrite._models" and preset.name in TILED_PRESETS:
        size = kwargs.get("size", preset.params["size"].default)
        for f in fmts:
            if f in ("r16", "raw"):
                check_raw_shape((size, size), f)


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
        raise UsageError(f"{where}: a tiled job writes {', '.join(_TILED_FORMATS)} only, not {bad[0]!r}")
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
            **({"writing": task.writing} if task.writing else {}),
            "device": rec["device"], "version": __version__, "outputs": task.outputs,
            "made": rec.get("made", ""), "seconds": rec["seconds"], "write_seconds": rec.get("write_seconds"),
            **{k: rec[k] for k in ("heightmap_range", "raw") if k in rec},  # (what reads 16-bit heightmaps back)
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
                         quiet=quiet, heightmap=task.writing.get("heightmap", False),
                         value_range=tuple(task.writing["range"]) if "range" in task.writing else None)
    man = _manifest(task, rec, started)
    _write_manifest(task, man)
    return man


# --------------------------------------------------------------------------- tiled Dendry fields


def _dendry_tile(window, *, setup: dict, output: str, device):
    from .cli import pick_device
    from .dendry import dendry

    # one thread a tile: the tiles are what runs in parallel (threads here, Dask's workers there)
    return dendry(**setup, output=output, window=window, device=pick_device(worker_device(device)), workers=1)


def _tiled_setup(task: Task):
    """``(keywords of wdendrite.dendry, output)`` of a tiled task, once the preset's own checks (those
    of its whole image, such as a terrain's size of at least 2) have passed its values."""
    from .cli import dendry_setup

    preset = all_presets()[task.preset]
    kwargs, _ = resolve(preset, task.values)
    _check_values(preset, kwargs, set())  # (a tiled image is the image the preset would make, or none)
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
    """Run a tiled Dendry task: every output written tile by tile, then (``manifest``) the manifest
    (raw heightmaps' levels span ``task.writing["range"]``); without a ``client``, ``workers``
    threads compute tiles at once (None: every core)."""
    from .cli import pick_device

    started = time.time()
    setup, output = _tiled_setup(task)
    dev = device if client is not None else pick_device(device)
    fn = functools.partial(_dendry_tile, setup=setup, output=output, device=dev)
    t0 = time.perf_counter()
    # tiles from another kind of device are not reused: CUDA's pow and exp may round differently
    kind = _workers_device_kind(client) if dev is None else str(dev).split(":")[0]
    levels = task.writing.get("range")  # (the levels of raw heightmaps)
    made = {}

    def placed_all():
        rec = {"device": dev or f"{kind} (default of each worker)", "seconds": round(time.perf_counter() - t0, 4)}
        h, w = setup["shape"]
        rec["made"] = f"{h} x {w} {output} in {counted(len(tile_windows(setup['shape'], task.tile)), 'tile')}"
        raw = [[p, h, w] for p in task.outputs if Path(p).suffix.lower() in (".r16", ".raw")]
        if raw:  # (what it takes to read them back)
            rec.update(heightmap_range=list(levels), raw=raw)
        made.update(_manifest(task, rec, started), tile=task.tile, output=output)
        if manifest:
            _write_manifest(task, made)

    from . import __version__
    from .heightmaps import describe

    attrs = {"wdendrite": __version__, "preset": task.preset, "params": task.params,
             **describe(setup["shape"], output, setup["domain"])}
    with _claimed(task) if manifest else contextlib.nullcontext():
        write_tiled(fn, setup["shape"], task.tile, list(task.outputs), client=client, progress=progress,
                    key=tile_key(task.params, kind, levels), placed_all=placed_all, name=output, attrs=attrs,
                    domain=setup["domain"], value_range=levels, workers=workers)
    return made


# --------------------------------------------------------------------------- running a file


def _client(scheduler: str, workers: int | None, processes: bool, timeout: float):
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise UsageError("--scheduler needs Dask: pip install 'wdendrite[distributed]'") from None
    if scheduler == "local":
        cluster = LocalCluster(n_workers=_local_workers(workers or 1), threads_per_worker=1, processes=processes,
                               dashboard_address=None)
        return Client(cluster), cluster
    try:
        return Client(scheduler, timeout=f"{timeout}s"), None
    except (OSError, TimeoutError) as exc:
        raise UsageError(f"cannot reach the Dask scheduler at {scheduler!r}: {exc}") from None


def _local_workers(workers: int) -> int:
    """``workers``, at most the cores this process may run on: each worker computes one task at a
    time, so more would only share those cores, each holding its own copy of Warp and its tiles
    (a million of them had the LocalCluster start process after process, growing memory, never a task).
    A capped count is told on stderr."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    if workers > cores:
        print(f"batch: --workers {workers} is more than the {counted(cores, 'core')} this machine gives the "
              f"batch; starting {counted(cores, 'worker')}", file=sys.stderr)
        return cores
    return workers


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
