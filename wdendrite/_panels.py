"""Figures of several panels: pictures of one size in a grid, each under its label (as the papers' figures)."""

from __future__ import annotations

import math

import numpy as np


def _font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow without FreeType: its small bitmap font
        return ImageFont.load_default()


def labelled(panels: list[np.ndarray], labels: list[str], columns: int, gap: int = 6) -> np.ndarray:
    """``panels`` (``(h, w, 3)`` floats in [0, 1], one size) in rows of ``columns``, white gaps between,
    each under its label in black on white (Pillow's default font, about 8 % of the panel's height,
    at least 11 pixels).

    Returns:
        ``(H, W, 3)`` float32 picture in [0, 1].
    """
    from PIL import Image, ImageDraw

    h, w = panels[0].shape[:2]
    size = max(11, round(0.08 * h))
    strip = size + 6
    rows = math.ceil(len(panels) / columns)
    out = np.ones((rows * (strip + h) + (rows - 1) * gap, columns * w + (columns - 1) * gap, 3), np.float32)
    text = Image.new("L", (out.shape[1], out.shape[0]), 255)
    draw, font = ImageDraw.Draw(text), _font(size)
    for i, (p, label) in enumerate(zip(panels, labels)):
        r, c = divmod(i, columns)
        y, x = r * (strip + h + gap), c * (w + gap)
        out[y + strip: y + strip + h, x: x + w] = p
        left, top, right, bottom = draw.textbbox((0, 0), label, font=font)
        draw.text((x + (w - (right - left)) / 2 - left, y + (strip - (bottom - top)) / 2 - top), label, fill=0,
                  font=font)
    ink = np.asarray(text, np.float32)[..., None] / 255.0
    return np.minimum(out, ink)
