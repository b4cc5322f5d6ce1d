"""The viewer for any environment: a chart per numeric variable, blocked steps,
interventions and the crash marked, captions that fit the environment, people's numbers —
read back from the rendered page in Chromium (screenshots under /tmp/tracecheck-screens)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.helpers import ROOT, browser_errors, open_browser
from tests.live.toy import CRUISE_SHIELD, Cruise
from tracecheck.checking.shield import load_shield
from tracecheck.live.adapter import EnvAdapter
from tracecheck.live.envs.grid_scene import GRID_CAPTION
from tracecheck.live.envs.highway_scene import ROAD_CAPTION
from tracecheck.render.viewer import episode_data, render_episode, short_value

NONE = ROOT / "sample_traces" / "base_none.mcap"
SCREENS = Path("/tmp/tracecheck-screens")


class _NoScene(Cruise):
    """The cruise adapter without its scene hook."""

    scene = EnvAdapter.scene


@pytest.fixture(scope="module")
def cruise_shield(tmp_path_factory):
    path = tmp_path_factory.mktemp("shield") / "cruise.mch"
    path.write_text(CRUISE_SHIELD)
    return load_shield(str(path))


def test_numbers_are_rounded_for_people_and_exact_on_hover():
    assert short_value(52.20011520385742) == "52.2"
    data = episode_data(NONE, 3, load_shield("paper"))
    name, short, full = next(row for row in data["steps"][1]["state"] if row[0] == "VehiclesX")
    import re

    exact = re.findall(r"-?\d+\.\d+", full)
    rounded = re.findall(r"-?\d+(?:\.\d+)?(?=\))", short)
    assert len(exact) == len(rounded) == 5 and max(map(len, exact)) > 12
    assert all(len(r.lstrip("-").replace(".", "").lstrip("0")) <= 4 for r in rounded)
    assert all(abs(float(r) - float(e)) <= 0.0005 * abs(float(e)) for r, e in zip(rounded, exact))


def test_every_numeric_variable_is_a_series_a_function_one_line_per_element():
    data = episode_data(NONE, 3, load_shield("paper"))
    names = [s["name"] for s in data["series"]]
    assert names == ["VehiclesX", "VehiclesY", "VehiclesVx", "VehiclesVy", "VehiclesAx",
                     "VehiclesAy", "Reward"]  # Crash (BOOL) and PresentVehicles (a set): no
    vx = next(s for s in data["series"] if s["name"] == "VehiclesVx")
    assert [line["label"] for line in vx["lines"]][0] == "VehiclesVx(EgoVehicle)"
    assert len(vx["lines"]) == 5 and all(len(line["values"]) == 40 for line in vx["lines"])
    assert data["blocked"][0] == data["first_infeasible"] == 5 and len(data["blocked"]) == 15


def test_a_non_highway_episode_does_not_carry_the_highway_caption(cruise_runs, cruise_shield,
                                                                  lake_run):
    """Bug 7: the highway's caption ("vehicles are drawn as 5 m × 2 m boxes") was printed
    under every episode, over a page that drew nothing."""
    plain = render_episode(cruise_runs[0], 0, cruise_shield)
    assert "5 m × 2 m" not in plain
    data = episode_data(cruise_runs[0], 0, cruise_shield)
    # issue 42: a caption that is true — the run's environment is not installed here
    assert data["scene"] is None and data["no_scene_caption"].startswith(
        "The run's environment cruise is not installed here, so no picture is drawn (give its "
        "adapter with --env package.module:Class")
    plain_data = episode_data(cruise_runs[0], 0, cruise_shield, adapter=_NoScene())
    assert plain_data["no_scene_caption"].startswith("The environment cruise draws no picture "
                                                     "(its adapter has no scene() hook")
    assert [s["name"] for s in data["series"]] == ["Gap", "Speed", "LeadSpeed", "reward"]
    drawn = episode_data(cruise_runs[0], 0, cruise_shield, adapter=Cruise())
    assert drawn["scene"]["caption"].startswith("The ego car (blue")
    assert any(s["kind"] == "text" and s["text"].startswith("gap ")
               for s in drawn["scene"]["shapes"])
    lake = episode_data(lake_run, 0, load_shield("frozenlake"))
    assert lake["scene"]["caption"] == GRID_CAPTION and "5 m × 2 m" not in GRID_CAPTION
    assert episode_data(NONE, 0)["scene"]["caption"] == ROAD_CAPTION


def test_an_adapter_s_scene_hook_that_returns_junk_is_named(cruise_runs):
    from tracecheck.errors import InputError

    class Broken(Cruise):
        def scene(self, step):
            return {"boxes": []}

    with pytest.raises(InputError, match="scene\\(\\) returned dict, not a tracecheck"):
        episode_data(cruise_runs[0], 0, adapter=Broken())


def _read_page(browser, page: Path, shot: str) -> dict:
    from selenium.webdriver.common.by import By

    browser.get(page.as_uri())
    charts = browser.find_elements(By.CSS_SELECTOR, "#series .chart")
    found = {
        "variables": [c.get_attribute("data-variable") for c in charts],
        "paths": [len(c.find_elements(By.CSS_SELECTOR, "path.series")) for c in charts],
        "blocked": [len(c.find_elements(By.CSS_SELECTOR, "rect.blocked")) for c in charts],
        "interventions": [len(c.find_elements(By.CSS_SELECTOR, "line.intervention"))
                          for c in charts],
        "crash": [len(c.find_elements(By.CSS_SELECTOR, "line.crash")) for c in charts],
        "caption": browser.find_element(By.ID, "caption").text,
        "picture": browser.find_element(By.ID, "picture").is_displayed(),
        "errors": browser_errors(browser),
    }
    SCREENS.mkdir(exist_ok=True)
    browser.set_window_size(1400, 1300)
    assert browser.save_screenshot(str(SCREENS / shot))
    return found


def test_the_time_series_panel_in_a_browser(cruise_runs, cruise_shield, lake_run, tmp_path):
    from selenium.webdriver.common.by import By

    pages = {}
    for name, (run_, episode, shield, adapter) in {
            "highway": (NONE, 3, load_shield("paper"), None),
            "frozenlake": (lake_run, 0, load_shield("frozenlake"), None),
            "cruise": (cruise_runs[0], 1, cruise_shield, Cruise()),
            "cruise-shielded": (cruise_runs[1], 1, cruise_shield, None)}.items():
        pages[name] = (tmp_path / f"{name}.html", episode_data(run_, episode, shield,
                                                              adapter=adapter))
        pages[name][0].write_text(render_episode(run_, episode, shield, adapter=adapter))
    browser = open_browser()
    try:
        for name, (page, data) in pages.items():
            found = _read_page(browser, page, f"viewer-{name}.png")
            assert found["errors"] == [], name
            assert found["variables"] == [s["name"] for s in data["series"]], name
            assert found["paths"] == [len(s["lines"]) for s in data["series"]], name
            assert set(found["blocked"]) == {len(data["blocked"])}, name
            assert set(found["interventions"]) == {len(data["interventions"])}, name
            assert set(found["crash"]) == {int(data["crash_step"] is not None)}, name
        highway = _read_page(browser, pages["highway"][0], "viewer-highway.png")
        assert highway["blocked"][0] == 15 and highway["paths"][2] == 5  # VehiclesVx
        assert "5 m × 2 m boxes" in highway["caption"] and highway["picture"]
        lake = _read_page(browser, pages["frozenlake"][0], "viewer-frozenlake.png")
        assert lake["caption"] == GRID_CAPTION and lake["picture"]
        cruise = _read_page(browser, pages["cruise"][0], "viewer-cruise.png")
        assert cruise["caption"].startswith("The ego car") and cruise["crash"][0] == 1
        assert cruise["blocked"][0] >= 1
        plain = _read_page(browser, pages["cruise-shielded"][0], "viewer-cruise-shielded.png")
        assert not plain["picture"] and "no picture is drawn" in plain["caption"]
        assert "5 m × 2 m" not in browser.page_source
        assert plain["interventions"][0] > 0  # the live shield replaced ACCEL
        # the rounded value in the chart's key, the exact one on hover
        browser.get(pages["highway"][0].as_uri())
        value = browser.find_element(By.CSS_SELECTOR, "#series .chart .value")
        assert value.text == "150.6" and value.get_attribute("title") == "150.57036876678467"
        browser.find_element(By.ID, "forward").click()
        assert browser.find_element(By.CSS_SELECTOR, "#series .chart .value").text != "150.6"
    finally:
        browser.quit()


class _GridCruise(Cruise):
    """The cruise run drawn as a 7×7 grid with no scale (a MiniGrid user's scene)."""

    scale = None

    def scene(self, step, shield=None):
        from tracecheck.live.scene import Box, Scene

        tiles = tuple(Box(x + 0.5, y + 0.5, 0.95, 0.95, fill=(0.6, 0.6, 0.6, 1.0))
                      for x in range(7) for y in range(7))
        return Scene(tiles, view=(0.0, 0.0, 7.0, 7.0), caption="a 7×7 grid",
                     scale=self.scale)


@pytest.mark.parametrize("scale", [None, 400.0])
def test_a_scene_fits_beside_its_controls(cruise_runs, cruise_shield, tmp_path, scale):
    """Issue 42: a custom 7×7 scene was drawn at the page's width (about 1300 px high), the
    controls and charts below the fold; a scale asked for more than fits is held to it."""
    from selenium.webdriver.common.by import By

    adapter = _GridCruise()
    adapter.scale = scale
    page = tmp_path / "grid.html"
    page.write_text(render_episode(cruise_runs[0], 1, cruise_shield, adapter=adapter))
    browser = open_browser()
    try:
        browser.set_window_size(1366, 900)
        browser.get(page.as_uri())
        height = browser.execute_script("return window.innerHeight")
        box = browser.find_element(By.ID, "picture").rect
        assert browser_errors(browser) == []
        assert 100 < box["height"] <= 0.6 * height + 2 and box["width"] == box["height"]
        SCREENS.mkdir(exist_ok=True)
        browser.save_screenshot(str(SCREENS / f"viewer-grid-{scale}.png"))
    finally:
        browser.quit()


def test_a_scene_s_scale_is_checked():
    from tracecheck.errors import InputError
    from tracecheck.live.scene import Scene

    with pytest.raises(InputError, match="a Scene has scale -1: give the pixels per unit"):
        Scene((), view=(0.0, 0.0, 1.0, 1.0), scale=-1)


def test_a_search_s_episode_shows_its_settings_and_point(tmp_path):
    """An episode ``falsify`` wrote carries its own settings and its search point (the
    summary line draws them as text)."""
    from tracecheck.episodes.files import write_run
    from tracecheck.episodes.model import SearchPoint
    from tracecheck.episodes.writer import new_header
    from dataclasses import replace

    from tests.helpers import episode

    point = SearchPoint(1, 4, {"seed": 7, "density": 1.5}, -1.0, True, "tpe", "shield gap", 2,
                        "the shield allowed IDLE at step 2 …")
    path = tmp_path / "s.mcap"
    write_run(path, new_header("recorded"), [replace(episode(0), config={"density": 1.5},
                                                     search=point)])
    data = episode_data(path, 0)
    assert data["config"] == {"density": 1.5}
    assert data["search"] == {"repetition": 1, "evaluation": 4, "parameters": {
        "seed": 7, "density": 1.5}, "objective": -1.0, "violated": True, "optimizer": "tpe",
        "attribution": "shield gap", "attribution_step": 2,
        "attribution_detail": "the shield allowed IDLE at step 2 …"}
    other = tmp_path / "plain.mcap"
    write_run(other, new_header("recorded"), [episode(0)])
    assert (episode_data(other, 0)["config"], episode_data(other, 0)["search"]) == (None, None)
