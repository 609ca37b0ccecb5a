"""Terrain files that describe themselves, each reloaded in the tool that reads it: 16-bit PNG
heightmaps with their range in text chunks (Pillow), raw .r16/.raw (NumPy), GeoTIFF (tifffile),
Zarr groups (xarray and zarr); the command's --range and its refusals; batch jobs."""

import json
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from wdendrite import batch, cli, heightmaps, tiles

TOP = 65535


def wd(*args, cwd, hook=""):
    """Run the command in a child (``hook``: Python run first in it); ``(code, stdout, stderr)``."""
    code = hook + "\nimport sys\nfrom wdendrite import cli\nsys.exit(cli.main(sys.argv[1:]))\n"
    p = subprocess.run([sys.executable, "-c", code, *map(str, args)], cwd=cwd, capture_output=True, text=True,
                       timeout=300)
    return p.returncode, p.stdout, p.stderr


def refused(args, cwd, *words, hook=""):
    """The command exits 2 with one line of error holding ``words``, and no traceback."""
    code, out, err = wd(*args, cwd=cwd, hook=hook)
    lines = [x for x in err.splitlines() if x.startswith("wdendrite:")]
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, out, err)
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def levels_from_png(path):
    """Grey levels and the text chunks of a PNG, read with Pillow."""
    with Image.open(path) as im:
        assert im.mode in ("I;16", "I") and im.format == "PNG"
        return np.asarray(im).astype(np.int64), dict(im.text)


def reconstructed(levels, text):
    lo, hi = float(text["wdendrite:min"]), float(text["wdendrite:max"])
    return lo + levels / TOP * (hi - lo), (hi - lo) / TOP


def pixel_centres(n, lo, hi):
    return lo + (np.arange(n) + 0.5) * (hi - lo) / n


_WRITE = tiles._Target.write


def tile_writes(monkeypatch, written: list, interrupted_after: int | None = None) -> None:
    """Tile writes append their windows to ``written``; the one after ``interrupted_after`` of them
    raises KeyboardInterrupt instead (as Ctrl-C there would)."""
    def write(self, window, values):
        if len(written) == interrupted_after:
            raise KeyboardInterrupt
        written.append(window)
        _WRITE(self, window, values)

    monkeypatch.setattr(tiles._Target, "write", write)


# --------------------------------------------------------------------------- PNG heightmaps


def test_a_png_heightmap_reads_back_into_elevations_within_one_level(tmp_path):
    code, out, err = wd("terrain", "--size", 72, "--seed", 3, "--heightmap", "-o", "t.png", "-o", "t.npy",
                        "--device", "cpu", "--quiet", cwd=tmp_path)
    assert code == 0, err
    z = np.load(tmp_path / "t.npy").astype(np.float64)
    levels, text = levels_from_png(tmp_path / "t.png")
    assert text["wdendrite:field"] == "elevation"
    assert (float(text["wdendrite:min"]), float(text["wdendrite:max"])) == (z.min(), z.max())
    back, level = reconstructed(levels, text)
    assert np.abs(back - z).max() <= 0.5 * level * (1 + 1e-9) and levels.min() == 0 and levels.max() == TOP
    # the grid: the domain the terrain covers (extent 4 by default) and its spacing per pixel
    assert json.loads(text["wdendrite:domain"]) == [[0.0, 0.0], [4.0, 4.0]]
    assert float(text["wdendrite:spacing"]) == 4.0 / 72
    assert f"grey 0 = {z.min():.6g}, 65535 = {z.max():.6g}" in out


