import inspect
import json
from pathlib import Path

import numpy as np
import pytest

DATA = Path(__file__).resolve().parent.parent / "data"

# Synthetic shapes several test modules use
SQUARE_WITH_HOLE = {
    "type": "Polygon",
    "coordinates": [
        [[-20, -10], [20, -10], [20, 15], [-20, 15], [-20, -10]],
        [[-5, -3], [6, -3], [6, 4], [-5, 4], [-5, -3]],
    ],
}
LINES = {
    "type": "MultiLineString",
    "coordinates": [[[-150, 10], [-100, 40], [-60, 5]], [[170, -30], [-170, -35]]],
}


@pytest.fixture(scope="session")
def world():
    """Natural Earth 110m countries: {name: Feature}."""
    fc = json.loads((DATA / "world_110m.geojson").read_text())
    return {f["properties"]["name"]: f for f in fc["features"]}


@pytest.fixture(scope="session")
def mexico_path():
    return DATA / "mexico_10m.geojson"


def uniform_sphere(n, seed=0):
    """n points uniform on the sphere, as lon/lat degrees."""
    rng = np.random.default_rng(seed)
    lon = rng.uniform(-180.0, 180.0, n)
    lat = np.degrees(np.arcsin(rng.uniform(-1.0, 1.0, n)))
    return lon, lat


# Readers of tile outputs and the one-line CLI error check, shared by the test modules


def read_mbtiles(path):
    """{(z, x, y): png bytes} with XYZ rows, and the metadata."""
    import sqlite3

    db = sqlite3.connect(path)
    tiles = {
        (z, x, (1 << z) - 1 - r): bytes(data) for z, x, r, data in db.execute("SELECT * FROM tiles")
    }
    meta = dict(db.execute("SELECT name, value FROM metadata"))
    db.close()
    return tiles, meta


def read_dir(path):
    """{(z, x, y): png bytes} of an XYZ folder."""
    import os

    out = {}
    for root, _, files in os.walk(path):
        for f in files:
            if f.endswith(".png"):
                z, x = (int(v) for v in os.path.relpath(root, path).split(os.sep))
                with open(os.path.join(root, f), "rb") as fh:
                    out[(z, x, int(f[:-4]))] = fh.read()
    return out


def read_tiles(path):
    """{(z, x, y): png bytes} and the metadata of an MBTiles, PMTiles or XYZ folder."""
    path = str(path)
    if path.endswith(".pmtiles"):
        from gloffset.tiles.store.pmtiles import read_pmtiles

        meta, tiles = read_pmtiles(path)
        return tiles, meta
    if path.endswith(".mbtiles"):
        return read_mbtiles(path)
    return read_dir(path), None


def assert_one_line_error(proc, *words):
    """A command that failed with exit 2 and one line naming ``words`` on stderr."""
    err = proc.stderr.decode()
    assert proc.returncode == 2, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("gloffset: error: "), err
    for w in words:
        assert w in lines[0], err


def assert_options_refused(call, func, what):
    """``call()`` passes ``func`` an unknown keyword (``sise``): a TypeError names it and
    lists the options, those its docstring's "Other Parameters" documents, in its order."""
    with pytest.raises(TypeError) as err:
        call()
    head = f"{what}() got an unexpected keyword argument 'sise'; its options are "
    msg = str(err.value)
    assert msg.startswith(head), msg
    section = inspect.getdoc(func).split("Other Parameters\n----------------\n")[1]
    names: list[str] = []
    for line in section.splitlines():
        if line and not line[0].isspace():
            if set(line) == {"-"}:  # the next section's underline: its title was last
                names.pop()
                break
            names += [n.strip() for n in line.split(" : ")[0].split(",")]
    assert msg[len(head) :].split(", ") == names
