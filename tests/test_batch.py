"""Batch jobs: sweeps, manifests, resuming, tiled fields on a real Dask LocalCluster, bad job files."""

import json
import os
import re
import subprocess
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from wdendrite import batch, cli
from wdendrite._spec import UsageError, all_presets

JOBS = """\
out = "runs"
device = "cpu"

[[job]]
preset = "fractal"
seeds = [0, 1]
sizes = [32, 40]
grid = { cheap = [0.0, 0.5] }

[[job]]
preset = "lightning"
size = 48
formats = ["png", "npz"]
params = { forks = 2, minor_forks = 2, main_width = [3.0, 2.0] }

[[job]]
preset = "dendry"
size = 50
tile = 16
formats = ["npy"]
params = { levels = 2, output = "elevation" }
"""


def wd(*args, cwd):
    # no time limit of its own: a first run compiles kernels, minutes on a loaded machine with an empty
    # cache; the suite's limit per test (pytest-timeout, in pyproject.toml) stops a run that hangs
    p = subprocess.run([sys.executable, "-m", "wdendrite.cli", *map(str, args)], cwd=cwd, capture_output=True,
                       text=True)
    return p.returncode, p.stdout, p.stderr


def _whole_dendry(size, **values):
    preset = all_presets()["dendry"]
    params = preset.groups["params"][0]
    import dataclasses

    params = dataclasses.replace(params, **{k: v for k, v in values.items() if k in ("levels",)})
    setup = cli.dendry_setup(size, params, extent=4.0, control="perlin", frequency=1.0, drained=False, seed=0)
    from wdendrite.dendry import dendry

    return setup, dendry(**setup, output="elevation", device="cpu")


def staged_by_a_dead_writer(path) -> Path:
    """A file staged for ``path`` by a process that then ended without clearing it (as a kill leaves it)."""
    code = ("import os, sys; from wdendrite._staging import Staging; "
            "print(Staging().temporary(sys.argv[1], 0o644)); os._exit(0)")
    made = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, check=True)
    return Path(made.stdout.strip())


def _ramp(window, plus=0.0):
    """The (h, w) window ``(row0, col0, h, w)`` of an image whose every value differs (tiled writers' tests)."""
    r0, c0, h, w = window
    return (np.add.outer(np.arange(r0, r0 + h) * 1000.0, np.arange(c0, c0 + w)) + plus).astype(np.float32)


def test_sweep_writes_outputs_and_manifests_then_resumes(tmp_path):
    (tmp_path / "jobs.toml").write_text(JOBS)
    code, out, err = wd("batch", "jobs.toml", "--quiet", cwd=tmp_path)
    assert code == 0, err
    runs = tmp_path / "runs"
    manifests = sorted(runs.glob("*.manifest.json"))
    assert len(manifests) == 8 + 1 + 1
    rec = json.loads((runs / "fractal_size40_seed1_cheap0.5.manifest.json").read_text())
    assert rec["params"] == {"size": 40, "count": 6, "d": None, "alpha": 1.8, "beta": 2.5, "epsilon": None,
                             "cheap": 0.5, "seed": 1} and rec["seed"] == 1
    assert rec["device"] == "cpu" and rec["version"] and rec["seconds"] >= 0 and "endpoints" in rec["made"]
    assert all(os.path.exists(p) for p in rec["outputs"])
    from wdendrite.io import load_dendrite

    assert load_dendrite(runs / "lightning_shape48x48_seed0.npz")[0].shape == (48, 48)
    light = json.loads((runs / "lightning_shape48x48_seed0.manifest.json").read_text())
    assert light["params"]["main_width"] == {"start": 3.0, "end": 2.0, "beta": 1.0, "along": "path"}
    _, whole = _whole_dendry(50, levels=2)
    assert np.array_equal(np.load(runs / "dendry_size50_seed0.npy"), whole)  # 16-pixel tiles join seamlessly
    tiled = json.loads((runs / "dendry_size50_seed0.manifest.json").read_text())
    assert tiled["made"] == "50 x 50 elevation in 16 tiles"  # (4 x 4 tiles of 16 pixels cover 50 x 50)
    assert not [p for p in runs.iterdir() if p.name.startswith(".")]  # no temporary files left

    # a re-run skips complete tasks; a lost output or a stale manifest is redone
    stamps = {m.name: m.stat().st_mtime_ns for m in manifests}
    (runs / "fractal_size32_seed0_cheap0.0.png").unlink()
    # a killed write left its temporary behind: the re-run sweeps it away
    stray = staged_by_a_dead_writer(runs / "fractal_size32_seed0_cheap0.0.png")
    stray.write_bytes(b"half")
    stale = runs / "fractal_size32_seed1_cheap0.0.manifest.json"
    stale.write_text(json.dumps({**json.loads(stale.read_text()), "params": {"size": 99}}))
    code, out, err = wd("batch", "jobs.toml", "--quiet", cwd=tmp_path)
    assert code == 0, err
    assert "2 run, 8 already complete" in out
    redone = {m.name for m in runs.glob("*.manifest.json") if m.stat().st_mtime_ns != stamps[m.name]}
    assert redone == {"fractal_size32_seed0_cheap0.0.manifest.json", stale.name}
    assert not stray.exists() and not [p for p in runs.iterdir() if p.name.startswith(".")]


def test_a_terrain_task_records_what_it_made_and_the_bar_ends_once(tmp_path):
    (tmp_path / "jobs.toml").write_text('out = "runs"\ndevice = "cpu"\n[[job]]\npreset = "terrain"\nsize = 40\n'
                                        'seeds = [0, 1]\nformats = ["png", "npy"]\n')
    code, out, err = wd("batch", "jobs.toml", cwd=tmp_path)  # the bar on, stderr a pipe
    assert code == 0, err
    for seed in (0, 1):
        made = json.loads((tmp_path / "runs" / f"terrain_size40_seed{seed}.manifest.json").read_text())["made"]
        z = np.load(tmp_path / "runs" / f"terrain_size40_seed{seed}.npy")
        assert made == f"40 x 40 elevation from {z.min():.6g} to {z.max():.6g}"
    # tqdm had drawn the finished bar once more when closing it: two copies of it in a captured stderr
    finished = [ln for ln in re.split(r"[\r\n]", err) if ln.startswith("batch: 100%")]
    assert len(finished) == 1, err


