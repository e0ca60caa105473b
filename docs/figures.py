"""Draw the README pictures from gloffset's own output (run: python docs/figures.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

import gloffset

HERE = Path(__file__).resolve().parent
DATA = HERE.parent / "data"


def vector_offsets(path=HERE / "mexico_offsets.png", size=(720, 460)):
    """Mexico (10m) and the regions within 50, 127 and 250 km of it (float64 reference
    at pixel centres), equirectangular."""
    w, s, e, n = -125.0, 5.0, -78.0, 38.0
    width, height = size
    shape = gloffset.read(DATA / "mexico_10m.geojson")
    lon = w + (np.arange(width) + 0.5) * (e - w) / width
    lat = n - (np.arange(height) + 0.5) * (n - s) / height
    lon, lat = np.meshgrid(lon, lat)
    inside = gloffset.contains(shape, lon, lat)
    dist = gloffset.distance(shape, lon, lat)
    rgb = np.full((height, width, 3), (250, 250, 248), dtype=np.uint8)
    for d, col in [(250e3, (209, 229, 240)), (127e3, (146, 197, 222)), (50e3, (67, 147, 195))]:
        rgb[dist <= d] = col
    rgb[inside] = (60, 60, 60)
    img = Image.fromarray(rgb)
    img.save(path)
    return path


def _borders(path: Path) -> Path:
    """The rings of world_110m as one MultiLineString (coasts and borders), as GeoJSON.

    The region within d of the countries is the countries plus the region within d of
    these lines; the lines avoid shared borders, which a polygon collection cannot hold.
    """
    import json

    fc = json.loads((DATA / "world_110m.geojson").read_text())
    lines = []
    for feature in fc["features"]:
        g = feature["geometry"]
        polys = [g["coordinates"]] if g["type"] == "Polygon" else g["coordinates"]
        lines += [ring for poly in polys for ring in poly]
    path.write_text(json.dumps({"type": "MultiLineString", "coordinates": lines}))
    return path


def _land(p: np.ndarray) -> np.ndarray:
    """Whether unit vectors ``p`` lie in a country of world_110m (float64 reference)."""
    import json

    lon, lat = gloffset.geometry.sphere.xyz_to_lonlat(p)
    inside = np.zeros(len(p), dtype=bool)
    for feature in json.loads((DATA / "world_110m.geojson").read_text())["features"]:
        inside |= gloffset.contains(feature, lon, lat)
    return inside


def _cube_faces(src: Path, distance: str, folder: Path, size: int) -> np.ndarray:
    """The six faces written by ``gloffset render --grid cube`` as a (6, N, N) bool array."""
    from gloffset.cli import main
    from gloffset.grids import FACE_NAMES

    args = ["render", str(src), "-d", distance, "--grid", "cube"]
    args += ["--size", str(size), "-o", str(folder)]
    if main.main(args, standalone_mode=False):
        raise RuntimeError(f"gloffset {' '.join(args)} failed")
    return np.stack([np.asarray(Image.open(folder / f"{n}.png")) > 0 for n in FACE_NAMES])


def cube_globe(path=HERE / "cube_globe.png", size=560, face=1024, view=(-75.0, 25.0)):
    """World countries (110m) and the region within 300 km of them: the region within
    300 km of their coasts and borders rendered as a cube map (``gloffset render --grid
    cube``), shown on an orthographic globe by sampling the six faces with
    :func:`gloffset.grids.locate` (the GL cube-map lookup); the countries themselves from
    the float64 reference ``gloffset.index.contains``."""
    import tempfile

    from gloffset.grids import locate

    with tempfile.TemporaryDirectory() as tmp:
        src = _borders(Path(tmp) / "borders.geojson")
        near = _cube_faces(src, "300km", Path(tmp) / "r", face)
    lon0, lat0 = np.radians(view)
    east = np.array([-np.sin(lon0), np.cos(lon0), 0.0])
    north = np.array([-np.sin(lat0) * np.cos(lon0), -np.sin(lat0) * np.sin(lon0), np.cos(lat0)])
    eye = np.cross(east, north)
    u = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    uu, vv = np.meshgrid(u, -u)
    r2 = uu**2 + vv**2
    disk = r2 < 1.0
    w = np.sqrt(np.clip(1.0 - r2, 0.0, None))
    p = uu[..., None] * east + vv[..., None] * north + w[..., None] * eye
    f, s, t = locate(p[disk])
    i = np.minimum((s * face).astype(int), face - 1)
    j = np.minimum((t * face).astype(int), face - 1)
    colour = np.empty((int(disk.sum()), 3))
    colour[:] = (214, 226, 236)  # sea
    land = _land(p[disk])
    colour[near[f, j, i] | land] = (120, 170, 215)  # within 300 km
    colour[land] = (70, 80, 90)  # countries
    lon, lat = gloffset.geometry.sphere.xyz_to_lonlat(p[disk])
    grid = (np.abs((lon + 15.0) % 30.0 - 15.0) < 0.35) | (np.abs((lat + 15.0) % 30.0 - 15.0) < 0.35)
    colour[grid] = colour[grid] * 0.85 + 255 * 0.15
    shade = 0.55 + 0.45 * w[disk]
    rgb = np.full((size, size, 3), 255.0)
    rgb[disk] = colour * shade[:, None]
    Image.fromarray(rgb.round().astype(np.uint8)).save(path)
    return path


def tile_example(path=HERE / "tile_example.png", z=5, lonlat=(-101.0, 21.0), scale=2):
    """One 256 px web-mercator tile of the pyramid of Mexico (10m) at 127 km
    (``gloffset tiles``: fill with opacity, outline of the border), over a light
    background so the transparency shows."""
    import tempfile

    import mercantile

    t = mercantile.tile(*lonlat, z)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "tiles"
        gloffset.tiles.pyramid(
            DATA / "mexico_10m.geojson",
            127e3,
            (z, z),
            out,
            fill="#3070c0",
            opacity=0.6,
            outline="#202020",
        )
        tile = Image.open(out / str(z) / str(t.x) / f"{t.y}.png").convert("RGBA")
    back = Image.new("RGBA", tile.size, (246, 244, 238, 255))
    img = Image.alpha_composite(back, tile).convert("RGB")
    img = img.resize((tile.width * scale, tile.height * scale), Image.NEAREST)
    img.save(path)
    return path


def raster_offset_fig13(path=HERE / "raster_offset_fig13.png", size=(512, 360), level=2):
    """Fig. 13 of the paper for Mexico's border rasterized by gloffset (no vector data
    used by the offset): the classes of a coarse level (left) and of the output level
    (right) at d = 127 km; contained black, frontier red, outside white, the curve's
    cells blue."""
    from gloffset.grids import Equirect
    from gloffset.io.png import CLASS_COLORS

    grid = Equirect(*size, bounds=(-125.0, 5.0, -78.0, 38.0))
    shape = gloffset.read(DATA / "mexico_10m.geojson")
    mask, parts = gloffset.rasterize(shape, grid, ordered=True)
    lut = np.array([CLASS_COLORS[k][:3] for k in range(3)], dtype=np.uint8)
    panels = []
    for lev in (level, grid.n_levels - 1):
        cls = gloffset.raster_offset(mask, 127e3, grid, level=lev, order=parts)
        b = grid.block(lev)
        up = np.repeat(np.repeat(cls, b, 0), b, 1)[: grid.height, : grid.width]
        curve = np.repeat(np.repeat(_coarse_mask(mask, b), b, 0), b, 1)[: grid.height, : grid.width]
        rgb = lut[up]
        rgb[curve] = (40, 90, 200)
        panels.append(rgb)
    gap = np.full((grid.height, 8, 3), 255, dtype=np.uint8)
    Image.fromarray(np.concatenate([panels[0], gap, panels[1]], axis=1)).save(path)
    return path


def _coarse_mask(mask, b):
    """A parent cell is intersected when any of its ``b x b`` descendants is."""
    h, w = -(-mask.shape[0] // b), -(-mask.shape[1] // b)
    pad = np.zeros((h * b, w * b), dtype=bool)
    pad[: mask.shape[0], : mask.shape[1]] = mask
    return pad.reshape(h, b, w, b).any(axis=(1, 3))


def globe_preview(path=HERE / "globe_preview.png", size=560, center=(-60.0, 15.0)):
    """``gloffset preview``: the countries (110m) and the region within 250 km of them on
    an orthographic globe, drawn from the cube maps in one GL pass."""
    from click.testing import CliRunner

    from gloffset.cli import main

    args = ["preview", str(DATA / "world_110m.geojson"), "-d", "250km", "-o", str(path)]
    args += ["--size", str(size), "--center", f"{center[0]},{center[1]}"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    return path


#: The field figure's ramp: (signed distance in km, RGB), inside (negative) to outside.
FIELD_RAMP = [
    (-2000.0, (103, 0, 31)),
    (-500.0, (214, 96, 77)),
    (-50.0, (253, 219, 199)),
    (0.0, (247, 247, 247)),
    (50.0, (209, 229, 240)),
    (500.0, (67, 147, 195)),
    (2000.0, (5, 48, 97)),
]


def _ramp(km: np.ndarray) -> np.ndarray:
    """The diverging colours of signed distances in km (:data:`FIELD_RAMP`, on a
    square-root scale: the near distances get most of the colours)."""
    stops = np.array([k for k, _ in FIELD_RAMP])
    cols = np.array([c for _, c in FIELD_RAMP], dtype=float)
    x = np.sign(km) * np.sqrt(np.abs(km))
    xs = np.sign(stops) * np.sqrt(np.abs(stops))
    return np.stack([np.interp(x, xs, cols[:, k]) for k in range(3)], axis=-1).astype(np.uint8)


def _edge(mask: np.ndarray) -> np.ndarray:
    """The pixels of ``mask`` with a neighbour outside it (columns wrap: a global grid)."""
    out = np.zeros_like(mask)
    for shift, axis in ((1, 1), (-1, 1)):
        out |= mask & ~np.roll(mask, shift, axis=axis)
    out[1:] |= mask[1:] & ~mask[:-1]
    out[:-1] |= mask[:-1] & ~mask[1:]
    return out


def distance_field(
    path=HERE / "distance_field.png", size=(1024, 512), src="countries_10m", contour=127e3
):
    """The signed distance field of the 1:10m countries of ``data/countries_10m.geojson``
    (234 of them: no Russia, Canada, China, Brazil, Mexico or Antarctica, among others,
    ``data/README.md``) on the globe (equirectangular),
    negative (red) inside the union of the countries, positive (blue) outside, with the
    ``contour`` (127 km) threshold's boundary in black: ``DistanceField.threshold``,
    the same pixels as ``gloffset.render`` at that distance."""
    shape = gloffset.read(DATA / f"{src}.geojson")
    field = gloffset.distance_field(shape, gloffset.grids.Equirect(*size))
    rgb = _ramp(field.values / 1e3)
    rgb[_edge(field.threshold(contour) > 0)] = (0, 0, 0)
    Image.fromarray(rgb, "RGB").save(path, optimize=True)
    return path


def polar_offsets(path=HERE / "polar_offsets.png", size=440):
    """Antarctica (1:110m) on EPSG:3031 (the south pole at the centre): the regions
    within 100 and 300 km of it and the region 100 km inside its coast, rendered straight
    on the polar grid (:class:`gloffset.grids.Projected`, every pixel the float64
    reference's at pyproj's pixel centre)."""
    fc = __import__("json").loads((DATA / "world_110m.geojson").read_text())
    ant = next(f for f in fc["features"] if f["properties"]["name"] == "Antarctica")
    shape = gloffset.read(ant)
    grid = gloffset.grids.Projected(
        size, size, crs="EPSG:3031", bounds=(-3.6e6,) * 2 + (3.6e6,) * 2
    )
    rgb = np.full((size, size, 3), (250, 250, 248), dtype=np.uint8)
    for d, col in [
        (300e3, (209, 229, 240)),
        (100e3, (146, 197, 222)),
        (0.0, (150, 150, 150)),
        (-100e3, (90, 90, 90)),
    ]:
        rgb[gloffset.render(shape, d, grid) > 0] = col
    c = size // 2
    rgb[c - 6 : c + 6, c - 1 : c + 1] = (200, 40, 40)  # the pole
    rgb[c - 1 : c + 1, c - 6 : c + 6] = (200, 40, 40)
    Image.fromarray(rgb, "RGB").quantize(16).save(path, optimize=True)
    return path


if __name__ == "__main__":
    print(polar_offsets())
    print(distance_field())
    print(vector_offsets())
    print(raster_offset_fig13())
    print(cube_globe())
    print(globe_preview())
    print(tile_example())
