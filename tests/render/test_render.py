"""The episode viewer and the report: self-contained pages, tested in a real browser."""

from __future__ import annotations

import re
import shutil


from tests.helpers import write_report, ROOT, browser_errors, open_browser, run
from tracecheck.episodes import EpisodeWriter, new_header
from tracecheck.render.viewer import episode_data, render_episode
from tracecheck.checking.shield import load_shield

NONE = ROOT / "sample_traces" / "base_none.mcap"


def test_viewer_data_marks_first_infeasible_and_crash():
    data = episode_data(NONE, 3, load_shield("paper"))
    assert data["first_infeasible"] == 5 and data["crash_step"] == 39
    assert len(data["steps"]) == 40 and data["blocked"][0] == 5
    zones = {s["label"] for s in data["scene"]["shapes"] if s.get("kind") == "box"
             and s["label"].split(":")[0] in ("LANE_LEFT", "FASTER", "IDLE")}
    assert zones  # the paper shield's zones, drawn
    step = data["steps"][5]
    assert step["action"] not in data["steps"][4]["shield_allows"]
    assert {row[0] for row in step["state"]} >= {"VehiclesX", "Crash"}
    assert step["values"] and step["live_allowed"]


def test_viewer_marks_where_an_ltl_formula_is_first_violated(capsys, tmp_path):
    from tracecheck.checking.replaying import ltl_formulas

    shield = load_shield("paper")
    formulas = ltl_formulas(shield, ["G({Crash = FALSE})", "F [FASTER]"])
    data = episode_data(NONE, 3, shield, formulas)
    assert data["ltl"] == [
        {"name": "--ltl 1", "formula": "G({Crash = FALSE})", "holds": False, "step": 39},
        {"name": "--ltl 2", "formula": "F [FASTER]", "holds": True, "step": None}]
    out = tmp_path / "ep.html"
    code, _, err = run(capsys, "render", str(NONE), "-e", "3", "--ltl", "G({Crash = FALSE})",
                       "-o", str(out))
    assert code == 2 and "--ltl and --ltl-assertions need --shield" in err
    code, _, _ = run(capsys, "render", str(NONE), "-e", "3", "--shield", "paper", "--ltl",
                     "G({Crash = FALSE})", "-o", str(out))
    assert code == 0 and '"step":39' in out.read_text()


def test_viewer_page_is_self_contained_and_small(tmp_path):
    page = render_episode(NONE, 0, load_shield("paper"))
    assert len(page.encode()) < 1_000_000  # a 60-step episode stays under 1 MB
    assert "<script src" not in page and "<link" not in page
    urls = set(re.findall(r"https?://[^\s\"')]+", page))
    assert urls <= {"http://www.w3.org/2000/svg"}  # an XML namespace, never fetched
    assert "const DATA = {" in page


def test_render_cli_and_errors(capsys, tmp_path):
    out = tmp_path / "ep.html"
    code, text, _ = run(capsys, "render", str(NONE), "--episode", "3", "--shield", "paper",
                        "-o", str(out))
    assert code == 0 and out.exists() and "wrote episode 3" in text
    out = tmp_path / "other.html"  # (the first exists: it would need --force)
    code, _, err = run(capsys, "render", str(NONE), "--episode", "99", "-o", str(out))
    assert code == 2 and "has no episode 99; it has 0, 1, 2" in err
    empty = tmp_path / "empty.mcap"
    with EpisodeWriter(empty, new_header("recorded")):
        pass
    code, _, err = run(capsys, "render", str(empty), "--episode", "0", "-o", str(out))
    assert code == 2 and "holds no complete episode" in err
    code, _, err = run(capsys, "render", str(NONE), "--episode", "1", "-o",
                       "/proc/nope/ep.html")
    assert code == 2 and "cannot write /proc/nope/ep.html" in err


def test_report_cli(capsys, tmp_path):
    out = tmp_path / "report.html"
    code, text, _ = run(capsys, "report", str(NONE), "--shield", "paper", "-o", str(out))
    assert code == 0 and "episode page(s)" in text
    page = out.read_text()
    assert "<h2>Runs</h2>" in page and "shield paper (sha256" in page
    assert "Statistics (generic+highway)" in page
    assert page.count("<svg") >= 2  # the plots, inline
    links = re.findall(r"href='([^']+)'", page)
    assert links and all((tmp_path / link).exists() for link in links)
    empty = tmp_path / "empty.mcap"
    with EpisodeWriter(empty, new_header("recorded")):
        pass
    code, _, err = run(capsys, "report", str(empty), "-o", str(tmp_path / "r.html"))
    assert code == 2 and "holds no complete episode: nothing to report" in err


# ------------------------------------------------------------------ in a real browser


