"""The README's examples run as written (same sizes, same values) and make the pictures it promises."""

import shlex
from pathlib import Path

import numpy as np
from PIL import Image
from scipy import ndimage
from skimage.morphology import skeletonize

from wdendrite import cli

README = Path(__file__).resolve().parents[1] / "README.md"


def _block(heading: str, fence: str) -> str:
    """The first ``fence`` code block after ``heading`` in the README."""
    return README.read_text().split(heading, 1)[1].split(f"```{fence}\n", 1)[1].split("```", 1)[0]


def _command(block: str, starts: str) -> list[str]:
    """The arguments of the ``wdendrite`` command in ``block`` whose line starts with ``starts``
    (after the last ``&&`` of a chained line; a trailing comment dropped)."""
    lines = [ln.split("&&")[-1].strip() for ln in block.splitlines()]
    line = next(ln for ln in lines if ln.startswith(starts))
    words = shlex.split(line, comments=True)
    assert words[0] == "wdendrite"
    return words[1:]


def _grey(path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("L"), np.float64) / 255.0


def _looks_like_a_dendrite(value: np.ndarray, root) -> None:
    """Light on black: mostly dark, the lit pixels one 8-connected branching figure through ``root``
    that reaches far from it (a carpet of light, or a speck, fails)."""
    lit = value > 0.25
    assert (value < 0.1).mean() > 0.7 and 0.01 < lit.mean() < 0.2
    labels, count = ndimage.label(lit, structure=np.ones((3, 3)))
    sizes = np.bincount(labels.ravel())[1:]
    assert labels[root] > 0 and sizes[labels[root] - 1] > 0.97 * lit.sum()  # (a few lit specks may stand apart)
    # branching: many tips, far more than a line or a blob has, reaching most of the way to the border
    rows, cols = np.nonzero(labels == labels[root])
    reach = np.hypot(rows - root[0], cols - root[1]).max()
    assert reach > 0.35 * min(value.shape)
    skeleton = skeletonize(lit)
    neighbours = ndimage.convolve(skeleton.astype(int), np.ones((3, 3), int), mode="constant") - 1
    assert (skeleton & (neighbours == 1)).sum() >= 20  # line ends: the tips of the branches