def test_a_shared_range_gives_several_runs_one_scale(tmp_path):
    runs = {}
    for seed in (0, 1):
        code, out, err = wd("terrain", "--size", 48, "--seed", seed, "--heightmap", "--range", "-0.5,1.5", "-o",
                            f"t{seed}.png", "-o", f"t{seed}.npy", "--device", "cpu", "--quiet", cwd=tmp_path)
        assert code == 0, err
        runs[seed] = np.load(tmp_path / f"t{seed}.npy").astype(np.float64), *levels_from_png(tmp_path / f"t{seed}.png")
    for z, levels, text in runs.values():
        assert (text["wdendrite:min"], text["wdendrite:max"]) == ("-0.5", "1.5")
        assert -0.5 < z.min() and z.max() < 1.5  # (the range holds both terrains: nothing clipped)
        back, level = reconstructed(levels, text)
        assert np.abs(back - z).max() <= 0.5 * level * (1 + 1e-9)
        # one scale, not each terrain's own: grey = nearest level of (z + 0.5) / 2 in both
        np.testing.assert_array_equal(levels, np.floor((z + 0.5) / 2.0 * TOP + 0.5))
    # a range narrower than the field clips, and says how many values it clipped
    z = runs[0][0]
    lo, hi = (float(q) for q in np.quantile(z, [0.25, 0.75]))
    code, out, err = wd("terrain", "--size", 48, "--heightmap", "--range", f"{lo!r},{hi!r}", "-o", "c.png", "--device",
                        "cpu", "--quiet", cwd=tmp_path)
    outside = np.count_nonzero((z < lo) | (z > hi))
    assert code == 0 and f"({outside} values outside, clipped)" in out, (out, err)
    levels, text = levels_from_png(tmp_path / "c.png")
    np.testing.assert_array_equal(levels[z < lo], 0)
    np.testing.assert_array_equal(levels[z > hi], TOP)


def test_windows_of_one_map_saved_with_one_range_join_without_seams(tmp_path):
    # the library's way to tile a large map: every window scaled to one range gives the levels of
    # the whole map, bit for bit, so tiles meet without a step
    import wdendrite as wd_

    params = wd_.DendryParams.terrain(levels=2, seed=4)
    domain = ((0.0, 0.0), (2.0, 2.0))
    whole = wd_.dendry((40, 40), domain=domain, params=params, output="elevation", device="cpu")
    rng = (float(whole.min()) - 0.1, float(whole.max()) + 0.1)
    heightmaps.save_heightmap(tmp_path / "whole.png", whole, range=rng, domain=domain, quantity="elevation")
    parts = []
    for k, window in enumerate([(0, 0, 40, 24), (0, 24, 40, 16)]):
        tile = wd_.dendry((40, 40), domain=domain, params=params, output="elevation", window=window, device="cpu")
        info = heightmaps.save_heightmap(tmp_path / f"w{k}.png", tile, range=rng)
        assert info["min"] == rng[0] and info["max"] == rng[1] and info["clipped"] == 0
        parts.append(levels_from_png(tmp_path / f"w{k}.png")[0])
    np.testing.assert_array_equal(np.hstack(parts), levels_from_png(tmp_path / "whole.png")[0])


# --------------------------------------------------------------------------- raw heightmaps


def test_raw_heightmaps_reload_with_numpy_and_the_command_tells_their_size(tmp_path):
    code, out, err = wd("terrain", "--size", 65, "--seed", 2, "-o", "t.r16", "-o", "t.raw", "-o", "t.npy",
                        "--device", "cpu", "--quiet", cwd=tmp_path)
    assert code == 0, err
    z = np.load(tmp_path / "t.npy").astype(np.float64)
    # an independent quantization: nearest level of (z - min) / (max - min) on 0..65535
    want = np.floor((z - z.min()) / (z.max() - z.min()) * TOP + 0.5).astype(np.uint16)
    for name in ("t.r16", "t.raw"):
        raw = np.fromfile(tmp_path / name, dtype="<u2")
        assert raw.size == 65 * 65 and (tmp_path / name).stat().st_size == 2 * 65 * 65  # no header
        np.testing.assert_array_equal(raw.reshape(65, 65), want)
        assert f"{name}: 65 x 65 pixels, 16-bit little-endian" in out
    assert f"grey 0 = {z.min():.6g}, 65535 = {z.max():.6g}" in out


