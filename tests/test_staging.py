"""Writes under faults, in real processes: SIGKILL at every step of a write, a second writer of the
same output, a full disk (a small tmpfs of a private mount namespace, where the machine allows
one) and a file-size limit."""

import errno
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from wdendrite import _staging, batch

PY = sys.executable
RUN = "\nimport sys\nfrom wdendrite import cli\nsys.exit(cli.main(sys.argv[1:]))\n"


def wd(*args, cwd, hook="", env=None, fsize=None, wait=True):
    """Run the command in a child (``hook``: Python run first in it, to patch what a test needs;
    ``fsize``: its file-size limit in bytes); a CompletedProcess, or the Popen with ``wait=False``."""
    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))

    cmd = [PY, "-c", hook + RUN, *map(str, args)]
    kw = dict(cwd=cwd, env={**os.environ, **(env or {})}, preexec_fn=limit if fsize else None, text=True,
              stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if not wait:
        return subprocess.Popen(cmd, **kw)
    return subprocess.run(cmd, timeout=300, **kw)


def message(err: str) -> str:
    """The command's one line of error (Warp may add a warning of its own when it cannot load a
    CUDA driver under a limit or in a namespace), with no traceback."""
    lines = [line for line in err.splitlines() if line.startswith("wdendrite:")]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def staged_by_a_dead_writer(path) -> Path:
    """A file staged for ``path`` by a process that then ended without clearing it (as a kill leaves it)."""
    code = ("import os, sys; from wdendrite._staging import Staging; "
            "print(Staging().temporary(sys.argv[1], 0o644)); os._exit(0)")
    made = subprocess.run([PY, "-c", code, str(path)], capture_output=True, text=True, check=True)
    return Path(made.stdout.strip())


def _ramp(window):
    r0, c0, h, w = window
    return np.add.outer(np.arange(r0, r0 + h) * 1000.0, np.arange(c0, c0 + w)).astype(np.float32)


# --------------------------------------------------------------------------- SIGKILL during a write

def killed_at(k: int, work, call, *, ops=("chmod", "link", "replace", "unlink"), inside: bool = False) -> str | None:
    """Run ``call()`` in a forked child, in the folder ``work``, that sends itself SIGKILL at its
    ``k``-th file operation of ``ops`` (names of ``os`` functions) in that folder (``inside``: or
    anywhere below it); the operation and the file's name (``"replace a.png"``), or None when it
    finished first."""
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # (the child never returns into the test)
        try:
            os.close(read)
            os.chdir(work)
            count = [0]

            def counted(name, real):
                def call_(*args, **kwargs):
                    path = os.path.abspath(os.fspath(args[-1] if name in ("link", "replace") else args[0]))
                    if os.path.dirname(path) == os.getcwd() or (inside and path.startswith(os.getcwd() + os.sep)):
                        count[0] += 1
                        if count[0] == k:
                            os.write(write, f"{name} {os.path.basename(path)}".encode())
                            os.kill(os.getpid(), signal.SIGKILL)
                    return real(*args, **kwargs)
                return call_

            for name in ops:
                setattr(os, name, counted(name, getattr(os, name)))
            call()
            os._exit(0)
        except BaseException:
            os._exit(1)
    os.close(write)
    _, status = os.waitpid(pid, 0)
    with os.fdopen(read) as f:
        step = f.read()
    if os.WIFEXITED(status):
        assert os.WEXITSTATUS(status) == 0
        return None
    assert os.WTERMSIG(status) == signal.SIGKILL
    return step


OUTS = ["a.png", "a.npy", "a.json"]


def _contents(folder):
    return {n: (folder / n).read_bytes() for n in OUTS}


def _lightning(seed: int):
    """The run of ``lightning --size 24 --seed SEED -o a.png -o a.npy -o a.json --force`` in the working folder."""
    from wdendrite import cli
    from wdendrite._spec import all_presets

    preset = all_presets()["lightning"]
    values = {preset.size_param: preset.sized(24), "seed": seed}
    return lambda: cli.run_preset("lightning", values, OUTS, device="cpu", force=True)


def _references(tmp_path, monkeypatch):
    """The outputs of seed 1 (the old set, left in ``tmp_path / "seed1"``) and seed 2 (the new one)."""
    sets = []
    for seed in (1, 2):
        folder = tmp_path / f"seed{seed}"
        folder.mkdir()
        monkeypatch.chdir(folder)
        _lightning(seed)()
        sets.append(_contents(folder))
    monkeypatch.chdir(tmp_path)
    assert all(sets[0][n] != sets[1][n] for n in OUTS)
    return sets


def test_a_set_of_outputs_killed_at_any_step_is_whole_after_a_sweep(tmp_path, monkeypatch):
    # SIGKILL at each file operation of `-o a.png -o a.npy -o a.json --force` over an older set:
    # killed before the renames begin, the sweep leaves the old set; from the first rename on, it
    # completes the new one (the renames were journalled); nothing hidden stays either way
    old, new = _references(tmp_path, monkeypatch)
    work, steps, renaming = tmp_path / "work", [], False
    for k in range(1, 60):
        shutil.rmtree(work, ignore_errors=True)
        shutil.copytree(tmp_path / "seed1", work)
        step = killed_at(k, work, _lightning(2))
        if step is None:
            break
        steps.append(step.split()[0] + (" " + step.split()[1] if not step.split()[1].startswith(".") else ""))
        renaming = renaming or step.split()[0] in ("link", "replace")
        if k == 4:  # (before the renames: a.npy's temporary, written in full, is left hidden)
            staged = [n for n in os.listdir(work) if n.endswith(".a.npy") and n != _staging.lock_path("a.npy").name]
            assert not renaming and np.load(work / staged[0]).shape == (24, 24)
        _staging.sweep(work)
        assert _contents(work) == (new if renaming else old), step
        assert sorted(os.listdir(work)) == sorted(OUTS), step
    assert _contents(work) == new and sorted(os.listdir(work)) == sorted(OUTS)
    # staged (each file made, then given its mode), each old file kept by a hard link before its
    # rename, the links deleted, then what the staging and the locks leave
    assert steps[:12] == ["chmod"] * 6 + ["link", "replace a.png", "link", "replace a.npy", "link",
                                           "replace a.json"], steps
    assert steps[12:] == ["unlink"] * 13, steps


def test_a_path_changed_after_a_killed_writer_journalled_it_is_left_as_it_is(tmp_path, monkeypatch):
    old, new = _references(tmp_path, monkeypatch)
    work = tmp_path / "work"
    shutil.copytree(tmp_path / "seed1", work)
    # killed after a.png took its new name and a.npy's old file was kept (the 9th step)
    assert killed_at(9, work, _lightning(2)).startswith("link .wdendrite-")
    (work / "a.json").write_text("edited by hand meanwhile")
    _staging.sweep(work)
    assert (work / "a.png").read_bytes() == new["a.png"] and (work / "a.npy").read_bytes() == new["a.npy"]
    assert (work / "a.json").read_text() == "edited by hand meanwhile"
    assert sorted(os.listdir(work)) == sorted(OUTS)


def test_the_next_command_removes_what_killed_writers_left_and_nothing_else(tmp_path, monkeypatch):
    # a kill during the write of z.npy leaves its whole temporary (hidden); the next command run on
    # the folder, whatever it writes, deletes it, but not the files of a writer still running nor
    # files it did not make, however alike their names
    from wdendrite import cli

    monkeypatch.chdir(tmp_path)
    assert killed_at(2, tmp_path, lambda: cli.main(["terrain", "--size", "64", "-o", "z.npy", "--quiet"])) \
        .startswith("chmod")
    left = [n for n in os.listdir(tmp_path) if n.endswith(".z.npy") and n != _staging.lock_path("z.npy").name]
    assert len(left) == 1 and np.load(tmp_path / left[0]).shape == (64, 64)  # written in full
    live = subprocess.Popen([PY, "-c", "import sys; from wdendrite._staging import Staging; s = Staging(); "
                                       "print(s.temporary(sys.argv[1], 0o644), flush=True); sys.stdin.read()",
                             str(tmp_path / "y.png")], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        running = Path(live.stdout.readline().strip())
        alike = [".z.npy.ryf648pm.npy", ".wdendrite-z.npy", ".wdendrite-0123456789abcdef.run~",
                 "wdendrite-0123456789abcdef-1.z.npy", ".wdendrite-lock"]
        for name in alike:
            (tmp_path / name).write_text("mine")
        p = wd("fractal", "--size", 16, "-o", "other.png", "--quiet", cwd=tmp_path)
        assert p.returncode == 0, p.stderr
        assert running.exists() and not (tmp_path / left[0]).exists()
        assert all((tmp_path / name).read_text() == "mine" for name in alike)
    finally:
        live.stdin.close()
        live.wait()
    _staging.sweep(tmp_path)  # its writer has ended (without clearing up): now it goes
    assert sorted(os.listdir(tmp_path)) == sorted([*alike, "other.png"])


# --------------------------------------------------------------------------- a second writer

# the first tile is written, then the run waits for the file "go" in $CONTROL
PAUSE = """
import os, time
from pathlib import Path
from wdendrite import tiles
_real, _control = tiles._tile_into, Path(os.environ["CONTROL"])
def _paused(*args, **kwargs):
    out = _real(*args, **kwargs)
    (_control / "started").touch()
    while not (_control / "go").exists():
        time.sleep(0.01)
    return out
tiles._tile_into = _paused
"""


def _paused_run(args, cwd, control):
    control.mkdir()
    first = wd(*args, cwd=cwd, hook=PAUSE, env={"CONTROL": str(control)}, wait=False)
    deadline = time.time() + 120
    while not (control / "started").exists():
        assert first.poll() is None and time.time() < deadline, first.communicate()
        time.sleep(0.01)
    return first


def test_a_second_run_writing_a_tiled_output_stops_at_once_and_the_first_finishes(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    ref = wd("terrain", "--size", 64, "--seed", 5, "-o", tmp_path / "ref.npy", "--quiet", cwd=tmp_path)
    assert ref.returncode == 0, ref.stderr
    tiled = ["terrain", "--size", 64, "--tile", 16, "-o", out / "t.npy", "--quiet"]
    first = _paused_run([*tiled[:5], "--seed", 5, *tiled[5:]], tmp_path, tmp_path / "control")
    try:
        # another image into the same file, tiled or whole: refused at once, naming the first run
        for args in ([*tiled[:5], "--seed", 6, *tiled[5:], "--force"],
                     ["terrain", "--size", 64, "--seed", 6, "-o", out / "t.npy", "--force", "--quiet"]):
            p = wd(*args, cwd=tmp_path)
            assert p.returncode == 2, p.stderr
            assert message(p.stderr) == (f"wdendrite: error: {str(out / 't.npy')!r} is being written by another run "
                                         f"of wdendrite (process {first.pid}); wait until it has finished or write "
                                         "elsewhere")
    finally:
        (tmp_path / "control" / "go").touch()
    assert first.wait(timeout=300) == 0, first.communicate()
    assert np.array_equal(np.load(out / "t.npy"), np.load(tmp_path / "ref.npy"))  # seed 5's alone
    assert sorted(os.listdir(out)) == ["t.npy"]


def test_a_second_batch_on_the_same_folder_stops_at_once(tmp_path):
    (tmp_path / "jobs.toml").write_text('out = "o"\ndevice = "cpu"\n[[job]]\npreset = "terrain"\nsize = 64\n'
                                        'tile = 16\nformats = ["npy"]\n')
    first = _paused_run(["batch", "jobs.toml", "--quiet"], tmp_path, tmp_path / "control")
    try:
        p = wd("batch", "jobs.toml", "--quiet", cwd=tmp_path)
        assert p.returncode == 2, p.stderr
        assert message(p.stderr) == (f"wdendrite: error: another batch is running in {str(tmp_path / 'o')!r} "
                                     f"(process {first.pid}); wait until it has finished")
    finally:
        (tmp_path / "control" / "go").touch()
    assert first.wait(timeout=300) == 0, first.communicate()
    p = wd("batch", "jobs.toml", "--quiet", cwd=tmp_path)
    assert p.returncode == 0 and "0 run, 1 already complete" in p.stdout
    assert sorted(os.listdir(tmp_path / "o")) == ["terrain_size64_seed0.manifest.json", "terrain_size64_seed0.npy"]


def test_locks_are_exclusive_between_processes_and_stale_ones_are_swept(tmp_path):
    out = tmp_path / "x.png"
    holder = subprocess.Popen([PY, "-c", "import sys; from wdendrite._staging import locked\n"
                                         "with locked([sys.argv[1]]):\n    print('held', flush=True); sys.stdin.read()",
                               str(out)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "held\n"
        with pytest.raises(FileExistsError, match=f"process {holder.pid}"):
            with _staging.locked([out]):
                pass
        _staging.sweep(tmp_path)  # a held lock stays
        assert os.listdir(tmp_path) == [_staging.lock_path(out).name]
    finally:
        holder.kill()  # (killed: its lock file stays, unlocked)
        holder.wait()
    assert os.listdir(tmp_path) == [_staging.lock_path(out).name]
    with _staging.locked([out]):  # taken over
        pass
    assert os.listdir(tmp_path) == []
    subprocess.run([PY, "-c", "import os, sys; from wdendrite._staging import locked\n"
                              "with locked([sys.argv[1]]):\n    os._exit(0)", str(out)], check=True)
    _staging.sweep(tmp_path)
    assert os.listdir(tmp_path) == []


# --------------------------------------------------------------------------- a full disk


def test_a_tiled_npy_file_has_its_space_allocated_before_its_first_tile(tmp_path):
    def dies(window):
        if window[2:] != (1, 1):  # (the corner probes pass)
            raise KeyboardInterrupt
        return _ramp(window)

    with pytest.raises(KeyboardInterrupt):
        batch.write_tiled(dies, (300, 200), 64, tmp_path / "t.npy")
    partial = tmp_path / ".t.partial.npy"
    st = partial.stat()
    assert np.load(partial, mmap_mode="r").shape == (300, 200) and st.st_size > 300 * 200 * 4
    assert st.st_blocks * 512 >= st.st_size  # every byte allocated (a sparse file meets a full disk as SIGBUS)
    batch.write_tiled(_ramp, (300, 200), 64, tmp_path / "t.npy")  # resumed with ordinary writes
    assert np.array_equal(np.load(tmp_path / "t.npy"), _ramp((0, 0, 300, 200)))


def test_free_space_is_counted_per_disk_before_any_file_is_made(tmp_path, monkeypatch):
    needs = {tmp_path / "a.npy": 3 * 2**20, tmp_path / "b.npy": 2**20}
    with pytest.raises(OSError) as info:
        _staging.check_space(needs, free=lambda folder: 4 * 2**20 - 1)
    assert info.value.errno == errno.ENOSPC
    assert str(info.value).endswith(f"could not write {str(tmp_path / 'a.npy')!r}: it needs 4.0 MiB (with 1 more "
                                    "output on that disk), but its disk has 4.0 MiB free")
    _staging.check_space(needs, free=lambda folder: 4 * 2**20)
    # a 2000000-pixel square in 1024-pixel tiles (a 16 TB file) is refused before any file or tile
    calls = []
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (2**30, hard))  # (a guard: no test may write more)
    try:
        with pytest.raises(OSError) as info:
            batch.write_tiled(lambda w: calls.append(w) or _ramp(w), (2_000_000, 2_000_000), 1024,
                              tmp_path / "huge.npy")
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    assert info.value.errno == errno.ENOSPC and "it needs 14.6 TiB" in str(info.value)
    assert all(w[2:] == (1, 1) for w in calls) and os.listdir(tmp_path) == []


def test_a_file_size_limit_fails_a_tiled_run_in_one_line_and_a_rerun_finishes(tmp_path):
    ref = wd("terrain", "--size", 256, "--tile", 64, "-o", "ref.npy", "--quiet", cwd=tmp_path)
    assert ref.returncode == 0, ref.stderr
    out = tmp_path / "out"
    out.mkdir()
    p = wd("terrain", "--size", 256, "--tile", 64, "-o", "t.npy", "--quiet", cwd=out, fsize=64 * 1024)
    assert p.returncode == 1, p.stderr
    assert message(p.stderr) == (f"wdendrite: error: [Errno {errno.EFBIG}] could not write 't.npy': it needs 256.1 "
                                 "KiB, more than the largest file this process may write (ulimit -f)")
    assert os.listdir(out) == []
    p = wd("terrain", "--size", 256, "--tile", 64, "-o", "t.npy", "--quiet", cwd=out)
    assert p.returncode == 0, p.stderr
    assert np.array_equal(np.load(out / "t.npy"), np.load(tmp_path / "ref.npy")) and os.listdir(out) == ["t.npy"]


def test_a_disk_with_no_room_at_all_fails_in_one_line_naming_the_file_and_leaves_nothing(tmp_path):
    # the lock's process id and the NPY header had met the limit first: "[Errno 27] File too large",
    # naming no file, and the lock file stayed
    p = wd("terrain", "--size", 32, "--tile", 16, "-o", "t.npy", "--quiet", cwd=tmp_path, fsize=1)
    assert p.returncode == 1 and message(p.stderr) == (
        f"wdendrite: error: [Errno {errno.EFBIG}] could not write 't.npy': it needs 4.1 KiB, more than the largest "
        "file this process may write (ulimit -f)")
    p = wd("lightning", "--size", 24, "-o", "a.png", "--quiet", cwd=tmp_path, fsize=1)
    assert p.returncode == 1 and message(p.stderr).startswith(f"wdendrite: error: [Errno {errno.EFBIG}] could not "
                                                               "write 'a.png'")
    assert os.listdir(tmp_path) == []


SMALL_DISK = """
import json, os, subprocess, sys
DISK, OUT, RUN = sys.argv[1], sys.argv[2], sys.argv[3]
def mount(size, again=False):
    subprocess.run(["mount", "-t", "tmpfs", "-o", ("remount," if again else "") + "size=" + size, "tmpfs", DISK],
                   check=True)
def wd(*args, hook=""):
    p = subprocess.run([sys.executable, "-c", hook + RUN, *map(str, args)], cwd=DISK, capture_output=True, text=True,
                       timeout=300)
    return {"code": p.returncode, "err": p.stderr, "out": p.stdout, "files": sorted(os.listdir(DISK))}
result = {}
"""


def on_a_small_disk(tmp_path, body: str) -> dict:
    """Run ``body`` (Python, after :data:`SMALL_DISK`) as root of a private user and mount namespace,
    where ``mount(size)`` makes the folder ``DISK`` a tmpfs of its own: a real file system that
    fills up, gone when the namespace ends. Skipped where the system allows no such namespace."""
    unshare = shutil.which("unshare")
    ns = [unshare, "--user", "--map-root-user", "--mount"] if unshare else None
    if ns is None or subprocess.run([*ns, "true"], capture_output=True).returncode != 0:
        pytest.skip("no unprivileged user and mount namespaces here: no small file system to fill")
    disk, out = tmp_path / "disk", tmp_path / "out"
    disk.mkdir()
    out.mkdir()
    code = SMALL_DISK + body + "\nprint(json.dumps(result))\n"
    p = subprocess.run([*ns, PY, "-c", code, str(disk), str(out), RUN], capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout.splitlines()[-1])


def test_a_full_disk_stops_a_tiled_run_in_one_line_and_a_rerun_after_freeing_space_finishes(tmp_path):
    ref = wd("terrain", "--size", 256, "-o", "ref.npy", "--quiet", cwd=tmp_path)
    assert ref.returncode == 0, ref.stderr
    r = on_a_small_disk(tmp_path, """
tiled = ["terrain", "--size", 256, "--tile", 64, "--quiet"]
mount("160k")
result["checked"] = wd(*tiled, "-o", "t.npy")       # refused: 256 KiB do not fit
# the check fooled (another writer fills the disk meanwhile): the allocation finds the disk full
fooled = "from wdendrite import _staging\\n_staging.free_bytes = lambda folder: 2**50\\n"
result["allocated"] = wd(*tiled, "-o", "t.npy", hook=fooled)
nofallocate = fooled + ("import os\\ndef _no(*a): raise OSError(95, 'Operation not supported')\\n"
                        "os.posix_fallocate = _no\\n")
result["zeros"] = wd(*tiled, "-o", "t.npy", hook=nofallocate)  # (where the system cannot allocate: zeros)
result["zarr"] = wd(*tiled, "-o", "t.zarr")                   # compressed chunks fill it part way
mount("4m", again=True)                                     # space freed
result["again"] = wd(*tiled, "-o", "t.npy")
counting = ("import atexit\\nfrom wdendrite import tiles\\n_real, _n = tiles._tile_into, [0]\\n"
            "tiles._tile_into = lambda *a, **k: _n.__setitem__(0, _n[0] + 1) or _real(*a, **k)\\n"
            f"atexit.register(lambda: open({os.path.join(OUT, 'tiles')!r}, 'w').write(str(_n[0])))\\n")
result["zarr again"] = wd(*tiled, "-o", "t.zarr", hook=counting)  # resumed: only the tiles it lacks
import numpy as np, zarr, shutil
shutil.copy(os.path.join(DISK, "t.npy"), OUT)
np.save(os.path.join(OUT, "z.npy"), zarr.open_array(os.path.join(DISK, "t.zarr"), path="elevation", mode="r")[:])
""")
    for case in ("checked", "allocated", "zeros"):
        assert r[case]["code"] == 1 and r[case]["files"] == [], (case, r[case])
    assert message(r["checked"]["err"]).startswith(f"wdendrite: error: [Errno {errno.ENOSPC}] could not write "
                                                   "'t.npy': it needs 256.1 KiB, but its disk has ")
    for case in ("allocated", "zeros"):
        assert message(r[case]["err"]) == (f"wdendrite: error: [Errno {errno.ENOSPC}] could not write 't.npy': it "
                                           "needs 256.1 KiB, but its disk is full (or the user's quota reached)")
    # a Zarr store has no size to allocate: the tiles that found the disk full are redone
    assert r["zarr"]["code"] == 1 and ".t.tiles.zarr" in r["zarr"]["files"], r["zarr"]
    assert "could not write 't.zarr': No space left on device" in message(r["zarr"]["err"])
    assert r["again"]["code"] == 0 and r["again"]["files"] == [".t.partial.zarr", ".t.tiles.zarr", "t.npy"]
    assert r["zarr again"]["code"] == 0 and r["zarr again"]["files"] == ["t.npy", "t.zarr"], r["zarr again"]
    assert 0 < int((tmp_path / "out" / "tiles").read_text()) < 16  # of the 16 tiles
    for name in ("t.npy", "z.npy"):
        assert np.array_equal(np.load(tmp_path / "out" / name), np.load(tmp_path / "ref.npy")), name


def test_a_batch_on_a_full_disk_runs_its_other_tasks_and_resumes_after_freeing_space(tmp_path):
    r = on_a_small_disk(tmp_path, """
with open(os.path.join(DISK, "..", "jobs.toml"), "w") as f:
    f.write('out = "disk"\\ndevice = "cpu"\\n[[job]]\\npreset = "terrain"\\nsize = 256\\ntile = 64\\n'
            'formats = ["npy"]\\n[[job]]\\npreset = "costs"\\nsize = 16\\n')
mount("160k")
def batch():
    p = subprocess.run([sys.executable, "-c", RUN, "batch", "jobs.toml", "--quiet"], cwd=os.path.dirname(DISK),
                       capture_output=True, text=True, timeout=300)
    return {"code": p.returncode, "err": p.stderr, "out": p.stdout, "files": sorted(os.listdir(DISK))}
result["full"] = batch()
mount("4m", again=True)
result["again"] = batch()
""")
    full, again = r["full"], r["again"]
    assert full["code"] == 1 and "1 run, 0 already complete, 1 failed" in full["out"], full
    assert "costs_size16_seed0.png" in full["files"] and "terrain_size256_seed0.npy" not in full["files"]
    assert f"task terrain_size256_seed0 failed: OSError: [Errno {errno.ENOSPC}] could not write " in full["err"]
    assert again["code"] == 0 and "1 run, 1 already complete" in again["out"], again
    assert not [n for n in again["files"] if n.startswith(".")]


# --------------------------------------------------------------------------- the fault matrix


def under_file_limit(limit: int, work, call) -> int:
    """Run ``call()`` in a forked child, in the folder ``work``, whose writes fail beyond ``limit``
    bytes a file (RLIMIT_FSIZE: the kernel's EFBIG, a disk that fills up at that size, needing no
    privilege); its exit code: 0 done, 1 an OSError (the command's own code for it), 3 anything else."""
    pid = os.fork()
    if pid == 0:
        code = 3
        try:
            os.chdir(work)
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))
            result = call()
            code = result if isinstance(result, int) else 0
        except OSError:
            code = 1
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    return os.WEXITSTATUS(status) if os.WIFEXITED(status) else -1


def fault_matrix(root: Path, *, tiles: int = 32) -> dict:
    """SIGKILL at every file operation of two writes, and a file-size limit at every size up to
    their files', each followed by what a user does next:

    - ``set``: ``lightning -o a.png -o a.npy -o a.json --force`` over an older set, then any
      command on the folder (its sweep);
    - ``tiled``: ``terrain --size TILES --tile 16 -o t.npy -o t.zarr``, then the same command
      again, and once more with ``--force`` if it refuses an output as existing;
    - ``set full``, ``tiled full``: the same writes failing at the limit (exit code 1 expected),
      then the next command and the same write without the limit.

    Returns ``{scenario: {"faults": kills tried, "lost": outputs missing or neither old nor new
    (tiled: not the image), "mixed": sets holding old and new files (tiled: the two files
    differing), "leftovers": files beside the outputs after the next command, "refused": (tiled)
    kills after which the same command refused an output it had made and needed ``--force``,
    "finished": (tiled) kills after the run had done all it shows (both outputs in place, no tile
    records left): the same command then refuses the outputs, as after any complete run}}``.
    """
    from wdendrite import cli

    report, cwd = {}, pytest.MonkeyPatch()
    try:
        old, new = _references(root, cwd)
    finally:
        cwd.undo()
    counts = report["set"] = dict(faults=0, lost=0, mixed=0, leftovers=0)
    for k in range(1, 200):
        work = root / "set"
        shutil.rmtree(work, ignore_errors=True)
        shutil.copytree(root / "seed1", work)
        if killed_at(k, work, _lightning(2)) is None:
            break
        counts["faults"] += 1
        _staging.sweep(work)  # (the first step of any command on the folder)
        got = {n: (work / n).read_bytes() if (work / n).exists() else None for n in OUTS}
        counts["lost"] += sum(got[n] not in (old[n], new[n]) for n in OUTS)
        counts["mixed"] += any(got[n] == old[n] for n in OUTS) and any(got[n] == new[n] for n in OUTS)
        counts["leftovers"] += len(set(os.listdir(work)) - set(OUTS))
    import zarr

    ref = root / "ref.npy"
    assert cli.main(["terrain", "--size", str(tiles), "-o", str(ref), "--quiet", "--device", "cpu"]) == 0
    counts = report["tiled"] = dict(faults=0, lost=0, mixed=0, leftovers=0, refused=0, finished=0)
    for k in range(1, 2000):
        work = root / "tiled"
        shutil.rmtree(work, ignore_errors=True)
        work.mkdir()
        command = ["terrain", "--size", str(tiles), "--tile", "16", "-o", str(work / "t.npy"), "-o",
                   str(work / "t.zarr"), "--quiet", "--device", "cpu"]
        if killed_at(k, work, lambda: cli.main(command), inside=True,
                     ops=("open", "mkdir", "chmod", "link", "replace", "unlink", "rmdir")) is None:
            break
        counts["faults"] += 1
        records = [n for n in os.listdir(work) if n.startswith(".t.")]  # (tiles, partial files)
        done = cli.main(command) == 0
        if not done and all((work / n).exists() for n in ("t.npy", "t.zarr")):
            counts["refused" if records else "finished"] += 1
            done = cli.main([*command, "--force"]) == 0
        a = np.load(work / "t.npy") if done else None
        b = zarr.open_array(str(work / "t.zarr"), path="elevation", mode="r")[:] if done else None
        counts["lost"] += (not done) or not np.array_equal(a, np.load(ref))
        counts["mixed"] += done and not np.array_equal(a, b)
        counts["leftovers"] += len(set(os.listdir(work)) - {"t.npy", "t.zarr"})

    # the disk "fills up" at each size below the largest file written: every write fails cleanly
    limits = sorted({0, 1, 100} | {n for f in OUTS for n in (len(new[f]) - 1, len(new[f]) // 2)})
    counts = report["set full"] = dict(faults=0, lost=0, mixed=0, leftovers=0, unclean=0)
    for limit in limits:
        work = root / "set"
        shutil.rmtree(work, ignore_errors=True)
        shutil.copytree(root / "seed1", work)
        code = under_file_limit(limit, work, _lightning(2))
        counts["faults"] += 1
        counts["unclean"] += code != 1
        _staging.sweep(work)
        got = {n: (work / n).read_bytes() if (work / n).exists() else None for n in OUTS}
        counts["lost"] += sum(got[n] not in (old[n], new[n]) for n in OUTS)
        counts["mixed"] += any(got[n] == old[n] for n in OUTS) and any(got[n] == new[n] for n in OUTS)
        counts["unclean"] += any(got[n] != old[n] for n in OUTS)  # (a failed write leaves the old set whole)
        counts["leftovers"] += len(set(os.listdir(work)) - set(OUTS))
        assert under_file_limit(2**40, work, _lightning(2)) == 0  # space freed: the write goes through
        counts["lost"] += sum((work / n).read_bytes() != new[n] for n in OUTS)
    npy_bytes = len(np.load(ref).tobytes()) + 128
    counts = report["tiled full"] = dict(faults=0, lost=0, mixed=0, leftovers=0, unclean=0)
    for limit in (0, 1, 128, npy_bytes // 2, npy_bytes - 1):
        work = root / "tiled"
        shutil.rmtree(work, ignore_errors=True)
        work.mkdir()
        command = ["terrain", "--size", str(tiles), "--tile", "16", "-o", str(work / "t.npy"), "-o",
                   str(work / "t.zarr"), "--quiet", "--device", "cpu"]
        counts["faults"] += 1
        counts["unclean"] += under_file_limit(limit, work, lambda: cli.main(command)) != 1
        counts["leftovers"] += len([n for n in os.listdir(work) if not n.startswith(".t.")])  # (records: kept to resume)
        done = under_file_limit(2**40, work, lambda: cli.main(command)) == 0
        a = np.load(work / "t.npy") if done else None
        b = zarr.open_array(str(work / "t.zarr"), path="elevation", mode="r")[:] if done else None
        counts["lost"] += (not done) or not np.array_equal(a, np.load(ref))
        counts["mixed"] += done and not np.array_equal(a, b)
        counts["leftovers"] += len(set(os.listdir(work)) - {"t.npy", "t.zarr"})
    return report


def test_kills_at_every_step_lose_mix_and_leave_nothing(tmp_path):
    report = fault_matrix(tmp_path)
    for scenario, counts in report.items():
        assert counts["lost"] == counts["mixed"] == counts["leftovers"] == counts.get("refused", 0) == 0, \
            (scenario, counts)
        assert counts.get("unclean", 0) == 0, (scenario, counts)  # (every full disk: exit 1, one line)
    assert report["set"]["faults"] >= 25 and report["tiled"]["faults"] >= 20, report
    assert report["set full"]["faults"] >= 6 and report["tiled full"]["faults"] == 5, report


if __name__ == "__main__":  # python tests/test_staging.py: the fault matrix as a table
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        print(f"{'scenario':>10} {'faults':>7} {'lost':>5} {'mixed':>6} {'leftovers':>10} {'refused':>8} "
              f"{'finished':>9} {'unclean':>8}")
        for scenario, c in fault_matrix(Path(tmp)).items():
            print(f"{scenario:>10} {c['faults']:>7} {c['lost']:>5} {c['mixed']:>6} {c['leftovers']:>10} "
                  f"{c.get('refused', '-'):>8} {c.get('finished', '-'):>9} {c.get('unclean', '-'):>8}")
