"""Vendor MapLibre GL JS into the package (gloffset/serve/static/) for the page of
``gloffset serve``, so that the page works offline and without a CDN.

Downloads the pinned version's tarball from the npm registry, checks it against the
pinned sha512 integrity hash (npm's ``dist.integrity``), and copies the browser build
(``dist/maplibre-gl.js``, ``dist/maplibre-gl.css``) and the licence. To upgrade, change
VERSION and INTEGRITY (``npm view maplibre-gl@VERSION dist.integrity``) and run it again:

    python scripts/vendor_maplibre.py
"""

from __future__ import annotations

import base64
import hashlib
import io
import sys
import tarfile
import urllib.request
from pathlib import Path

VERSION = "5.24.1"
INTEGRITY = "sha512-HyiYBwtsbk3L1n1EPLJHWqdoyMiF80n7tEYXFZyu2m1TjvaNx6KMLiFeDdmszt1/mq2zvsR1TJuX/NMu5BonXQ=="  # noqa: E501
URL = f"https://registry.npmjs.org/maplibre-gl/-/maplibre-gl-{VERSION}.tgz"
FILES = {
    "package/dist/maplibre-gl.js": "maplibre-gl.js",
    "package/dist/maplibre-gl.css": "maplibre-gl.css",
    "package/LICENSE.txt": "maplibre-gl.LICENSE.txt",
}
DEST = Path(__file__).resolve().parent.parent / "gloffset" / "serve" / "static" / "vendor"


def check(data: bytes, integrity: str) -> None:
    """Raise SystemExit unless ``data`` has the subresource-integrity hash ``integrity``."""
    algo, _, want = integrity.partition("-")
    got = base64.b64encode(hashlib.new(algo, data).digest()).decode()
    if got != want:
        raise SystemExit(f"integrity mismatch for {URL}: expected {integrity}, got {algo}-{got}")


def main() -> int:
    with urllib.request.urlopen(URL, timeout=120) as r:
        data = r.read()
    check(data, INTEGRITY)
    DEST.mkdir(parents=True, exist_ok=True)
    with tarfile.open(fileobj=io.BytesIO(data), mode="r:gz") as tar:
        names = set(tar.getnames())
        missing = [n for n in FILES if n not in names]
        if missing:
            raise SystemExit(f"{URL} lacks {', '.join(missing)}")
        for src, dst in FILES.items():
            (DEST / dst).write_bytes(tar.extractfile(src).read())
    (DEST / "VERSION").write_text(f"maplibre-gl {VERSION} {INTEGRITY}\n")
    print(f"maplibre-gl {VERSION} (integrity checked) -> {DEST}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
