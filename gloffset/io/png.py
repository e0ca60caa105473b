"""Mask and class images (Pillow): PNG or TIFF out, masks in.

Images are written through :mod:`gloffset.io.output` (atomic for files, through pipes and
devices, ``-`` for standard output), in the format the name asks for (:func:`image_format`).
"""

from __future__ import annotations

import functools
import io
import os
import re
import struct
import zlib
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageColor, features
from PIL.PngImagePlugin import PngInfo

from ..errors import InputFormatError, OptionError, OutputError
from .georef import Georef, write_geotiff, write_world_files
from .output import STDOUT, write_bytes

__all__ = [
    "CLASS_COLORS",
    "IMAGE_FORMATS",
    "image_format",
    "palette_png",
    "parse_color",
    "read_mask",
    "write_classes",
    "write_mask",
    "write_image",
    "write_animation",
]

#: Colours of the paper's Fig. 13: contained black, frontier red, outside white.
CLASS_COLORS = {0: (255, 255, 255, 255), 1: (220, 30, 30, 255), 2: (0, 0, 0, 255)}

#: Lossless image formats that outputs can be written in, by file extension.
IMAGE_FORMATS = {".png": "PNG", ".tif": "TIFF", ".tiff": "TIFF"}


#: The former name of :class:`~gloffset.errors.OptionError` (a colour that cannot be parsed),
#: kept so that ``except ColorError`` works.
ColorError = OptionError


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
    raise OptionError(
        f"cannot read colour {text!r}: use a name (red), #rrggbb, #rrggbbaa or r,g,b[,a]"
    )


_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


@functools.lru_cache(maxsize=64)
def _palette_chunks(palette: tuple) -> bytes:
    """The ``PLTE`` and ``tRNS`` chunks of ``palette`` (RGBA tuples): the same for every
    tile of a pyramid, made once."""
    return _png_chunk(b"PLTE", bytes(c for rgba in palette for c in rgba[:3])) + _png_chunk(
        b"tRNS", bytes(rgba[3] for rgba in palette)
    )


@functools.lru_cache(maxsize=64)
def _header_chunk(w: int, h: int, depth: int) -> bytes:
    """The signature and the ``IHDR`` chunk of a palette image (made once per size)."""
    return _PNG_SIGNATURE + _png_chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, 3, 0, 0, 0))


_IEND = _png_chunk(b"IEND", b"")


