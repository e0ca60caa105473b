"""Where a pyramid's tiles go: the tile stores (:mod:`.tilestore` opens one), MBTiles
(:mod:`.mbtiles`), PMTiles (:mod:`.pmtiles`) and XYZ folders (:mod:`.xyzdir`)."""