def test_killed_tiled_run_resumes_with_the_missing_tiles(tmp_path):
    shape, tile = (37, 45), 10

    def value(window):
        r0, c0, h, w = window
        rr, cc = np.mgrid[r0:r0 + h, c0:c0 + w]
        return (np.sin(rr * 0.3) + cc * 0.01).astype(np.float32)

    calls = []

    def dies_after_five(window):
        if window[2:] == (1, 1):  # the setup's check, before any file is made
            return value(window)
        if len(calls) == 5:
            raise KeyboardInterrupt  # the run is killed
        calls.append(window)
        return value(window)

    out = tmp_path / "f.npy"
    with pytest.raises(KeyboardInterrupt):
        batch.write_tiled(dies_after_five, shape, tile, out)
    assert not out.exists()  # nothing half-written under the final name
    seen = []
    batch.write_tiled(lambda w: w[2:] == (1, 1) or seen.append(w) or value(w), shape, tile, out)
    assert len(seen) == len(batch.tile_windows(shape, tile)) - 5 and not set(seen) & set(calls)
    assert np.array_equal(np.load(out), value((0, 0, *shape)))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.npy"]
    # tiles recorded for another image (other parameters) are never reused
    calls.clear()
    with pytest.raises(KeyboardInterrupt):
        batch.write_tiled(dies_after_five, shape, tile, out, key="levels=2")
    seen.clear()
    batch.write_tiled(lambda w: (w[2:] == (1, 1) or seen.append(w) or True) and value(w) + 1, shape, tile,
                      out, key="levels=3")
    assert len(seen) == len(batch.tile_windows(shape, tile))
    assert np.array_equal(np.load(out), value((0, 0, *shape)) + 1)


def test_a_tiled_task_resumes_only_tiles_of_the_same_kind_of_device(tmp_path, monkeypatch):
    # a killed run on one kind of device leaves tiles a run on another kind does not reuse
    # (CUDA's pow and exp may round differently); on the same kind it resumes them
    from wdendrite import cli

    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "terrain"\nsize = 40\ntile = 16\n'
                                        'formats = "npy"\n')
    task = batch.load_jobs(tmp_path / "jobs.toml")[0][0]
    (tmp_path / "o").mkdir()
    monkeypatch.setattr(cli, "pick_device", lambda name: name)  # a machine with every device
    calls, dies = [], [True]

    def tile(window, *, setup, output, device):
        if window[2:] == (1, 1):
            return np.zeros((1, 1), np.float32)
        if dies[0] and len(calls) == 3:
            raise KeyboardInterrupt  # the run is killed after three tiles
        calls.append(device)
        return np.zeros((window[2], window[3]), np.float32)

    def run(device, killed):
        calls.clear()
        dies[0] = killed
        if killed:
            with pytest.raises(KeyboardInterrupt):
                batch.run_tiled(task, device=device)
        else:
            batch.run_tiled(task, device=device)
        return len(calls)

    monkeypatch.setattr(batch, "_dendry_tile", tile)
    total = len(batch.tile_windows((40, 40), 16))
    assert run("cpu", killed=True) == 3
    assert run("cuda:0", killed=False) == total  # the CPU's tiles are not reused on a GPU
    task.manifest.unlink()
    (tmp_path / "o" / "terrain_size40_seed0.npy").unlink()
    assert run("cuda:0", killed=True) == 3
    assert run("cuda:1", killed=False) == total - 3  # another GPU resumes them


def test_workers_without_a_device_key_their_tiles_by_their_one_default_kind(tmp_path):
    # with a Dask client and no --device each worker runs on its own default device; the tiles'
    # key needs that kind, and workers of different kinds cannot share one tiled file
    class Client:
        def __init__(self, kinds):
            self.kinds = kinds

        def run(self, fn):
            assert fn is batch._default_device_kind
            return self.kinds

    assert batch._workers_device_kind(Client({"tcp://a": "cuda", "tcp://b": "cuda"})) == "cuda"
    with pytest.raises(UsageError, match=r"default devices differ \(tcp://a: cpu, tcp://b: cuda\).*--device"):
        batch._workers_device_kind(Client({"tcp://a": "cpu", "tcp://b": "cuda"}))
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "terrain"\nsize = 40\ntile = 16\n'
                                        'formats = "npy"\n')
    task = batch.load_jobs(tmp_path / "jobs.toml")[0][0]
    (tmp_path / "o").mkdir()
    with pytest.raises(UsageError, match="differ"):
        batch.run_tiled(task, client=Client({"x": "cpu", "y": "cuda"}))
    assert not list((tmp_path / "o").iterdir())  # refused before any tile
    assert batch._default_device_kind() == "cpu"  # this machine has no GPU


def test_tiles_on_a_local_cluster_equal_the_whole_image(tmp_path):
    distributed = pytest.importorskip("distributed")
    setup, whole = _whole_dendry(41, levels=2)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        arr = batch.dendry_array(setup, tile=12, device="cpu")
        assert arr.numblocks == (4, 4)
        assert np.array_equal(arr.compute(), whole)
        ticks = []
        batch.write_tiled(arr_fn := __import__("functools").partial(batch._dendry_tile, setup=setup,
                                                                     output="elevation", device="cpu"),
                          (41, 41), 12, tmp_path / "t.npy", client=client, progress=lambda d, t: ticks.append(d))
        assert arr_fn((0, 0, 3, 3)).shape == (3, 3)
    assert np.array_equal(np.load(tmp_path / "t.npy"), whole) and ticks[-1] == 16


