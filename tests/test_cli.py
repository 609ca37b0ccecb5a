"""The `wdendrite` command, run as a real subprocess (exit codes, messages, files), plus its registry."""

import itertools
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from wdendrite import cli
from wdendrite._spec import UsageError, all_presets


def wd(*args, cwd):
    """Run the command; returns (exit code, stdout, stderr)."""
    # no time limit of its own: a first run compiles kernels, minutes on a loaded machine with an empty
    # cache; the suite's limit per test (pytest-timeout, in pyproject.toml) stops a run that hangs
    p = subprocess.run([sys.executable, "-m", "wdendrite.cli", *map(str, args)], cwd=cwd, capture_output=True,
                       text=True)
    return p.returncode, p.stdout, p.stderr


def bad(args, tmp_path, *words):
    """The command fails with exit code 2, a message holding ``words`` and no traceback."""
    code, out, err = wd(*args, cwd=tmp_path)
    assert code == 2, (code, out, err)
    assert "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    return err


def test_main_job_writes_the_fractal(tmp_path):
    # the README's main job, exactly
    code, out, err = wd("fractal", "--size", 256, "-o", "fractal.png", "--force", cwd=tmp_path)
    assert code == 0, err
    img = np.asarray(Image.open(tmp_path / "fractal.png"))
    assert img.shape == (256, 256) and img.max() > 0 and "fractal.png" in out and "endpoints" in out
    # same seed, same picture
    code, _, err = wd("fractal", "--size", 256, "-o", "again.png", "--quiet", cwd=tmp_path)
    assert code == 0, err
    assert np.array_equal(np.asarray(Image.open(tmp_path / "again.png")), img)


def test_help_lists_every_preset_and_parameter_with_default_and_unit(tmp_path):
    code, out, _ = wd("--help", cwd=tmp_path)
    assert code == 0 and "exit codes" in out and "--seed INT" in out
    main = subprocess.run([sys.executable, "-m", "wdendrite", "--help"], capture_output=True, text=True, cwd=tmp_path)
    assert main.returncode == 0 and main.stdout == out
    code, version, _ = wd("--version", cwd=tmp_path)
    assert code == 0 and version.startswith("wdendrite ")
    for name in ("lightning", "tree", "coral", "lichen", "moss", "rock", "fractal", "letters", "competition",
                 "terrain", "dendry", "costs", "batch"):
        assert name in out
    # presets named after their models also answer to their functions' names
    assert "tree (elm-tree)" in out and "coral (staghorn-coral)" in out and "lichen (lichen-on-rock)" in out
    code, out, _ = wd("lightning", "--help", cwd=tmp_path)
    assert code == 0
    assert "--glow-radius X Blur radius of the halo (pixels), > 0 (default: 14.0) [pixels]" in " ".join(out.split())
    parser = cli.build_parser()
    subs = parser._subparsers._group_actions[0].choices
    for name, preset in all_presets().items():
        text = " ".join(subs[name].format_help().split())
        for prm in preset.params.values():
            if prm.name in ("seed", "size"):
                continue
            assert "--" + prm.name.replace("_", "-") in text, (name, prm.name)
            assert "(default:" in text
        # docstrings' reST reads as plain words on a terminal
        assert "``" not in text and not re.search(r":\w+:`", text), (name, text)
        if preset.size_param:
            # a picture's side is in pixels, a lattice's in nodes
            unit = "pixels" if name in ("dendry", "terrain") else "nodes"
            # a shape's largest side, else the one length that sizes the preset, in its own words
            what = "largest side" if preset.size_param in ("shape", "size") else re.escape(
                preset.params[preset.size_param].doc.rstrip("."))
            assert re.search(r"--size N " + what + r"; sets '\w+' \(default: \d+\) \[" + unit + r"\]", text), (name, text)
        if "shape" in preset.params:  # a 2D preset's shape is (H, W), a 3D one's (D, H, W)
            assert ("(D, H, W)" in text) == preset.meshes, (name, text)


def test_formats_from_the_suffix(tmp_path):
    outs = ["l.png", "l.npy", "l.npz", "l.json", "l.svg"]
    code, _, err = wd("lightning", "--size", 48, "--forks", 2, "--minor-forks", 2, "--main-width", "3,2",
                      *sum((["-o", o] for o in outs), []),
                      "--quiet", cwd=tmp_path)
    assert code == 0, err
    assert np.asarray(Image.open(tmp_path / "l.png")).shape == (48, 48, 3)
    assert np.load(tmp_path / "l.npy").shape == (48, 48)
    from wdendrite.io import load_dendrite

    den, width = load_dendrite(tmp_path / "l.npz")
    den2, _ = load_dendrite(tmp_path / "l.json")
    assert den.shape == (48, 48) and np.array_equal(den.nodes, den2.nodes) and len(width) == len(den)
    assert (tmp_path / "l.svg").read_text().startswith("<svg")
    meshes = ["t.glb", "t.obj", "t.ply", "t.stl"]
    code, _, err = wd("tree", "--size", 16, "--endpoints", 4, *sum((["-o", o] for o in meshes), []), "--quiet",
                      cwd=tmp_path)
    assert code == 0, err
    import trimesh

    for m in meshes:
        mesh = trimesh.load(tmp_path / m, force="mesh")
        assert len(mesh.faces) > 0, m


def test_heightmap_and_npy_equal_the_dendry_function(tmp_path):
    code, out, err = wd("terrain", "--size", 40, "--no-rivers", "-o", "t.png", "-o", "t.npy", "--heightmap",
                        "--device", "cpu", "--quiet", cwd=tmp_path)
    assert code == 0, err
    z = np.load(tmp_path / "t.npy")
    assert f"grey 0 = {z.min():.6g}, 65535 = {z.max():.6g}" in out
    preset = all_presets()["terrain"]
    setup = cli.dendry_setup(40, preset.groups["params"][0], extent=4.0, control="perlin", frequency=1.0,
                             drained=True, seed=0)
    from wdendrite.dendry import dendry

    assert np.array_equal(z, dendry(**setup, output="elevation", device="cpu"))
    png = Image.open(tmp_path / "t.png")
    assert png.mode.startswith("I") and np.asarray(png).max() == 65535 and np.asarray(png).min() == 0


