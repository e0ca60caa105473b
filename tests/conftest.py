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