def test_zarr_output(tmp_path):
    zarr = pytest.importorskip("zarr")

    def value(window):
        r0, c0, h, w = window
        return np.add.outer(np.arange(r0, r0 + h), np.arange(c0, c0 + w) * 100).astype(np.float32)

    batch.write_tiled(value, (20, 30), 8, tmp_path / "v.zarr")
    assert np.array_equal(zarr.open_array(str(tmp_path / "v.zarr"), path="field", mode="r")[:], value((0, 0, 20, 30)))
    # both formats of one image, each tile computed once for the two
    calls = []
    outs = batch.write_tiled(lambda w: calls.append(w) or value(w), (20, 30), 8, [tmp_path / "w.npy",
                                                                                  tmp_path / "w.zarr"])
    assert len(calls) == len(batch.tile_windows((20, 30), 8)) + len(batch.probe_windows((20, 30)))
    assert np.array_equal(np.load(outs[0]), value((0, 0, 20, 30)))
    assert np.array_equal(zarr.open_array(str(outs[1]), path="field", mode="r")[:], value((0, 0, 20, 30)))


def test_workers_beyond_the_cores_are_capped_with_a_message(tmp_path, monkeypatch, capsys):
    # a million workers had the LocalCluster start worker after worker, growing memory, never a task
    import os

    distributed = pytest.importorskip("distributed")
    cores = len(os.sched_getaffinity(0))
    started, real = [], distributed.LocalCluster

    def counting(*, n_workers, **kw):
        started.append(n_workers)
        assert n_workers <= cores, f"{n_workers} workers asked of a LocalCluster on {cores} cores"
        return real(n_workers=n_workers, **kw)

    monkeypatch.setattr(distributed, "LocalCluster", counting)
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "costs"\nsize = 16\n')
    assert batch.run_file(tmp_path / "jobs.toml", scheduler="local", workers=10**6, processes=False, quiet=True,
                          device="cpu") == 0
    assert started == [cores] and (tmp_path / "o" / "costs_size16_seed0.png").exists()
    err = capsys.readouterr().err
    assert f"--workers 1000000 is more than the {cores} core" in err and f"starting {cores} worker" in err


def test_batch_on_a_local_cluster_of_processes(tmp_path):
    pytest.importorskip("distributed")
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "costs"\nseeds = [1, 2]\nsize = 24\n'
                                        '[[job]]\npreset = "terrain"\nsize = 30\ntile = 16\nformats = "npy"\n')
    code, out, err = wd("batch", "jobs.toml", "--scheduler", "local", "--workers", 1, "--device", "cpu", "--quiet",
                        cwd=tmp_path)
    assert code == 0, err
    assert "3 run" in out
    names = sorted(p.name for p in (tmp_path / "o").iterdir())
    assert names == ["costs_size24_seed1.manifest.json", "costs_size24_seed1.png", "costs_size24_seed2.manifest.json",
                     "costs_size24_seed2.png", "terrain_size30_seed0.manifest.json", "terrain_size30_seed0.npy"]


