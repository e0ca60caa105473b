"""``tiles --resume`` continues only the pyramid of the same input: the archive records a
digest of its input's geometry (MBTiles and PMTiles metadata, an XYZ folder's
metadata.json), and a resume over another input's archive, or one that records none, is
refused with one line and exit status 2, leaving the archive as it was."""

import json
import sqlite3
import subprocess
import sys

import pytest
from click.testing import CliRunner
from conftest import DATA

import gloffset
from gloffset.cli import main
from gloffset.tiles.store.pmtiles import read_pmtiles
from gloffset.tiles.store.tilestore import INPUT_KEY, input_digest

MEXICO = DATA / "mexico_10m.geojson"
ARGS = ["-d", "100km", "-z", "0-2", "--tile-size", "64"]


def tiles(path, args=(), check=True):
    r = CliRunner().invoke(main, ["tiles", *map(str, args)])
    if check:
        assert r.exit_code == 0, r.output
    return r


@pytest.fixture(scope="module")
def cuba(tmp_path_factory):
    world = json.loads((DATA / "world_110m.geojson").read_text())
    (feat,) = [f for f in world["features"] if f["properties"]["name"] == "Cuba"]
    path = tmp_path_factory.mktemp("in") / "cuba.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", "features": [feat]}))
    return path


def stored(out):
    """The archive's metadata and tiles, to check that a refused resume changed nothing."""
    if out.suffix == ".mbtiles":
        with sqlite3.connect(out) as db:
            meta = dict(db.execute("SELECT name, value FROM metadata"))
            rows = sorted(db.execute("SELECT zoom_level, tile_column, tile_row FROM map"))
        return meta, rows
    if out.suffix == ".pmtiles":
        meta, found = read_pmtiles(out)
        return meta, sorted(found)
    files = sorted(str(p.relative_to(out)) for p in out.rglob("*.png"))
    return json.loads((out / "metadata.json").read_text()), files


def forget_digest(out):
    if out.suffix == ".mbtiles":
        with sqlite3.connect(out) as db:
            db.execute("DELETE FROM metadata WHERE name = ?", (INPUT_KEY,))
    else:
        meta = json.loads((out / "metadata.json").read_text())
        del meta[INPUT_KEY]
        (out / "metadata.json").write_text(json.dumps(meta))


def test_the_digest_follows_the_geometry(cuba):
    a, b = gloffset.read(MEXICO), gloffset.read(MEXICO)
    assert input_digest(a) == input_digest(b)
    assert input_digest(a) != input_digest(gloffset.read(cuba))
    assert input_digest(a).startswith("sha256:") and len(input_digest(a)) == 7 + 64


@pytest.mark.parametrize("name", ["t.mbtiles", "t.pmtiles", "xyz"])
def test_resume_over_another_inputs_archive_is_refused(tmp_path, cuba, name):
    if name.endswith(".pmtiles"):
        pytest.importorskip("pmtiles")
    out = tmp_path / name
    tiles(out, [MEXICO, *ARGS, "-o", out])
    before = stored(out)
    assert before[0][INPUT_KEY] == input_digest(gloffset.read(MEXICO))
    # the same input resumes
    r = tiles(out, [MEXICO, *ARGS, "-o", out, "--resume"])
    assert "already present" in r.output
    # another input: one line, exit 2, the archive unchanged
    proc = subprocess.run(
        [sys.executable, "-m", "gloffset", "tiles", str(cuba), *ARGS, "-o", str(out), "--resume"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gloffset: error: cannot resume"), lines
    assert "tiles of another input" in lines[0] and "--force" in lines[0]
    assert stored(out) == before
    # --force starts again from the new input
    tiles(out, [cuba, *ARGS, "-o", out, "--force"])
    assert stored(out)[0][INPUT_KEY] == input_digest(gloffset.read(cuba))


@pytest.mark.parametrize("name", ["t.mbtiles", "xyz"])
def test_resume_of_an_archive_without_a_digest_is_refused(tmp_path, name):
    out = tmp_path / name
    tiles(out, [MEXICO, *ARGS, "-o", out])
    forget_digest(out)
    r = tiles(out, [MEXICO, *ARGS, "-o", out, "--resume"], check=False)
    assert r.exit_code == 2 and "records no digest of its input" in r.output, r.output