def palette_png(index: np.ndarray, palette) -> bytes:
    """PNG bytes of a small palette image: ``index`` (h x w, integers below ``len(palette)``)
    into ``palette`` (at most 4 RGBA tuples; alpha goes to the ``tRNS`` chunk).

    The image is written at the smallest bit depth that holds the palette (1 bit for 2
    colours, 2 bits for 3 or 4), rows unfiltered (the PNG specification's advice for
    palette images) and deflated by zlib at its default level. Decoders give back exactly
    ``index``. This is the map tiles' encoder: on Mexico's rendered 256 px tiles it takes
    67 us and 328 bytes a tile against Pillow's 166 us and 448 bytes
    (``benchmarks/tile_png.py``). The chunks that depend on the size and the palette alone
    are made once.
    """
    index = np.asarray(index)
    if index.ndim != 2 or not 1 <= len(palette) <= 4:
        raise ValueError("palette_png takes an h x w index array and 1 to 4 colours")
    h, w = index.shape
    if len(palette) <= 2:
        depth, bits = 1, index if index.dtype == bool else index.astype(bool)
    else:  # two bits a pixel, high bit first
        idx = index.astype(np.uint8)
        depth, bits = 2, np.stack([idx & 2, idx & 1], axis=-1).reshape(h, 2 * w).astype(bool)
    rows = np.empty((h, 1 + (depth * w + 7) // 8), dtype=np.uint8)
    rows[:, 0] = 0  # filter byte 0: none
    rows[:, 1:] = np.packbits(bits, axis=1)
    return b"".join(
        (
            _header_chunk(w, h, depth),
            _palette_chunks(tuple(tuple(rgba) for rgba in palette)),
            _png_chunk(b"IDAT", zlib.compress(rows.data, 6)),
            _IEND,
        )
    )


def image_format(target) -> str:
    """The format written for an output name: ``"PNG"``, or ``"TIFF"`` for ``.tif``/``.tiff``.

    A name without an extension (``/dev/stdout``, a FIFO) or ``-`` is PNG. JPEG is refused: it
    is lossy, so a mask would come out with other values than 0 and 255 along every edge and the
    classes with other colours. Any other extension is refused too (raises
    :class:`~gloffset.errors.OutputError` naming the supported ones).
    """
    name = os.fspath(target)
    if name == STDOUT:
        return "PNG"
    ext = os.path.splitext(os.path.basename(name))[1].lower()
    if ext == "":
        return "PNG"
    if ext in IMAGE_FORMATS:
        return IMAGE_FORMATS[ext]
    if ext in (".jpg", ".jpeg", ".jpe", ".jfif"):
        why = (
            "JPEG is lossy and would change the image's values along every edge; "
            "write .png or .tif instead"
        )
    else:
        why = f"unsupported image extension {ext!r}; use .png, .tif or .tiff (no extension: PNG)"
    raise OutputError(f"cannot write {name!r}: {why}")


def _save(img: Image.Image, target, place=None) -> None:
    """Encode ``img`` in the format of ``target``'s name and write it (see
    :mod:`gloffset.io.output`: atomic for files, through pipes and devices, ``-`` stdout).

    ``place``: a :class:`Placement` (where the image lies on the Earth). A TIFF is then a
    GeoTIFF (a COG with ``place.cog``), and a PNG written to a file gets a world file and
    a ``.prj`` beside it unless ``place.worldfile`` is False.
    """
    fmt = image_format(target)
    if fmt == "TIFF" and place is not None:
        return write_geotiff(target, np.asarray(img), place.ref, cog=place.cog)
    buf = io.BytesIO()
    if fmt == "TIFF":
        compression = "tiff_adobe_deflate" if features.check("libtiff") else None
        img.save(buf, format="TIFF", compression=compression)
    else:
        info = None
        if place is not None and place.ref.description:
            info = PngInfo()
            info.add_text("Description", place.ref.description)
        img.save(buf, format="PNG", pnginfo=info)
    write_bytes(target, buf.getvalue())
    if place is not None and place.worldfile and fmt == "PNG" and _is_file_name(target):
        write_world_files(target, place.ref)


@dataclass(frozen=True)
class Placement:
    """Where a written image lies (:class:`~gloffset.io.georef.Georef`) and how to say it:
    ``cog`` (a Cloud Optimized GeoTIFF for ``.tif``), ``worldfile`` (beside a PNG)."""

    ref: Georef
    cog: bool = False
    worldfile: bool = True


def _is_file_name(target) -> bool:
    """Whether ``target`` names a regular file (not ``-``, a device or a pipe)."""
    name = os.fspath(target)
    return name != STDOUT and (not os.path.exists(name) or os.path.isfile(name))


def write_mask(
    mask: np.ndarray, target, *, fill=None, opacity=1.0, background=None, place=None
) -> None:
    """Write a 0/255 mask: greyscale (255 inside), or RGBA with ``fill`` inside (its alpha
    times ``opacity``) and ``background`` outside.

    ``target`` is a path (PNG, or TIFF for ``.tif``/``.tiff``) or ``-`` for standard output;
    ``place`` georeferences it (see :func:`_save`). A PNG says in its ``Description`` text
    which value is inside.
    """
    if fill is None and background is None and opacity == 1.0:
        return _save(Image.fromarray(mask.astype(np.uint8), mode="L"), target, place)
    fill_rgba = list(parse_color(fill) if fill else (255, 255, 255, 255))
    fill_rgba[3] = int(round(fill_rgba[3] * opacity))
    fg = np.array(fill_rgba, dtype=np.uint8)
    bg = np.array(parse_color(background) if background else (0, 0, 0, 0), dtype=np.uint8)
    rgba = np.where(mask[..., None] > 0, fg, bg).astype(np.uint8)
    return _save(Image.fromarray(rgba, mode="RGBA"), target, place)


def write_classes(classes: np.ndarray, target, *, place=None) -> None:
    """Write a class raster (0 outside, 1 frontier, 2 contained) in the colours of Fig. 13."""
    lut = np.array([CLASS_COLORS[k] for k in range(3)], dtype=np.uint8)
    return _save(Image.fromarray(lut[np.clip(classes, 0, 2)], mode="RGBA"), target, place)


#: Image modes a mask may have; 16-bit greys are halved at 32768.
_GREY16 = ("I;16", "I;16B", "I;16L", "I")


def read_mask(path) -> np.ndarray:
    """Read a curve mask: (height, width) bool, row 0 the top (northern) row of the image.

    A mask is one of:

    - a greyscale image (1-bit, 8-bit or 16-bit grey, or an RGB/RGBA/palette image whose
      every pixel is grey, R = G = B): the curve is every pixel at least half white
      (>= 128 of 255, >= 32768 of 65535);
    - an image with an alpha channel that is not opaque everywhere: the curve is every pixel
      at least half opaque (alpha >= 128), whatever its colour.

    Anything else (a colour image without transparency, float or CMYK pixels) raises
    :class:`~gloffset.errors.InputFormatError`.
    """
    where = str(path)
    try:
        with Image.open(path) as img:
            img.load()
            mode = img.mode
            if mode in ("P", "PA"):
                img = img.convert("RGBA")
            elif mode == "1":
                img = img.convert("L")
            arr = np.asarray(img)
    except (OSError, ValueError, Image.DecompressionBombError) as exc:
        raise InputFormatError(f"cannot read mask image {where!r}: {exc}") from None
    if mode in _GREY16:
        return arr.astype(np.int64) >= 32768
    if mode not in ("1", "L", "LA", "P", "PA", "RGB", "RGBA"):
        raise InputFormatError(
            f"mask image {where!r} has {mode} pixels: a mask is a grey image (curve where at "
            "least half white) or an image with transparency (curve where at least half opaque)"
        )
    arr = arr.reshape(arr.shape[0], arr.shape[1], -1)
    if arr.shape[2] in (2, 4):  # grey or colour with alpha
        alpha = arr[..., -1]
        if (alpha < 255).any():
            return alpha >= 128
        arr = arr[..., :-1]
    if arr.shape[2] == 3:
        colour = (arr[..., 0] != arr[..., 1]) | (arr[..., 1] != arr[..., 2])
        if colour.any():
            j, i = (int(v[0]) for v in np.nonzero(colour))
            raise InputFormatError(
                f"mask image {where!r} is a colour image (pixel row {j}, column {i} is "
                f"{tuple(int(v) for v in arr[j, i])}): a mask is a grey image (curve where at "
                "least half white) or an image with transparency (curve where at least half "
                "opaque)"
            )
    return arr[..., 0] >= 128


def write_image(rgba: np.ndarray, target) -> None:
    """Write an RGBA picture (h, w, 4) uint8 (PNG, or TIFF by the name; ``-`` stdout)."""
    return _save(Image.fromarray(np.ascontiguousarray(rgba, dtype=np.uint8), mode="RGBA"), target)


def write_animation(frames: list, target, *, duration_ms: int = 80) -> None:
    """Write RGBA frames as an animated PNG (APNG), or a GIF when the name ends in .gif;
    looping forever."""
    name = os.fspath(target)
    fmt = "GIF" if name.lower().endswith(".gif") else "PNG"
    if fmt == "PNG":
        image_format(target)  # refuses other extensions
    images = [Image.fromarray(np.ascontiguousarray(f, dtype=np.uint8), mode="RGBA") for f in frames]
    buf = io.BytesIO()
    extra = {"disposal": 2} if fmt == "GIF" else {"disposal": 1}
    images[0].save(
        buf, format=fmt, save_all=True, append_images=images[1:], duration=duration_ms, loop=0,
        **extra,
    )  # fmt: skip
    write_bytes(target, buf.getvalue())
