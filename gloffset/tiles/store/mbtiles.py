"""MBTiles 1.3 output: a SQLite file of PNG tiles, written in committed batches.

The schema is the common deduplicating one: ``map`` (zoom_level, tile_column,
tile_row, tile_id) points into ``images`` (tile_data, tile_id), a ``tiles`` view
joins them, and ``metadata`` holds name/value rows. Identical images are stored
once (``tile_id`` is the MD5 of the PNG), so the one image of every fully-inside
tile is a single blob. Rows are TMS: ``tile_row = 2^z - 1 - y``.

The file is created complete (schema and metadata) under a temporary name and
moved into place, and tiles are committed every ``batch`` rows, so an interrupted
run leaves a valid MBTiles file that holds every tile committed so far.
"""

from __future__ import annotations

import hashlib
import sqlite3
from pathlib import Path

from ...errors import OutputError, OutputExistsError
from ...io.output import replacing

__all__ = ["MBTilesWriter", "read_mbtiles_metadata", "tms_row", "SCHEMA"]

SCHEMA = """
CREATE TABLE metadata (name TEXT, value TEXT);
CREATE UNIQUE INDEX metadata_name ON metadata (name);
CREATE TABLE map (zoom_level INTEGER, tile_column INTEGER, tile_row INTEGER, tile_id TEXT);
CREATE UNIQUE INDEX map_index ON map (zoom_level, tile_column, tile_row);
CREATE TABLE images (tile_data BLOB, tile_id TEXT);
CREATE UNIQUE INDEX images_id ON images (tile_id);
CREATE VIEW tiles AS
    SELECT map.zoom_level AS zoom_level, map.tile_column AS tile_column,
           map.tile_row AS tile_row, images.tile_data AS tile_data
    FROM map JOIN images ON images.tile_id = map.tile_id;
"""


def tms_row(z: int, y: int) -> int:
    """The MBTiles (TMS) row of XYZ row ``y`` at zoom ``z``: ``2^z - 1 - y``."""
    return (1 << z) - 1 - y


def read_mbtiles_metadata(path) -> dict:
    """The metadata rows of the MBTiles file ``path``, read only (the file is not changed);
    :class:`~gloffset.errors.OutputError` for a file that is not a gloffset MBTiles file."""
    try:
        db = sqlite3.connect(Path(path).absolute().as_uri() + "?mode=ro", uri=True)
        try:
            names = {r[0] for r in db.execute("SELECT name FROM sqlite_master")}
            if not {"map", "images", "metadata"} <= names:
                raise OutputError(
                    f"{str(path)!r} was not written by gloffset (no map/images tables); "
                    "use --force to replace it"
                )
            return dict(db.execute("SELECT name, value FROM metadata"))
        finally:
            db.close()
    except sqlite3.Error as exc:
        raise OutputError(f"{str(path)!r} is not an MBTiles file: {exc}") from None


