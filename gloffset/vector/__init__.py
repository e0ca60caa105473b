"""Vector offsets (Sec. 4): offset curves of small-circle arcs (:mod:`.offset`,
:mod:`.smallcircle`), the multiresolution decomposition (:mod:`.multires`) and the
removal of self-intersections (:mod:`.selfintersect`)."""
