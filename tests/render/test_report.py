"""The report, as a supervisor reads it: the runs side by side, the re-simulation headline,
comparisons in words, the episodes that matter first — for any environment."""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import write_report, ROOT
from tracecheck.checking.shield import load_shield
from tracecheck.render.report import (comparison_sentences, resimulation_headline)
from tracecheck.stats.properties import load_properties

NONE = ROOT / "sample_traces" / "base_none.mcap"
PAPER = ROOT / "sample_traces" / "base_paper.mcap"
CORRIDOR = "tests.live.toy:Corridor"


@pytest.fixture(scope="module")
def highway_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report") / "report.html"
    write_report([NONE, PAPER], out, shield=load_shield("paper"),
                  pset=load_properties("highway"), max_pages=6)
    return out


def test_each_run_has_its_own_section_side_by_side(highway_report):
    page = highway_report.read_text()
    sections = re.findall(r"<section class='run'>(.*?)</section>", page)
    assert len(sections) == 2
    assert "base_none.mcap" in sections[0] and "base_paper.mcap" in sections[1]
    assert "<th>recorded under shield</th><td>none</td>" in sections[0]
    assert "<th>recorded under shield</th><td>paper</td>" in sections[1]
    assert "<th>crashes</th><td>6 (25%)</td>" in sections[0]
    # without re-simulation nothing claims a crash was prevented: the table's column is
    # replay's "crash after a blocked step", a fact of the recording
    assert "prevented" not in page.replace("would have prevented a crash", "")
    head = re.findall(r"<tr><th>episode</th>(.*?)</tr>", page)[0]
    assert "<th>crash after a blocked step</th>" in head and "re-simulated" not in head
    episodes = page[page.index("Episodes that matter"):]
    cells = re.findall(r"<td class='\w*'>([^<]*)</td><td class='pic'>",
                       episodes[:episodes.index("<h3>base_paper.mcap</h3>")])
    assert cells.count("yes") == 6 and cells.count("no") == 0 and len(cells) == 24


def test_comparisons_are_sentences_that_name_their_test(highway_report):
    page = highway_report.read_text()
    assert "H0" not in page and "not rejected" not in page
    assert ("The share of episodes that satisfy SAF2 (“The agent must drive faster than 20 "
            "m/s”) is lower in base_paper than in base_none (33% vs 71%; exact McNemar test "
            "on 24 pair(s) of episodes with the same seed, p = 0.012).") in page
    assert "No significant difference in the share of episodes that satisfy SAF1" in page
    assert "paired t-test, p = 0.029" in page


def test_a_plot_too_wide_for_a_column_gets_the_pages_width(highway_report):
    """The property shares of 6 properties × 2 runs (1037 pt wide) were shrunk to 560 px,
    their labels 5 px high; the box plots (360 pt) stay in columns."""
    page = highway_report.read_text()
    assert page.count("<figure class='wide'><svg") == 1 and "figure.wide svg{max-width:100%}" \
        in page
    assert page.count("<figure><svg") == 5  # one per metric of the highway set


def test_episodes_that_matter_come_first_and_the_tail_is_collapsed(highway_report):
    page = highway_report.read_text()
    none = page[page.index("<h3>base_none.mcap</h3>", page.index("Episodes that matter")):]
    shown, hidden = none.split("<details>", 1)
    first = re.findall(r"<tr><td>(\d+)</td>", shown)
    assert first[:6] == ["1", "3", "4", "8", "18", "21"]  # the six crashes after a block
    assert "<summary>16 more episode(s)</summary>" in hidden
    assert shown.count("<td class='pic'><svg") == 8  # each shown episode's picture
    links = re.findall(r"href='([^']+)'", page)
    # 6 pages shared by the runs: 3 each, of which base_paper needs only its 2 crashes
    assert len(links) == 5 and sum("base_paper" in link for link in links) == 2
    assert all((highway_report.parent / link).exists() for link in links)


def test_the_resimulation_headline():
    summary = {"crashes_prevented": 5, "new_crashes": 0, "mismatches": 0, "without_seed": 0}
    assert resimulation_headline("paper", 6, summary) == \
        "shield paper would have prevented 5 of 6 crashes; 0 new"
    assert resimulation_headline("paper", 1, {**summary, "crashes_prevented": 1,
                                              "mismatches": 2}) == (
        "shield paper would have prevented 1 of 1 crash; 0 new (2 episode(s) did not "
        "reproduce from their seed and are not counted)")