@pytest.mark.parametrize("seed", [2**32, -1])
def test_one_seed_range_on_the_command_line_in_config_and_job_files(tmp_path, seed):
    # lightning had taken 2**32 from the command line and a config file (its own generator takes
    # any integer), while job files and the weights refuse it: every way in now says the same
    (tmp_path / "c.toml").write_text(f"seed = {seed}\n")
    (tmp_path / "jobs.toml").write_text(f'out = "o"\n[[job]]\npreset = "lightning"\nsize = 24\nseed = {seed}\n')
    for args, where in ((["--seed", seed], "--seed"), (["--config", "c.toml"], "config key 'seed'")):
        bad(["lightning", "--size", 24, *args, "-o", "l.png"], tmp_path, where, "[0, 2**32)", f"got {seed}")
    bad(["batch", "jobs.toml"], tmp_path, "job 1 (lightning)", "'seed'", "[0, 2**32)", f"got {seed}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.toml", "jobs.toml"]
    # the library's own seeds refuse the same values
    import wdendrite as wd

    with pytest.raises(ValueError, match=re.escape("[0, 2**32)")):
        wd.weights.Uniform(seed=seed)


def test_config_file_and_command_line_override(tmp_path):
    (tmp_path / "c.toml").write_text("size = 40\nseed = 3\ncheap = 0.5\n")
    code, _, err = wd("fractal", "--config", "c.toml", "-o", "a.png", "--quiet", cwd=tmp_path)
    assert code == 0, err
    assert np.asarray(Image.open(tmp_path / "a.png")).shape == (40, 40)
    code, _, err = wd("fractal", "--config", "c.toml", "--size", 32, "-o", "b.png", "--quiet", cwd=tmp_path)
    assert code == 0, err
    assert np.asarray(Image.open(tmp_path / "b.png")).shape == (32, 32)
    (tmp_path / "bad.toml").write_text("size = 40\nchaep = 0.5\n")
    bad(["fractal", "--config", "bad.toml", "-o", "c.png"], tmp_path, "'chaep'", "did you mean 'cheap'")
    (tmp_path / "broken.toml").write_text("size = 40\ncheap = = 1\n")
    bad(["fractal", "--config", "broken.toml", "-o", "c.png"], tmp_path, "line 2", "cheap = = 1")
    (tmp_path / "half.toml").write_text("size = 64.5\n")
    bad(["fractal", "--config", "half.toml", "-o", "c.png"], tmp_path, "config key 'size'", "64.5")
    assert not (tmp_path / "c.png").exists()
    # TOML has numbers and booleans: text for them is refused, as 'size = "32"' always was ('levels =
    # "3"' and 'drained = "false"' had been read as 3 and False, while 'levels = 3.0' was refused)
    for text, key in (('levels = "3"', "levels"), ('eps = "0.1"', "eps"), ('drained = "false"', "drained"),
                      ("levels = 3.0", "levels")):
        (tmp_path / "text.toml").write_text(text + "\n")
        words = ["without quotes"] if '"' in text else []
        bad(["terrain", "--size", "16", "--config", "text.toml", "-o", "t.png"], tmp_path, f"config key '{key}'",
            *words)
    (tmp_path / "typed.toml").write_text("levels = 3\neps = 0.1\ndrained = false\ncontrol = \"ridged\"\n")
    assert cli.main(["terrain", "--size", "16", "--config", str(tmp_path / "typed.toml"), "-o",
                     str(tmp_path / "t.png"), "--quiet"]) == 0


def test_unknown_preset_and_option_suggest_the_nearest(tmp_path):
    bad(["lightnin"], tmp_path, "did you mean 'lightning'")
    bad(["fractal", "--sed", "3"], tmp_path, "'--sed'", "did you mean '--seed'")


def test_only_names_a_few_edits_away_are_suggested(capsys):
    # '--colour' is no typo of '--count' (it had been suggested); '--cuont' is
    assert cli.main(["fractal", "--colour", "red"]) == 2
    err = capsys.readouterr().err
    assert "unrecognized option '--colour' for 'fractal'" in err and "did you mean" not in err
    assert cli.main(["fractal", "--cuont", "3"]) == 2
    assert "did you mean '--count'?" in capsys.readouterr().err


def _edit_counts(alphabet: str, longest: int, swaps: bool) -> dict:
    """Least single edits between every two words of up to ``longest`` letters, by breadth-first search
    (insert, delete, substitute; with ``swaps`` also swapping two neighbours)."""
    words = [""] + ["".join(w) for n in range(1, longest + 1) for w in itertools.product(alphabet, repeat=n)]

    def steps(w):
        for i in range(len(w) + 1):
            for ch in alphabet:
                yield w[:i] + ch + w[i:]
        for i in range(len(w)):
            yield w[:i] + w[i + 1:]
            for ch in alphabet:
                yield w[:i] + ch + w[i + 1:]
            if swaps and i + 1 < len(w):
                yield w[:i] + w[i + 1] + w[i] + w[i + 2:]

    out = {}
    for a in words:
        seen, frontier, k = {a: 0}, [a], 0
        while frontier:
            k += 1
            frontier = [v for w in frontier for v in steps(w) if len(v) <= longest + 1 and v not in seen]
            for v in frontier:
                seen.setdefault(v, k)
        out.update({(a, b): seen[b] for b in words})
    return out


def test_edit_counts_lie_between_brute_force_searches_with_and_without_swaps():
    from wdendrite._spec import edits

    with_swaps, plain = _edit_counts("abc", 3, True), _edit_counts("abc", 3, False)
    for (a, b), d in plain.items():
        assert with_swaps[(a, b)] <= edits(a, b) <= d, (a, b)
        if a[::-1] != a and len(a) == 2:  # one swap of neighbours is one edit
            assert edits(a, a[::-1]) == 1
    assert (edits("kitten", "sitting"), edits("chaep", "cheap"), edits("colour", "count")) == (3, 1, 4)


