"""The parts of :func:`gloffset.distance_field` (:mod:`gloffset.raster.field`): the walk
down the levels (:mod:`~gloffset.raster.fields.walk`), its lists walked on the GPU
(:mod:`~gloffset.raster.fields.lists`), the GPU backend's pixels
(:mod:`~gloffset.raster.fields.gpu`) and the sign from the nearest features
(:mod:`~gloffset.raster.fields.sign`)."""
