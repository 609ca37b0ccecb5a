"""Writing results to disk safely (temporary file, then rename)."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

__all__ = ["atomic_write", "save_png"]


def _target(path, overwrite: bool) -> Path:
    path = Path(path)
    if not path.parent.exists():
        raise ValueError(f"The folder of 'path' does not exist: {str(path.parent)!r}")
    if path.exists() and not overwrite:
        raise FileExistsError(f"'path' {str(path)!r} exists; pass overwrite=True to replace it")
    return path


def atomic_write(path, write, *, overwrite: bool = False) -> Path:
    """Call ``write(tmp_path)`` on a temporary file beside ``path``, then rename it to ``path``.

    An interrupted write leaves no half-written ``path`` behind.
    """
    path = _target(path, overwrite)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def save_png(path, image: np.ndarray, *, bits: int = 8, overwrite: bool = False) -> Path:
    """Save a 2D grey (H, W) or colour (H, W, 3|4) image with values in [0, 1] as an 8- or 16-bit PNG."""
    from PIL import Image

    img = np.asarray(image, dtype=np.float64)
    if img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] not in (3, 4)):
        raise ValueError(f"Expected 'image' of shape (H, W), (H, W, 3) or (H, W, 4), but got {img.shape}")
    if bits not in (8, 16):
        raise ValueError(f"Expected 'bits' in (8, 16), but got {bits!r}")
    if bits == 16 and img.ndim == 3:
        raise ValueError("16-bit PNGs are written for grey images only (shape (H, W))")
    img = np.nan_to_num(np.clip(img, 0.0, 1.0))
    if bits == 8:
        pil = Image.fromarray((img * 255 + 0.5).astype(np.uint8))
    else:
        pil = Image.fromarray((img * 65535 + 0.5).astype(np.uint16))
    return atomic_write(path, lambda tmp: pil.save(tmp, format="PNG"), overwrite=overwrite)
