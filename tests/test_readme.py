"""The README's API screenful runs as written (at smaller sizes), so it cannot drift from the code."""

from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_api_block_runs():
    text = README.read_text()
    block = text.split("## The API in a screenful", 1)[1].split("```python", 1)[1].split("```", 1)[0]
    small = {"(512, 512)": "(96, 96)", "[[256, 256]]": "[[48, 48]]", "d=600": "d=120", "epsilon=40": "epsilon=20",
             "(1024, 1024)": "(128, 128)", "(0, 0, 256, 256)": "(0, 0, 64, 64)", "(40, 40, 40)": "(24, 24, 24)"}
    for big, little in small.items():
        assert big in block, f"README API block no longer contains {big!r}; update this test"
        block = block.replace(big, little)
    scope: dict = {}
    exec(compile(block, str(README), "exec"), scope)
    assert scope["cf"].dist.shape == (96, 96)
    assert scope["img"].shape == (96, 96) and 0.0 <= scope["img"].min() and scope["img"].max() <= 1.0
    assert scope["mesh"].is_watertight and len(scope["mesh"].split(only_watertight=False)) == 1
    assert scope["terrain"].shape == (64, 64)
    assert scope["heights"].shape == (2,)
    # the filled terrain drains to its border: the border cells with no lower neighbour on the
    # filled surface are where all the area ends (an interior end would keep some of it)
    import numpy as np

    area, filled = scope["area"], scope["wd"].hydrology.fill(scope["terrain"])
    pad = np.pad(filled, 1, constant_values=np.inf)
    lowest = np.min([pad[1 + dr:65 + dr, 1 + dc:65 + dc] for dr in (-1, 0, 1) for dc in (-1, 0, 1)
                     if dr or dc], axis=0)
    border = np.zeros((64, 64), bool)
    border[[0, -1], :] = border[:, [0, -1]] = True
    assert area.shape == (64, 64) and area[border & (lowest >= filled)].sum() == 64 * 64
