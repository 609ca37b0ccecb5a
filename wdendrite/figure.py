"""Figures of several panels: pictures of one size in a grid, each under a label naming what made it.

Every multi-panel picture of :mod:`wdendrite.presets` (and of the notebooks) is laid out here, so
that a reader can match each panel to its parameter values::

    img = panels([a, b, c], labels=["alpha 2", "alpha 1.5", "alpha 1.2"])
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from . import _checks

__all__ = ["font", "panels"]


def font(size: int):
    """Pillow's default font at ``size`` pixels (FreeType's, antialiased), or its small bitmap font where
    Pillow has no FreeType."""
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow without FreeType (or before 10.1): one size only
        return ImageFont.load_default()


_LABEL_PAD = 3
"""Pixels of paper around a panel's label (above and below its line)."""


def _label_size(labels: list[str], width: int, height: int) -> int:
    """One font size for every label of a figure: a twelfth of the panel's height (9 to 15 pixels), less
    where the longest label would not fit the panel's width (to 1 pixel: a label is never cut)."""
    from PIL import Image, ImageDraw

    draw = ImageDraw.Draw(Image.new("L", (1, 1)))
    size = int(np.clip(round(height / 12), 9, 15))
    while size > 1 and max(draw.textlength(t, font=font(size)) for t in labels) > width - 2:
        size -= 1
    return size


def panels(images: Sequence[np.ndarray], *, columns: int | None = None, labels: Sequence[str] | None = None,
           gap: int = 4) -> np.ndarray:
    """Pictures of one size in a grid on white paper, each under its label (a figure's panels).

    A label is one line of dark text, centred in a strip of paper above its panel, in one font size
    for the whole figure (a twelfth of a panel's height, 9 to 15 pixels, smaller where the longest
    label would overflow the panel's width). Panels keep their pixels: a label never covers them.

    Args:
        images: ``(H, W)`` grey or ``(H, W, 3)`` RGB pictures in [0, 1] (clipped to it), one shape for all.
        columns: panels per row (default: all in one row), >= 1.
        labels: one string per panel (say which parameter values made it), or None for no labels.
        gap: paper between panels (pixels), >= 0.

    Returns:
        ``(rows * (H + strip) + (rows - 1) * gap, columns * W + (columns - 1) * gap, 3)`` float32 in
        [0, 1], ``strip`` being 0 without labels.

    Raises:
        ValueError: no images, images of different shapes or non-finite values, a label count other
            than the image count, a label with a line break, ``columns`` < 1, ``gap`` < 0.
        TypeError: a label that is not a str.
    """
    from PIL import Image, ImageDraw

    pics = [_checks.finite_array(f"images[{i}]", v, "(H, W) or (H, W, 3)",
                                 lambda s: len(s) == 2 or (len(s) == 3 and s[2] == 3)) for i, v in enumerate(images)]
    if not pics:
        raise ValueError("'images' is empty: at least one panel is needed")
    pics = [np.clip(p if p.ndim == 3 else np.repeat(p[..., None], 3, axis=2), 0.0, 1.0) for p in pics]
    for i, p in enumerate(pics[1:], 1):
        if p.shape != pics[0].shape:
            raise ValueError(f"'images[{i}]' has shape {p.shape[:2]}, but 'images[0]' has shape {pics[0].shape[:2]}")
    columns = len(pics) if columns is None else _checks.integer("columns", columns, low=1)
    gap = _checks.integer("gap", gap, low=0)
    if labels is not None:
        if isinstance(labels, str) or len(labels) != len(pics):
            raise ValueError(f"Expected one label per panel ({len(pics)}), but got {labels!r}")
        for t in labels:
            if not isinstance(t, str):
                raise TypeError(f"Expected every label as a str, but got {t!r}")
            if "\n" in t or "\r" in t:
                raise ValueError(f"Expected one-line labels, but got {t!r}")
    h, w = pics[0].shape[:2]
    columns = min(columns, len(pics))
    rows = math.ceil(len(pics) / columns)
    size = _label_size(list(labels), w, h) if labels else 0
    strip = 0
    if labels:
        ascent, descent = font(size).getmetrics()
        strip = ascent + descent + 2 * _LABEL_PAD
    out = np.ones((rows * (h + strip) + (rows - 1) * gap, columns * w + (columns - 1) * gap, 3), np.float32)
    for i, p in enumerate(pics):
        r, c = divmod(i, columns)
        y, x = r * (h + strip + gap), c * (w + gap)
        out[y + strip: y + strip + h, x: x + w] = p
        if labels and labels[i]:
            # black text on white paper: the strip is the text's coverage, inverted
            canvas = Image.new("L", (w, strip), 0)
            draw = ImageDraw.Draw(canvas)
            left = (w - draw.textlength(labels[i], font=font(size))) / 2
            draw.text((max(left, 0.0), _LABEL_PAD), labels[i], fill=255, font=font(size))
            out[y: y + strip, x: x + w] = 1.0 - np.asarray(canvas, np.float32)[..., None] / 255.0
    return out
