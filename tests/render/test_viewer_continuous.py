"""The viewer of continuous actions: per parameter a chart of the agent's proposal, the executed
value and the live shield's allowed band (each interval shaded), the step panel saying what
was proposed, executed and allowed — in the page's data and in a real browser (screenshots
under /tmp/tracecheck-screens); a discrete run's page has none of it."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from tests.helpers import browser_errors, open_browser
from tests.stats.continuous_run import record_throttle, write_hand_run
from tracecheck.render.viewer import episode_data, render_episode

SCREENS = Path("/tmp/tracecheck-screens")


@pytest.fixture(scope="module")
def hand_run(tmp_path_factory):
    """The hand-made run of tests/stats/continuous_run.py: several intervals, an unbounded
    end, a step where nothing was allowed."""
    return write_hand_run(tmp_path_factory.mktemp("continuous") / "hand.mcap",
                          action_low=[-4.0], action_high=[2.0])


@pytest.fixture(scope="module")
def throttle_run(tmp_path_factory):
    """One episode of 30 steps of full throttle under throttle_v1.mch, projected."""
    return record_throttle(tmp_path_factory.mktemp("throttle"), steps=30, episodes=1)


def _page_data(html: str) -> dict:
    return json.loads(re.search(r"const DATA = (.*?);\n", html).group(1))


def test_each_parameter_is_a_chart_of_proposal_execution_and_allowed_band(hand_run):
    data = episode_data(hand_run, 1)
    action = data["series"][0]
    assert data["parameters"] == ["a"]
    assert (action["name"], action["kind"], action["parameter"]) == \
        ("ACCELERATE(a)", "action", "a")
    proposed, executed = action["lines"]
    assert proposed == {"label": "a proposed", "dashed": True,
                        "values": [None, 2.0, 1.0, -2.0, 1.5, -3.5]}
    assert executed["label"] == "a executed" and executed["values"][:2] == [None, -4.0]
    assert action["bands"] == [None, [], [[None, 0.0]], [[-3.0, -1.0]],
                               [[-4.0, 1.5 + 1e-4]], [[-3.0, 2.0]]]
    assert episode_data(hand_run, 0)["series"][0]["bands"][3] == [[-4.0, -1.0], [0.5, 2.0]]
    assert data["interventions"] == [1, 2, 5]  # where the executed value is not the proposal
    step = data["steps"][1]
    assert (step["proposal"], step["parameters"], step["distance"], step["deadlock"],
            step["allowed"]) == ({"a": 2.0}, {"a": -4.0}, 6.0, True, {"a": []})
    assert [s["name"] for s in data["series"][1:]] == ["x", "reward"]  # the state's own


def test_a_discrete_episode_has_no_action_chart(cruise_runs, hand_run):
    page = render_episode(cruise_runs[1], 1)
    data = _page_data(page)
    assert "parameters" not in data and '"bands"' not in page
    assert not any("bands" in s or s.get("kind") == "action" for s in data["series"])
    assert not any("allowed" in s or "proposal" in s for s in data["steps"])
    continuous = render_episode(hand_run, 0)
    assert '"bands"' in continuous and _page_data(continuous)["series"][0]["bands"]


def _chart(browser, name):
    from selenium.webdriver.common.by import By

    return next(c for c in browser.find_elements(By.CSS_SELECTOR, "#series .chart")
                if c.get_attribute("data-variable") == name)


def _count(chart, selector) -> int:
    from selenium.webdriver.common.by import By

    return len(chart.find_elements(By.CSS_SELECTOR, selector))


def _panel(browser) -> dict:
    from selenium.webdriver.common.by import By

    rows = browser.find_elements(By.CSS_SELECTOR, "#step tr")
    return {r.find_elements(By.TAG_NAME, "td")[0].text: r.find_elements(By.TAG_NAME, "td")[1]
            for r in rows}


def test_the_bands_in_a_browser(hand_run, throttle_run, tmp_path):
    from selenium.webdriver.common.by import By

    pages = {}
    for name, (path, episode) in {"hand0": (hand_run, 0), "hand1": (hand_run, 1),
                                  "throttle": (throttle_run, 0)}.items():
        pages[name] = tmp_path / f"{name}.html"
        pages[name].write_text(render_episode(path, episode))
    browser = open_browser()
    try:
        browser.set_window_size(1400, 1300)
        for name, page in pages.items():
            browser.get(page.as_uri())
            assert browser_errors(browser) == [], name
            data = _page_data(page.read_text())
            bands = data["series"][0]["bands"]
            chart = _chart(browser, "ACCELERATE(a)")
            assert _count(chart, "rect.allowed") == sum(len(b or []) for b in bands), name
            assert _count(chart, "rect.none-allowed") == sum(b == [] for b in bands), name
            assert _count(chart, "path.series") == 2, name
            assert _count(chart, "path.series[stroke-dasharray]") == 1, name  # the proposal
            assert "allowed by the live shield" in chart.text
            for other in data["series"][1:]:  # the state's charts have no band
                assert _count(_chart(browser, other["name"]), "rect.allowed") == 0
            SCREENS.mkdir(exist_ok=True)
            assert browser.save_screenshot(str(SCREENS / f"viewer-continuous-{name}.png"))
        # hand1: two intervals at step 3 of episode 0; the fallback at step 1 of episode 1
        browser.get(pages["hand1"].as_uri())
        browser.find_element(By.ID, "forward").click()
        panel = _panel(browser)
        assert panel["agent proposed"].text == "a = 2"
        assert panel["executed"].text == "a = -4" and "blocked" in \
            panel["executed"].get_attribute("class")
        assert panel["projection distance"].text == "6"
        assert panel["live shield allowed a"].text == "nothing"
        assert "fallback" in panel["fallback"].text
        browser.find_element(By.ID, "forward").click()
        assert _panel(browser)["live shield allowed a"].text == "−∞ … 0"
        browser.get(pages["hand0"].as_uri())
        for _ in range(3):
            browser.find_element(By.ID, "forward").click()
        assert _panel(browser)["live shield allowed a"].text == "-4 … -1, 0.5 … 2"
        legend = browser.find_element(By.ID, "legend").text
        assert "the live shield moved the agent's proposal" in legend
        # the throttle run: projected steps lie on the band's top
        browser.get(pages["throttle"].as_uri())
        chart = _chart(browser, "ACCELERATE(a)")
        titles = [t.get_attribute("textContent") for t in
                  chart.find_elements(By.CSS_SELECTOR, "rect.allowed title")]
        assert titles[0].startswith("step 1: a allowed in -4 … ")
    finally:
        browser.quit()


def test_a_hybrid_operation_taken_at_single_steps_is_drawn_as_dots(tmp_path):
    """A hybrid run: ACCELERATE executed at steps 1 and 3, BRAKE at step 2 — values with no
    neighbour to join are dots, so none is invisible."""
    from selenium.webdriver.common.by import By

    from tracecheck.episodes import new_header
    from tracecheck.episodes.files import write_run
    from tracecheck.episodes.model import Episode, StepRecord, make_end

    moves = [("ACCELERATE", {"a": 1.0}, {"a": ((0.0, 2.0),)}),
             ("BRAKE", {"b": 3.0}, {"b": ((2.5, 4.0),)}),
             ("ACCELERATE", {"a": 0.5}, {"a": ((0.0, 0.5),)})]
    steps = [StepRecord(0, 0.0, None, {"x": 0.0}, 0.0, False)]
    for k, (op, values, intervals) in enumerate(moves, 1):
        steps.append(StepRecord(k, float(k), op, {"x": float(k)}, 1.0, False,
                                parameters=values, proposal={"a": 2.0},
                                allowed_intervals=intervals,
                                allowed_actions=("ACCELERATE", "BRAKE")))
    steps = tuple(steps)
    path = tmp_path / "hybrid.mcap"
    write_run(path, new_header("recorded", actions=["ACCELERATE", "BRAKE"], variables=["x"],
                               action_parameters={"ACCELERATE": ["a"], "BRAKE": ["b"]},
                               action_low=[0.0, 0.0], action_high=[2.0, 4.0],
                               shield_mode="mask"),
              [Episode(0, steps, make_end(steps, "time-limit"), seed=0)])
    page = tmp_path / "hybrid.html"
    page.write_text(render_episode(path, 0))
    browser = open_browser()
    try:
        browser.get(page.as_uri())
        assert browser_errors(browser) == []
        accelerate, brake = _chart(browser, "ACCELERATE(a)"), _chart(browser, "BRAKE(b)")
        assert _count(accelerate, "circle.series") == 2  # a at steps 1 and 3, apart
        assert _count(brake, "circle.series") == 1  # b at step 2 alone
        dots = accelerate.find_elements(By.CSS_SELECTOR, "circle.series title")
        assert {d.get_attribute("textContent") for d in dots} == {"a executed"}
        SCREENS.mkdir(exist_ok=True)
        assert browser.save_screenshot(str(SCREENS / "viewer-hybrid.png"))
    finally:
        browser.quit()


def test_render_with_another_shield_draws_that_shield_s_band(throttle_run, tmp_path):
    """Issue 42: `render --shield S` on a continuous run marked S's blocked steps but drew
    only the live shield's band."""
    from selenium.webdriver.common.by import By

    from tests.helpers import ACC_ENV
    from tracecheck.checking.shield import load_shield
    from tracecheck.episodes.reader import read_run

    v2 = load_shield(str(ACC_ENV / "acc_cruise" / "throttle_v2.mch"))
    action = episode_data(throttle_run, 0, v2)["series"][0]
    steps = read_run(throttle_run).episodes[0].steps
    assert action["shield_bands"][0] is None and len(action["shield_bands"]) == len(steps)
    for k in range(1, len(steps)):  # v2's guard in the state before each step: 5 m more
        s = steps[k - 1].state
        bound = (s["Gap"] + s["LeadSpeed"] - 6.0 - 2.0 * s["EgoSpeed"]) / 2.0
        (band,) = action["shield_bands"][k] or [[None, None]]
        if bound < -4.0:
            assert action["shield_bands"][k] == []
        else:
            assert band[0] == -4.0 and band[1] == pytest.approx(min(bound, 2.0), abs=1e-9)
    assert action["shield_bands"] != action["bands"]  # not the live shield's (v1's)
    assert "shield_bands" not in episode_data(throttle_run, 0, None)["series"][0]
    page = tmp_path / "v2.html"
    page.write_text(render_episode(throttle_run, 0, v2))
    browser = open_browser()
    try:
        browser.set_window_size(1400, 1300)
        browser.get(page.as_uri())
        assert browser_errors(browser) == []
        chart = _chart(browser, "ACCELERATE(a)")
        drawn = chart.find_elements(By.CSS_SELECTOR, "rect.shield-allowed, rect.shield-none")
        assert len(drawn) == sum(max(len(b), 1) for b in action["shield_bands"] if b is not None)
        assert "allowed by throttle_v2" in chart.text
        SCREENS.mkdir(exist_ok=True)
        browser.save_screenshot(str(SCREENS / "viewer-continuous-other-shield.png"))
    finally:
        browser.quit()