@pytest.mark.parametrize("text, words", [
    ('out = "o"\n[[job]]\npreset = "lightning"\nseeds = [1, 2\n', ["does not parse", "line 4", "seeds = [1, 2"]),
    ('out = "o"\n[[job]]\npreset = "lightnin"\n', ["job 1", "did you mean 'lightning'"]),
    ('out = "o"\n[[job]]\npreset = "fractal"\nseedz = [1]\n', ["job 1 (fractal)", "'seedz'", "did you mean 'seed'"]),
    ('out = "o"\n[[job]]\npreset = "fractal"\ngrid = { chaep = [0.1] }\n', ["'chaep'", "did you mean 'cheap'"]),
    ('out = "o"\n[[job]]\npreset = "fractal"\nparams = { cheap = "lots" }\n', ["cheap", "'lots'"]),
    ('out = "o"\n[[job]]\npreset = "fractal"\nformats = ["tga"]\n', ["unknown format 'tga'"]),
    # terrain files: a range needs a 16-bit heightmap to scale, and a raw file a size its engine takes
    ('out = "o"\n[[job]]\npreset = "terrain"\nformats = ["npy", "tif"]\nrange = [0, 1]\n',
     ["job 1 (terrain)", "'range' scales 16-bit heightmaps", "writes none"]),
    ('out = "o"\n[[job]]\npreset = "terrain"\nformats = ["png"]\nrange = [0, 1]\n', ["writes none"]),
    ('out = "o"\n[[job]]\npreset = "terrain"\nformats = ["r16"]\nrange = [1, 0]\n',
     ["job 1 (terrain): 'range' expects LO,HI", "[1, 0]"]),
    ('out = "o"\n[[job]]\npreset = "terrain"\nformats = ["r16"]\nrange = "0,inf"\n', ["'range'", "'0,inf'"]),
    ('out = "o"\n[[job]]\npreset = "terrain"\nformats = ["png"]\nheightmap = "yes"\n',
     ["'heightmap' must be true or false"]),
    ('out = "o"\n[[job]]\npreset = "terrain"\nsizes = [65, 64]\nformats = ["raw"]\n',
     ["job 1 (terrain)", "64 x 64", "make it 65 x 65"]),
    ('out = "o"\n[[job]]\npreset = "terrain"\nsize = 48\ntile = 16\nformats = ["npy", "r16"]\n',
     ["tiled job's raw heightmaps ('r16', 'raw') need 'range'"]),
    ('out = "o"\n[[job]]\npreset = "terrain"\nsize = 48\ntile = 16\nformats = ["npy", "png"]\n',
     ["writes npy, zarr, r16, raw only, not 'png'"]),
    ('out = "o"\n[[job]]\npreset = "terrain"\nsize = 48\ntile = 16\nformats = ["raw"]\nrange = [0, 1]\n',
     ["48 x 48", "make it 33 x 33"]),
    ('out = "o"\n[[job]]\npreset = "lightning"\ntile = 64\n', ["'tile' is for"]),
    ('[[job]]\npreset = "fractal"\n', ["needs an output folder"]),
    ('out = "/proc/wdendrite-runs"\n[[job]]\npreset = "fractal"\nsize = 16\n', ["not writable"]),
    # a value given in two places would be overwritten silently, and the file names would lie
    ('out = "o"\n[[job]]\npreset = "lightning"\nseeds = [1, 2]\ngrid = { seed = [5, 6] }\n',
     ["job 1 (lightning)", "grid 'seed'", "one place"]),
    ('out = "o"\n[[job]]\npreset = "lightning"\nsize = 48\nparams = { shape = [32, 32] }\n',
     ["params 'shape'", "one place"]),
    ('out = "o"\n[[job]]\npreset = "fractal"\nsizes = [48, 0]\n', ["job 1 (fractal)", "'size'/'sizes'", "got 0"]),
    ('out = "o"\n[[job]]\npreset = "fractal"\nsize = 48.5\n', ["job 1 (fractal)", "got 48.5"]),
    ('out = "o"\n[[job]]\npreset = "fractal"\nformats = ["png", "PNG"]\n', ["'png' is listed twice"]),
    ('out = "o"\n[[job]]\npreset = "tree"\nformats = ["svg"]\n', ["3D", "drop 'svg'"]),
    ('out = "jobs.toml"\n[[job]]\npreset = "fractal"\n', ["is a file"]),
    ('out = "o"\n[[job]]\npreset = "fractal"\nseeds = [0, -1]\n', ["job 1 (fractal)", "[0, 2**32)", "got -1"]),
    ('out = "o"\n[[job]]\npreset = "terrain"\nformats = ["png", "npz"]\n', ["makes no dendrite", "'npz'"]),
    ('out = "o"\n[[job]]\npreset = "rock"\nformats = ["obj", "json"]\n', ["makes no dendrite", "'json'"]),
    # values the preset would refuse when it runs are refused before any task runs, naming the job
    ('out = "o"\n[[job]]\npreset = "costs"\n[[job]]\npreset = "fractal"\nsize = 4\n',
     ["job 2 (fractal)", "'size'", "got 4"]),
    ('out = "o"\n[[job]]\npreset = "fractal"\ngrid = { alpha = [2.0, 0.5] }\n', ["job 1 (fractal)", "'alpha'"]),
    ('out = "o"\n[[job]]\npreset = "terrain"\nsize = 40\ntile = 16\nformats = "npy"\nparams = { extent = -1 }\n',
     ["job 1 (terrain)", "'extent'", "-1"]),
    ('out = "o"\n[[job]]\npreset = "lightning"\nsize = 4\n', ["job 1 (lightning)", "'shape'", "(4, 4)"]),
    ('out = "o"\n[[job]]\npreset = "simple-dendrite"\nsize = 32\ngrid = { endpoints = [3, 0] }\n',
     ["job 1 (simple-dendrite)", "'endpoints'", "got 0"]),
    ('out = "o"\n[[job]]\npreset = "coral"\nparams = { refine_n = 2 }\n', ["job 1 (coral)", "'refine_n'"]),
    ('out = "o"\n[[job]]\npreset = "weight-distributions"\nsize = 32\nparams = { ns = [0, -1] }\n',
     ["job 1 (weight-distributions)", "'ns'", "-1"]),
    ('out = "o"\n[[job]]\npreset = "costs"\nsize = 16\n[[job]]\npreset = "terrain"\nsize = 256\n'
     'params = { extent = 1000000.0 }\n', ["job 2 (terrain)", "'extent' = 1000000.0 takes the image's pixel centres beyond"]),
    # a value listed twice (the error had blamed two jobs writing one file)
    ('out = "o"\n[[job]]\npreset = "fractal"\nsize = 16\nseeds = [0, 1, 0]\n', ["job 1 (fractal): 'seeds' lists 0 twice"]),
    ('out = "o"\n[[job]]\npreset = "fractal"\nsize = 16\ngrid = { alpha = [2.0, 3.0, 2.0] }\n',
     ["job 1 (fractal): grid 'alpha' lists 2.0 twice"]),
    # a parameter fixed and swept: the grid's value had silently won
    ('out = "o"\n[[job]]\npreset = "fractal"\nsize = 16\nparams = { alpha = 1.5 }\ngrid = { alpha = [2.0] }\n',
     ["job 1 (fractal): params 'alpha' and grid 'alpha' both set it; give it in one place"]),
    # TOML's numbers are numbers: text for one is refused (it had been read as the number)
    ('out = "o"\n[[job]]\npreset = "terrain"\nsize = 16\nparams = { levels = "3" }\n',
     ["job 1 (terrain) params 'levels' expects an integer, but got '3'", "without quotes"]),
    ('out = "o"\n[[job]]\npreset = "terrain"\nsize = 16\ngrid = { eps = ["0.1", 0.2] }\n',
     ["job 1 (terrain) grid 'eps' expects a number or numbers", "but got '0.1'"]),
    ('out = "o"\n[[job]]\npreset = "costs"\nsize = 16\n[[job]]\npreset = "weight-distributions"\nsize = 32\n'
     'params = { endpoints = 0 }\n', ["job 2 (weight-distributions)", "'endpoints'"]),
    ('out = "o"\n[[job]]\npreset = "fractal"\nsize = 100000\n', ["job 1 (fractal)", "2**31"]),
    ('out = "o"\n[[job]]\npreset = ["fractal"]\n', ["job 1", "needs a 'preset' name", "['fractal']"]),
    ('out = "o"\n[[job]]\npreset = "letters"\nformats = ["json", "png"]\ngrid = { text = ["Hi"] }\n'
     '[[job]]\npreset = "letters"\nformats = ["json"]\ngrid = { text = ["Hi.manifest"] }\n',
     ["would both write", "textHi.manifest.json"]),
    ('out = "o"\n[[job]]\nsize = 4\n', ["job 1", "needs a 'preset'"]),
    ('out = "o"\n[[job]]\npreset = "costs"\nname = 5\n', ["job 1 (costs)", "'name'", "got 5"]),
    ('out = "o"\n[[job]]\npreset = "costs"\nname = "' + "n" * 300 + '"\n', ["job 1 (costs)", "shorter 'name'"]),
    ('out = "o"\ndevice = "cuda:97"\n[[job]]\npreset = "costs"\n', ["job file 'jobs.toml': 'device'", "'cuda:97'"]),
])
def test_bad_job_files_exit_2_and_write_nothing(tmp_path, text, words):
    (tmp_path / "jobs.toml").write_text(text)
    code, out, err = wd("batch", "jobs.toml", cwd=tmp_path)
    assert code == 2, (out, err)
    assert "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jobs.toml"]


