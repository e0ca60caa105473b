"""Rasters of the offset region over any grid: the float64 level classification
(:mod:`.levels`, :mod:`.scatter`), the level driver, rasterized input (Sec. 5,
:mod:`.rasterized`), renders (:mod:`.render`) and tile pyramids (:mod:`.tiles`,
:mod:`.tilepaint`). The GPU passes are in :mod:`gloffset.gl`, which runs what this package
plans: :mod:`.gpu` and :mod:`.curve_gpu` pack the records (:mod:`.records`) and the bin
layout (:mod:`.layout`) and hand them over."""
