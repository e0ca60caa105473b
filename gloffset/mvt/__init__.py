"""Mapbox Vector Tiles (MVT 2.1) of the offset region: one tile (:func:`vector_tile`,
:mod:`gloffset.mvt.tile`), the boundary near a tile (:mod:`gloffset.mvt.boundary`), its
geometry in tile coordinates (:mod:`gloffset.mvt.geometry`) and pyramids of them
(:mod:`gloffset.mvt.pyramid`)."""

from .tile import vector_tile

__all__ = ["vector_tile"]