def test_unreachable_scheduler_exits_2(tmp_path):
    pytest.importorskip("distributed")
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "fractal"\nsize = 16\n')
    code, out, err = wd("batch", "jobs.toml", "--scheduler", "tcp://127.0.0.1:9", "--timeout", 1, cwd=tmp_path)
    assert code == 2 and "cannot reach the Dask scheduler" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jobs.toml"]
    # remote workers bring their own GPUs: this machine (none here) does not decide "cuda"; a
    # misspelt device is refused before anything is tried
    code, out, err = wd("batch", "jobs.toml", "--scheduler", "tcp://127.0.0.1:9", "--timeout", 1, "--device", "cuda",
                        cwd=tmp_path)
    assert code == 2 and "cannot reach the Dask scheduler" in err
    code, out, err = wd("batch", "jobs.toml", "--scheduler", "tcp://127.0.0.1:9", "--device", "gpu", cwd=tmp_path)
    assert code == 2 and "--device must be cpu, cuda or cuda:N" in err


@pytest.mark.parametrize("args, words", [
    (["--workers", "0", "--scheduler", "local"], ["--workers", "positive"]),
    (["--workers", "2"], ["--scheduler local"]),
    (["--timeout", "-1", "--scheduler", "local"], ["--timeout"]),
    (["--scheduler", "nowhere"], ["'nowhere'", "tcp://host:8786"]),
    (["--device", "cuda:9"], ["not available"]),
])
def test_bad_batch_options_exit_2(tmp_path, args, words):
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "fractal"\nsize = 16\n')
    code, out, err = wd("batch", "jobs.toml", *args, cwd=tmp_path)
    assert code == 2 and "Traceback" not in err, err
    for w in words:
        assert w in err, (w, err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jobs.toml"]


def test_load_jobs_rejects_duplicate_task_names(tmp_path):
    (tmp_path / "j.toml").write_text('out = "o"\n[[job]]\npreset = "costs"\n[[job]]\npreset = "costs"\n')
    with pytest.raises(UsageError, match="different 'name'"):
        batch.load_jobs(tmp_path / "j.toml")


def test_dry_run_lists_tasks_and_writes_nothing(tmp_path):
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "costs"\nseeds = [1, 2]\nsize = 16\n')
    code, out, err = wd("batch", "jobs.toml", "--dry-run", cwd=tmp_path)
    assert code == 0, err
    assert out.count("todo") == 2 and "costs_size16_seed2" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jobs.toml"]


def test_plain_cuda_is_left_alone_off_a_worker():
    assert batch.worker_device("cuda") == "cuda" and batch.worker_device("cpu") == "cpu"
    assert batch.worker_device(None) is None


def test_a_killed_batch_resumes_where_it_stopped(tmp_path):
    import signal
    import time

    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "costs"\nseeds = ' + str(list(range(40)))
                                        + '\nsize = 160\n')
    run = subprocess.Popen([sys.executable, "-m", "wdendrite.cli", "batch", "jobs.toml", "--quiet"], cwd=tmp_path,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    out = tmp_path / "o"
    deadline = time.time() + 120
    while run.poll() is None and time.time() < deadline and len(list(out.glob("*.png"))) < 3:
        time.sleep(0.005)
    run.send_signal(signal.SIGKILL)
    run.wait()
    staged_by_a_dead_writer(out / "costs_size160_seed39.png").write_bytes(b"half")  # as a killed write leaves
    mine = out / ".costs_size160_seed39.png.orig"  # files of the user's, named alike
    mine.write_bytes(b"mine")
    also_mine = out / ".wdendrite-costs_size160_seed39.png"
    also_mine.write_bytes(b"mine")
    # a task's manifest vouches for its parameters once its outputs are in (before, it only lists them)
    done = sum(json.loads(m.read_text())["params"] is not None for m in out.glob("*.manifest.json"))
    code, stdout, err = wd("batch", "jobs.toml", "--quiet", cwd=tmp_path)
    assert code == 0, err
    assert f"{40 - done} run, {done} already complete" in stdout
    assert len(list(out.glob("*.manifest.json"))) == 40 and len(list(out.glob("[!.]*.png"))) == 40
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == sorted([mine.name, also_mine.name])


def test_a_value_out_of_range_fails_its_task_only_with_exit_2(tmp_path):
    # more endpoints than the lattice has nodes: found only once the lattice is built (a value a
    # preset refuses outright, such as endpoints = 0, is refused before any task runs)
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "simple-dendrite"\nsize = 32\n'
                                        'grid = { endpoints = [3, 5000] }\n')
    code, out, err = wd("batch", "jobs.toml", "--quiet", cwd=tmp_path)
    assert code == 2 and "'endpoints' = 5000" in err and "Traceback" not in err
    names = sorted(p.name for p in (tmp_path / "o").iterdir())
    assert names == ["simple-dendrite_shape32x32_seed0_endpoints3.manifest.json",
                     "simple-dendrite_shape32x32_seed0_endpoints3.png"]


def test_a_value_a_preset_refuses_names_its_job(tmp_path):
    f = tmp_path / "jobs.toml"
    f.write_text('out = "runs"\n[[job]]\npreset = "fractal"\nsize = 32\n\n[[job]]\npreset = "dendry"\nsize = 32\n'
                 "params = { levels = 9 }\n")
    with pytest.raises(UsageError, match=r"job 2 \(dendry\): Expected 'levels' in \[1, 6\], but got 9"):
        batch.load_jobs(f)
    assert not (tmp_path / "runs").exists()


def test_job_names_keep_letters_of_any_script(tmp_path):
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "costs"\nname = "été"\nsize = 16\n'
                                        '[[job]]\npreset = "costs"\nname = "ötö"\nsize = 16\n'
                                        '[[job]]\npreset = "costs"\nname = "a/b c"\nsize = 16\n')
    tasks, _ = batch.load_jobs(tmp_path / "jobs.toml")
    assert [t.name.split("_")[0] for t in tasks] == ["été", "ötö", "a-b-c"]