def test_raw_formats_refuse_fields_their_engines_cannot_take(tmp_path):
    # a raw file holds no size: square only; Unity (.raw) takes sides of 2**n + 1 from 33 to 4097
    assert heightmaps.UNITY_SIDES == (33, 65, 129, 257, 513, 1025, 2049, 4097)
    with pytest.raises(ValueError, match=r"must be square .* 4 x 6"):
        heightmaps.save_heightmap(tmp_path / "a.r16", np.zeros((4, 6)))
    with pytest.raises(ValueError, match=r"64 x 64 is not a side Unity's terrains take .* make it 65 x 65"):
        heightmaps.save_heightmap(tmp_path / "a.raw", np.zeros((64, 64)))
    with pytest.raises(ValueError, match=r"larger than Unity's largest terrain, 4097 x 4097: make it 4097 x 4097"):
        heightmaps.check_raw_shape((8193, 8193), "raw")
    heightmaps.check_raw_shape((8193, 8193), "r16")  # (Unreal: any square side)
    heightmaps.save_heightmap(tmp_path / "b.r16", np.arange(36.0).reshape(6, 6))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.r16"]
    # the command: a Dendry model's size is refused before it runs; another preset's field once made,
    # before any write
    refused(["terrain", "--size", 64, "-o", "t.raw", "-o", "t.npy"], tmp_path, "-o/--out 't.raw'", "64 x 64",
            "make it 65 x 65", "nothing was written")
    refused(["lightning", "--size", 40, "-o", "l.raw", "-o", "l.png"], tmp_path, "-o/--out 'l.raw'", "40 x 40")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.r16"]


def test_a_tiled_raw_heightmap_is_the_untiled_one_and_a_killed_run_resumes(tmp_path, monkeypatch):
    # every tile scaled to the one range given: the levels of the whole field, bit for bit
    out = tmp_path / "t.r16"
    command = ["terrain", "--size", "65", "--tile", "16", "--range", "-0.25,1.5", "-o", str(out), "-o",
               str(tmp_path / "t.raw"), "--device", "cpu", "--quiet"]
    written = []
    tile_writes(monkeypatch, written, interrupted_after=6)
    assert cli.main(command) == 130 and not out.exists()
    tile_writes(monkeypatch, written)
    assert cli.main(command) == 0
    # 25 tiles, each into two files: the three whole ones and the half-written fourth are not redone
    assert len(written) == 50 and len(set(written)) == 25
    code, out_text, err = wd("terrain", "--size", 65, "--range", "-0.25,1.5", "-o", "whole.r16", "-o", "z.npy",
                             "--device", "cpu", "--quiet", cwd=tmp_path)
    assert code == 0, err
    z = np.load(tmp_path / "z.npy").astype(np.float64)
    want = np.floor(np.clip((z + 0.25) / 1.75, 0, 1) * TOP + 0.5).astype(np.uint16)  # (an independent scaling)
    for name in ("t.r16", "t.raw", "whole.r16"):
        np.testing.assert_array_equal(np.fromfile(tmp_path / name, "<u2").reshape(65, 65), want)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.r16", "t.raw", "whole.r16", "z.npy"]
    # tiles recorded under another range are not reused
    written.clear()
    tile_writes(monkeypatch, written, interrupted_after=6)
    assert cli.main([*command[:6], "0,2", *command[7:], "--force"]) == 130
    tile_writes(monkeypatch, [])
    assert cli.main([*command[:6], "0,1", *command[7:], "--force"]) == 0
    np.testing.assert_array_equal(np.fromfile(out, "<u2").reshape(65, 65),
                                  np.floor(np.clip(z, 0, 1) * TOP + 0.5).astype(np.uint16))


def test_a_tiled_raw_heightmap_needs_a_range_and_a_side_its_engine_takes(tmp_path):
    code, out, err = wd("terrain", "--size", 48, "--tile", 16, "--range", "0,1", "-o", "t.r16", "--device", "cpu",
                        "--quiet", cwd=tmp_path)
    assert code == 0 and "t.r16: 48 x 48 pixels, 16-bit little-endian" in out and "grey 0 = 0, 65535 = 1" in out
    (tmp_path / "t.r16").unlink()
    refused(["terrain", "--size", 48, "--tile", 16, "-o", "t.r16"], tmp_path, "-o/--out 't.r16'",
            "needs --range LO,HI")
    refused(["terrain", "--size", 48, "--tile", 16, "--range", "0,1", "-o", "t.raw"], tmp_path, "48 x 48",
            "make it 33 x 33")
    refused(["terrain", "--size", 33, "--tile", 16, "--range", "1,nan", "-o", "t.raw"], tmp_path, "--range",
            "'1,nan'")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match="'value_range'"):
        tiles.write_tiled(lambda w: np.zeros(w[2:]), (8, 8), 4, tmp_path / "x.r16")
    with pytest.raises(ValueError, match="must be square"):
        tiles.write_tiled(lambda w: np.zeros(w[2:]), (8, 9), 4, tmp_path / "x.r16", value_range=(0, 1))
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- GeoTIFF