def test_a_non_significant_metric_reads_as_no_difference():
    result = {"runs": [{"name": "a", "properties": {}}, {"name": "b", "properties": {}}],
              "descriptions": {"len": "Episode length"},
              "comparisons": [{"runs": ["a", "b"], "pairs": 10, "properties": {},
                               "metrics": {"len": {"mean_difference": 1.5,
                                                   "paired_t_p": 0.384, "wilcoxon_p": 0.4}}}]}
    assert comparison_sentences(result) == [
        "No significant difference in Episode length between a and b (mean difference a − b "
        "1.5 over 10 pair(s); paired t-test, p = 0.384)."]


@pytest.fixture(scope="module")
def corridor(tmp_path_factory):
    from tests.live.toy import SHIELD, left_leaning_table
    from tracecheck.cli import main

    folder = tmp_path_factory.mktemp("corridor")
    shield, agent = folder / "corridor.mch", folder / "left.npy"
    shield.write_text(SHIELD)
    np.save(agent, left_leaning_table())
    recorded = folder / "toy.mcap"
    with pytest.raises(SystemExit) as info:
        main(["record", "--env", CORRIDOR, "--agent", str(agent), "--shield", "none", "-n",
              "4", "-o", str(recorded)])
    assert info.value.code in (0, None)
    props = folder / "corridor.toml"
    props.write_text('[metrics.position]\nexpression = "pos"\ndescription = "Cell"\n'
                     '[properties.safe]\npredicate = "pos > 0"\n'
                     'description = "never in the pit"\n')
    return recorded, shield, agent, props


def test_a_users_environment_gets_the_headline_and_time_series(corridor, tmp_path):
    recorded, shield, agent, props = corridor
    out = tmp_path / "report.html"
    write_report([recorded], out, shield=load_shield(str(shield)),
                  pset=load_properties(str(props)), resimulate=True, agent=agent,
                  env=CORRIDOR)
    page = out.read_text()
    crashes = int(re.search(r"<th>crashes</th><td>(\d+)", page).group(1))
    assert crashes >= 1
    assert (f"Re-simulation: shield corridor would have prevented {crashes} of {crashes} "
            f"crash{'es' if crashes > 1 else ''}; 0 new.") in page
    # the table says what the headline counts, in replay's words, episode by episode
    head = re.findall(r"<tr><th>episode</th>(.*?)</tr>", page)[0]
    assert "<th>re-simulated</th>" in head and "crash after" not in head
    cells = re.findall(r"<td class='(\w*)'>([^<]*)</td><td class='pic'>", page)
    assert cells.count(("good", "prevented")) == crashes == len(cells)
    # the corridor draws no scene: its episodes show their variables over time instead
    assert "<td class='pic'><svg" in page and ">pos<title>pos</title></text><polyline" in page


def _count_reads(monkeypatch) -> list:
    """Every read of a run file from here on, as (what, file name): its columns
    (``read_columns``), its decoded episodes (``read_run``) and each walk over its episodes
    that decodes their steps (``read_pieces``), wherever tracecheck imported the name."""
    import sys

    import tracecheck.checking.replaying  # noqa: F401 (their imported names are counted too)
    import tracecheck.live.resimulate  # noqa: F401
    import tracecheck.stats.estimates  # noqa: F401
    from tracecheck.episodes import columns, reader

    reads = []

    def counting(what, original):
        def read(path, *args, **kwargs):
            if what != "read_pieces" or kwargs.get("decode", True):
                reads.append((what, Path(path).name))
            return original(path, *args, **kwargs)
        return read

    for name, original in (("read_columns", columns.read_columns),
                           ("read_run", reader.read_run), ("read_pieces", reader.read_pieces)):
        wrapper = counting(name, original)
        for module in [m for n, m in sys.modules.items() if n.split(".")[0] == "tracecheck"]:
            if getattr(module, name, None) is original:
                monkeypatch.setattr(module, name, wrapper)
    return reads


def test_past_its_tail_a_campaign_s_episodes_are_counted_not_listed(tmp_path, monkeypatch):
    """A campaign of 10^5 episodes has tens of thousands that matter: the report lists the
    first ones and counts the rest by kind (replay --format csv lists them all)."""
    import tracecheck.render.report as R

    monkeypatch.setattr(R, "TAIL", 4)
    out = tmp_path / "report.html"
    write_report([NONE], out, shield=load_shield("paper"), pset=load_properties("generic"),
                  max_pages=2)
    page = out.read_text()
    hidden = page[page.index("<details>"):]
    assert "<summary>16 more episode(s)</summary>" in hidden
    assert len(re.findall(r"<tr><td>\d+</td>", hidden)) == 4
    note = re.search(r"… and (\d+) more, not listed: ([^.]*)\.", hidden)
    assert note and note.group(1) == "12"
    counts = [int(n) for n in re.findall(r"(\d+) with ", note.group(2))]
    assert sum(counts) == 12 and "replay --format csv</code> lists every episode" in hidden