def test_a_job_names_a_preset_by_its_function_too(tmp_path):
    # elm_tree and elm-tree are the command's "tree", in job files as on the command line
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "elm_tree"\nsize = 16\n'
                                        '[[job]]\npreset = "staghorn-coral"\nsize = 16\n'
                                        '[[job]]\npreset = "simple_dendrite"\nsize = 16\n')
    tasks, _ = batch.load_jobs(tmp_path / "jobs.toml")
    assert [t.preset for t in tasks] == ["tree", "coral", "simple-dendrite"]


def test_batch_refuses_files_it_did_not_make_unless_forced(tmp_path):
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "costs"\nsize = 16\nseeds = [1, 2]\n')
    (tmp_path / "o").mkdir()
    mine = tmp_path / "o" / "costs_size16_seed2.png"
    mine.write_bytes(b"a picture of mine")
    code, out, err = wd("batch", "jobs.toml", "--quiet", cwd=tmp_path)
    assert code == 2 and "costs_size16_seed2.png" in err and "--force" in err, err
    assert mine.read_bytes() == b"a picture of mine" and sorted(p.name for p in mine.parent.iterdir()) == [mine.name]
    code, out, err = wd("batch", "jobs.toml", "--dry-run", cwd=tmp_path)
    assert code == 0 and out.count("needs --force") == 1
    code, out, err = wd("batch", "jobs.toml", "--quiet", "--force", cwd=tmp_path)
    assert code == 0, err
    assert mine.read_bytes().startswith(b"\x89PNG")
    # files the batch made are its own: other parameters under the same name overwrite them unforced
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "costs"\nsize = 16\nseeds = [1, 2]\n'
                                        'params = { generators = 2 }\n')
    before = mine.read_bytes()
    code, out, err = wd("batch", "jobs.toml", "--quiet", cwd=tmp_path)
    assert code == 0 and "2 run" in out, err
    assert mine.read_bytes() != before
    assert json.loads((tmp_path / "o" / "costs_size16_seed2.manifest.json").read_text())["params"]["generators"] == 2


def test_a_tiled_job_computes_each_tile_once_for_all_its_outputs(tmp_path):
    shape, tile = (30, 26), 8

    calls = []

    def counted(window, die_after=None):
        if window[2:] != (1, 1):
            if die_after is not None and len(calls) == die_after:
                raise KeyboardInterrupt
            calls.append(window)
        return _ramp(window)

    outs = [tmp_path / "a.npy", tmp_path / "b.npy"]
    with pytest.raises(KeyboardInterrupt):
        batch.write_tiled(lambda w: counted(w, die_after=4), shape, tile, outs)
    assert not any(p.exists() for p in outs)  # neither file under its final name
    assert batch.write_tiled(counted, shape, tile, outs) == outs
    windows = batch.tile_windows(shape, tile)
    assert sorted(calls) == sorted(windows)  # each tile once over both runs, for both files
    for p in outs:
        assert np.array_equal(np.load(p), _ramp((0, 0, *shape)))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npy", "b.npy"]


def test_workers_on_one_host_take_different_gpus_whatever_their_names():
    class Client:
        def __init__(self, addresses):
            self.addresses = addresses

        def scheduler_info(self, n_workers=-1):
            return {"workers": {a: {} for a in self.addresses}}

    class Worker:
        def __init__(self, address, name, client):
            self.address, self.name, self.client = address, name, client

    addresses = ["tcp://10.0.0.1:4001", "tcp://10.0.0.1:39999", "tcp://10.0.0.2:4000", "tcp://10.0.0.1:5000"]
    client = Client(addresses)
    # names that hash alike, or that are not numbers at all, must not put two workers on one GPU
    workers = [Worker(a, f"worker-{k % 2}", client) for k, a in enumerate(addresses)]
    ranks = [batch._rank_on_host(w) for w in workers]
    assert ranks == [0, 2, 0, 1]  # per host, in the order of the addresses
    # the first worker restarts on a higher port: the others' places are asked again, not kept
    restarted = Worker("tcp://10.0.0.1:41000", "worker-0", client)
    client.addresses = [restarted.address] + addresses[1:]
    assert sorted(batch._rank_on_host(w) for w in (restarted, workers[1], workers[3])) == [0, 1, 2]


def test_a_batch_killed_before_a_manifest_keeps_its_files_its_own(tmp_path, monkeypatch):
    # killed after a task's outputs are in place but before its manifest: the next run redoes the
    # task instead of refusing the files as someone else's
    (tmp_path / "jobs.toml").write_text('out = "o"\nformats = ["png", "npy"]\n[[job]]\npreset = "costs"\nsize = 16\n')
    real = batch._manifest

    def killed(*args):
        raise KeyboardInterrupt

    monkeypatch.setattr(batch, "_manifest", killed)
    with pytest.raises(KeyboardInterrupt):
        batch.run_file(tmp_path / "jobs.toml", quiet=True)
    out = tmp_path / "o"
    assert {p.name for p in out.iterdir()} == {"costs_size16_seed0.png", "costs_size16_seed0.npy",
                                               "costs_size16_seed0.manifest.json"}
    monkeypatch.setattr(batch, "_manifest", real)
    assert batch.run_file(tmp_path / "jobs.toml", quiet=True) == 0
    assert json.loads((out / "costs_size16_seed0.manifest.json").read_text())["params"]["size"] == 16


