"""Writing files: atomic writes, refusal to overwrite or write into missing folders, round trips."""

import json
import os
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import wdendrite as wd
from wdendrite.io import (
    DENDRITE_FORMATS,
    MESH_FORMATS,
    atomic_write,
    load_dendrite,
    save_dendrite,
    save_mesh,
    save_png,
    save_svg,
    svg_polylines,
)
from wdendrite.render import Taper, branch_order, node_widths

LAT2 = wd.Lattice((24, 30), 8, weights=wd.weights.Uniform(r=10, seed=2))
DEN2 = wd.trace(wd.shortest_paths(LAT2, [[1, 15]]), [[22, 3], [22, 27], [15, 10], [20, 15]])
LAT3 = wd.Lattice((12, 12, 12), 26, weights=wd.weights.Uniform(r=10, seed=2))
DEN3 = wd.trace(wd.shortest_paths(LAT3, [[1, 6, 6]]), [[10, 2, 2], [10, 10, 9], [9, 6, 2]])


def _leftovers(folder):
    return [p for p in os.listdir(folder) if p.startswith(".")]


def test_png_8_and_16_bit_round_trip(tmp_path):
    img = np.linspace(0, 1, 64 * 32).reshape(64, 32)
    p8 = save_png(tmp_path / "a.png", img)
    p16 = save_png(tmp_path / "b.png", img, bits=16)
    a8 = np.asarray(Image.open(p8))
    a16 = np.asarray(Image.open(p16))
    assert a8.dtype == np.uint8 and np.abs(a8 / 255.0 - img).max() <= 0.5 / 255 + 1e-9
    assert a16.dtype.itemsize == 2 or a16.dtype == np.int32
    assert np.abs(a16 / 65535.0 - img).max() <= 0.5 / 65535 + 1e-9
    rgb = np.random.default_rng(0).random((8, 9, 3))
    back = np.asarray(Image.open(save_png(tmp_path / "c.png", rgb)))
    assert back.shape == (8, 9, 3)
    # an image quantized in several bands of rows, values outside [0, 1] clipped
    big = (np.random.default_rng(1).random((700, 600, 3)) * 1.2 - 0.1).astype(np.float32)
    want = np.floor(np.clip(big.astype(np.float64), 0, 1) * 255 + 0.5)
    np.testing.assert_array_equal(np.asarray(Image.open(save_png(tmp_path / "d.png", big))), want)
    assert not _leftovers(tmp_path)


def test_existing_file_needs_overwrite_and_missing_folder_is_refused(tmp_path):
    p = save_png(tmp_path / "a.png", np.zeros((4, 4)))
    with pytest.raises(FileExistsError, match="overwrite=True"):
        save_png(p, np.ones((4, 4)))
    save_png(p, np.ones((4, 4)), overwrite=True)
    assert np.asarray(Image.open(p)).min() == 255
    with pytest.raises(ValueError, match="folder"):
        save_png(tmp_path / "missing" / "a.png", np.zeros((4, 4)))
    with pytest.raises(ValueError, match="folder"):
        save_mesh(tmp_path / "missing" / "a.obj", _box())
    with pytest.raises(ValueError, match="folder"):
        save_dendrite(tmp_path / "missing" / "d.json", DEN2)


def test_interrupted_write_leaves_no_file(tmp_path):
    def broken(tmp):
        with open(tmp, "w") as f:
            f.write("half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        atomic_write(tmp_path / "x.txt", broken)
    assert os.listdir(tmp_path) == []
    # an interrupted overwrite keeps the old file intact
    (tmp_path / "y.txt").write_text("old")
    with pytest.raises(KeyboardInterrupt):
        atomic_write(tmp_path / "y.txt", broken, overwrite=True)
    assert (tmp_path / "y.txt").read_text() == "old"
    assert os.listdir(tmp_path) == ["y.txt"]


def test_a_write_the_system_refuses_names_the_file_and_leaves_nothing(tmp_path):
    # a file-size limit makes the system refuse the write part way (as a full disk would): the
    # error names the file asked for, not the hidden temporary one, and nothing is left
    import errno
    import resource

    image = np.random.default_rng(0).random((256, 256))  # noise: its PNG cannot shrink below the limit
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (4096, hard))  # (Python ignores SIGXFSZ: the write raises)
    try:
        with pytest.raises(OSError) as info:
            save_png(tmp_path / "a.png", image)
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
    assert info.value.errno == errno.EFBIG
    assert str(info.value) == f"[Errno {errno.EFBIG}] could not write {str(tmp_path / 'a.png')!r}: File too large"
    assert os.listdir(tmp_path) == []