@pytest.mark.parametrize("preset, listed", [
    ("lightning", ".png, .npy, .tif, .r16, .raw, .npz, .json, .svg"),
    ("terrain", ".png, .npy, .tif, .r16, .raw"),
    ("tree", ".png, .npy, .tif, .r16, .raw, .obj, .ply, .stl, .glb, .npz, .json"),
    ("rock", ".png, .npy, .tif, .r16, .raw, .obj, .ply, .stl, .glb"),
])
def test_an_unknown_suffix_lists_only_what_the_preset_writes(preset, listed, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main([preset, "-o", "x.jpg"]) == 2
    err = capsys.readouterr().err
    assert err == f"wdendrite: error: -o/--out 'x.jpg': unknown suffix '.jpg'; use one of {listed}\n"
    assert not list(tmp_path.iterdir())


def test_bad_values_are_named(tmp_path):
    bad(["lightning", "--size", 48, "--forks", -1, "-o", "l.png"], tmp_path, "forks")
    bad(["lightning", "--size", 48, "--forks", "many", "-o", "l.png"], tmp_path, "--forks", "integer", "'many'")
    bad(["dendry", "--size", 32, "--levels", 9, "-o", "d.png"], tmp_path, "levels")
    bad(["lightning", "--size", 48, "--main-width=-4,2", "-o", "l.png"], tmp_path, "--main-width", "'start'")
    bad(["lightning", "--size", 48, "--main-width", "4,2,1,pth", "-o", "l.png"], tmp_path, "'along'", "'pth'")
    bad(["dendry", "--size", 32, "--control", "perlinn", "-o", "d.png"], tmp_path, "did you mean 'perlin'")
    bad(["fractal", "--size", 4, "-o", "f.png"], tmp_path, "--size")
    # a shape derived from --size is named as such
    bad(["moss", "--size", 16, "-o", "m.png"], tmp_path, "'shape'", "--size 16 gives shape=(7, 16, 16)")
    assert "gives shape" not in bad(["moss", "--size", 24, "--endpoints", 0, "-o", "m.png"], tmp_path, "endpoints")
    bad(["fractal", "--size", 32, "--device", "gpu", "-o", "f.png"], tmp_path, "--device", "'gpu'")
    bad(["fractal", "--size", 32, "--device", "cuda:7", "-o", "f.png"], tmp_path, "not available")
    bad(["lightning", "--size", 48, "-o", "l.glb"], tmp_path, "no mesh")
    bad(["fractal", "--size", 32, "-o", "f.tga"], tmp_path, "unknown suffix", ".png")
    # known formats a run does not write are named as such, with what to do instead
    bad(["terrain", "--size", 32, "-o", "t.zarr"], tmp_path, "written tile by tile: add --tile N")
    bad(["terrain", "--size", 32, "--tile", 16, "-o", "t.png"], tmp_path, "'.png' is not written tile by tile",
        ".npy, .zarr")
    bad(["fractal", "--size", 32, "-o", "f.png", "-o", "./f.png"], tmp_path, "given twice")
    assert not list(tmp_path.iterdir())


def test_outputs_are_never_clobbered_or_half_written(tmp_path):
    (tmp_path / "f.png").write_bytes(b"keep")
    bad(["fractal", "--size", 32, "-o", "f.png"], tmp_path, "exists", "--force")
    assert (tmp_path / "f.png").read_bytes() == b"keep"
    (tmp_path / "file").write_text("not a folder")
    bad(["fractal", "--size", 32, "-o", "file/f.png"], tmp_path, "not a folder")
    bad(["fractal", "--size", 32, "-o", "missing/f.png"], tmp_path, "does not exist")
    bad(["fractal", "--size", 32, "-o", "/proc/f.png"], tmp_path, "not writable")
    # the preset fails after the outputs were checked (rock has no dendrite): nothing is left behind
    bad(["rock", "--size", 16, "-o", "r.png", "-o", "r.npz"], tmp_path, "no dendrite")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.png", "file"]
    # a folder in the way, even with --force, and SVG for a 3D preset: refused before any work
    (tmp_path / "dir.png").mkdir()
    bad(["fractal", "--size", 32, "-o", "ok.png", "-o", "dir.png", "--force"], tmp_path, "dir.png", "is a folder")
    bad(["tree", "--size", 16, "-o", "t.png", "-o", "t.svg"], tmp_path, "3D", "SVG")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir.png", "f.png", "file"]


@pytest.mark.parametrize("ctl", ["perlin", "ridged", "radial", "plane", "lichtenberg"])
def test_every_terrain_control_makes_a_terrain(tmp_path, ctl):
    # every --control the terrain offers is one terrains take (values in [0, 1])
    rec = cli.run_preset("terrain", {"size": 24, "control": ctl}, [tmp_path / "t.npy"], device="cpu")
    assert np.isfinite(np.load(tmp_path / "t.npy")).all() and rec["outputs"]


@pytest.mark.parametrize("links", [True, False])
def test_a_failed_rename_puts_back_what_earlier_renames_replaced(links, tmp_path, monkeypatch):
    # three outputs, the first replacing a file: the third rename fails, so the first path holds
    # its old bytes again, the second (new) path is gone, and nothing temporary is left; also
    # where the file system makes no hard links (the old file is then moved aside)
    import os

    (tmp_path / "a.npy").write_bytes(b"keep")
    real, calls = os.replace, []
    if not links:
        monkeypatch.setattr(os, "link", lambda *a, **k: (_ for _ in ()).throw(OSError("no hard links here")))

    def flaky(src, dst):
        calls.append(dst)
        if str(dst).endswith("c.png"):
            raise OSError("device went away")
        return real(src, dst)

    monkeypatch.setattr(os, "replace", flaky)
    outs = [tmp_path / "a.npy", tmp_path / "b.npz", tmp_path / "c.png"]
    with pytest.raises(OSError, match="device went away"):
        cli.run_preset("fractal", {"size": 24}, outs, device="cpu", force=True)
    assert (tmp_path / "a.npy").read_bytes() == b"keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npy"]
    assert any(str(d).endswith("c.png") for d in calls)


@pytest.mark.parametrize("links", [True, False])
def test_a_failed_rename_onto_an_existing_output_keeps_it_and_leaves_nothing(links, tmp_path, monkeypatch):
    # the rename onto a path that holds a file fails: that file keeps its bytes and no copy of
    # it is left beside it, with or without hard links
    import os

    (tmp_path / "a.npy").write_bytes(b"keep")
    real, onto = os.replace, []

    def flaky(src, dst):  # the first rename onto a.npy (the staged file's) fails; putting back works
        if str(dst) == str(tmp_path / "a.npy"):
            onto.append(src)
            if len(onto) == 1:
                raise OSError("device went away")
        return real(src, dst)

    monkeypatch.setattr(os, "replace", flaky)
    if not links:
        monkeypatch.setattr(os, "link", lambda *a, **k: (_ for _ in ()).throw(OSError("no hard links here")))
    with pytest.raises(OSError, match="device went away"):
        cli.run_preset("fractal", {"size": 16}, [tmp_path / "a.npy", tmp_path / "b.png"], device="cpu", force=True)
    assert (tmp_path / "a.npy").read_bytes() == b"keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npy"]


def test_a_read_only_output_is_replaced_and_stays_read_only(tmp_path):
    # the staged file is written while its owner may write it, and takes the old file's mode
    # just before the rename (which does not need the old file to be writable)
    import os
    import stat

    from wdendrite import io

    for name, write in [("a.npy", lambda: cli.run_preset("fractal", {"size": 16}, [tmp_path / "a.npy"],
                                                         device="cpu", force=True)),
                        ("b.txt", lambda: io.atomic_write(tmp_path / "b.txt", lambda p: open(p, "w").write("new"),
                                                          overwrite=True))]:
        (tmp_path / name).write_bytes(b"old")
        os.chmod(tmp_path / name, 0o444 | stat.S_ISUID)
        write()
        assert (tmp_path / name).read_bytes() != b"old"
        assert (tmp_path / name).stat().st_mode & 0o7777 == 0o444  # (set-id bits are not carried over)


