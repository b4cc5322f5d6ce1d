"""A falsify run in the validation report: the search's figures (those falsify printed),
the objective's plot, and every violation with its search point, attribution, picture and
viewer page; the page inert whatever the file says."""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import pytest

from tests.helpers import ROOT, run
from tracecheck.episodes import EpisodeWriter
from tracecheck.episodes.reader import read_header, read_run

pytest.importorskip("gymnasium")

AGENT = ROOT / "models" / "agents" / "frozenlake.npy"
PROPERTY = "G({not(x = 3 & y = 3)})"


@pytest.fixture(scope="module")
def searched(tmp_path_factory) -> tuple[Path, dict]:
    import contextlib
    import io

    from tracecheck.cli import main

    out = tmp_path_factory.mktemp("falsify") / "lake.mcap"
    text = io.StringIO()
    with contextlib.redirect_stdout(text), pytest.raises(SystemExit):
        main([str(a) for a in ["falsify", "--agent", AGENT, "--env", "frozenlake", "--shield",
                               "frozenlake", "--param", "seed=0..9999", "--param",
                               "is_slippery={True,False}", "--property", PROPERTY,
                               "--budget", 30, "--repeat", 2, "--optimizer", "tpe", "-o", out,
                               "--json"]])
    return out, json.loads(text.getvalue())


def html_text(cell: str) -> str:
    import html

    return html.unescape(cell)


def _cells(html: str, first: str) -> list[str]:
    """The cells of the table row whose first cell is ``first``."""
    row = re.search(rf"<tr><td>{re.escape(first)}</td>(.*?)</tr>", html, re.S)
    assert row, f"no row {first}"
    return re.findall(r"<td[^>]*>(.*?)</td>", row.group(1), re.S)


def test_the_report_gives_the_search_s_figures_and_its_violations(searched, capsys, tmp_path):
    out, data = searched
    violations = [ep for ep in read_run(out).episodes if ep.search.violated]
    assert violations, "the search found no violation to draw"
    page = tmp_path / "report.html"
    code, _, err = run(capsys, "report", out, "-o", page)
    assert code == 0, err
    html = page.read_text()
    assert "<h2>Searches</h2>" in html and "space: seed 0..9999, is_slippery {True,False}" in html
    for summary in data["optimizers"]:  # the figures falsify printed, read back from the file
        cells = _cells(html, summary["optimizer"])
        assert cells[0] == "2"
        assert cells[1] == f"{summary['falsified']} ({summary['rate']:.0%})"
        assert cells[3] == f"{summary['violations']} of {summary['evaluations']}"
        if summary["first_median"] is not None:
            assert cells[2].startswith(f"{summary['first_median']:.4g} (mean")
    assert html.count("lowest objective so far") >= 1  # the plot (inline SVG)
    for ep in violations[:8]:
        cells = _cells(html, str(ep.id))
        assert f"seed={ep.seed}" in cells[1] and "is_slippery=" in cells[1]
        assert html_text(cells[3]).startswith(ep.search.attribution)
        assert "<svg" in cells[4]  # its picture
        link = re.search(r"href='([^']+)'", cells[5]).group(1)
        assert (tmp_path / link).exists()


def test_an_episode_in_both_sections_gets_one_viewer_page(searched, capsys, tmp_path):
    out, _ = searched
    page = tmp_path / "both.html"
    code, text, err = run(capsys, "report", out, "--shield", "frozenlake", "-o", page)
    assert code == 0, err
    pages = sorted(p.name for p in (tmp_path / "both_files").iterdir())
    assert len(pages) == len(set(pages)) and int(text.split(" and ")[1].split()[0]) == len(pages)


def test_the_search_section_is_inert(searched, tmp_path, capsys):
    """A file can say anything: its property, its parameters' names and values, its
    attribution are shown as text."""
    out, _ = searched
    source = read_run(out)
    header = read_header(out)
    evil = "<script>alert(1)</script>"
    header = header.model_copy(update={"search": header.search.model_copy(update={
        "property": evil, "space": {evil: [0, 1]}})})
    crafted = tmp_path / "crafted.mcap"
    with EpisodeWriter(crafted, header) as w:
        for ep in source.episodes[:5]:
            point = replace(ep.search, parameters={evil: "<img src=x onerror=alert(2)>"},
                            violated=True, attribution="shield gap", attribution_detail=evil)
            w.write(replace(ep, search=point))
    page = tmp_path / "inert.html"
    code, _, err = run(capsys, "report", crafted, "-o", page)
    assert code == 0, err
    html = page.read_text()
    assert "<script>alert" not in html and "<img src=x" not in html
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html