def _box():
    import trimesh

    return trimesh.creation.box(extents=(1.0, 2.0, 3.0))


@pytest.mark.parametrize("fmt", MESH_FORMATS)
def test_mesh_formats_load_back(tmp_path, fmt):
    import trimesh

    from wdendrite.geometry import tubes

    mesh = tubes(DEN3, 0.4, sides=6)
    p = save_mesh(tmp_path / f"m.{fmt}", mesh)
    back = trimesh.load(p, force="mesh", process=True)
    assert back.volume == pytest.approx(mesh.volume, rel=1e-3)  # positive: faces still point outward
    bounds = mesh.bounds
    if fmt == "glb":  # glTF is y-up: (x, y, z) is stored as (x, z, -y), so lattice axis 0 points up there
        bounds = np.array([[bounds[0, 0], bounds[0, 2], -bounds[1, 1]], [bounds[1, 0], bounds[1, 2], -bounds[0, 1]]])
    np.testing.assert_allclose(back.bounds, bounds, atol=1e-4)
    assert not _leftovers(tmp_path)


def test_unknown_formats_list_the_allowed_ones(tmp_path):
    with pytest.raises(ValueError, match="obj, ply, stl, glb"):
        save_mesh(tmp_path / "m.fbx", _box())
    with pytest.raises(ValueError, match="obj, ply, stl, glb"):
        save_mesh(tmp_path / "m.obj", _box(), format="dae")
    with pytest.raises(ValueError, match="npz, json"):
        save_dendrite(tmp_path / "d.csv", DEN2)
    assert os.listdir(tmp_path) == []
    assert DENDRITE_FORMATS == ("npz", "json")


@pytest.mark.parametrize("fmt", DENDRITE_FORMATS)
@pytest.mark.parametrize("den", [DEN2, DEN3], ids=["2d", "3d"])
def test_dendrite_round_trip(tmp_path, fmt, den):
    taper = Taper(3.0, 0.5)
    p = save_dendrite(tmp_path / f"d.{fmt}", den, width=taper)
    back, width = load_dendrite(p)
    for f in ("nodes", "parent", "cost", "label", "generation", "endpoints"):
        np.testing.assert_array_equal(getattr(back, f), getattr(den, f))
    assert back.shape == tuple(den.shape) and back.spacing == den.spacing
    np.testing.assert_allclose(width, node_widths(den, taper))
    np.testing.assert_array_equal(back.depth, den.depth)
    # the loaded dendrite works with the rest of the package
    np.testing.assert_array_equal(back._padded, den._padded)
    if fmt == "json":
        raw = json.loads(p.read_text())
        assert {"nodes", "parent", "cost", "width"} <= set(raw)


def test_svg_polylines_cover_every_edge_once(tmp_path):
    p = save_svg(tmp_path / "d.svg", DEN2, width=Taper(2.0, 0.5))
    root = ET.parse(p).getroot()
    polys = [el for el in root.iter() if el.tag.endswith("polyline")]
    edges = set()
    for el in polys:
        pts = np.array([[float(v) for v in xy.split(",")] for xy in el.get("points").split()])
        for a, b in zip(pts[:-1], pts[1:]):
            edges.add((tuple(a), tuple(b)))
        assert float(el.get("stroke-width")) > 0
    want = {(tuple(DEN2.nodes[DEN2.parent[i], ::-1].astype(float)), tuple(DEN2.nodes[i, ::-1].astype(float)))
            for i in np.flatnonzero(DEN2.parent >= 0)}
    assert edges == want
    assert len(polys) == len(np.unique(branch_order(DEN2).start)) == len(svg_polylines(DEN2))
    with pytest.raises(ValueError, match="2D"):
        save_svg(tmp_path / "e.svg", DEN3)
    # a node alone (a root with no path) is a dot: its point twice, stroked with round caps (it had drawn nothing)
    lone = wd.Dendrite.from_arrays((8, 8), [[2, 5]], [-1])
    polys = [el for el in ET.parse(save_svg(tmp_path / "one.svg", lone, width=1.5)).getroot().iter()
             if el.tag.endswith("polyline")]
    assert [el.get("points") for el in polys] == ["5,2 5,2"] and float(polys[0].get("stroke-width")) == 3.0
    assert polys[0].get("stroke-linecap") == "round"