def test_a_moved_project_keeps_its_files_and_odd_manifests_do_not_crash(tmp_path):
    first = tmp_path / "proj"
    first.mkdir()
    (first / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "costs"\nsize = 16\n')
    assert wd("batch", "jobs.toml", "--quiet", cwd=first)[0] == 0
    moved = tmp_path / "moved"
    first.rename(moved)
    (moved / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "costs"\nsize = 16\nparams = { generators = 2 }\n')
    code, out, err = wd("batch", "jobs.toml", "--quiet", cwd=moved)
    assert code == 0 and "1 run" in out, err
    # a manifest whose outputs are not file names vouches for nothing: the files count as foreign
    man = moved / "o" / "costs_size16_seed0.manifest.json"
    man.write_text(json.dumps({"params": None, "outputs": [["x"], {"y": 1}, 3]}))
    code, out, err = wd("batch", "jobs.toml", "--quiet", cwd=moved)
    assert code == 2 and "--force" in err and "Traceback" not in err, err
    assert wd("batch", "jobs.toml", "--quiet", "--force", cwd=moved)[0] == 0


@pytest.mark.parametrize("name", ["costs_size16_seed2.png", "costs_size16_seed2.manifest.json"])
def test_a_folder_in_the_way_of_an_output_is_refused_before_any_task(tmp_path, name):
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "costs"\nsize = 16\nseeds = [1, 2]\n')
    (tmp_path / "o" / name).mkdir(parents=True)
    code, out, err = wd("batch", "jobs.toml", "--dry-run", cwd=tmp_path)
    assert code == 0 and f"a folder is in the way: move '{name}'" in out, out
    for force in ([], ["--force"]):
        code, out, err = wd("batch", "jobs.toml", "--quiet", *force, cwd=tmp_path)
        assert code == 2 and "is a folder" in err, err
        assert sorted(p.name for p in (tmp_path / "o").iterdir()) == [name]


def test_a_file_of_the_users_named_as_a_manifest_is_not_overwritten_unforced(tmp_path):
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "costs"\nsize = 16\n')
    (tmp_path / "o").mkdir()
    notes = tmp_path / "o" / "costs_size16_seed0.manifest.json"
    notes.write_text('{"my": "notes"}')
    code, out, err = wd("batch", "jobs.toml", "--quiet", cwd=tmp_path)
    assert code == 2 and "manifest.json" in err and "--force" in err, err
    assert notes.read_text() == '{"my": "notes"}'
    assert wd("batch", "jobs.toml", "--quiet", "--force", cwd=tmp_path)[0] == 0
    assert json.loads(notes.read_text())["name"] == "costs_size16_seed0"


def test_tiled_outputs_replace_old_stores_and_links(tmp_path):
    zarr = pytest.importorskip("zarr")

    outs = [tmp_path / "t.npy", tmp_path / "t.zarr"]
    batch.write_tiled(_ramp, (20, 17), 8, outs)
    # the new image replaces an old store (a folder) and, through a link, leaves what it pointed at
    theirs = tmp_path / "elsewhere.npy"
    np.save(theirs, np.zeros(3))
    outs[0].unlink()
    outs[0].symlink_to(theirs)
    batch.write_tiled(lambda w: _ramp(w, 1.0), (20, 17), 8, outs)
    assert not outs[0].is_symlink() and np.array_equal(np.load(outs[0]), _ramp((0, 0, 20, 17), 1.0))
    assert np.array_equal(zarr.open_array(str(outs[1]), path="field", mode="r")[:], _ramp((0, 0, 20, 17), 1.0))
    assert np.array_equal(np.load(theirs), np.zeros(3))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["elsewhere.npy", "t.npy", "t.zarr"]


def test_a_tiled_image_killed_between_its_renames_is_not_computed_again(tmp_path, monkeypatch):
    outs = [tmp_path / "a.npy", tmp_path / "b.npy"]
    real = os.replace

    def dies_at_b(src, dst):
        if Path(dst) == outs[1]:
            raise KeyboardInterrupt  # killed after a.npy took its name, before b.npy did
        real(src, dst)

    monkeypatch.setattr(batch.os, "replace", dies_at_b)
    with pytest.raises(KeyboardInterrupt):
        batch.write_tiled(_ramp, (21, 19), 8, outs)
    monkeypatch.setattr(batch.os, "replace", real)
    assert outs[0].exists() and not outs[1].exists()
    calls = []
    batch.write_tiled(lambda w: calls.append(w) or _ramp(w), (21, 19), 8, outs)
    assert all(w[2:] == (1, 1) for w in calls)  # only the setup's corner probes: no tile again
    for p in outs:
        assert np.array_equal(np.load(p), _ramp((0, 0, 21, 19)))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npy", "b.npy"]
    # a plain file where a Zarr store goes is replaced like an old store
    zarr = pytest.importorskip("zarr")
    store = tmp_path / "c.zarr"
    store.write_text("not a store")
    batch.write_tiled(_ramp, (21, 19), 8, store)
    assert np.array_equal(zarr.open_array(str(store), path="field", mode="r")[:], _ramp((0, 0, 21, 19)))


def test_records_left_by_a_kill_vouch_only_for_the_file_they_renamed(tmp_path, monkeypatch):
    # killed while clearing its tile records (after every output took its name): a file put there
    # since, by the user or an untiled run, is not taken for the tiled image
    out = tmp_path / "a.npy"
    real = os.replace

    def dies(src, dst):
        if Path(src).name == ".a.tiles.npy" and out.exists():  # (the records leave in one rename)
            raise KeyboardInterrupt
        real(src, dst)

    monkeypatch.setattr(os, "replace", dies)
    with pytest.raises(KeyboardInterrupt):
        batch.write_tiled(_ramp, (20, 20), 8, out)
    monkeypatch.setattr(os, "replace", real)
    assert np.array_equal(np.load(out), _ramp((0, 0, 20, 20))) and (tmp_path / ".a.tiles.npy").is_dir()
    np.save(out, np.zeros((3, 3), np.float32))  # the user's own array under that name
    calls = []
    batch.write_tiled(lambda w: calls.append(w) or _ramp(w), (20, 20), 8, out)
    assert len([w for w in calls if w[2:] != (1, 1)]) == len(batch.tile_windows((20, 20), 8))
    assert np.array_equal(np.load(out), _ramp((0, 0, 20, 20)))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npy"]


def test_a_complete_tiled_task_has_the_records_a_kill_left_cleared(tmp_path, monkeypatch):
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "terrain"\nsize = 40\ntile = 16\n'
                                        'formats = "npy"\n')
    real = os.replace

    def dies(src, dst):
        if Path(src).name.endswith(".tiles.npy") and (tmp_path / "o" / "terrain_size40_seed0.npy").exists():
            raise KeyboardInterrupt  # after the manifest, while clearing the tile records
        real(src, dst)

    monkeypatch.setattr(os, "replace", dies)
    with pytest.raises(KeyboardInterrupt):
        batch.run_file(tmp_path / "jobs.toml", quiet=True, device="cpu")
    monkeypatch.setattr(os, "replace", real)
    out = tmp_path / "o"
    assert (out / ".terrain_size40_seed0.tiles.npy").is_dir()
    assert batch.run_file(tmp_path / "jobs.toml", quiet=True, device="cpu") == 0
    assert sorted(p.name for p in out.iterdir()) == ["terrain_size40_seed0.manifest.json", "terrain_size40_seed0.npy"]


def test_checking_a_preset_stops_before_its_weight_arrays(tmp_path, monkeypatch):
    # weight-distributions draws full-size weight arrays before its first lattice: a check (here a
    # dry run) must stop before them, and leave memory to the machine that runs the task
    from wdendrite import presets

    drawn = []
    monkeypatch.setattr(presets, "_polynomial", lambda *a: drawn.append(a))
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "weight-distributions"\nsizes = [6000]\n')
    assert batch.run_file(tmp_path / "jobs.toml", dry_run=True) == 0
    assert drawn == []


@pytest.mark.parametrize("paths", [[], ["a.npy", "./a.npy"]])
def test_write_tiled_refuses_no_paths_and_a_path_twice(tmp_path, monkeypatch, paths):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError, match="distinct output paths for 'path'"):
        batch.write_tiled(_ramp, (8, 8), 8, paths)
    assert not list(tmp_path.iterdir())


