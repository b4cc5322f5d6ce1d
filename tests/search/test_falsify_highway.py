"""falsify on the highway with the bundled agent under the paper's shield and the strict
one: crashes found, each attributed, each run again from the run file alone to the same
crash."""

from __future__ import annotations

import pytest

from tests.helpers import ROOT
from tracecheck.checking.shield import load_shield
from tracecheck.episodes.reader import read_run
from tracecheck.live.resimulate import rerun
from tracecheck.live.rollout import RecordSettings
from tracecheck.search.falsify import FalsifySettings, falsify

pytest.importorskip("highway_env")

AGENT = ROOT / "models" / "agents" / "base.zip"


@pytest.mark.parametrize("shield", ["paper", "strict"])
def test_crashes_found_attributed_and_run_again(tmp_path, shield):
    settings = FalsifySettings(
        RecordSettings(agent=str(AGENT), shield=shield, episodes=1, env="highway",
                       duration=30),
        ("seed=0..100000", "vehicles_density=1.5..3.0"), None, budget=6, optimizer="halton",
        baseline=False, attribute=3)
    out = tmp_path / f"{shield}.mcap"
    result = falsify(settings, out)
    crashed = [ep for ep in read_run(out).episodes if ep.end.crashed]
    assert crashed, f"no crash under {shield} in 6 dense episodes"
    assert result.summaries[0].violations == len(crashed)
    assert sum(result.summaries[0].attributions.values()) == len(crashed)
    for ep in crashed:
        assert ep.search.violated and ep.search.attribution in (
            "shield gap", "unavoidable under the shield", "agent's choice")
        again = rerun(out, ep.id, shield if ep.id % 2 else load_shield(shield))
        assert [s.action for s in again.steps] == [s.action for s in ep.steps]
        assert again.end.crashed and again.end.steps == ep.end.steps


def test_a_continuous_shield_s_room_guides_the_search(tmp_path):
    """On the continuous highway an episode that does not crash is valued by the room its
    guard left the acceleration (the allowed intervals each step recorded), not a flat +1."""
    settings = FalsifySettings(
        RecordSettings(agent=str(ROOT / "models" / "agents" / "highway_continuous_sac.zip"),
                       shield="highway_continuous", episodes=1, env="highway-continuous",
                       duration=12),
        ("seed=0..9999", "other_speed=20.0..30.0"), None, budget=3, optimizer="random",
        baseline=False, attribute=0)
    falsify(settings, tmp_path / "c.mcap")
    kept = [ep for ep in read_run(tmp_path / "c.mcap").episodes if not ep.search.violated]
    assert kept and all(0.0 <= ep.search.objective < 2.0 for ep in kept)
    assert any(ep.search.objective != 1.0 for ep in kept)
    for ep in kept:  # the smallest room over the steps, from what each step recorded
        rooms = [min(max((hi - lo) if lo == -1.0 else (hi - lo) / 2 for lo, hi in bands)
                     if bands else 0.0 for name, bands in s.allowed_intervals.items()
                     if name == "acceleration") for s in ep.steps[1:]]
        assert ep.search.objective == pytest.approx(min(rooms), abs=1e-6)
