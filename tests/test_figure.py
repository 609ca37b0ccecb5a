"""Figures of labelled panels: panels keep their pixels, each label is its text, centred over its panel."""

import numpy as np
import pytest
from PIL import Image, ImageDraw

from wdendrite import figure


def _panels(n, shape=(60, 90)):
    rng = np.random.default_rng(0)
    return [rng.uniform(0.2, 0.8, (*shape, 3)).astype(np.float32) for _ in range(n)]


def _ink_columns(strip: np.ndarray) -> np.ndarray:
    """Columns of a label strip that hold ink (dark pixels)."""
    return np.flatnonzero((strip < 0.5).any(axis=(0, 2)))


def test_panels_sit_in_a_grid_and_keep_their_pixels():
    pics = _panels(5)
    out = figure.panels(pics, columns=3, gap=4)
    assert out.shape == (2 * 60 + 4, 3 * 90 + 2 * 4, 3) and out.dtype == np.float32
    for i, p in enumerate(pics):
        r, c = divmod(i, 3)
        np.testing.assert_array_equal(out[r * 64: r * 64 + 60, c * 94: c * 94 + 90], p)
    assert np.all(out[:, 90:94] == 1.0) and np.all(out[60:64] == 1.0)  # white gaps
    assert np.all(out[64:, 2 * 94:] == 1.0)  # the empty sixth place is paper
    grey = figure.panels([np.zeros((8, 8)), np.ones((8, 8))])  # grey pictures become RGB
    assert grey.shape == (8, 20, 3) and np.all(grey[:, :8] == 0.0) and np.all(grey[:, 12:] == 1.0)


def test_each_label_is_its_text_centred_over_its_panel():
    labels = ["alpha 2, beta 3", "n = 0", ""]
    pics = _panels(3)
    out = figure.panels(pics, labels=labels, gap=4)
    size = int(np.clip(round(60 / 12), 9, 15))  # the documented size: a twelfth of the panel's height, 9 to 15
    ascent, descent = figure.font(size).getmetrics()
    strip = ascent + descent + 6
    assert out.shape == (60 + strip, 3 * 90 + 2 * 4, 3)
    for k, text in enumerate(labels):
        x = k * 94
        np.testing.assert_array_equal(out[strip:, x: x + 90], pics[k])  # the label never covers its panel
        cols = _ink_columns(out[:strip, x: x + 90])
        if not text:
            assert cols.size == 0
            continue
        # the ink spans the text's width as Pillow lays it out, centred under the panel
        width = ImageDraw.Draw(Image.new("L", (1, 1))).textlength(text, font=figure.font(size))
        assert abs((cols[-1] + 1 - cols[0]) - width) <= 2
        assert abs((cols[0] + cols[-1] + 1) / 2 - 45) <= 1.5


def test_a_long_label_shrinks_every_label_to_fit():
    out = figure.panels(_panels(2, (120, 60)), labels=["a label far too long for a narrow panel", "b"])
    cols = _ink_columns(out[: out.shape[0] - 120, :60])
    assert cols.size and cols[0] > 0 and cols[-1] < 59  # the whole text, inside its panel's width
    short = figure.panels(_panels(2, (120, 60)), labels=["a", "b"])
    assert out.shape[0] < short.shape[0]  # one smaller font for the whole figure: a lower strip


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(images=[]), ValueError, "'images' is empty"),
    (dict(images=[np.zeros((4, 4)), np.zeros((4, 5))]), ValueError, r"'images\[1\]' has shape \(4, 5\)"),
    (dict(images=[np.zeros((4, 4, 2))]), ValueError, r"'images\[0\]'"),
    (dict(images=[np.full((4, 4), np.nan)]), ValueError, r"'images\[0\]'"),
    (dict(images=[np.zeros((4, 4))] * 2, labels=["one"]), ValueError, "one label per panel"),
    (dict(images=[np.zeros((4, 4))], labels="a"), ValueError, "one label per panel"),
    (dict(images=[np.zeros((4, 4))], labels=[3]), TypeError, "every label as a str"),
    (dict(images=[np.zeros((4, 4))], labels=["two\nlines"]), ValueError, "one-line labels"),
    (dict(images=[np.zeros((4, 4))], columns=0), ValueError, "'columns'"),
    (dict(images=[np.zeros((4, 4))], gap=-1), ValueError, "'gap'"),
])
def test_bad_figures_are_refused(kwargs, error, match):
    with pytest.raises(error, match=match):
        figure.panels(**kwargs)
