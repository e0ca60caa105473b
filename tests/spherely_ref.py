"""Build spherely (S2) geographies from a gloffset Shape, for independent cross-checks."""

from __future__ import annotations

import numpy as np
import spherely

from gloffset.geometry.sphere import xyz_to_lonlat


def _lonlat(ring: np.ndarray) -> list:
    lon, lat = xyz_to_lonlat(ring)
    return list(zip(lon.tolist(), lat.tolist()))


def polygons(shape) -> list:
    """One spherely polygon per region component (exterior with its holes), oriented."""
    out = []
    for g in range(shape.n_groups):
        idx = np.flatnonzero(shape.ring_groups == g)
        shells = [i for i in idx if not shape.ring_holes[i]]
        holes = [_lonlat(shape.rings[i]) for i in idx if shape.ring_holes[i]]
        for i in shells:
            out.append(
                spherely.create_polygon(_lonlat(shape.rings[i]), holes or None, oriented=True)
            )
            holes = []  # a component has one exterior; extra shells get no holes
    return out


def boundary(shape):
    """All curves of the shape (ring boundaries and lines) as one spherely geography."""
    lines = [_lonlat(np.vstack([r, r[:1]])) for r in shape.rings]
    lines += [_lonlat(ln) for ln in shape.lines if len(ln) > 1]
    return spherely.create_multilinestring(lines)


def points(lon, lat):
    return np.array([spherely.create_point(float(x), float(y)) for x, y in zip(lon, lat)])