def test_a_geotiff_holds_the_values_and_the_domain_as_its_transform(tmp_path):
    tifffile = pytest.importorskip("tifffile")
    code, out, err = wd("terrain", "--size", 50, "--extent", 2.5, "-o", "t.tif", "-o", "t.npy", "--device", "cpu",
                        "--quiet", cwd=tmp_path)
    assert code == 0, err
    z = np.load(tmp_path / "t.npy")
    with tifffile.TiffFile(tmp_path / "t.tif") as tif:
        page = tif.pages[0]
        values = page.asarray()
        affine = np.array(page.tags["ModelTransformationTag"].value).reshape(4, 4)
        keys = page.tags["GeoKeyDirectoryTag"].value
        described = json.loads(page.tags["ImageDescription"].value)
    assert values.dtype == np.float32 and np.array_equal(values, z)
    # pixel (row, col) centred at (col + 0.5, row + 0.5) maps to the centres wdendrite.dendry uses
    cols, rows = np.meshgrid(np.arange(50) + 0.5, np.arange(50) + 0.5)
    x, y, _, _ = np.tensordot(affine, np.stack([cols, rows, np.zeros_like(cols), np.ones_like(cols)]), axes=1)
    np.testing.assert_allclose(x[0], pixel_centres(50, 0.0, 2.5), rtol=0, atol=1e-12)
    np.testing.assert_allclose(y[:, 0], pixel_centres(50, 0.0, 2.5), rtol=0, atol=1e-12)
    assert keys[:4] == (1, 1, 0, 1) and keys[4:] == (1025, 0, 1, 1)  # GTRasterTypeGeoKey: pixels are areas
    assert described["field"] == "elevation" and described["domain"] == [[0.0, 0.0], [2.5, 2.5]]
    # without a domain: the values alone
    heightmaps.save_geotiff(tmp_path / "plain.tiff", np.arange(6.0).reshape(2, 3))
    with tifffile.TiffFile(tmp_path / "plain.tiff") as tif:
        assert "ModelTransformationTag" not in tif.pages[0].tags
        assert np.array_equal(tif.pages[0].asarray(), np.arange(6.0, dtype=np.float32).reshape(2, 3))


def test_a_geotiff_without_tifffile_is_one_line_and_nothing_is_written(tmp_path):
    hook = "import sys\nsys.modules['tifffile'] = None  # (as if the extra were not installed)\n"
    refused(["terrain", "--size", 33, "-o", "t.npy", "-o", "t.tif"], tmp_path, "-o/--out 't.tif'",
            "pip install 'wdendrite[tiff]'", "nothing was written", hook=hook)
    assert list(tmp_path.iterdir()) == []
    sys_modules = dict(sys.modules)
    try:
        sys.modules["tifffile"] = None
        with pytest.raises(ImportError, match=r"wdendrite\[tiff\]"):
            heightmaps.save_geotiff(tmp_path / "x.tif", np.zeros((2, 2)))
    finally:
        sys.modules.clear()
        sys.modules.update(sys_modules)
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("value", ["2,1", "1,1", "nan,1", "0,inf", "1", "a,b", "1,2,3"])
def test_a_bad_range_is_refused_naming_it_before_any_work(tmp_path, value):
    refused(["terrain", "--size", 33, "--heightmap", "--range", value, "-o", "t.png"], tmp_path, "--range",
            repr(value), "LO < HI")
    assert list(tmp_path.iterdir()) == []


def test_a_range_needs_a_16_bit_heightmap_to_scale(tmp_path):
    refused(["terrain", "--size", 33, "--range", "0,1", "-o", "t.png", "-o", "t.tif"], tmp_path, "--range",
            "writes none")
    refused(["terrain", "--size", 48, "--tile", 16, "--range", "0,1", "-o", "t.npy"], tmp_path, "--range", "--tile")
    assert list(tmp_path.iterdir()) == []


