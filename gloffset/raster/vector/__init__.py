"""The vector classifier: the cells of a grid against the offset region of vector curves,
level by level in float64 (:class:`~.curves.CurveCells`, :func:`~.curves.classify_curves`).

:mod:`.levels` holds the level operations (decide, refine, distances), :mod:`.scatter`
enters a level directly, :mod:`.node_levels` classifies a pyramid's coarse levels with the
multiresolution curve's nodes. The GPU levels below the bins are planned in
:mod:`gloffset.raster.gpu` (records, layout) and run by :mod:`gloffset.gl.vector_pass`.
"""