def test_svg_colours_are_written_and_bad_ones_refused_before_writing(tmp_path):
    p = save_svg(tmp_path / "c.svg", DEN2, color="#1a2b3c", background="rgb(10, 20, 30)")
    root = ET.parse(p).getroot()
    assert {el.get("stroke") for el in root.iter() if el.tag.endswith("polyline")} == {"#1a2b3c"}
    assert [el.get("fill") for el in root.iter() if el.tag.endswith("rect")] == ["rgb(10, 20, 30)"]
    for name, bad in [("color", 'red" onload="x'), ("color", ""), ("color", " "), ("color", "black\x0c"),
                      ("color", 3), ("background", "<b>"), ("background", ["white"])]:
        with pytest.raises((ValueError, TypeError), match=f"'{name}'"):
            save_svg(tmp_path / "bad.svg", DEN2, **{name: bad})
    assert not (tmp_path / "bad.svg").exists() and not _leftovers(tmp_path)


def test_every_writer_refuses_to_overwrite_and_empty_dendrites(tmp_path):
    from wdendrite.geometry import spheres

    writers = [
        lambda p, **kw: save_mesh(p / "m.ply", spheres(DEN3, 0.5), **kw),
        lambda p, **kw: save_dendrite(p / "d.npz", DEN2, **kw),
        lambda p, **kw: save_svg(p / "d.svg", DEN2, **kw),
    ]
    for write in writers:
        first = write(tmp_path)
        before = first.read_bytes()
        with pytest.raises(FileExistsError, match="overwrite"):
            write(tmp_path)
        assert first.read_bytes() == before
        write(tmp_path, overwrite=True)
    with pytest.raises(ValueError, match="empty"):
        save_dendrite(tmp_path / "e.json", empty_dendrite((8, 8)))
    with pytest.raises(ValueError, match="empty"):
        save_svg(tmp_path / "e.svg", empty_dendrite((8, 8)))
    assert not _leftovers(tmp_path)


def _png_chunks(data: bytes) -> dict:
    import struct

    out, at = {}, 8
    while at < len(data):
        length = struct.unpack(">I", data[at:at + 4])[0]
        out[data[at + 4:at + 8]] = out.get(data[at + 4:at + 8], b"") + data[at + 8:at + 8 + length]
        at += 12 + length
    return out


