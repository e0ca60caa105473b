"""The README's examples: its command-line block names every subcommand, with options
the subcommand takes, and its Python block runs and says what it gives."""

from __future__ import annotations

import ast
import json
import re
from pathlib import Path

from gloffset.cli import main

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _block(heading: str, lang: str) -> list[str]:
    """The lines of the first ``lang`` code block after ``heading``."""
    rest = README[README.index(f"\n{heading}\n") :]
    start = rest.index(f"```{lang}\n") + len(lang) + 4
    return rest[start : rest.index("```", start)].splitlines()


def test_the_command_line_block_shows_every_subcommand_with_its_own_options():
    lines = [ln for ln in _block("## Command line", "bash") if ln.startswith("gloffset ")]
    shown: dict[str, set] = {}
    for line in lines:
        code = re.split(r"\s#\s", line, maxsplit=1)[0]  # not the comment
        words = code.replace("[", " ").replace("]", " ").split()
        options = {w for w in words[2:] if re.fullmatch(r"--?[a-zA-Z][\w-]*", w)}
        shown.setdefault(words[1], set()).update(options)
        command = main.commands.get(words[1])
        assert command is not None, f"no subcommand {words[1]!r}: {line}"
        takes = {o for p in command.params for o in (*p.opts, *p.secondary_opts)}
        assert options <= takes, f"{line}: {sorted(options - takes)} not options of it"
    assert sorted(shown) == sorted(main.commands), "subcommands missing from the README"
    # several distances at once, and the server's cross-origin option
    assert any(re.search(r" -d \d+km,\d+km", ln) for ln in lines)
    assert "--cors" in shown["serve"] and "--field" in shown["tiles"]
    # the endpoints' form, the layer in the path
    assert "/distance/LAYER?lon=" in "\n".join(_block("## Command line", "bash"))


def test_the_python_block_runs_and_says_what_it_gives(monkeypatch):
    """The block's lines run in order (those reading files that are not in the
    repository are left out), and its comments' values are what the lines give: a
    literal after an expression, the start of a repr after an assignment."""
    monkeypatch.chdir(ROOT)
    ns: dict = {}
    checked = 0
    for line in _block("## In Python", "python"):
        if "rivers.gpkg" in line or "geodataframe" in line:  # not in data/
            continue
        code, _, comment = line.partition("  #")
        code, comment = code.strip(), comment.strip()
        exec(code, ns)
        if "=" not in code.split("(")[0]:  # an expression: its value, when it is a literal
            try:
                want = ast.literal_eval(comment)
            except (ValueError, SyntaxError):
                continue
            assert list(eval(code, ns)) == want, line
            checked += 1
        elif comment.endswith("...)"):  # an assignment: its repr
            name = code.split("=")[0].strip()
            assert repr(ns[name]).startswith(comment.removesuffix("...)")), (repr(ns[name]), line)
            checked += 1
    assert checked == 2
    assert ns["mask"].shape == (2048, 4096) and ns["faces"].shape == (6, 1024, 1024)
    off = ns["off"]  # its centres and junctions: lists of (m, 3) arrays, one per ring
    assert isinstance(off.centers, list) and len(off.centers) == len(off.rings) > 1
    for q, r in zip(off.centers, off.junctions):
        assert q.ndim == 2 and q.shape[1] == 3 and q.shape == r.shape


def _points(c):
    """The positions of GeoJSON coordinates at any depth."""
    if isinstance(c[0], (int, float)):
        yield c
    else:
        for x in c:
            yield from _points(x)


def _vertices(fc: dict) -> int:
    return sum(len(list(_points(f["geometry"]["coordinates"]))) for f in fc["features"])


def test_the_data_readme_says_what_countries_10m_holds():
    """``countries_10m`` is not the whole world: the countries that data/README.md says
    are missing are missing (and are in the 1:110m file), and its counts are the file's."""
    text = " ".join((ROOT / "data" / "README.md").read_text().split())
    big = json.loads((ROOT / "data" / "countries_10m.geojson").read_text())
    small = json.loads((ROOT / "data" / "world_110m.geojson").read_text())
    assert f"{len(big['features'])} countries and territories at 1:10m" in text
    assert f"({_vertices(big):,} vertices;" in text
    assert f"the {len(small['features'])} countries of Natural Earth 1:110m" in text
    listed = re.search(r"not in it: (.*?) \(nor (.*?)\)", text)
    assert listed, text
    countries, others = (re.split(r", | and the | and ", g) for g in listed.groups())
    assert len(countries) == 16 and "Sixteen countries of the 1:110m file" in text
    have = {f["properties"]["name"] for f in big["features"]}
    # the 1:110m file's names of the countries that the 1:10m file names otherwise
    renamed = {
        "United States of America": "United States",
        "North Korea": "Dem. Rep. Korea",
        "South Korea": "Republic of Korea",
        "Congo": "Republic of the Congo",
        "Dem. Rep. Congo": "Democratic Republic of the Congo",
        "Fr. S. Antarctic Lands": "Fr. S. and Antarctic Lands",
    }
    assert set(renamed.values()) <= have
    missing = [f["properties"]["name"] for f in small["features"]]
    missing = [n for n in missing if renamed.get(n, n) not in have]
    assert sorted(missing) == sorted(countries + others)
    lats = [c[1] for f in big["features"] for c in _points(f["geometry"]["coordinates"])]
    assert f"from {-min(lats):.1f} S to {max(lats):.1f} N" in text
