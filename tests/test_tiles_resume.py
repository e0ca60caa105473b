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
from conftest import DATA, read_mbtiles

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


# ------------------------------------------------------------------ field pyramids

FIELD = ["--field", "-z", "0-2", "--tile-size", "16"]


class Stop(Exception):
    pass


def field_output(out):
    """Everything a field pyramid wrote: an archive's bytes, or a folder's files."""
    if out.is_dir():
        files = sorted(p for p in out.rglob("*") if p.is_file())
        return {str(p.relative_to(out)): p.read_bytes() for p in files}
    if out.suffix == ".mbtiles":
        return stored(out), sorted(read_mbtiles(out)[0].items())
    return out.read_bytes()


def interrupted_field(out, after):
    """A field pyramid of Mexico stopped after ``after`` tiles."""
    from gloffset.tiles.tiling.fieldtiles import field_pyramid

    def stop(done, total):
        if done >= after:
            raise Stop

    with pytest.raises(Stop):
        field_pyramid(
            gloffset.read(MEXICO), "0-2", out, size=16, source="mexico_10m", progress=stop
        )


@pytest.mark.parametrize("name", ["f.mbtiles", "f.pmtiles", "fxyz"])
def test_an_interrupted_field_pyramid_resumes_to_the_uninterrupted_one(tmp_path, cuba, name):
    if name.endswith(".pmtiles"):
        pytest.importorskip("pmtiles")
    whole = tmp_path / "whole" / name
    whole.parent.mkdir()
    tiles(whole, [MEXICO, *FIELD, "-o", whole])
    out = tmp_path / name
    interrupted_field(out, 9)
    assert out.exists() or (tmp_path / f"{name}.partial.mbtiles").exists()
    # a rerun without --resume, or with other options or over another input, is refused
    # with one line and leaves the output as it was
    kept = field_output(tmp_path)
    for args, words in [
        ([MEXICO, *FIELD], ("exists", "--resume")),
        ([MEXICO, *FIELD[:-1], "32", "--resume"], ("cannot resume", "other options")),
        ([MEXICO, *FIELD[:2], "0-3", *FIELD[3:], "--resume"], ("other options",)),
        ([cuba, *FIELD, "--resume"], ("cannot resume", "tiles of another input")),
    ]:
        r = tiles(out, [*args, "-o", out], check=False)
        assert r.exit_code == 2, r.output
        line = r.output.strip()
        assert "\n" not in line and all(w in line for w in words), line
        assert field_output(tmp_path) == kept
    r = tiles(out, [MEXICO, *FIELD, "-o", out, "--resume"])
    assert "12 field tiles written" in r.output
    assert field_output(out) == field_output(whole)
    assert not (tmp_path / f"{name}.partial.mbtiles").exists()
    # a finished field pyramid resumes to itself
    tiles(out, [MEXICO, *FIELD, "-o", out, "--resume"])
    assert field_output(out) == field_output(whole)


def test_a_killed_field_pyramid_keeps_its_tiles_and_resumes(tmp_path):
    """A field run killed (no cleanup: ``os._exit``) keeps the tiles committed until then
    (every ``COMMIT_SECONDS``), and ``--resume`` completes it to the uninterrupted run."""
    whole, out = tmp_path / "whole.mbtiles", tmp_path / "f.mbtiles"
    tiles(whole, [MEXICO, *FIELD, "-o", whole])
    script = (
        "import os, sys\n"
        "import gloffset.tiles.tiling.fieldtiles as ft\n"
        "from gloffset.cli import main\n"
        "ft.COMMIT_SECONDS = 0.0\n"
        "put = ft.encode_field\n"
        "n = [0]\n"
        "def killed(*a, **k):\n"
        "    n[0] += 1\n"
        "    if n[0] > 9:\n"
        "        os._exit(9)\n"
        "    return put(*a, **k)\n"
        "ft.encode_field = killed\n"
        "main(sys.argv[1:])\n"
    )
    args = ["tiles", str(MEXICO), *FIELD, "-o", str(out)]
    proc = subprocess.run([sys.executable, "-c", script, *args], capture_output=True, text=True)
    assert proc.returncode == 9, proc.stderr
    with sqlite3.connect(out) as db:
        assert db.execute("SELECT count(*) FROM map").fetchone()[0] == 9
    r = tiles(out, [MEXICO, *FIELD, "-o", out], check=False)
    assert r.exit_code == 2 and "use --resume" in r.output
    r = tiles(out, [MEXICO, *FIELD, "-o", out, "--resume"])
    assert "12 field tiles written" in r.output
    assert field_output(out) == field_output(whole)