def test_a_link_to_a_device_replaced_with_force_gives_the_new_file_a_file_s_mode(tmp_path):
    # /dev/null is 0o666 for everyone: the file that replaces a link to it takes what a new file
    # gets under the umask, not the device's mode (a link to a regular file still passes its mode on)
    import os

    (tmp_path / "null.png").symlink_to("/dev/null")
    (tmp_path / "kept.npy").write_bytes(b"old")
    os.chmod(tmp_path / "kept.npy", 0o640)
    (tmp_path / "link.npy").symlink_to(tmp_path / "kept.npy")
    old = os.umask(0o077)
    try:
        assert cli.main(["fractal", "--size", "16", "-o", str(tmp_path / "null.png"), "-o", str(tmp_path / "link.npy"),
                         "--force", "--quiet", "--device", "cpu"]) == 0
    finally:
        os.umask(old)
    for name, mode in (("null.png", 0o600), ("link.npy", 0o640)):
        out = tmp_path / name
        assert not out.is_symlink() and out.is_file(), name
        assert out.stat().st_mode & 0o777 == mode, (name, oct(out.stat().st_mode))
    assert (tmp_path / "kept.npy").read_bytes() == b"old"


def test_outputs_are_written_all_or_nothing(tmp_path, monkeypatch):
    # the second output fails while being written: the first is not left behind, and a file
    # already at the first path keeps its bytes
    from wdendrite import io

    (tmp_path / "c.png").write_bytes(b"keep")

    def broken(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(io, "save_dendrite", broken)
    with pytest.raises(OSError, match="disk full"):
        cli.run_preset("fractal", {"size": 32}, [tmp_path / "c.png", tmp_path / "c.npz"], device="cpu", force=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.png"]
    assert (tmp_path / "c.png").read_bytes() == b"keep"
    monkeypatch.undo()
    rec = cli.run_preset("fractal", {"size": 32}, [tmp_path / "c.png", tmp_path / "c.npz"], device="cpu", force=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.npz", "c.png"] and len(rec["outputs"]) == 2
    assert Image.open(tmp_path / "c.png").size[0] > 0


def test_a_write_the_system_refuses_is_one_line_naming_the_output(tmp_path, monkeypatch, capsys):
    # a full disk is no bug: one line naming the output (not a traceback), exit 1, nothing left
    import errno

    from wdendrite import io

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(io, "save_dendrite", full)
    out = tmp_path / "c.npz"
    assert cli.main(["fractal", "--size", "32", "-o", str(tmp_path / "c.png"), "-o", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert err == f"wdendrite: error: [Errno {errno.ENOSPC}] could not write {str(out)!r}: No space left on device\n"
    assert os.listdir(tmp_path) == []


def test_unexpected_failure_exits_with_1(monkeypatch, capsys):
    preset = all_presets()["costs"]

    def broken(**kwargs):
        raise RuntimeError("boom")

    monkeypatch.setattr(preset, "func", broken)
    assert cli.main(["costs", "--size", "16", "-o", "/tmp/never-written-by-wdendrite.png", "--quiet"]) == 1
    assert "boom" in capsys.readouterr().err


def test_run_preset_record_lists_every_parameter(tmp_path):
    rec = cli.run_preset("costs", {"size": 16, "generators": 2}, [tmp_path / "c.npy"], device="cpu")
    assert rec["params"] == {"size": 16, "generators": 2, "seed": 0} and rec["device"] == "cpu"
    assert np.load(tmp_path / "c.npy").shape == (16, 16)
    json.dumps(rec)


def test_a_new_preset_appears_with_typed_documented_options(monkeypatch, tmp_path):
    from dataclasses import dataclass
    from typing import Literal

    from wdendrite import _spec, presets

    @dataclass(frozen=True)
    class GlowParams:
        radius: float = 2.0
        """Halo radius (pixels)."""
        seed: int = 5
        """Shadowed by the function's own seed."""

    def sparkle(shape=(40, 40), *, colour: Literal["red", "blue"] = "red", gains: tuple[float, ...] = (1.0, 0.5),
                limit: int | None = None, smooth: bool = True, mask=None, params: GlowParams = GlowParams(),
                seed: int = 0):
        """Sparkles on a dark sky.

        Args:
            colour: the sparkle colour.
            gains: brightness of each layer.
        """
        from wdendrite._models import Made

        img = np.zeros((*shape, 3), np.float32)
        img[..., 0 if colour == "red" else 2] = params.radius / 4
        return Made(img, parts={"field": img[..., 0] + (limit or 0)})

    monkeypatch.setattr(presets, "sparkle", sparkle, raising=False)
    monkeypatch.setattr(presets, "__all__", [*presets.__all__, "sparkle"])
    monkeypatch.setattr(_spec, "_CACHE", {})
    p = all_presets()["sparkle"]
    kinds = {k: (v.kind, v.choices, v.group) for k, v in p.params.items()}
    assert kinds == {"shape": ("ints", (), None), "colour": ("choice", ("red", "blue"), None),
                     "gains": ("floats", (), None), "limit": ("int?", (), None), "smooth": ("bool", (), None),
                     "radius": ("float", (), "GlowParams"), "seed": ("int", (), None)}
    assert p.fixed == ["mask"] and p.size_param == "shape" and p.summary == "Sparkles on a dark sky."
    assert p.params["colour"].doc == "the sparkle colour." and p.params["radius"].doc == "Halo radius (pixels)."
    help_text = " ".join(cli.build_parser()._subparsers._group_actions[0].choices["sparkle"].format_help().split())
    assert "--colour {red,blue} the sparkle colour; one of red, blue (default: red)" in help_text
    assert cli.main(["sparkle", "--size", "16", "--colour", "blue", "--radius", "4", "--limit", "none",
                     "-o", str(tmp_path / "s.npy"), "--quiet"]) == 0
    assert np.load(tmp_path / "s.npy").shape == (16, 16)
    assert cli.main(["sparkle", "--colour", "bleu", "-o", str(tmp_path / "t.png")]) == 2


def test_tiled_terrain_from_the_command_equals_the_whole_image(tmp_path):
    code, out, err = wd("dendry", "--size", 45, "--output", "elevation", "--tile", 16, "-o", "d.npy", "--quiet",
                        "--device", "cpu", cwd=tmp_path)
    assert code == 0, err
    preset = all_presets()["dendry"]
    setup = cli.dendry_setup(45, preset.groups["params"][0], extent=4.0, control="perlin", frequency=1.0,
                             drained=False, seed=0)
    from wdendrite.dendry import dendry

    assert np.array_equal(np.load(tmp_path / "d.npy"), dendry(**setup, output="elevation", device="cpu"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.npy"]
    bad(["terrain", "--size", 45, "--tile", 16, "-o", "t.png"], tmp_path, "'.png'", ".npy, .zarr")
    bad(["terrain", "--size", 45, "--tile", 4, "-o", "t.npy"], tmp_path, "--tile")


def test_a_size_the_whole_image_refuses_is_refused_in_tiles_too(tmp_path):
    # `--size 1 --tile 8` had written a 1 x 1 terrain that `--size 1` refuses
    def line(err):
        return [x for x in err.splitlines() if x.startswith("wdendrite:")]

    whole = bad(["terrain", "--size", 1, "-o", "t.npy"], tmp_path, "'size' >= 2", "got 1", "(--size)")
    tiled = bad(["terrain", "--size", 1, "--tile", 8, "-o", "t.npy"], tmp_path)
    assert line(tiled) == line(whole)
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "terrain"\nsize = 1\ntile = 8\n'
                                        'formats = ["npy"]\n')
    bad(["batch", "jobs.toml"], tmp_path, "job 1 (terrain)", "'size' >= 2")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jobs.toml"]


def test_a_terrain_written_as_npy_alone_skips_its_picture(tmp_path, monkeypatch):
    # shading and drainage take longer than the terrain: only a picture output should pay for them
    from wdendrite import _models

    made = []
    real = _models.relief
    monkeypatch.setattr(_models, "relief", lambda *a, **k: made.append(1) or real(*a, **k))
    cli.run_preset("terrain", {"size": 32}, [tmp_path / "t.npy"], device="cpu")
    assert made == [] and np.load(tmp_path / "t.npy").shape == (32, 32)
    cli.run_preset("terrain", {"size": 32}, [tmp_path / "t.png", tmp_path / "u.npy"], device="cpu")
    assert made == [1]
    np.testing.assert_array_equal(np.load(tmp_path / "t.npy"), np.load(tmp_path / "u.npy"))


def test_a_deferred_picture_that_fails_leaves_no_output(tmp_path, monkeypatch):
    # the picture is made with the model, before the first output is written
    from wdendrite import _models

    def broken(*args, **kwargs):
        raise MemoryError("no room for the picture")

    monkeypatch.setattr(_models, "relief", broken)
    with pytest.raises(MemoryError):
        cli.run_preset("terrain", {"size": 32}, [tmp_path / "t.npy", tmp_path / "t.png"], device="cpu")
    assert list(tmp_path.iterdir()) == []


def test_an_upper_case_suffix_writes_the_file_named(tmp_path):
    # NumPy appends ".npy" to a name not ending in it: f.NPY must still hold the field
    cli.run_preset("fractal", {"size": 24}, [tmp_path / "f.NPY"], device="cpu")
    assert np.load(tmp_path / "f.NPY").shape == (24, 24)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.NPY"]


def test_outputs_with_long_names_are_staged_once(tmp_path, monkeypatch):
    # the command stages every output beside its path and renames them together; the writers must
    # not stage again inside (a second, longer temporary name), and a 255-byte name must work
    from wdendrite._staging import Staging

    made = []
    real = Staging.temporary

    def spy(self, path, mode):
        made.append(path)
        return real(self, path, mode)

    monkeypatch.setattr(Staging, "temporary", spy)
    long = tmp_path / ("b" * 251 + ".png")
    cli.run_preset("fractal", {"size": 32}, [long, tmp_path / "f.npz"], device="cpu")
    assert long.exists() and (tmp_path / "f.npz").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([long.name, "f.npz"])
    assert len(made) == 2  # one temporary per output, made by the command


def test_every_output_reaches_the_disk_before_the_renames(tmp_path, monkeypatch):
    # each staged file is flushed before any of them takes its name; then the folder is
    from wdendrite import _staging, io

    events = []
    real_sync, real_folder, real_replace = io.sync_to_disk, _staging.sync_folder, os.replace
    monkeypatch.setattr(io, "sync_to_disk", lambda p: (events.append(("file", Path(p).suffix)), real_sync(p)))
    monkeypatch.setattr(_staging, "sync_folder", lambda p: (events.append(("folder", Path(p))), real_folder(p)))
    monkeypatch.setattr(os, "replace", lambda a, b: (events.append(("rename", Path(b).suffix)), real_replace(a, b)))
    cli.run_preset("fractal", {"size": 32}, [tmp_path / "f.png", tmp_path / "f.npz"], device="cpu")
    assert events == [("file", ".png"), ("file", ".npz"), ("rename", ".png"), ("rename", ".npz"), ("folder", tmp_path)]


@pytest.mark.parametrize("args, config, words", [
    (["tropisms", "--size", "32"], "toward = []\n", ["config key 'toward'", "but got []"]),
    (["weight-distributions", "--size", "32"], "ns = []\n", ["config key 'ns'", "but got []"]),
    (["simple-dendrite"], "shape = [64, 32]\nsize = 100\n", ["gives 'size' and 'shape'"]),
    (["dla-imitation", "--size", "32", "--alpha", "0"], None, ["positive finite number for 'alpha'"]),
    (["dla-imitation", "--size", "32", "--alpha", "1e308"], None, ["'alpha' = 1e+308 over 'iterations' = 4"]),
    (["fractal-grid", "--cell", "32", "--iterations", "1000000000000"], None, ["'iterations' = 1000000000000"]),
    (["dendry", "--size", "32", "--frequency", "1e308"], None, ["'frequency' = 1e+308", "2**22"]),
    (["terrain", "--size", "32", "-o", "t.png", "-o", "t.npz"], None, ["'terrain' makes no dendrite"]),
    (["rock", "--size", "16", "-o", "r.svg"], None, ["'rock' makes no dendrite", "or a mesh"]),
    # the formats named are the preset's own (dendry had been told to write .npz, .json or .svg)
    (["dendry", "--size", "16", "-o", "d.obj"], None, ["'dendry' makes no mesh (it is 2D); write .png, .npy, .tif, .r16 "
                                                         "or .raw"]),
    (["lightning", "--size", "16", "-o", "l.stl"], None, ["'lightning' makes no mesh (it is 2D); write .png, .npy, "
                                                           ".tif, .r16, .raw, .npz, .json or .svg"]),
    (["fractal", "--size", "16", "-o", "b" * 300 + ".png"], None, ["File name too long"]),
    (["tropism-objects", "--size", "16", "--seed", "-1"], None, ["--seed expects an integer in [0, 2**32)",
                                                           "but got -1"]),
    (["tropisms", "--size", "8"], None, ["'endpoints' = 20 is more than fit in the upper three quarters of the 8 x 8"]),
    # a library check names the Python parameter; the command adds its option
    (["lightning", "--size", "32", "--forks", "-1"], None, ["'forks' >= 0, but got -1 (--forks)"]),
    (["lightning", "--size", "32", "--glow-radius", "-3"], None, ["'glow_radius', but got -3.0 (--glow-radius)"]),
    (["fractal", "--size", "32", "--alpha", "0.9"], None, ["'alpha' must be > 1", "(--alpha)"]),
    (["dendry", "--size", "32", "--output", "d.png"], None, ["--output expects one of distance, elevation, level",
                                                            "output files are named with -o/--out"]),
    (["tree", "--size", "16", "--geometry", "cones"], None,
     ["--geometry expects one of smooth, tubes, spheres, isosurface"]),
    # a distance image with no branch in view had made an all-black heightmap said to span [0, 0]
    (["dendry", "--size", "24", "--control", "lichtenberg", "--extent", "0.05", "--levels", "1", "-o", "h.png",
      "--heightmap"], None, ["--heightmap: the field has no finite value", "nothing was written"]),
    (["dendry", "--size", "32", "--tile", "8", "--heightmap", "-o", "x.npy"], None,
     ["--heightmap makes .png outputs, which --tile does not write"]),
    # refused only once the terrain was made, naming an internal 'z'
    (["terrain", "--size", "1", "-o", "s.png"], None, ["'size' >= 2, but got 1 (--size)"]),
    # 1 / resolution overflowed float32: an all-NaN file was written
    (["dendry", "--size", "16", "--output", "elevation", "--resolution", "1e-40", "-o", "z.npy"], None,
     ["'resolution' in [1e-30, 1000000.0], but got 1e-40 (--resolution)"]),
    # every node a generator had made NaN bands (refused at the save); 99999999 had run 24 s first
    (["costs", "--size", "8", "--generators", "1000"], None, ["'generators' <= 64", "but got 1000 (--generators)"]),
    (["costs", "--size", "8", "--generators", "99999999"], None, ["'generators' <= 64", "(--generators)"]),
    # the schedule from so large a d had overflowed its endpoint counts, blamed on --count and --beta
    (["fractal", "--size", "32", "--d", "1e30"], None, ["'d' <= ", "but got 1e+30 (--d)"]),
    (["tropisms", "--size", "32", "--toward", "left,left", "--roots", "right"], None,
     ["'toward' lists ('left', 'right') twice", "(--toward)"]),
    (["tropisms", "--size", "32", "--toward", "left,top"], None,
     ["one entry of 'roots' per entry of 'toward' (2), or one for all, but got 8", "(--roots, --toward)"]),
    (["weight-distributions", "--size", "32", "--ns", "1,1.0"], None, ["'ns' lists 1.0 twice", "(--ns)"]),
    # a value the config file gave is said to come from it, not from an option never given
    (["tropism-objects", "--size", "16"], "seed = -3\n", ["config key 'seed' in 'c.toml'", "but got -3"]),
])
def test_more_bad_input_exits_2_with_one_line_naming_it(args, config, words, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    if config is not None:
        (tmp_path / "c.toml").write_text(config)
        args = [*args, "--config", "c.toml"]
    assert cli.main([*args, "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err and "endpoints' = 24" not in err
    for w in words:
        assert w in err, (w, err)
    assert not list(tmp_path.iterdir()) or [p.name for p in tmp_path.iterdir()] == ["c.toml"]


def test_the_fractal_takes_every_growth_parameter(tmp_path, monkeypatch):
    # the schedule's options reach the growth: fewer first endpoints and a steeper attenuation
    # make fewer endpoints, and d and epsilon in weight units replace the size-relative defaults
    monkeypatch.chdir(tmp_path)
    made = {}
    for name, extra in [("default", []), ("few", ["--count", "2", "--alpha", "3"]),
                        ("explicit", ["--d", str(1.2 * 96), "--epsilon", str(0.12 * 96)])]:
        assert cli.main(["fractal", "--size", "96", *extra, "-o", f"{name}.npz", "--quiet"]) == 0
        made[name] = np.load(tmp_path / f"{name}.npz")["nodes"]
    assert len(made["few"]) < len(made["default"])
    np.testing.assert_array_equal(made["explicit"], made["default"])


def test_huge_but_valid_values_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["letters", "--size", "32", "--paths-per-1000", "1e308", "-o", "l.png", "--quiet"]) == 0
    assert cli.main(["lightning", "--size", "32", "--glow-radius", "1e308", "-o", "g.npy", "--quiet"]) == 0
    assert np.isfinite(np.load(tmp_path / "g.npy")).all()


def test_a_tiled_terrain_refused_by_its_tiles_leaves_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for extent in ("1e30", "270000"):  # refused at every pixel; refused only far from the origin
        assert cli.main(["terrain", "--size", "64", "--tile", "16", "--extent", extent, "-o", "big.npy",
                         "--quiet"]) == 2
        assert not list(tmp_path.iterdir())  # no hidden partial file, no tile marks


def test_a_reader_that_goes_away_does_not_make_a_finished_run_fail(tmp_path):
    p = subprocess.run(f"{sys.executable} -m wdendrite.cli fractal --size 16 -o f.png --quiet | true",
                       shell=True, cwd=tmp_path, capture_output=True, text=True)  # (no time limit: see wd)
    assert "Traceback" not in p.stderr and (tmp_path / "f.png").exists()
    p = subprocess.run(["bash", "-c", f"set -o pipefail; {sys.executable} -m wdendrite.cli fractal --size 16 "
                                      "-o g.png --quiet | true"], cwd=tmp_path, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr


def test_a_run_with_stdout_and_stderr_closed_finishes(tmp_path):
    # Python then has no sys.stderr: the progress bar (shown after half a second) must stay off,
    # it had failed inside tqdm's lock and hung the run
    p = subprocess.run(["bash", "-c", f"{sys.executable} -m wdendrite.cli terrain --size 256 -o t.png >&- 2>&-"],
                       cwd=tmp_path)
    assert p.returncode == 0 and (tmp_path / "t.png").exists()


@pytest.mark.parametrize("value", ["nan", "inf", "2.5"])
def test_a_bad_integer_for_a_common_option_is_one_line(value, capsys):
    for option in ("--size", "--seed"):
        with pytest.raises(SystemExit) as exc:
            cli.main(["fractal", option, value])
        err = capsys.readouterr().err.strip()
        assert exc.value.code == 2 and len(err.splitlines()) == 1, err
        assert f"argument {option}: invalid int value: '{value}'" in err and "--help" in err


def test_a_tiled_output_whose_partial_file_name_would_be_too_long_is_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["terrain", "--size", "32", "--tile", "8", "-o", "a" * 244 + ".npy", "--quiet"]) == 2
    assert "2 bytes too long" in capsys.readouterr().err and not list(tmp_path.iterdir())
    assert cli.main(["terrain", "--size", "32", "--tile", "8", "-o", "a" * 240 + ".npy", "--quiet"]) == 0


@pytest.mark.parametrize(
    "model, kw, exc, match",
    [
        # each was refused only after the noise control's range had been sampled with kernels, or not at all
        ("dendry", dict(extent=1e7), ValueError, r"'extent' = 10000000.0 takes the image's pixel centres beyond .*below about 2.1648e\+06 domain units"),
        ("dendry", dict(params={}), TypeError, "DendryParams for 'params', but got dict"),
        ("dendry", dict(output="height"), ValueError, "'output'"),
        ("dendry", dict(control="radial", frequency=-1), ValueError, "'frequency', but got -1"),
        ("dendry", dict(control="cone"), ValueError, "'control'"),
        ("dendry", dict(drained="no"), TypeError, "'drained', but got 'no'"),
        ("dendry", dict(seed=-1), ValueError, "'seed'"),
        ("terrain", dict(rivers="no"), TypeError, "'rivers', but got 'no'"),
        ("terrain", dict(extent=1e6), ValueError, r"'extent' = 1000000.0 .*below about 270600 domain units at size 16"),
        ("terrain", dict(extent=1e-44), ValueError, r"'extent' = 1e-44 makes a 'domain' .* the image refuses: The mapping"),
    ],
)
def test_dendry_models_check_everything_before_any_kernel(model, kw, exc, match, launches):
    from wdendrite import _models

    with pytest.raises(exc, match=match):
        getattr(_models, model)(16, **kw)
    assert launches == []


def test_a_link_to_a_missing_file_is_not_clobbered(tmp_path, monkeypatch, capsys):
    # exists() follows links: a dangling one was replaced by the output without --force
    monkeypatch.chdir(tmp_path)
    for args in (["dendry", "--size", "16", "-o", "link.png"], ["dendry", "--size", "16", "--tile", "8", "-o", "l.npy"]):
        link = Path(args[-1])
        link.symlink_to("missing" + link.suffix)
        assert cli.main([*args, "--quiet"]) == 2
        assert "is a link to a missing file; pass --force" in capsys.readouterr().err
        assert link.is_symlink() and {p.name for p in tmp_path.iterdir()} <= {"l.npy", "link.png"}
    from wdendrite import io

    with pytest.raises(FileExistsError, match="link to a missing file"):
        io.save_png(tmp_path / "link.png", np.zeros((4, 4)))


def test_heightmap_scales_the_finite_values_and_paints_inf_white(tmp_path):
    from wdendrite import heightmaps

    z = np.array([[0.0, np.inf], [1.0, 2.0]])
    assert cli._heightmap(z) == (0.0, 2.0, 0) and cli._heightmap(z, (0.5, 1.5)) == (0.5, 1.5, 2)
    heightmaps.save_heightmap(tmp_path / "z.png", z)
    np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "z.png")), [[0, 65535], [32768, 65535]])
    with pytest.raises(UsageError, match="NaN"):
        cli._heightmap(np.array([[0.0, np.nan]]))


def test_exponents_of_weight_distributions_may_be_any_real_number(tmp_path, monkeypatch, capsys):
    prm = all_presets()["weight-distributions"].params["ns"]
    assert prm.convert("0.5,2") == (0.5, 2.0) and prm.metavar() == "X,X,..."
    assert "(default: 0,1,4,8)" in prm.help_text()  # the default reads as before
    monkeypatch.chdir(tmp_path)
    assert cli.main(["weight-distributions", "--size", "16", "--endpoints", "3", "--ns", "0.5,2", "-o", "w.npz",
                     "--quiet"]) == 0, capsys.readouterr().err
    assert (tmp_path / "w.npz").exists()


def test_a_config_file_that_is_not_utf8_is_named(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "c.toml").write_bytes(b"seed = 1\n\xff = 2\n")
    assert cli.main(["fractal", "--size", "16", "--config", "c.toml", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--config 'c.toml' is not UTF-8 text" in err
    # an option given on the command line is named as the option, even when the file sets it too
    (tmp_path / "c.toml").write_text("seed = 1\n")
    assert cli.main(["tropism-objects", "--size", "16", "--config", "c.toml", "--seed", "-2", "--quiet"]) == 2
    assert capsys.readouterr().err.strip().endswith("--seed expects an integer in [0, 2**32), but got -2")


def test_the_summary_counts_in_words(tmp_path):
    # "1 endpoint", not "1 endpoints"
    code, out, err = wd("simple-dendrite", "--size", 32, "--endpoints", 1, "-o", "s.png", "--quiet", cwd=tmp_path)
    assert code == 0, err
    assert ", 1 endpoint in " in out, out
    code, out, err = wd("simple-dendrite", "--size", 32, "--endpoints", 2, "-o", "t.png", "--quiet", cwd=tmp_path)
    assert ", 2 endpoints in " in out, out


def test_a_models_extent_is_refused_exactly_where_the_image_would_refuse_its_domain():
    from wdendrite import _models
    from wdendrite.control import plane
    from wdendrite.dendry import dendry as image

    params, size = _models.TABLE1, 8
    for output, limit in (("elevation", 262144.0), ("distance", 2.0**21)):  # 2**22 over the finest cells per unit
        edge = limit * size / (size - 0.5)  # the extent whose last pixel centre lies at the limit
        for extent in (float(np.nextafter(edge, 0.0)), edge):
            try:
                image((size, size), domain=((0.0, 0.0), (extent, extent)), params=params,
                      control=plane((0.0, 1.0)), output=output, window=(size - 1, size - 1, 1, 1))
            except ValueError as e:
                assert "reaches coordinate" in str(e)
                with pytest.raises(ValueError, match=f"'extent' = {extent!r} takes the image's pixel centres"):
                    _models.dendry_setup(size, params, extent=extent, control="plane", frequency=1.0,
                                         drained=False, seed=0, output=output)
                assert extent == edge
            else:
                _models.dendry_setup(size, params, extent=extent, control="plane", frequency=1.0, drained=False,
                                     seed=0, output=output)
                assert extent < edge


def test_an_option_is_taken_by_its_whole_name_only(tmp_path):
    # argparse had read --devic as --device and --siz as --size without a word
    bad(["fractal", "--size", "16", "--devic", "cpu", "-o", "f.png"], tmp_path, "unrecognized option '--devic'",
        "did you mean '--device'")
    bad(["batch", "jobs.toml", "--dry"], tmp_path, "'--dry'")
    assert not (tmp_path / "f.png").exists()


def test_a_tiled_command_killed_between_its_renames_finishes_when_run_again(tmp_path, monkeypatch, capsys):
    # the first output had taken its name: the same command refused it as the user's file
    from wdendrite import batch

    a, b = tmp_path / "a.npy", tmp_path / "b.npy"
    command = ["terrain", "--size", "40", "--tile", "16", "-o", str(a), "-o", str(b), "--quiet", "--device", "cpu"]
    real = os.replace

    def dies_at_b(src, dst):
        if Path(dst) == b:
            raise KeyboardInterrupt  # killed after a.npy took its name, before b.npy did
        real(src, dst)

    monkeypatch.setattr(batch.os, "replace", dies_at_b)
    assert cli.main(command) == 130
    monkeypatch.setattr(batch.os, "replace", real)
    assert a.exists() and not b.exists()
    other = [*command[:5], "--seed", "1", *command[5:]]  # another image may not take it
    assert cli.main(other) == 2 and "pass --force" in capsys.readouterr().err
    assert cli.main(command) == 0
    fresh = tmp_path / "fresh"
    fresh.mkdir()
    assert cli.main(["terrain", "--size", "40", "-o", str(fresh / "t.npy"), "--quiet", "--device", "cpu"]) == 0
    for p in (a, b):
        assert np.array_equal(np.load(p), np.load(fresh / "t.npy"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npy", "b.npy", "fresh"]


def test_a_ctrl_c_during_the_renames_waits_for_them_to_end(tmp_path, monkeypatch, python_sigint):
    # a SIGINT right after the first rename had left one new output beside two old ones and
    # deleted the old file's kept copy
    import signal

    outs = [str(tmp_path / n) for n in ("a.png", "a.npz", "a.npy")]
    assert cli.main(["fractal", "--size", "24", "--seed", "1", *sum((["-o", p] for p in outs), []), "--quiet"]) == 0
    old = {p: Path(p).read_bytes() for p in outs}
    real, renamed = os.replace, []

    def then_ctrl_c(src, dst):
        real(src, dst)
        if Path(dst) == Path(outs[0]) and not renamed:
            renamed.append(dst)
            os.kill(os.getpid(), signal.SIGINT)

    monkeypatch.setattr(cli.os, "replace", then_ctrl_c)
    args = ["fractal", "--size", "24", "--seed", "2", *sum((["-o", p] for p in outs), []), "--quiet", "--force"]
    assert cli.main(args) == 130 and renamed  # the interrupt is still reported, once every rename is done
    monkeypatch.setattr(cli.os, "replace", real)
    assert all(Path(p).read_bytes() != old[p] for p in outs)  # all new: none was left half way
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npy", "a.npz", "a.png"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_tiled_command_killed_while_clearing_its_records_finishes_when_run_again(tmp_path, monkeypatch):
    # killed once the first output's records had gone, before the second's did: the re-run had
    # refused the first output, complete, as the user's file (and needed --force)
    from wdendrite import batch

    a, b = tmp_path / "a.npy", tmp_path / "b.npy"
    command = ["terrain", "--size", "40", "--tile", "16", "-o", str(a), "-o", str(b), "--quiet", "--device", "cpu"]
    real, killed = os.replace, []

    def dies_at_b_records(src, dst):
        if Path(src).name == ".b.tiles.npy":
            killed.append(src)
            assert not os.path.lexists(tmp_path / ".a.tiles.npy")  # the first output's records are gone
            raise KeyboardInterrupt
        real(src, dst)

    monkeypatch.setattr(batch.os, "replace", dies_at_b_records)
    assert cli.main(command) == 130 and killed
    monkeypatch.setattr(batch.os, "replace", real)
    first = np.load(a)
    assert cli.main(command) == 0
    assert np.array_equal(np.load(a), first) and np.array_equal(np.load(b), first)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npy", "b.npy"]
    assert cli.main(command) == 2  # (complete and cleared: existing outputs, as for any run)


@pytest.fixture
def small_bands(monkeypatch):
    """Three cores and bands of a few rows, so that small images split among threads."""
    import importlib

    from wdendrite import _parallel

    monkeypatch.setattr(_parallel, "cores", lambda: 3)
    monkeypatch.setattr(_parallel, "BAND_PIXELS", 64)
    monkeypatch.setattr(importlib.import_module("wdendrite.dendry"), "_BAND_PIXELS", 64)


@pytest.mark.parametrize("preset", ["dendry", "terrain"])
def test_workers_change_no_byte_of_the_outputs(preset, tmp_path, monkeypatch, small_bands):
    import threading

    from wdendrite import _parallel

    monkeypatch.chdir(tmp_path)
    threads = set()
    real = _parallel.each
    monkeypatch.setattr(_parallel, "each", lambda fn, items, n: real(
        lambda item: threads.add(threading.get_ident()) or fn(item), items, n))
    for n in (1, 3):
        threads.clear()
        assert cli.main([preset, "--size", "48", "--levels", "3", "--workers", str(n), "-o", f"{n}.png",
                         "-o", f"{n}.npy", "--quiet", "--device", "cpu"]) == 0
        assert len(threads) == n
    for suffix in ("png", "npy"):
        assert (tmp_path / f"1.{suffix}").read_bytes() == (tmp_path / f"3.{suffix}").read_bytes()


def test_tiles_computed_on_several_threads_make_the_same_file(tmp_path, monkeypatch, small_bands):
    import threading

    from wdendrite import batch

    monkeypatch.chdir(tmp_path)
    threads = set()
    real = batch._dendry_tile

    def tile(window, **kw):
        if window[2:] != (1, 1):  # (not the corner pixels checked first, in this thread)
            threads.add(threading.get_ident())
        return real(window, **kw)

    monkeypatch.setattr(batch, "_dendry_tile", tile)
    for n in (1, 3):
        threads.clear()
        assert cli.main(["terrain", "--size", "45", "--tile", "8", "--workers", str(n), "-o", f"{n}.npy", "--quiet",
                         "--device", "cpu"]) == 0
        assert len(threads) == n
    assert (tmp_path / "1.npy").read_bytes() == (tmp_path / "3.npy").read_bytes()


def test_workers_are_checked_and_capped_at_the_cores(tmp_path, monkeypatch, capsys):
    from wdendrite import _parallel

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(_parallel, "cores", lambda: 2)
    assert cli.main(["dendry", "--size", "16", "--workers", "0", "-o", "a.npy", "--quiet"]) == 2
    assert "--workers must be a positive integer, but got 0" in capsys.readouterr().err
    assert not (tmp_path / "a.npy").exists()
    assert cli.main(["terrain", "--size", "16", "--workers", "9", "-o", "a.npy", "--quiet"]) == 0
    assert "--workers 9 is more than the 2 cores this process may use: using 2" in capsys.readouterr().err
    bad(["fractal", "--workers", "2"], tmp_path, "--workers")  # (a preset without threads has no such option)
