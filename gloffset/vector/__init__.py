"""Vector offsets (paper Sec. 4), one module a concept:

* :mod:`.offset`: the raw offset, closed rings of small-circle arcs (Sec. 4.1, Eq. 1-4);
* :mod:`.smallcircle`: small-circle arcs and their intersections (Sec. 4.4);
* :mod:`.multires`: the multiresolution decomposition and offsets (Sec. 4.2, 4.3);
* :mod:`.selfintersect`: self-intersection removal (Sec. 4.4), the entry point
  ``resolve`` and the raw rings both methods start from;
* :mod:`.paper`: Algorithm 1 as published, ring by ring;
* :mod:`.arrangement`: the general method, the arrangement of all raw arcs;
* :mod:`.rings`: closed rings sorted into exteriors and holes, crossing parity, areas;
* :mod:`.resolved`: the result, :class:`~.resolved.ResolvedOffset`.
"""