def _unfiltered(raw: np.ndarray, bpp: int) -> np.ndarray:
    """PNG scanlines decoded by the specification's rules, one byte at a time (the test's reference)."""
    h, n = raw.shape[0], raw.shape[1] - 1
    out = np.zeros((h, n), np.int64)
    for r in range(h):
        kind = int(raw[r, 0])
        for i in range(n):
            a = int(out[r, i - bpp]) if i >= bpp else 0
            b = int(out[r - 1, i]) if r else 0
            c = int(out[r - 1, i - bpp]) if r and i >= bpp else 0
            p = a + b - c
            pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
            paeth = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            out[r, i] = (int(raw[r, 1 + i]) + (0, a, b, (a + b) // 2, paeth)[kind]) % 256
    return out.astype(np.uint8)


def _png16_samples(path, h, w, c):
    import struct
    import zlib

    chunks = _png_chunks(Path(path).read_bytes())
    assert struct.unpack(">IIBB", chunks[b"IHDR"][:10]) == (w, h, 16, 2 if c == 3 else 6)
    raw = np.frombuffer(zlib.decompress(chunks[b"IDAT"]), np.uint8).reshape(h, 1 + w * c * 2)
    return raw[:, 0], _unfiltered(raw, 2 * c).view(">u2").reshape(h, w, c)


@pytest.mark.parametrize("channels", [3, 4])
def test_16_bit_colour_png_is_valid_and_exact(tmp_path, channels):
    rng = np.random.default_rng(3)
    # rows that suit different filters: noise, a ramp along x, a copy of the row above, a flat colour
    rgb = rng.random((12, 40, channels))
    rgb[3:6] = np.linspace(0, 1, 40)[None, :, None] * np.array([1.0, 0.5, 0.25, 1.0][:channels])
    rgb[6:9] = rgb[2]
    rgb[9:] = 0.3
    p = save_png(tmp_path / "c16.png", rgb, bits=16)
    want = (rgb * 65535 + 0.5).astype(np.uint16)
    # Pillow decodes it (to 8 bits: the high bytes), which checks the chunks, CRCs and its own unfiltering
    with Image.open(p) as im:
        im.load()
        assert im.size == (40, 12)
        np.testing.assert_array_equal(np.asarray(im), (want >> 8).astype(np.uint8))
    # every 16-bit sample, unfiltered by the specification's rules
    kinds, samples = _png16_samples(p, 12, 40, channels)
    np.testing.assert_array_equal(samples, want)
    assert len(set(kinds.tolist())) >= 3, kinds  # (the rows did take different filters)
    assert not _leftovers(tmp_path)


def test_a_smooth_16_bit_colour_png_is_smaller_filtered(tmp_path):
    from wdendrite import io as wio

    y, x = np.mgrid[0:64, 0:96] / 95.0
    data = wio._quantized(np.stack([x, y, 0.5 * (x + y)], axis=-1), 16)
    wio._png16_rgb(tmp_path / "plain.png", data, filtered=False)
    wio._png16_rgb(tmp_path / "filtered.png", data)
    plain, filtered = ((tmp_path / f).stat().st_size for f in ("plain.png", "filtered.png"))
    assert filtered * 5 < plain, (filtered, plain)
    np.testing.assert_array_equal(_png16_samples(tmp_path / "filtered.png", 64, 96, 3)[1], data)


@pytest.mark.parametrize("channels", [None, 3, 4])
def test_uint8_and_uint16_images_are_levels_of_their_dtype(tmp_path, channels):
    rng = np.random.default_rng(5)
    shape = (6, 7) if channels is None else (6, 7, channels)
    u8 = rng.integers(0, 256, shape).astype(np.uint8)
    u8.flat[:2] = (0, 255)
    u16 = rng.integers(0, 65536, shape).astype(np.uint16)
    u16.flat[:4] = (0, 65535, 128, 385)  # (385 = 257 + 128: the largest level rounding down to 1)
    expect8 = np.floor(u16 / 257.0 + 0.5).astype(np.uint8)  # the nearest 8-bit level
    # at their own depth they are kept; at the other, rescaled to the nearest level
    np.testing.assert_array_equal(np.asarray(Image.open(save_png(tmp_path / "a.png", u8))), u8)
    np.testing.assert_array_equal(np.asarray(Image.open(save_png(tmp_path / "b.png", u16, bits=8))), expect8)
    big_endian = u16.astype(">u2")  # (any byte order)
    np.testing.assert_array_equal(np.asarray(Image.open(save_png(tmp_path / "c.png", big_endian, bits=8))), expect8)
    for name, img, want in (("d.png", u16, u16), ("e.png", u8, u8.astype(np.uint16) * 257)):
        p = save_png(tmp_path / name, img, bits=16)
        if channels in (3, 4):
            np.testing.assert_array_equal(_png16_samples(p, 6, 7, channels)[1], want)
        else:
            np.testing.assert_array_equal(np.asarray(Image.open(p)).astype(np.int64), want)
    # floats stay values in [0, 1], other integer dtypes 0 and 1 only
    np.testing.assert_array_equal(np.asarray(Image.open(save_png(tmp_path / "f.png", u8 / 255.0))), u8)
    with pytest.raises(ValueError, match=r"this int64 image spans \[0, 255\]; pass 8-bit levels as uint8"):
        save_png(tmp_path / "g.png", u8.astype(np.int64))


def empty_dendrite(shape):
    """A dendrite with no nodes (what a failed or filtered trace could leave)."""
    from wdendrite.dendrite import Dendrite

    nd = len(shape)
    return Dendrite(shape=shape, nodes=np.zeros((0, nd), np.int64), parent=np.zeros(0, np.int64),
                    cost=np.zeros(0, np.float32), label=np.zeros(0, np.int32), generation=np.zeros(0, np.int32),
                    endpoints=np.zeros(0, np.int64), _padded=np.zeros(0, np.int64))


def test_written_files_follow_the_umask(tmp_path):
    import os

    from wdendrite.io import atomic_write

    old = os.umask(0o022)
    try:
        out = atomic_write(tmp_path / "x.txt", lambda p: open(p, "w").write("hi"))
    finally:
        os.umask(old)
    assert (out.stat().st_mode & 0o777) == 0o644


def test_a_replaced_file_keeps_its_permissions(tmp_path):
    import os

    from wdendrite.io import atomic_write

    out = tmp_path / "x.txt"
    out.write_text("old")
    os.chmod(out, 0o640)
    atomic_write(out, lambda p: open(p, "w").write("new"), overwrite=True)
    assert out.read_text() == "new"
    assert (out.stat().st_mode & 0o777) == 0o640


@pytest.mark.parametrize(
    "image, exc, match",
    [
        (np.full((4, 4), np.nan), ValueError, r"'image' must be finite, but has 16 NaN/inf entries .*\(0, 0\): nan"),
        (np.array([[0.0, np.inf]]), ValueError, r"'image' must be finite.*\(0, 1\): inf"),
        ("abc", TypeError, "'image', but got dtype <U3"),
        (np.zeros((0, 0)), ValueError, r"'image', but got shape \(0, 0\)"),
        (np.zeros((4, 4, 2)), ValueError, r"'image', but got shape \(4, 4, 2\)"),
        (np.full((4, 4), 200, np.int32), ValueError, r"values in \[0, 1\], but this int32 image spans \[200, 200\]"),
    ],
)
def test_bad_png_images_name_image_and_leave_the_old_file(tmp_path, image, exc, match):
    p = save_png(tmp_path / "a.png", np.zeros((4, 4)))
    before = p.read_bytes()
    with pytest.raises(exc, match=match):
        save_png(p, image, overwrite=True)
    assert p.read_bytes() == before and os.listdir(tmp_path) == ["a.png"]


def test_bool_png_images_are_fine(tmp_path):
    p = save_png(tmp_path / "m.png", np.eye(3, dtype=bool))
    np.testing.assert_array_equal(np.asarray(Image.open(p)), np.eye(3) * 255)


@pytest.mark.parametrize(
    "write",
    [
        lambda p: save_png(p, np.zeros((4, 4)), overwrite=True),
        lambda p: save_mesh(p, _box(), format="obj", overwrite=True),
        lambda p: save_dendrite(p, DEN2, format="npz", overwrite=True),
        lambda p: save_svg(p, DEN2, overwrite=True),
    ],
    ids=["png", "mesh", "dendrite", "svg"],
)
def test_writers_refuse_a_folder_as_path(tmp_path, write):
    folder = tmp_path / "out"
    folder.mkdir()
    (folder / "keep.txt").write_text("mine")
    with pytest.raises(ValueError, match=r"'path' '.*out' is a folder"):
        write(folder)
    assert sorted(os.listdir(tmp_path)) == ["out"] and os.listdir(folder) == ["keep.txt"]


def test_save_mesh_refuses_non_meshes_and_non_finite_vertices(tmp_path):
    with pytest.raises(TypeError, match="'mesh', but got ndarray"):
        save_mesh(tmp_path / "m.obj", np.zeros((3, 3)))
    box = _box()
    box.vertices[2] = np.nan
    with pytest.raises(ValueError, match=r"'mesh.vertices' must be finite.*\(2, 0\): nan"):
        save_mesh(tmp_path / "m.obj", box)
    assert os.listdir(tmp_path) == []


def _write(path, data: bytes):
    path.write_bytes(data)
    return path


def _dendrite_json(tmp_path, **change):
    raw = json.loads(save_dendrite(tmp_path / "good.json", DEN2).read_text())
    raw.update(change)
    return _write(tmp_path / "bad.json", json.dumps(raw).encode())


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda d: _write(d / "p.npz", b"garbage"), r"'path' '.*p\.npz' is not a dendrite file: it is not an .npz"),
        (lambda d: _write(d / "p.json", b"{not json"), r"'path' '.*p\.json' is not a dendrite file: JSONDecodeError"),
        (lambda d: _write(d / "p.json", b"\xff\xfe"), r"'path' '.*p\.json' is not a dendrite file: UnicodeDecodeError"),
        (lambda d: _write(d / "p.json", b"[1, 2]"), r"'path' '.*p\.json' .*JSON object, but it holds a list"),
        (lambda d: _write(d / "p.json", b'{"shape": [[1], [1, 2]]}'), r"'path' '.*p\.json' is not a dendrite file"),
        (lambda d: _dendrite_json(d, parent=[0]), r"'path' '.*bad\.json' is not a dendrite file: .*'parent'"),
        (lambda d: _dendrite_json(d, spacing="a"), r"'path' '.*bad\.json' is not a dendrite file"),
        (lambda d: _dendrite_json(d, width=[1.0]), r"'path' '.*bad\.json' holds 1 widths"),
        # values other tools could write: refused, not wrapped, truncated or failing later
        (lambda d: _dendrite_json(d, origin=[0.0]), r"bad\.json' is not a dendrite file: .*'origin'"),
        (lambda d: _dendrite_json(d, spacing=0), r"bad\.json' is not a dendrite file: .*'spacing'"),
        (lambda d: _dendrite_json(d, shape=[40.7, 40.2]), r"bad\.json' is not a dendrite file: .*'shape'"),
        (lambda d: _write(d / "deep.json", b"[" * 100000 + b"]" * 100000), r"deep\.json' .*nested too deeply"),
    ],
)
def test_load_dendrite_names_a_corrupt_file(tmp_path, make, match):
    with pytest.raises(ValueError, match=match):
        load_dendrite(make(tmp_path))


