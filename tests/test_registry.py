"""The registry of environments: what a misbehaving plug-in does to the others (nothing),
names two environments declare (refused where they are asked for), and how a command without
--env finds the environment (the agent's model card)."""

from __future__ import annotations

import json
from importlib import metadata

import pytest

from tests.helpers import ROOT
from tracecheck import registry
from tracecheck.errors import InputError


def _install(monkeypatch, **targets):
    points = dict(registry.entry_points())
    for name, target in targets.items():
        points[name] = metadata.EntryPoint(name, target, registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(registry, "entry_points", lambda: points)


def test_a_plugin_with_bad_declarations_leaves_the_others_working(monkeypatch):
    from tracecheck.checking.shield import load_shield, shield_names
    from tracecheck.stats.properties import builtin_sets

    _install(monkeypatch, badshields="tests.live.plugins:BadShields")
    assert "paper" in shield_names() and "ok" not in builtin_sets()
    assert load_shield("paper").name == "paper"


def test_a_name_two_environments_declare_is_refused_and_each_keeps_its_own(monkeypatch):
    from tracecheck.checking.shield import load_shield
    from tracecheck.live.adapter import get_adapter
    from tracecheck.stats.formulas import own_shield

    _install(monkeypatch, papertoo="tests.live.plugins:PaperToo")
    with pytest.raises(InputError, match="the shield name 'paper' is declared by the "
                                         "environments highway, papertoo"):
        load_shield("paper")
    assert own_shield(get_adapter("highway")).path.endswith("shields/paper.mch")


def test_a_failing_claims_claims_nothing(monkeypatch):
    from tracecheck.live.adapter import claiming_adapter
    from tracecheck.live.envs.highway import VARIABLES

    _install(monkeypatch, claimsraises="tests.live.plugins:ClaimsRaises")
    assert claiming_adapter(VARIABLES).name == "highway"
    assert claiming_adapter(("pos",)) is None


@pytest.mark.parametrize("card,found", [
    (None, "has no model card"),
    ({"agent": "a.npy"}, "names no environment"),
    ({"environment": "frozenlake"}, "frozenlake"),
    ({"environment": "highway-fast-v0", "algorithm": "DQN"}, "highway"),
    ({"environment": "highway-fast-v0", "algorithm": "SAC"}, "highway-continuous"),
    ({"environment": "highway-fast-v0", "algorithm": "PPO"},
     "which several installed environments have: highway, highway-continuous"),
    ({"environment": "minigrid"}, "is not installed here"),
])
def test_the_environment_an_agents_model_card_names(tmp_path, card, found):
    from tracecheck.live.agents import card_environment

    agent = tmp_path / "a.npy"
    agent.write_bytes(b"")
    if card is not None:
        (tmp_path / "a.json").write_text(json.dumps(card))
    if found in ("frozenlake", "highway", "highway-continuous"):
        assert card_environment(agent)[0] == found
    else:
        with pytest.raises(InputError, match=found):
            card_environment(agent)


def test_the_continuous_highway_trains_with_the_algorithms_own_settings():
    from tracecheck.live.adapter import get_adapter

    assert get_adapter("highway-continuous").training_settings("sac", 20_000) == {}
    assert get_adapter("highway").training_settings("ppo", 20_000) == {"gamma": 0.8}


def test_traces_imported_in_an_environments_vocabulary_are_that_environments(capsys,
                                                                            tmp_path):
    """import --env writes the environment into the run: stats then use its property set."""
    from tests.helpers import run

    lake = tmp_path / "lake.mcap"
    assert run(capsys, "record", "--env", "frozenlake", "--agent",
               ROOT / "models" / "agents" / "frozenlake.npy", "-n", 2, "-o", lake)[0] == 0
    assert run(capsys, "export", "simb", lake, "-o", tmp_path / "traces")[0] == 0
    back = tmp_path / "back.mcap"
    assert run(capsys, "import", "simb", tmp_path / "traces", "--env", "frozenlake", "-o",
               back)[0] == 0
    code, out, _ = run(capsys, "stats", back, "--json")
    assert code == 0 and json.loads(out)["properties_set"] == "generic+frozenlake"
