"""The ellipsoid (WGS84, GRS80, any ``(a, f)``): its model and conformal sphere
(:mod:`.model`), the bounds between its geodesic distances and the spherical ones
(:mod:`.bounds`), and the shortest geodesic from a point to a geodesic edge
(:mod:`.intercept`). The maths layer: numpy and geographiclib (and pyproj's C geodesics
when installed, the same routines vectorised), nothing above."""

from .bounds import edge_deviation, lower_distance, upper_distance, window_scale
from .intercept import edge_distance, edge_distances, geodesic_midpoints
from .model import ELLIPSOIDS, Ellipsoid, as_ellipsoid

__all__ = [
    "ELLIPSOIDS",
    "Ellipsoid",
    "as_ellipsoid",
    "edge_deviation",
    "edge_distance",
    "edge_distances",
    "geodesic_midpoints",
    "lower_distance",
    "upper_distance",
    "window_scale",
]