def test_write_tiled_refuses_bad_tiles_and_paths_before_writing(tmp_path):
    def value(window):
        return np.ones(window[2:], np.float32)

    for tile, exc, match in [(-1, ValueError, "'tile' >= 1, but got -1"), (0, ValueError, "'tile' >= 1"),
                             (2.5, TypeError, "'tile', but got 2.5"), (True, TypeError, "'tile', but got True")]:
        with pytest.raises(exc, match=match):
            batch.write_tiled(value, (5, 7), tile, tmp_path / "t.npy")
        with pytest.raises(exc, match=match):
            batch.dendry_array({"shape": (5, 7)}, tile=tile)
    with pytest.raises(ValueError, match="'.npy', '.zarr', '.r16' or '.raw'"):
        batch.write_tiled(value, (5, 7), 4, tmp_path / "t.txt")
    with pytest.raises(ValueError, match="'shape'"):
        batch.write_tiled(value, (5, 7, 2), 4, tmp_path / "t.npy")
    # a folder named like the output had been moved aside and deleted, with its contents
    (tmp_path / "data.npy").mkdir()
    (tmp_path / "data.npy" / "notes.txt").write_text("keep")
    with pytest.raises(ValueError, match="is a folder"):
        batch.write_tiled(value, (5, 7), 4, tmp_path / "data.npy")
    assert (tmp_path / "data.npy" / "notes.txt").read_text() == "keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data.npy"]


def test_zarr_chunks_fit_the_image_and_the_suffix_is_read_in_any_case(tmp_path):
    zarr = pytest.importorskip("zarr")

    def value(window):
        r0, c0, h, w = window
        return np.add.outer(np.arange(r0, r0 + h), np.arange(c0, c0 + w) * 100).astype(np.float32)

    out = batch.write_tiled(value, (5, 7), 8192, tmp_path / "v.ZARR")
    arr = zarr.open_array(str(out), path="field", mode="r")  # (an upper-case suffix had made an NPY file)
    assert arr.chunks == (5, 7) and np.array_equal(arr[:], value((0, 0, 5, 7)))


def test_tile_windows_name_a_bad_tile_and_write_tiled_a_missing_folder_before_any_tile(tmp_path):
    with pytest.raises(ValueError, match=r"'tile' >= 1, but got 0"):
        batch.tile_windows((10, 13), 0)
    # tiles are how an image outgrows int32 indices (2^32 pixels here); each side must still fit one
    tiles = batch.tile_windows((65536, 65536), 16384)
    assert len(tiles) == 16 and tiles[-1] == (49152, 49152, 16384, 16384)
    with pytest.raises(ValueError, match=r"'shape' \(2147483648, 8\) has a size of 2147483648"):
        batch.tile_windows((2**31, 8), 8)
    calls = []
    missing = tmp_path / "missing" / "x.npy"
    with pytest.raises(ValueError, match=rf"'path' {re.escape(repr(str(missing)))}: the folder .*missing' does not "
                                         "exist"):
        batch.write_tiled(lambda w: calls.append(w) or _ramp(w), (10, 13), 4, missing)
    assert calls == [] and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("suffix", [".npy", ".zarr"])
def test_tiles_of_several_threads_are_written_in_order_and_a_failure_stops_the_writes_there(tmp_path, suffix,
                                                                                           monkeypatch):
    if suffix == ".zarr":
        pytest.importorskip("zarr")
    import threading

    from wdendrite import _parallel

    monkeypatch.setattr(_parallel, "cores", lambda: 3)

    shape, tile = (29, 27), 6
    windows = batch.tile_windows(shape, tile)
    failing = windows[11]
    threads, written = set(), []

    def tiles(window, fail=True):
        if window[2:] != (1, 1):
            threads.add(threading.get_ident())
        if fail and window == failing:
            raise RuntimeError("tile failed")
        return _ramp(window)

    out = tmp_path / f"t{suffix}"
    with pytest.raises(RuntimeError, match="tile failed"):
        batch.write_tiled(tiles, shape, tile, out, workers=3, progress=lambda done, total: written.append(done))
    assert len(threads) == 3 and written == list(range(1, 12))  # the tiles before the failing one, in order
    again = []
    batch.write_tiled(lambda w: w[2:] == (1, 1) or again.append(w) or tiles(w, fail=False), shape, tile, out,
                      workers=3)
    assert sorted(again) == sorted(windows[11:])  # a resumed run computes only the tiles not written
    got = np.load(out) if suffix == ".npy" else __import__("zarr").open_array(str(out), path="field", mode="r")[:]
    assert np.array_equal(got, _ramp((0, 0, *shape)))
    with pytest.raises(ValueError, match=r"'workers' >= 1 \(or None: every core\), but got 0"):
        batch.write_tiled(_ramp, shape, tile, tmp_path / "u.npy", workers=0)