class MBTilesWriter:
    """Write PNG tiles into an MBTiles file (see the module notes).

    Parameters
    ----------
    path : str or Path
        The ``.mbtiles`` file. It must not exist unless ``resume`` (append, skipping
        tiles already there) or ``overwrite`` (start afresh).
    metadata : dict
        Metadata rows (name -> value); values are stored as text.
    resume, overwrite : bool
    batch : int
        Map rows per committed transaction at most (a pyramid also commits after each
        zoom and each task). Each commit waits for the disk: a million entries took
        16 s in batches of 2,000 and 5.5 s in batches of 50,000.
    """

    suffix = ".mbtiles"

    def __init__(self, path, metadata: dict, *, resume=False, overwrite=False, batch=50_000):
        self.path = Path(path)
        self.batch = int(batch)
        self._pending = 0
        if self.path.exists() and not resume and not overwrite:
            raise OutputExistsError(self.path)
        if not self.path.exists() or not resume:  # a new file replaces (its mode kept)
            self._create(metadata)
        try:
            self.db = sqlite3.connect(self.path, isolation_level=None)
            self.db.execute("PRAGMA synchronous=NORMAL")
            names = {r[0] for r in self.db.execute("SELECT name FROM sqlite_master")}
        except sqlite3.DatabaseError as exc:
            raise OutputError(f"{str(self.path)!r} is not an MBTiles file: {exc}") from None
        if not {"map", "images", "metadata"} <= names:
            self.db.close()
            raise OutputError(
                f"{str(self.path)!r} was not written by gloffset (no map/images tables); "
                "use --force to replace it"
            )
        self._ids: set[str] = set()
        self.db.execute("BEGIN")

    def _create(self, metadata: dict) -> None:
        try:
            with replacing(self.path) as tmp:
                db = sqlite3.connect(tmp)
                try:
                    db.executescript(SCHEMA)
                    db.executemany(
                        "INSERT INTO metadata (name, value) VALUES (?, ?)",
                        [(k, str(v)) for k, v in metadata.items()],
                    )
                    db.commit()
                finally:
                    db.close()
        except (OSError, sqlite3.Error) as exc:
            if isinstance(exc, OutputError):
                raise
            raise OutputError(f"cannot create {str(self.path)!r}: {exc}") from None

    # ------------------------------------------------------------------ reading
    def metadata(self) -> dict:
        """The metadata rows as a dict of strings."""
        return dict(self.db.execute("SELECT name, value FROM metadata"))

    def existing(self) -> set[tuple[int, int, int]]:
        """XYZ ``(z, x, y)`` of every tile already stored."""
        rows = self.db.execute("SELECT zoom_level, tile_column, tile_row FROM map")
        return {(z, x, tms_row(z, r)) for z, x, r in rows}

    def extent(self, z: int):
        """``(xmin, ymin, xmax, ymax)`` (XYZ) of the stored tiles of zoom ``z``, or None."""
        row = self.db.execute(
            "SELECT min(tile_column), min(tile_row), max(tile_column), max(tile_row) "
            "FROM map WHERE zoom_level = ?",
            (z,),
        ).fetchone()
        if row[0] is None:
            return None
        return (row[0], tms_row(z, row[3]), row[2], tms_row(z, row[1]))

    # ------------------------------------------------------------------ writing
    def _image(self, data: bytes) -> str:
        tid = hashlib.md5(data).hexdigest()
        if tid not in self._ids:
            self.db.execute(
                "INSERT OR IGNORE INTO images (tile_data, tile_id) VALUES (?, ?)",
                (sqlite3.Binary(data), tid),
            )
            self._ids.add(tid)
        return tid

    def put(self, z: int, x: int, y: int, data: bytes) -> None:
        """Store one tile (XYZ ``z/x/y``), replacing any tile there."""
        self.put_many([(z, x, y)], data)

    def put_many(self, tiles, data: bytes) -> None:
        """Store the one image ``data`` at every XYZ ``(z, x, y)`` of ``tiles``."""
        tid = self._image(data)
        rows = [(int(z), int(x), tms_row(int(z), int(y)), tid) for z, x, y in tiles]
        for s in range(0, len(rows), self.batch):
            part = rows[s : s + self.batch]
            self.db.executemany(
                "INSERT OR REPLACE INTO map (zoom_level, tile_column, tile_row, tile_id) "
                "VALUES (?, ?, ?, ?)",
                part,
            )
            self._pending += len(part)
            if self._pending >= self.batch:
                self.commit()

    def set_metadata(self, values: dict) -> None:
        """Insert or replace metadata rows."""
        self.db.executemany(
            "INSERT OR REPLACE INTO metadata (name, value) VALUES (?, ?)",
            [(k, str(v)) for k, v in values.items()],
        )

    def commit(self) -> None:
        """Make everything stored so far durable, and open the next batch."""
        self.db.execute("COMMIT")
        self.db.execute("BEGIN")
        self._pending = 0

    def finish(self) -> None:
        """The pyramid is complete: make everything durable."""
        self.commit()

    def close(self) -> None:
        """Commit and close (also after an error: what was stored stays valid)."""
        if self.db is not None:
            if self.db.in_transaction:
                self.db.execute("COMMIT")
            self.db.close()
            # closed: the other methods run on an open store only
            self.db = None  # type: ignore[assignment]

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
