"""Where a tile pyramid goes: an MBTiles file, a PMTiles archive or an XYZ directory,
chosen by the path.

The stores offer the same small interface (``existing``, ``put``, ``put_many``,
``metadata``, ``set_metadata``, ``extent``, ``commit``, ``finish`` once the pyramid is
complete, ``close``), so the pyramid does not care which it writes.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Protocol

import numpy as np

from ...errors import OutputError, OutputExistsError

__all__ = [
    "INPUT_KEY",
    "OutputExistsError",
    "check_store",
    "TileStore",
    "check_tile_output",
    "input_digest",
    "open_store",
]

#: The file formats of a tile pyramid, by ending; any other output is an XYZ folder.
TILE_FILES = (".mbtiles", ".pmtiles")

#: The metadata entry that holds :func:`input_digest` of the pyramid's input.
INPUT_KEY = "gloffset_input"


class TileStore(Protocol):
    """What a pyramid writes its tiles to (MBTiles, PMTiles, an XYZ folder, or a store
    of the caller's): tiles by XYZ ``(z, x, y)`` (y = 0 at the north)."""

    def existing(self) -> set[tuple[int, int, int]]:
        """The tiles already there (a resumed output's)."""
        ...

    def put(self, z: int, x: int, y: int, data: bytes) -> None:
        """Write one tile."""
        ...

    def put_many(self, tiles, data: bytes) -> None:
        """Write the one image ``data`` at every ``(z, x, y)`` of ``tiles``."""
        ...

    def metadata(self) -> dict:
        """The metadata recorded (strings)."""
        ...

    def set_metadata(self, values: dict) -> None:
        """Update the metadata with ``values``."""
        ...

    def extent(self, z: int) -> tuple[int, int, int, int] | None:
        """``(x0, y0, x1, y1)`` of the tiles of zoom ``z`` written (None if none)."""
        ...

    def commit(self) -> None:
        """Make the tiles written so far durable."""
        ...

    def finish(self) -> None:
        """The pyramid is complete."""
        ...

    def close(self) -> None:
        """Release the output."""
        ...


def input_digest(shape) -> str:
    """``"sha256:HEX"`` of a :class:`~gloffset.Shape`'s geometry: its rings and lines (the
    float64 unit vectors, little-endian), each ring's seams, components and holes, and the
    number and length of each part. Two inputs with the same digest are the same region
    and curves; a resumed pyramid checks that it continues the same input with it."""
    h = hashlib.sha256(b"gloffset shape 1")
    parts = (
        ("rings", shape.rings, "<f8"),
        ("seams", shape.ring_seams, "|b1"),
        ("lines", shape.lines, "<f8"),
    )
    for name, arrays, dtype in parts:
        h.update(f"{name}:{len(arrays)}".encode())
        for a in arrays:
            a = np.ascontiguousarray(a, dtype=dtype)
            h.update(f"{a.shape}".encode())
            h.update(a.tobytes())
    h.update(np.ascontiguousarray(shape.ring_groups, dtype="<i8").tobytes())
    h.update(np.ascontiguousarray(shape.ring_holes, dtype="|b1").tobytes())
    return "sha256:" + h.hexdigest()


def check_tile_output(path) -> None:
    """Refuse (:class:`~gloffset.errors.OutputError`) an output name that is neither a tile
    file (``.mbtiles``, ``.pmtiles``) nor a folder: a folder is a name without an
    extension, one ending in ``/``, or an existing folder. ``tiles.txt`` or ``t.png``
    would otherwise become a folder of that name."""
    text = os.fspath(path)
    p = Path(text)
    suffix = p.suffix.lower()
    if suffix in TILE_FILES or not suffix or text.endswith(("/", os.sep)) or p.is_dir():
        return
    raise OutputError(
        f"{text!r}: {p.suffix!r} is no tile format; name the output NAME.mbtiles, "
        f"NAME.pmtiles or a folder for z/x/y.png tiles (a name without an extension, or "
        f"one ending in '/': {p.stem + '/'!r})"
    )


def check_store(path, *, resume: bool = False, overwrite: bool = False) -> dict | None:
    """Check, reading only, that :func:`open_store` with these flags would open ``path``;
    the metadata of the output that ``resume`` continues (None: there is none, a new
    output is written).

    Raises what :func:`open_store` raises, before anything is written or unpacked: a
    caller checks every output of a run (and whether each resumes the same pyramid) before
    it writes any."""
    check_tile_output(path)
    path = Path(path)
    if path.suffix.lower() == ".mbtiles":
        from .mbtiles import read_mbtiles_metadata as read_metadata

        busy = path.exists()
    elif path.suffix.lower() == ".pmtiles":
        from .pmtiles import read_pmtiles_metadata as read_metadata

        busy = path.exists() or Path(f"{path}.partial.mbtiles").exists()
    else:
        from .xyzdir import read_xyz_metadata as read_metadata

        if path.exists() and not path.is_dir():
            raise OutputError(f"{str(path)!r} is a file, not a tile directory")
        busy = path.is_dir() and any(path.iterdir())
        if busy and overwrite and not resume and "gloffset" not in read_metadata(path):
            raise OutputError(
                f"{str(path)!r} is not a tile directory written by gloffset "
                "(no metadata.json); refusing to delete it"
            )
    if not busy or overwrite and not resume:
        return None
    if not resume:
        raise OutputExistsError(path)
    return read_metadata(path)


def open_store(path, metadata: dict, *, resume: bool = False, overwrite: bool = False):
    """An MBTiles writer for a path ending in ``.mbtiles``, a PMTiles writer for
    ``.pmtiles``, else an XYZ directory writer.

    Raises :class:`OutputExistsError` when the output exists and neither ``resume``
    nor ``overwrite`` is set, :class:`~gloffset.errors.OutputError` for a name that is
    no tile output (:func:`check_tile_output`).
    """
    check_tile_output(path)
    path = Path(path)
    if path.suffix.lower() == ".mbtiles":
        from .mbtiles import MBTilesWriter

        return MBTilesWriter(path, metadata, resume=resume, overwrite=overwrite)
    if path.suffix.lower() == ".pmtiles":
        from .pmtiles import PMTilesWriter

        return PMTilesWriter(path, metadata, resume=resume, overwrite=overwrite)
    from .xyzdir import XYZDirWriter

    return XYZDirWriter(path, metadata, resume=resume, overwrite=overwrite)