def test_load_dendrite_names_missing_arrays_and_files(tmp_path):
    np.savez(tmp_path / "p.npz", nodes=np.zeros((1, 2)))
    with pytest.raises(ValueError, match=r"'path' '.*p\.npz' is not a dendrite file: missing 'shape', 'parent'"):
        load_dendrite(tmp_path / "p.npz")
    with pytest.raises(FileNotFoundError, match=r"'path' '.*nope\.npz' does not exist"):
        load_dendrite(tmp_path / "nope.npz")
    (tmp_path / "d.json").mkdir()
    with pytest.raises(ValueError, match=r"'path' '.*d\.json' is a folder"):
        load_dendrite(tmp_path / "d.json")


def test_names_up_to_the_file_system_limit_are_written(tmp_path):
    # a 255-byte name is legal; the temporary beside it must fit as well (its name is shortened)
    for stem in ("b" * 251, "é" * 125):
        path = tmp_path / f"{stem}.png"
        save_png(path, np.zeros((4, 4)))
        assert path.exists()
        assert not _leftovers(tmp_path)
        path.unlink()


def test_staged_names_fit_and_stay_apart(tmp_path):
    from wdendrite._staging import Staging

    # a staged file's name is the writer's prefix, then the name of the file it stands for, cut
    # and marked with a hash of the whole name when it is long: two long names with a common
    # start never share it, and the suffix (which names the format) stays
    with Staging() as stage:
        plain = stage.name(tmp_path / "f.png").name
        assert plain.startswith(".wdendrite-" + stage.token + "-") and plain.endswith(".f.png")
        a, b = ("a" * 241 + ".png", "a" * 241 + "_seed2.npy")
        na, nb = (stage.name(tmp_path / n).name.split(".", 2)[2] for n in (a, b))
        assert na != nb and not nb.startswith(na[:-4]) and not na.startswith(nb[:-4])
        assert na.endswith(".png") and nb.endswith(".npy")
        for n in (a, b, "é" * 126 + ".png"):
            assert len(os.fsencode(stage.name(tmp_path / n).name)) <= 255
    # a name that is not UTF-8 (bytes the file system allows) is written like any other
    odd = os.fsdecode(b"\xff-odd.png")
    save_png(tmp_path / odd, np.zeros((2, 2)))
    assert (tmp_path / odd).exists() and not _leftovers(tmp_path)


