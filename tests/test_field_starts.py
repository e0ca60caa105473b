"""Kept start lists of canonical discs (``gloffset.raster.fields.starts``): each disc lies
inside its canonical disc, and grids bounded from the kept lists give the same field bits
as from the tree's top nodes, on real borders."""

from __future__ import annotations

import numpy as np
import pytest

import gloffset
from gloffset.geometry.sphere import angle, normalize
from gloffset.grids import Equirect, Tile
from gloffset.raster.fields import starts, walk
from gloffset.raster.vector.node_levels import NodeArcs


def test_every_disc_lies_inside_its_canonical_disc():
    """Random centres (the lattice's worst places included: halfway between its points)
    and radii over the keyed range: angle to the canonical centre plus the radius is at
    most the canonical radius; the canonical radius is less than 4 times the radius."""
    rng = np.random.default_rng(4)
    n = 6000
    c = normalize(rng.normal(size=(n, 3)))
    reach = 10.0 ** rng.uniform(-7, np.log10(starts._H_MAX), n)
    for k in range(n // 4):  # centres at the middle of a lattice cube
        h = 2.0 ** np.ceil(np.log2(reach[k]))
        c[k] = normalize((np.floor(c[k] / h) + 0.5) * h)
    worst = 0.0
    for ck, rk in zip(c, reach):
        key, cc, cr = starts.canonical_disc(ck, float(rk))
        slack = cr - (float(angle(ck, cc)) + rk)
        assert slack >= 0.0
        assert cr < 4.0 * rk + 1e-11
        worst = max(worst, (float(angle(ck, cc)) + rk) / cr)
    assert worst > 0.5  # the bound is not loose everywhere
    assert starts.canonical_disc(c[0], 0.6) is None


@pytest.mark.parametrize(
    "grid",
    [Tile(6, 15, 29), Tile(9, 99, 220), Equirect(256, 256, (-118.0, 14.0, -86.0, 33.0))],
    ids=["z6", "z9", "box"],
)
def test_grids_from_kept_lists_keep_their_bits(mexico_path, grid, monkeypatch):
    shape = gloffset.read(mexico_path)
    kept = starts.kept_lists(NodeArcs.from_shape(shape))
    before = len(kept)
    got = gloffset.distance_field(shape, grid, radius=1.0).values
    assert len(kept) > before  # the canonical disc's list was kept
    again = gloffset.distance_field(shape, grid, radius=1.0).values  # bounded from it
    monkeypatch.setattr(walk, "KEEP_STARTS", False)
    want = gloffset.distance_field(shape, grid, radius=1.0).values
    assert got.tobytes() == want.tobytes() == again.tobytes()


def test_a_broken_canonical_radius_is_caught(mexico_path, monkeypatch):
    """A canonical disc too small for the grids it keys drops nodes they need: the field
    is off the CPU's values."""
    shape = gloffset.read(mexico_path)
    grid = Tile(6, 15, 29)
    want = gloffset.distance_field(shape, grid, radius=1.0, backend="cpu").values
    real = starts.canonical_disc

    def small(c, reach):
        key, cc, cr = real(c, reach)
        return ("small", *key), cc, 0.01 * cr

    monkeypatch.setattr(starts, "canonical_disc", small)
    bad = gloffset.distance_field(shape, grid, radius=1.0).values
    off = np.abs(bad.astype(np.float64) - want) > np.spacing(np.abs(want))
    assert off.sum() > 100
