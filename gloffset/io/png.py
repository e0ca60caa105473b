"""PNG output of masks and class rasters (Pillow), written atomically."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
from PIL import Image, ImageColor

from ..errors import GloffsetError

__all__ = ["parse_color", "read_mask", "write_mask", "write_classes", "CLASS_COLORS"]

#: Colours of the paper's Fig. 13: contained black, frontier red, outside white.
CLASS_COLORS = {0: (255, 255, 255, 255), 1: (220, 30, 30, 255), 2: (0, 0, 0, 255)}


class ColorError(GloffsetError, ValueError):
    """A colour cannot be parsed."""


def parse_color(text: str) -> tuple[int, int, int, int]:
    """RGBA from a CSS colour name, ``#rgb``, ``#rrggbb``, ``#rrggbbaa`` or ``r,g,b[,a]``."""
    s = str(text).strip()
    m = re.fullmatch(r"(\d+),(\d+),(\d+)(?:,(\d+))?", s.replace(" ", ""))
    if m:
        vals = [int(v) for v in m.groups(default="255")]
        if all(0 <= v <= 255 for v in vals):
            return tuple(vals)  # type: ignore[return-value]
    elif re.fullmatch(r"#[0-9a-fA-F]{8}", s):
        return tuple(int(s[i : i + 2], 16) for i in (1, 3, 5, 7))  # type: ignore[return-value]
    else:
        try:
            rgb = ImageColor.getrgb(s)
        except ValueError:
            pass
        else:
            return (*rgb[:3], rgb[3] if len(rgb) == 4 else 255)
    raise ColorError(
        f"cannot read colour {text!r}: use a name (red), #rrggbb, #rrggbbaa or r,g,b[,a]"
    )


def _save(img: Image.Image, path) -> Path:
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    try:
        img.save(tmp, format="PNG")
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise GloffsetError(f"cannot write {str(path)!r}: {exc.strerror or exc}") from None
    return path


def write_mask(mask: np.ndarray, path, *, fill=None, background=None) -> Path:
    """Write a 0/255 mask: greyscale, or RGBA with ``fill`` inside and ``background`` outside."""
    if fill is None and background is None:
        return _save(Image.fromarray(mask.astype(np.uint8), mode="L"), path)
    fg = np.array(parse_color(fill) if fill else (255, 255, 255, 255), dtype=np.uint8)
    bg = np.array(parse_color(background) if background else (0, 0, 0, 0), dtype=np.uint8)
    rgba = np.where(mask[..., None] > 0, fg, bg).astype(np.uint8)
    return _save(Image.fromarray(rgba, mode="RGBA"), path)


def write_classes(classes: np.ndarray, path) -> Path:
    """Write a class raster (0 outside, 1 frontier, 2 contained) in the colours of Fig. 13."""
    lut = np.array([CLASS_COLORS[k] for k in range(3)], dtype=np.uint8)
    return _save(Image.fromarray(lut[np.clip(classes, 0, 2)], mode="RGBA"), path)


def read_mask(path) -> np.ndarray:
    """Read a curve mask: (height, width) bool, True where any channel of a pixel is non-zero.

    Row 0 is the top (northern) row of the image.
    """
    try:
        with Image.open(path) as img:
            arr = np.asarray(img.convert("RGBA") if img.mode == "P" else img)
    except (OSError, ValueError) as exc:
        raise GloffsetError(f"cannot read mask image {str(path)!r}: {exc}") from None
    return arr.reshape(arr.shape[0], arr.shape[1], -1).any(axis=2)
