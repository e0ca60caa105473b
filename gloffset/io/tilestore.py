"""Where a tile pyramid goes: an MBTiles file or an XYZ directory, chosen by the path.

Both stores offer the same small interface (``existing``, ``put``, ``put_many``,
``metadata``, ``set_metadata``, ``extent``, ``commit``, ``close``), so the pyramid
does not care which it writes.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import OutputExistsError

__all__ = ["OutputExistsError", "open_store"]


def open_store(path, metadata: dict, *, resume: bool = False, overwrite: bool = False):
    """An MBTiles writer for a path ending in ``.mbtiles``, else an XYZ directory writer.

    Raises :class:`OutputExistsError` when the output exists and neither ``resume``
    nor ``overwrite`` is set.
    """
    path = Path(path)
    if path.suffix.lower() == ".mbtiles":
        from .mbtiles import MBTilesWriter

        return MBTilesWriter(path, metadata, resume=resume, overwrite=overwrite)
    from .xyzdir import XYZDirWriter

    return XYZDirWriter(path, metadata, resume=resume, overwrite=overwrite)
