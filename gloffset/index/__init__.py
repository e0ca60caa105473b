"""The fast inside test: ``contains`` and the reusable :class:`~.tree.Index` (Sec. 4.3,
Eq. 9), over lat/lon bins (:mod:`.bins`)."""