def test_readme_api_block_runs_as_written_and_draws_a_dendrite(tmp_path, monkeypatch):
    block = _block("## The API in a screenful", "python")
    monkeypatch.chdir(tmp_path)  # (the block writes dendrite.png into the working folder)
    scope: dict = {}
    exec(compile(block, str(README), "exec"), scope)
    n = 256
    assert scope["cf"].dist.shape == (n, n)
    paths = scope["den"].paths()
    assert isinstance(paths, list) and len(paths) == len(scope["den"].endpoints) == 20
    img = scope["img"]
    assert img.shape == (n, n) and 0.0 <= img.min() and img.max() <= 1.0
    _looks_like_a_dendrite(img, (n // 2, n // 2))
    # the file holds that picture (8-bit)
    np.testing.assert_allclose(_grey(tmp_path / "dendrite.png"), img, atol=0.5 / 255 + 1e-6)
    assert scope["mesh"].is_watertight and len(scope["mesh"].split(only_watertight=False)) == 1  # one body
    assert scope["terrain"].shape == (256, 256)
    assert scope["heights"].shape == (2,)
    # the filled terrain drains to its border: the border cells with no lower neighbour on the
    # filled surface are where all the area ends (an interior end would keep some of it)
    area, filled = scope["area"], scope["wd"].hydrology.fill(scope["terrain"])
    m = filled.shape[0]
    pad = np.pad(filled, 1, constant_values=np.inf)
    lowest = np.min([pad[1 + dr:m + 1 + dr, 1 + dc:m + 1 + dc] for dr in (-1, 0, 1) for dc in (-1, 0, 1)
                     if dr or dc], axis=0)
    border = np.zeros((m, m), bool)
    border[[0, -1], :] = border[:, [0, -1]] = True
    assert area.shape == (m, m) and area[border & (lowest >= filled)].sum() == m * m


def test_readme_first_command_draws_the_fractal(tmp_path, monkeypatch):
    args = _command(_block("## Two commands", "bash"), "wdendrite fractal")
    monkeypatch.chdir(tmp_path)
    assert cli.main([*args, "--quiet"]) == 0
    img = _grey(tmp_path / "fractal.png")
    assert img.shape == (256, 256)
    _looks_like_a_dendrite(img, (128, 128))


def test_readme_lichtenberg_command_draws_fine_antialiased_branches(tmp_path, monkeypatch):
    args = _command(_block("## The command", "bash"), "wdendrite dendry --size 768 --levels 5")
    assert {"lichtenberg"} <= set(args) and "level" not in args
    monkeypatch.chdir(tmp_path)
    assert cli.main([*args, "--quiet"]) == 0
    out = next(a for a in args if a.endswith(".png"))
    ink = 1.0 - _grey(tmp_path / out)  # dark branches on paper
    # mostly paper; antialiased (many shades between paper and ink, where the old picture had five greys)
    assert (ink < 0.05).mean() > 0.55 and 0.1 < (ink > 0.5).mean() < 0.35
    assert len(np.unique(np.round(ink * 255))) > 100
    # one branching figure: nearly all the ink 8-connected
    labels, _ = ndimage.label(ink > 0.5, structure=np.ones((3, 3)))
    sizes = np.bincount(labels.ravel())[1:]
    assert sizes.max() > 0.95 * sizes.sum()
    # fine branches with thick trunks: most ink lies within a pixel of paper, but some strokes are
    # several pixels wide
    depth = ndimage.distance_transform_edt(ink > 0.5)
    assert np.mean(depth[ink > 0.5] <= 1.0) > 0.6 and depth.max() >= 2.5


def test_readme_layout_names_every_module_and_folder():
    """The README's picture of the package names every module of ``wdendrite/`` (as ``name.py``)
    and of ``kernels/`` (by its concept, the module's name) and every top-level folder, and names
    no file that is not there."""
    root = README.parent
    layout = _block("## Layout", "")
    words = {w.strip("`()") for w in layout.replace(";", " ").replace(",", " ").replace(":", " ").split()}
    host = {p.name for p in (root / "wdendrite").glob("*.py")} - {"__init__.py", "__main__.py"}
    missing = sorted(m for m in host if m not in words)
    kernels_text = layout.split("\nkernels/", 1)[1].split("\ntests/", 1)[0]
    kernel_words = {w.strip("`()") for w in kernels_text.replace(";", " ").replace(",", " ").replace(":", " ").split()}
    missing += sorted(f"kernels/{p.name}" for p in (root / "kernels").glob("*.py")
                      if p.name != "__init__.py" and p.stem not in kernel_words)
    assert not missing, f"README's layout does not mention {missing}"
    assert {"wdendrite/", "kernels/", "tests/", "benchmarks/", "notebooks/", "scripts/", "docs/"} <= words
    stale = sorted(w for w in words if w.endswith(".py") and w != ".py" and w not in host
                   and not any((root / d / w).exists() for d in ("tests", "benchmarks", "scripts")))
    assert not stale, f"README's layout names files that do not exist: {stale}"


def test_readme_terrain_files_reload_as_its_lines_say(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    commands = [ln for ln in _block("### Terrain files", "bash").splitlines() if ln.startswith("wdendrite")]
    assert [c.split("-o ")[1].split()[0] for c in commands] == ["dem.png", "dem.r16", "dem.tif", "dem.zarr"]
    for line in commands:
        assert cli.main([*_command(line, "wdendrite"), "--quiet", "--device", "cpu"]) == 0, line
    names = {}
    exec(_block("### Terrain files", "python"), names)  # the reading lines, as written
    z, r16, tif, ds = (names[k] for k in ("z", "r16", "tif", "ds"))
    # one terrain (seed 0, extent 4) in every file: the float32 files equal, the 16-bit ones its
    # levels on -1..2 (an independent scaling), the PNG's text chunks giving the elevations back
    assert tif.dtype == np.float32 and np.array_equal(ds["elevation"].values, tif)
    want = np.floor((tif.astype(np.float64) + 1.0) / 3.0 * 65535 + 0.5)
    np.testing.assert_array_equal(r16, want)
    np.testing.assert_array_equal(np.asarray(names["png"]), want)
    assert np.abs(z - tif).max() <= 0.5 * 3.0 / 65535 * (1 + 1e-9)
    assert ds.attrs["domain"] == [[0.0, 0.0], [4.0, 4.0]] and ds["x"].values[0] == 2.0 / 257
    ds.close()