def test_every_single_bit_flip_of_an_npz_loads_or_is_named(tmp_path):
    # damaged zip headers had escaped as RuntimeError ("encrypted"), NotImplementedError or OSError,
    # and a damaged first byte as numpy's advice to load pickles
    good = save_dendrite(tmp_path / "good.npz", DEN2).read_bytes()
    bad = tmp_path / "bad.npz"
    rng = np.random.default_rng(0)
    spots = sorted(set(range(64)) | set(rng.integers(0, len(good), 300).tolist()) | set(range(len(good) - 64, len(good))))
    for i in spots:
        for bit in (0, 3, 7):
            flipped = bytearray(good)
            flipped[i] ^= 1 << bit
            bad.write_bytes(bytes(flipped))
            try:
                den, _ = load_dendrite(bad)
            except ValueError as err:
                assert "is not a dendrite file" in str(err) or "holds" in str(err), (i, bit, err)
            else:  # a flip in bytes nothing reads (a timestamp, a comment)
                np.testing.assert_array_equal(den.nodes, DEN2.nodes)


def test_a_file_that_appears_while_writing_is_not_replaced(tmp_path):
    target = tmp_path / "mine.txt"

    def write(tmp):
        target.write_text("someone else's file")  # after atomic_write's own check
        with open(tmp, "w") as f:
            f.write("mine")

    with pytest.raises(FileExistsError, match="appeared while it was written"):
        atomic_write(target, write)
    assert target.read_text() == "someone else's file" and _leftovers(tmp_path) == []
    atomic_write(tmp_path / "fresh.txt", lambda tmp: open(tmp, "w").write("ok"))
    assert (tmp_path / "fresh.txt").read_text() == "ok" and _leftovers(tmp_path) == []