def test_the_report_reads_each_run_once_for_its_columns_and_once_for_its_episodes(
        monkeypatch, tmp_path):
    """The columns go to the statistics, replay and re-simulation; the episodes its
    pictures and viewer pages show are decoded in one walk of the file."""
    reads = _count_reads(monkeypatch)
    _, pages = write_report([NONE, PAPER], tmp_path / "report.html",
                             shield=load_shield("paper"), pset=load_properties("highway"),
                             max_pages=6)
    assert pages == 5
    once = {(what, run.name): 1 for run in (NONE, PAPER)
            for what in ("read_columns", "read_run", "read_pieces")}
    assert Counter(reads) == once


def test_the_report_with_resimulation_reads_each_run_once(corridor, monkeypatch, tmp_path):
    recorded, shield, agent, props = corridor
    reads = _count_reads(monkeypatch)
    write_report([recorded], tmp_path / "report.html", shield=load_shield(str(shield)),
                  pset=load_properties(str(props)), resimulate=True, agent=agent,
                  env=CORRIDOR)
    assert Counter(reads) == {("read_columns", "toy.mcap"): 1, ("read_run", "toy.mcap"): 1,
                              ("read_pieces", "toy.mcap"): 1}


def test_report_text_is_inert(tmp_path):
    import shutil

    hostile = tmp_path / "<b>x<i>&.mcap"
    shutil.copy(NONE, hostile)
    out = tmp_path / "r.html"
    write_report([hostile], out, shield=load_shield("paper"), pset=load_properties("highway"),
                  max_pages=1)
    page = out.read_text()
    assert "<b>x<i>" not in page and "&lt;b&gt;x&lt;i&gt;&amp;.mcap" in page


def test_report_resimulate_needs_a_shield(capsys, tmp_path):
    from tests.helpers import run

    code, _, err = run(capsys, "report", str(NONE), "--resimulate", "-o",
                       str(tmp_path / "r.html"))
    assert code == 2 and "--resimulate needs --shield" in err


def test_the_picture_shows_the_state_where_the_shield_would_have_acted(tmp_path):
    """Issue 42: the thumbnail "at the first blocked step" drew the state after the blocked
    action — the agent already in the hole — not the state the shield decides in."""
    from tracecheck.checking.replaying import replay
    from tracecheck.episodes.reader import read_run
    from tracecheck.live.record import RecordSettings, record

    run_file = tmp_path / "lake.mcap"
    record(RecordSettings(env="frozenlake", agent=str(ROOT / "models" / "agents" /
                                                      "frozenlake.npy"),
                          shield="none", episodes=3, seed=0, duration=30,
                          env_config={"is_slippery": True}), run_file)
    shield = load_shield("frozenlake")
    out = tmp_path / "report.html"
    write_report([run_file], out, shield=shield, pset=load_properties("generic"))
    pictures = dict(re.findall(r"<tr><td>(\d+)</td>.*?<td class='pic'><svg.*?<title>agent at "
                               r"\((\d+, \d+)\)</title>", out.read_text()))
    episodes = {e.id: e for e in read_run(run_file).episodes}
    blocked = {e.episode: e.first_infeasible for e in replay([run_file], shield).per_episode
               if e.first_infeasible is not None}
    assert blocked and set(blocked) <= {int(k) for k in pictures}
    for episode, k in blocked.items():
        before = episodes[episode].steps[k - 1].state
        assert pictures[str(episode)] == f"{before['x']}, {before['y']}"


def test_crashes_the_shield_would_not_have_blocked_need_no_re_simulation(tmp_path):
    """A new user's shielded run had crashes (slips) but no blocked step: the report still
    said whether blocking would have prevented them "needs re-simulation"."""
    out = tmp_path / "report.html"
    write_report([PAPER], out, shield=load_shield("paper"), pset=load_properties("generic"))
    page = out.read_text()
    assert "needs re-simulation" not in page
    assert "paper would have blocked no step before any of these crashes" in page
