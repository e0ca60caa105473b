"""Where a tile pyramid goes: an MBTiles file, a PMTiles archive or an XYZ directory,
chosen by the path.

The stores offer the same small interface (``existing``, ``put``, ``put_many``,
``metadata``, ``set_metadata``, ``extent``, ``commit``, ``finish`` once the pyramid is
complete, ``close``), so the pyramid does not care which it writes.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import OutputExistsError

__all__ = ["OutputExistsError", "open_store"]


def open_store(path, metadata: dict, *, resume: bool = False, overwrite: bool = False):
    """An MBTiles writer for a path ending in ``.mbtiles``, a PMTiles writer for
    ``.pmtiles``, else an XYZ directory writer.

    Raises :class:`OutputExistsError` when the output exists and neither ``resume``
    nor ``overwrite`` is set.
    """
    path = Path(path)
    if path.suffix.lower() == ".mbtiles":
        from .mbtiles import MBTilesWriter

        return MBTilesWriter(path, metadata, resume=resume, overwrite=overwrite)
    if path.suffix.lower() == ".pmtiles":
        from .pmtiles import PMTilesWriter

        return PMTilesWriter(path, metadata, resume=resume, overwrite=overwrite)
    from .xyzdir import XYZDirWriter

    return XYZDirWriter(path, metadata, resume=resume, overwrite=overwrite)