def test_a_dendrite_saved_under_another_suffix_loads_with_its_format(tmp_path):
    for fmt in DENDRITE_FORMATS:
        path = save_dendrite(tmp_path / f"d-{fmt}.dat", DEN2, format=fmt)
        den, _ = load_dendrite(path, format=fmt)
        np.testing.assert_array_equal(den.nodes, DEN2.nodes)
    with pytest.raises(ValueError, match="Unknown dendrite format from the suffix"):
        load_dendrite(tmp_path / "d-npz.dat")


def test_a_written_file_reaches_the_disk_before_its_rename(tmp_path, monkeypatch):
    # the temporary file is flushed (fsync) before it takes the name, then the folder's entries
    events = []
    real_fsync, real_replace, real_link = os.fsync, os.replace, os.link

    def fsync(fd):
        events.append(("fsync", os.path.basename(os.readlink(f"/proc/self/fd/{fd}"))))
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "replace", lambda a, b: (events.append(("rename", os.path.basename(a))), real_replace(a, b)))
    monkeypatch.setattr(os, "link", lambda a, b: (events.append(("rename", os.path.basename(a))), real_link(a, b)))
    for overwrite in (False, True):
        events.clear()
        atomic_write(tmp_path / "out.txt", lambda tmp: open(tmp, "w").write("data"), overwrite=overwrite)
        names = [e for e in events if e[0] == "fsync"]
        assert len(names) == 2 and names[0][1].startswith(".wdendrite-") and names[0][1].endswith(".out.txt")
        assert names[1][1] == tmp_path.name
        assert events.index(names[0]) < events.index(("rename", names[0][1])) < events.index(names[1])


def _triangle(faces, vertices=((0, 0, 0), (1, 0, 0), (0, 1, 0))):
    import trimesh

    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)


@pytest.mark.parametrize(
    "mesh, match",
    [
        (_triangle([[0, 1, 10**9]]), r"Expected 'mesh.faces' indices in \[0, 3\), but got 1000000000"),
        (_triangle([[0, 1, -1]]), r"Expected 'mesh.faces' indices in \[0, 3\), but got -1"),
        # a finite vertex that float32 cannot hold is not called NaN/inf
        (_triangle([[0, 1, 2]], ((0, 0, 0), (1e300, 0, 0), (0, 1, 0))),
         r"'mesh.vertices' must fit in float32, but has 1 entries beyond its range \(first at \(1, 0\): "
         r"1e\+300 \(too large for float32\)\)"),
    ],
    ids=["face-beyond", "face-negative", "vertex-beyond-float32"],
)
def test_save_mesh_refuses_faces_off_the_vertices_and_vertices_beyond_float32(tmp_path, mesh, match):
    for fmt in MESH_FORMATS:
        with pytest.raises(ValueError, match=match):
            save_mesh(tmp_path / f"m.{fmt}", mesh)
    assert os.listdir(tmp_path) == []


