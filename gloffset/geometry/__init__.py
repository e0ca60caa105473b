"""The maths on the unit sphere, below everything that reads or draws a shape.

:mod:`.sphere` the exact predicates; :mod:`.caps` the spherical bounds, each once with its
error bound; :mod:`.captree` a tree of bounding caps; :mod:`.arrangement` the steps an
arrangement of arcs shares; :mod:`.crossings` point in polygon by crossing parity;
:mod:`.classes` the class codes of grid cells; :mod:`.lonlat` lon/lat input rings checked and
made unit vectors. Each module states its accuracy contract.
"""
