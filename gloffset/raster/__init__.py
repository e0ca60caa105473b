"""Rasters of the offset region over any grid, by concept: the level driver
(:mod:`.driver`), the vector classifier (:mod:`.vector`: cells against vector curves in
float64), rasterized input (:mod:`.rasterized`, Sec. 5), renders (:mod:`.render`,
:mod:`.simplified`, the preview :mod:`.globe`) and tile pyramids (:mod:`.pyramid`). The
GPU passes are in :mod:`gloffset.gl`, which runs what this package plans: :mod:`.gpu` and
:mod:`.rasterized.curve_gpu` pack the records (:mod:`.records`) and the bin layout
(:mod:`.layout`) and hand them over."""