def test_png_and_svg_writers_refuse_other_suffixes_and_png_bits_other_than_int_8_or_16(tmp_path):
    img = np.zeros((4, 4))
    for name in ("x.jpg", "x.svg", "x", "x.png.tmp"):
        with pytest.raises(ValueError, match=rf"Unknown image format from the suffix of 'path' '.*{name}'; "
                                             "allowed formats: png$"):
            save_png(tmp_path / name, img)
    for name in ("x.png", "x.SVGZ", "x"):
        with pytest.raises(ValueError, match=rf"Unknown drawing format from the suffix of 'path' '.*{name}'; "
                                             "allowed formats: svg$"):
            save_svg(tmp_path / name, DEN2)
    for bits in (8.0, True, "8"):
        with pytest.raises(TypeError, match=rf"'bits', but got {bits!r}"):
            save_png(tmp_path / "x.png", img, bits=bits)
    assert os.listdir(tmp_path) == []
    save_png(tmp_path / "X.PNG", img, bits=np.int64(16))
    save_svg(tmp_path / "X.Svg", DEN2)
    assert sorted(os.listdir(tmp_path)) == ["X.PNG", "X.Svg"]


def test_load_dendrite_refuses_widths_of_zero_and_integers_beyond_int64(tmp_path):
    with pytest.raises(ValueError, match=r"'path' '.*bad\.json' is not a dendrite file: 'width' must be positive, "
                                         r"but its minimum is 0\.0"):
        load_dendrite(_dendrite_json(tmp_path, width=[0.0] + [1.0] * (len(DEN2) - 1)))
    path = save_dendrite(tmp_path / "good.npz", DEN2)
    with np.load(path) as z:
        raw = {k: z[k] for k in z.files}
    raw["parent"] = raw["parent"].astype(np.uint64)  # the root's -1 becomes 2**64 - 1
    np.savez(tmp_path / "u64.npz", **raw)
    with pytest.raises(ValueError, match=r"'path' '.*u64\.npz' is not a dendrite file: 'parent' has rows "
                                         r"beyond int64: 18446744073709551615 at index"):
        load_dendrite(tmp_path / "u64.npz")


def test_overwrite_given_as_text_is_refused_and_the_file_kept(tmp_path):
    # overwrite="no" had counted as true and replaced the file
    p = tmp_path / "a.png"
    save_png(p, np.zeros((4, 4)))
    with pytest.raises(TypeError, match="Expected a bool for 'overwrite', but got 'no'"):
        save_png(p, np.ones((4, 4)), overwrite="no")
    assert np.asarray(Image.open(p)).max() == 0


def test_a_float_image_in_0_255_levels_is_saved_with_a_warning(tmp_path):
    # floats are clipped (saturating light); most of them above 1 means levels, which save white
    levels = np.arange(256, dtype=np.float64).reshape(16, 16)
    with pytest.warns(UserWarning, match="most of its values above 1 .* divide 8-bit levels by 255"):
        save_png(tmp_path / "a.png", levels)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        glowing = np.where(levels > 200, 1.7, levels / 255)  # a few saturated pixels: no warning
        save_png(tmp_path / "b.png", glowing)
    np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "b.png"))[levels > 200], 255)


def test_an_error_about_another_file_is_not_blamed_on_the_output(tmp_path):
    # a writer that reads a missing input: the error names the input (it had said "could not write")
    with pytest.raises(FileNotFoundError) as info:
        atomic_write(tmp_path / "out.txt", lambda t: open(tmp_path / "missing.dat").read())
    assert info.value.filename == str(tmp_path / "missing.dat") and "could not write" not in str(info.value)
    assert os.listdir(tmp_path) == []


def test_a_held_ctrl_c_is_not_lost_to_the_blocks_own_error(python_sigint):
    import signal

    from wdendrite.io import interrupts_held

    with pytest.raises(KeyboardInterrupt) as info:
        with interrupts_held():
            os.kill(os.getpid(), signal.SIGINT)
            raise OSError("disk full")
    assert isinstance(info.value.__cause__, OSError)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    with pytest.raises(OSError):  # no Ctrl-C: the block's error as it is
        with interrupts_held():
            raise OSError("disk full")