def test_viewer_in_a_browser(tmp_path):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    page = tmp_path / "episode.html"
    from tracecheck.checking.replaying import ltl_formulas

    shield = load_shield("paper")
    page.write_text(render_episode(NONE, 3, shield,
                                   ltl_formulas(shield, ["G({VehiclesVx(EgoVehicle) > 0.0})",
                                                         "G({Crash = FALSE})"])))
    browser = open_browser()
    try:
        browser.get(page.as_uri())
        panel = browser.find_element(By.ID, "step")
        assert panel.text.startswith("step 0")
        browser.find_element(By.ID, "forward").click()
        assert browser.find_element(By.ID, "step").text.startswith("step 1")
        browser.find_element(By.TAG_NAME, "body").send_keys(Keys.ARROW_RIGHT)
        assert browser.find_element(By.ID, "step").text.startswith("step 2")
        browser.find_element(By.ID, "back").click()
        assert "step 1 of 39" in browser.find_element(By.ID, "where").text
        assert len(browser.find_elements(By.CSS_SELECTOR, "#picture rect")) >= 5
        assert browser.find_element(By.CSS_SELECTOR, "#timeline span.first").text == "!"
        assert "LTL --ltl 2 first violated at step 39" in \
            browser.find_element(By.ID, "summary").text
        assert "LTL --ltl 1 holds" in browser.find_element(By.ID, "summary").text
        assert browser_errors(browser) == []
        assert browser.save_screenshot(str(tmp_path / "episode.png"))
    finally:
        browser.quit()


def test_report_in_a_browser(tmp_path):
    from selenium.webdriver.common.by import By

    out = tmp_path / "report.html"
    from tracecheck.stats.properties import load_properties

    write_report([NONE], out, shield=load_shield("paper"), pset=load_properties("highway"), max_pages=2)
    browser = open_browser()
    try:
        browser.get(out.as_uri())
        assert "Episodes that matter" in browser.page_source
        browser.find_element(By.LINK_TEXT, "open").click()
        browser.find_element(By.ID, "forward").click()
        assert browser.find_element(By.ID, "step").text.startswith("step 1")
        assert browser_errors(browser) == []
        assert browser.save_screenshot(str(tmp_path / "report.png"))
    finally:
        browser.quit()


def test_report_pages_of_runs_with_the_same_file_name_do_not_collide(tmp_path):
    from tracecheck.stats.properties import load_properties

    runs = []
    for folder, sample in (("a", "base_none.mcap"), ("b", "base_paper.mcap")):
        (tmp_path / folder).mkdir()
        runs.append(tmp_path / folder / "run.mcap")
        shutil.copy(ROOT / "sample_traces" / sample, runs[-1])
    page, count = write_report(runs, tmp_path / "out" / "report.html",
                                shield=load_shield("strict"),
                                pset=load_properties("highway"), max_pages=200)
    written = sorted(p.name for p in (tmp_path / "out" / "report_files").glob("*.html"))
    assert len(written) == count
    assert any(n.startswith("run_1_") for n in written)
    assert any(n.startswith("run_2_") for n in written)


# ------------------------------------------------------------------ inert embedded data

HOSTILE = "<!--<script>\u2028</script><b>&amp;\u2029"


def _hostile_run(path):
    from tests.helpers import state
    from tracecheck.episodes.model import Episode, StepRecord, make_end

    steps = []
    for k in range(3):
        s = state(100.0 + k)
        s["Label"] = HOSTILE
        steps.append(StepRecord(k, float(k), None if k == 0 else "IDLE", s, 0.0, False))
    steps = tuple(steps)
    with EpisodeWriter(path, new_header("recorded")) as w:
        w.write(Episode(0, steps, make_end(steps), seed=1))
    return path


def test_no_string_can_end_or_comment_out_the_viewer_script(tmp_path):
    """A B string "<!--<script>" in a state used to swallow the rest of the page (the
    browser's script-data-escaped state): the embedded JSON has no <, >, & or U+2028/2029
    left, only their \\u escapes, and reads back as the same data."""
    import json

    run_ = _hostile_run(tmp_path / "{{DATA}} {{TITLE}}.mcap")
    page = render_episode(run_, 0)
    script = page[page.index("const DATA = ") + len("const DATA = "):]
    payload = script[:script.index(";\nconst ACTIONS")]
    for bad in ("<", ">", "&", "\u2028", "\u2029"):
        assert bad not in payload, bad
    assert "\\u003c!--\\u003cscript\\u003e" in payload
    assert json.loads(payload) == json.loads(json.dumps(episode_data(run_, 0)))
    state = {name: full for name, _, full in json.loads(payload)["steps"][0]["state"]}
    assert state["Label"] == f'"{HOSTILE}"'
    assert page.count("</script>") == 1 and page.count("<script>") == 1
    # a file named {{DATA}} stays a title: the data goes in once, into the script
    assert "<title>{{DATA}} {{TITLE}}.mcap, episode 0 — tracecheck</title>" in page
    assert page.count("const DATA = {") == 1 and page.count('"steps":[') == 1


def test_report_plots_take_dollars_and_markup_as_text(capsys, tmp_path):
    """matplotlib read "$\\frac{1}$" in a description or a file name as TeX and crashed
    `report`; the page shows such text, and HTML in it, as text."""
    props = tmp_path / "p.toml"
    props.write_text('[metrics.m]\nexpression = "Reward"\ndescription = "$\\\\frac{1}$ '
                     '<script>alert(1)</script>"\n[properties.p]\npredicate = "Crash = FALSE"\n'
                     'description = "$x$ and $"\n')
    run_ = tmp_path / "$\\frac{1}$.mcap"
    shutil.copy(NONE, run_)
    out = tmp_path / "report.html"
    code, _, err = run(capsys, "report", str(run_), "--properties", str(props), "-o", str(out))
    assert code == 0, err
    page = out.read_text()
    assert "<script>alert(1)</script>" not in page and page.count("<svg") >= 2
    assert "$\\frac{1}$" in page  # the file name, as text
