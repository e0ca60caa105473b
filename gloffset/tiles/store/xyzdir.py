"""XYZ tile directory output: ``DIR/z/x/y.png`` (y = 0 at the north) and ``metadata.json``
(``z/x/y.pbf`` for vector tiles: the metadata's ``format``).

Every file is written to a temporary name and moved into place with
:func:`os.replace`, so a file that exists is complete whatever interrupted the run.
Tiles that share one image (fully inside the region) are hard links to the first
file written with it, where the file system allows.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

from ...errors import OutputError, OutputExistsError

__all__ = ["XYZDirWriter", "METADATA_FILE", "read_xyz_metadata"]

METADATA_FILE = "metadata.json"


def read_xyz_metadata(path) -> dict:
    """The ``metadata.json`` of the tile directory ``path`` as strings (empty when missing
    or unreadable), read only."""
    try:
        meta = json.loads((Path(path) / METADATA_FILE).read_text())
    except (OSError, ValueError):
        return {}
    return {k: str(v) for k, v in meta.items()} if isinstance(meta, dict) else {}


class XYZDirWriter:
    """Write PNG tiles as ``z/x/y.png`` files under a directory (see the module notes).

    Parameters
    ----------
    path : str or Path
        The directory. If it exists and is not empty, ``resume`` adds the missing
        tiles and ``overwrite`` deletes it first (only a directory that gloffset
        wrote: one with a ``metadata.json`` naming gloffset).
    metadata : dict
        Written to ``metadata.json``.
    """

    def __init__(self, path, metadata: dict, *, resume=False, overwrite=False):
        self.path = Path(path)
        #: the tiles' file ending: the metadata's ``format`` (``png``, or ``pbf`` for MVT)
        self.ext = str(metadata.get("format", "png"))
        if self.path.exists() and not self.path.is_dir():
            raise OutputError(f"{str(self.path)!r} is a file, not a tile directory")
        busy = self.path.is_dir() and any(self.path.iterdir())
        if busy and not resume:
            if not overwrite:
                raise OutputExistsError(self.path)
            if "gloffset" not in self._read_metadata():
                raise OutputError(
                    f"{str(self.path)!r} is not a tile directory written by gloffset "
                    f"(no {METADATA_FILE}); refusing to delete it"
                )
            shutil.rmtree(self.path)
            busy = False
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"cannot create {str(self.path)!r}: {exc.strerror}") from None
        self._dirs: set[Path] = set()
        self._links: dict[bytes, Path] = {}
        self._extent: dict[int, list[int]] = {}
        self._existing = self._scan() if busy else set()
        for z, x, y in self._existing:
            self._grow(z, x, y)
        if not busy:
            self._write_metadata(metadata)

    # ------------------------------------------------------------------ reading
    def _read_metadata(self) -> dict:
        try:
            return json.loads((self.path / METADATA_FILE).read_text())
        except (OSError, ValueError):
            return {}

    def metadata(self) -> dict:
        """The contents of ``metadata.json`` (empty when missing)."""
        return {k: str(v) for k, v in self._read_metadata().items()}

    def _scan(self) -> set[tuple[int, int, int]]:
        out = set()
        for zd in self.path.iterdir():
            if not (zd.is_dir() and zd.name.isdigit()):
                continue
            for xd in zd.iterdir():
                if not (xd.is_dir() and xd.name.isdigit()):
                    continue
                for f in os.scandir(xd):
                    stem, dot, ext = f.name.partition(".")
                    if ext == self.ext and stem.isdigit():
                        out.add((int(zd.name), int(xd.name), int(stem)))
        return out

    def existing(self) -> set[tuple[int, int, int]]:
        """XYZ ``(z, x, y)`` of every tile file present when the writer was opened."""
        return set(self._existing)

    def extent(self, z: int):
        """``(xmin, ymin, xmax, ymax)`` of the tiles of zoom ``z`` present or written."""
        e = self._extent.get(z)
        return None if e is None else tuple(e)

    # ------------------------------------------------------------------ writing
    def _grow(self, z, x, y):
        e = self._extent.get(z)
        if e is None:
            self._extent[z] = [x, y, x, y]
        else:
            e[0], e[1], e[2], e[3] = min(e[0], x), min(e[1], y), max(e[2], x), max(e[3], y)

    def _file(self, z, x, y) -> Path:
        d = self.path / str(z) / str(x)
        if d not in self._dirs:
            d.mkdir(parents=True, exist_ok=True)
            self._dirs.add(d)
        return d / f"{y}.{self.ext}"

    def _atomic(self, path: Path, data: bytes | None, link: Path | None = None) -> None:
        tmp = path.with_name(path.name + ".tmp")
        try:
            if link is not None:
                tmp.unlink(missing_ok=True)
                os.link(link, tmp)
            else:
                assert data is not None  # given without a link
                tmp.write_bytes(data)
            os.replace(tmp, path)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            if link is not None:  # no hard links here: write a copy
                self._atomic(path, link.read_bytes())
                return
            raise OutputError(f"cannot write {str(path)!r}: {exc.strerror or exc}") from None

    def put(self, z: int, x: int, y: int, data: bytes) -> None:
        """Write one tile file (XYZ ``z/x/y``)."""
        z, x, y = int(z), int(x), int(y)
        self._atomic(self._file(z, x, y), data)
        self._grow(z, x, y)

    def put_many(self, tiles, data: bytes) -> None:
        """Write the one image ``data`` at every ``(z, x, y)``: one file, the rest hard links."""
        for z, x, y in tiles:
            z, x, y = int(z), int(x), int(y)
            path = self._file(z, x, y)
            src = self._links.get(data)
            if src is None:
                self._atomic(path, data)
                self._links[data] = path
            else:
                self._atomic(path, None, link=src)
            self._grow(z, x, y)

    def _write_metadata(self, values: dict) -> None:
        self._atomic(self.path / METADATA_FILE, json.dumps(values, indent=2).encode())

    def set_metadata(self, values: dict) -> None:
        """Update ``metadata.json`` with ``values``."""
        self._write_metadata({**self._read_metadata(), **values})

    def put_document(self, name: str, data: bytes) -> None:
        """Write the file ``name`` beside the tiles (the TileMatrixSet of a pyramid that is
        not web mercator)."""
        self._atomic(self.path / name, data)

    def commit(self) -> None:
        """Files are complete as soon as they are written: nothing to do."""

    def finish(self) -> None:
        """The pyramid is complete: make everything durable."""
        self.commit()

    def close(self) -> None:
        """Nothing is held open."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