def test_value_range_takes_text_or_a_pair():
    assert heightmaps.value_range("-1,2.5") == (-1.0, 2.5) and heightmaps.value_range([0, 3]) == (0.0, 3.0)
    for bad in ([1, 0], [0, True], (0, 1, 2), None, [0, float("inf")], "0;1"):
        with pytest.raises(ValueError, match="'range' expects LO,HI"):
            heightmaps.value_range(bad)


# --------------------------------------------------------------------------- Zarr


def test_a_tiled_zarr_store_opens_in_xarray_with_coordinates_and_parameters(tmp_path):
    xr = pytest.importorskip("xarray")
    zarr = pytest.importorskip("zarr")
    code, out, err = wd("terrain", "--size", 40, "--extent", 2.0, "--tile", 16, "-o", "t.zarr", "-o", "t.npy",
                        "--device", "cpu", "--quiet", cwd=tmp_path)
    assert code == 0, err
    z = np.load(tmp_path / "t.npy")
    with xr.open_zarr(tmp_path / "t.zarr") as ds:
        assert ds["elevation"].dims == ("y", "x") and np.array_equal(ds["elevation"].values, z)
        np.testing.assert_allclose(ds["x"].values, pixel_centres(40, 0.0, 2.0), rtol=0, atol=1e-12)
        np.testing.assert_allclose(ds["y"].values, pixel_centres(40, 0.0, 2.0), rtol=0, atol=1e-12)
        assert ds.attrs["preset"] == "terrain" and ds.attrs["params"]["size"] == 40
        assert ds.attrs["params"]["extent"] == 2.0 and ds.attrs["domain"] == [[0.0, 0.0], [2.0, 2.0]]
        assert float(ds.attrs["spacing"]) == 0.05 and ds.attrs["field"] == "elevation"
    group = zarr.open_group(str(tmp_path / "t.zarr"), mode="r")
    assert group["elevation"].chunks == (16, 16) and np.array_equal(group["elevation"][:], z)


def test_a_killed_tiled_zarr_run_resumes_into_the_same_group(tmp_path, monkeypatch):
    xr = pytest.importorskip("xarray")
    out = tmp_path / "t.zarr"
    command = ["terrain", "--size", 40, "--tile", 16, "-o", str(out), "--device", "cpu", "--quiet"]
    written = []
    tile_writes(monkeypatch, written, interrupted_after=4)
    assert cli.main(list(map(str, command))) == 130 and not out.exists()
    tile_writes(monkeypatch, written)
    assert cli.main(list(map(str, command))) == 0
    assert len(written) == 9 and len(set(written)) == 9  # the five tiles left, none twice
    fresh = tmp_path / "fresh"
    fresh.mkdir()
    assert cli.main(["terrain", "--size", "40", "-o", str(fresh / "t.npy"), "--device", "cpu", "--quiet"]) == 0
    with xr.open_zarr(out) as ds:
        assert np.array_equal(ds["elevation"].values, np.load(fresh / "t.npy"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fresh", "t.zarr"]


@pytest.mark.parametrize("zarr_format", [2, 3])
def test_both_zarr_formats_name_their_dimensions_for_xarray(tmp_path, zarr_format):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("zarr", minversion="3")  # (zarr 2 writes format 2 alone)
    store = tmp_path / "g.zarr"
    # (zeros in the data and the coordinates: xarray had read a v2 array's default fill value, 0, as missing)
    group = tiles.new_zarr_group(store, (3, 5), 2, name="depth", attrs={"note": "x"}, domain=((-2, 2), (3, 8)),
                                 _zarr_format=zarr_format)
    group["depth"][:2] = np.arange(10, dtype=np.float32).reshape(2, 5)
    with xr.open_zarr(store) as ds:
        assert ds["depth"].dims == ("y", "x") and ds.attrs["note"] == "x"
        np.testing.assert_allclose(ds["x"].values, [-1.5, -0.5, 0.5, 1.5, 2.5])
        np.testing.assert_allclose(ds["y"].values, [3.0, 5.0, 7.0])
        np.testing.assert_array_equal(ds["depth"].values[:2], np.arange(10).reshape(2, 5))
        assert np.isnan(ds["depth"].values[2]).all()  # (a row no tile wrote yet: missing, not 0)
    domain = ((-2.5, 1.0), (2.5, 7.0))  # (a pixel centre at x = 0 exactly)
    tiles.new_zarr_group(store, (3, 5), 2, domain=domain, _zarr_format=zarr_format)["field"][:] = 0.0
    with xr.open_zarr(store) as ds:
        np.testing.assert_array_equal(ds["x"].values, [-2.0, -1.0, 0.0, 1.0, 2.0])
        np.testing.assert_array_equal(ds["field"].values, np.zeros((3, 5)))


# --------------------------------------------------------------------------- batch jobs


def test_batch_jobs_write_terrain_files_with_a_shared_range(tmp_path):
    pytest.importorskip("tifffile")
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "terrain"\nsize = 33\nseeds = [0, 1]\n'
                                        'formats = ["png", "r16", "raw", "tif", "npy"]\nheightmap = true\n'
                                        'range = [-1.0, 2.0]\n')
    assert batch.run_file(tmp_path / "jobs.toml", device="cpu", quiet=True) == 0
    for seed in (0, 1):
        stem = tmp_path / "o" / f"terrain_size33_seed{seed}"
        z = np.load(f"{stem}.npy").astype(np.float64)
        levels, text = levels_from_png(f"{stem}.png")
        back, level = reconstructed(levels, text)
        assert (text["wdendrite:min"], text["wdendrite:max"]) == ("-1.0", "2.0")
        assert np.abs(back - z).max() <= 0.5 * level * (1 + 1e-9)
        for raw in ("r16", "raw"):
            np.testing.assert_array_equal(np.fromfile(f"{stem}.{raw}", "<u2").reshape(33, 33), levels)
        man = json.loads(open(f"{stem}.manifest.json").read())
        assert man["writing"] == {"heightmap": True, "range": [-1.0, 2.0]} and man["heightmap_range"] == [-1.0, 2.0]
        assert man["raw"] == [[f"{stem}.r16", 33, 33], [f"{stem}.raw", 33, 33]]
    # done: a second run skips both; another range redoes them
    assert all(t.complete() for t in batch.load_jobs(tmp_path / "jobs.toml")[0])
    (tmp_path / "jobs.toml").write_text((tmp_path / "jobs.toml").read_text().replace("2.0]", "3.0]"))
    assert not any(t.complete() for t in batch.load_jobs(tmp_path / "jobs.toml")[0])
    assert batch.run_file(tmp_path / "jobs.toml", device="cpu", quiet=True) == 0
    assert levels_from_png(tmp_path / "o" / "terrain_size33_seed0.png")[1]["wdendrite:max"] == "3.0"


def test_a_tiled_batch_job_writes_raw_heightmaps_of_its_range(tmp_path):
    (tmp_path / "jobs.toml").write_text('out = "o"\n[[job]]\npreset = "terrain"\nsize = 33\ntile = 16\n'
                                        'formats = ["npy", "r16", "raw"]\nrange = [0.0, 1.25]\n')
    assert batch.run_file(tmp_path / "jobs.toml", device="cpu", quiet=True) == 0
    stem = tmp_path / "o" / "terrain_size33_seed0"
    z = np.load(f"{stem}.npy").astype(np.float64)
    want = np.floor(np.clip(z / 1.25, 0, 1) * TOP + 0.5)
    for raw in ("r16", "raw"):
        np.testing.assert_array_equal(np.fromfile(f"{stem}.{raw}", "<u2").reshape(33, 33), want)
    man = json.loads(open(f"{stem}.manifest.json").read())
    assert man["writing"] == {"range": [0.0, 1.25]} and man["heightmap_range"] == [0.0, 1.25]
    assert man["raw"] == [[f"{stem}.r16", 33, 33], [f"{stem}.raw", 33, 33]]
    assert all(t.complete() for t in batch.load_jobs(tmp_path / "jobs.toml")[0])
