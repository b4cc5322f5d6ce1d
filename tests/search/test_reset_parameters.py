"""What an episode starts from, searched: an adapter's ``reset_parameters`` reach its
``reset`` hook as options — through the environment's own reset (the corridor) or set by
the adapter after it (the highway's other vehicles' speed) — and every episode keeps them,
so that it replays, re-simulates and is attributed from the same start."""

from __future__ import annotations

import json

import pytest

from tests.helpers import ROOT, run
from tests.search import corridor
from tracecheck.episodes.reader import read_run
from tracecheck.errors import InputError
from tracecheck.live.adapter import EnvAdapter, load_adapter
from tracecheck.live.resimulate import rerun
from tracecheck.search.space import check_space

ENV = "tests.search.corridor:Corridor"


def _falsify(capsys, tmp_path, *params, shield=corridor.OPEN, duration=3, extra=()):
    shield_file = tmp_path / "corridor.mch"
    shield_file.write_text(shield)
    out = tmp_path / "f.mcap"
    code, text, err = run(capsys, "falsify", "--agent", corridor.agent_file(tmp_path),
                          "--env", ENV, "--shield", shield_file, *sum(
                              (["--param", p] for p in params), []), "--duration", duration,
                          "--budget", 10, "--optimizer", "halton", "--no-baseline", "-o", out,
                          "--json", *extra)
    return code, out, (json.loads(text) if code == 0 else err)


def test_a_reset_parameter_is_searched_and_kept_with_each_episode(capsys, tmp_path):
    # in 3 steps the walker reaches the pit at 5 only from a head start of 2 or more
    code, out, data = _falsify(capsys, tmp_path, "head_start=0..4")
    assert code == 0, data
    assert data["space"] == {"head_start": [0, 4]}
    episodes = read_run(out).episodes
    starts = {ep.reset_options["head_start"] for ep in episodes}
    assert starts == {0, 1, 2, 3, 4}  # integers: both ends are written whole
    for ep in episodes:
        start = ep.reset_options["head_start"]
        assert ep.config is None and ep.search.parameters == {"head_start": start}
        assert ep.steps[0].state["pos"] == start
        assert ep.search.violated == (start >= 2) == ep.end.crashed
        if ep.end.crashed:  # the agent walked on where EXIT was allowed
            assert ep.search.attribution == "agent's choice"
    crashed = next(ep for ep in episodes if ep.end.crashed)
    again = rerun(out, crashed.id, str(tmp_path / "corridor.mch"), env=ENV)
    assert again.reset_options == crashed.reset_options
    assert [s.state for s in again.steps] == [s.state for s in crashed.steps]


def test_replay_re_simulates_from_the_recorded_start(capsys, tmp_path):
    # a shield that blocks the step into the pit: every recorded crash is re-run from its
    # own start (else its first state differs from the recording: "did not reproduce")
    _, out, _ = _falsify(capsys, tmp_path, "head_start=0..4", duration=5)
    guarded = tmp_path / "guarded.mch"
    guarded.write_text(corridor.GUARDED)
    code, text, _ = run(capsys, "replay", out, "--shield", guarded, "--env", ENV,
                        "--resimulate", "--json")
    assert code == 0
    resim = json.loads(text)["resimulation"]
    crashes = sum(ep.end.crashed for ep in read_run(out).episodes)
    assert crashes and resim["resimulated"] == crashes
    assert resim["crashes_prevented"] == crashes and resim["mismatches"] == 0


def test_a_reset_value_is_tried_before_any_episode(capsys, tmp_path):
    code, out, err = _falsify(capsys, tmp_path, "head_start=0.5..2.0")
    assert code == 2 and not out.exists()
    assert "--param head_start=0.5..2.0" in err  # the environment refused a float position


def test_an_unknown_name_lists_the_settings_and_reset_parameters(capsys, tmp_path):
    # the corridor does not list its settings: the environment's own refusal is shown
    code, _, err = _falsify(capsys, tmp_path, "head=0..4")
    assert code == 2 and "--param head=0..4" in err and "'head'" in err
    pytest.importorskip("highway_env")
    with pytest.raises(InputError) as info:
        check_space(["other_sped=5..35"], load_adapter("highway"))
    message = info.value.message
    assert "no setting nor reset parameter 'other_sped'" in message
    assert "vehicles_density" in message and "its reset parameters other_speed" in message
    assert "other vehicle's initial speed" in info.value.hint


class _NoReset(EnvAdapter):
    name = "no-reset"
    actions = ("A",)
    variables = ("x",)
    reset_parameters = {"seed": "the seed again"}


def test_a_reset_parameter_named_seed_is_refused_when_the_adapter_loads():
    with pytest.raises(InputError, match="reset_parameters"):
        load_adapter(f"{__name__}:_NoReset")


def test_the_highway_sets_the_other_vehicles_speed(tmp_path):
    pytest.importorskip("highway_env")
    from tracecheck.checking.shield import load_shield
    from tracecheck.live.envs.highway import ELEMENTS
    from tracecheck.live.rollout import RecordSettings, Session, run_episode

    adapter = load_adapter("highway")
    space = check_space(["other_speed=5..35", "vehicles_density=1..2"], adapter)
    assert [d.name for d in space.resets] == ["other_speed"]
    assert [d.name for d in space.settings] == ["vehicles_density"]
    settings = RecordSettings(agent=str(ROOT / "models" / "agents" / "base.zip"),
                              shield="paper", episodes=1, duration=3, env="highway")
    session = Session(settings, shield=load_shield("paper"))
    try:
        plain = run_episode(session, 0, seed=7)
        slow = run_episode(session, 0, seed=7, options={"other_speed": 15.0})
    finally:
        session.env.close()
    ego = plain.steps[0].state["VehiclesVx"]
    own = ego.map[ELEMENTS[0]]
    relative = {v for e, v in slow.steps[0].state["VehiclesVx"].map.items()
                if e != ELEMENTS[0]}
    assert relative == {15.0 - own}
    assert slow.reset_options == {"other_speed": 15.0} and plain.reset_options is None
    with pytest.raises(InputError, match="other_speed=-1"):
        check_space(["other_speed=-1..35"], adapter)


def test_envs_lists_the_reset_parameters(capsys):
    pytest.importorskip("highway_env")
    code, text, _ = run(capsys, "envs", "--json")
    rows = {r["name"]: r for r in json.loads(text)}
    assert code == 0 and list(rows["highway"]["reset_parameters"]) == ["other_speed"]
    assert "reset_parameters" not in rows["frozenlake"]
    code, text, _ = run(capsys, "envs")
    assert "reset parameters other_speed" in " ".join(text.split())


def test_the_highway_passes_its_own_reset_options_on():
    pytest.importorskip("highway_env")
    adapter = load_adapter("highway")
    env = adapter.make_env(adapter.config())
    try:
        obs, _ = adapter.reset(env, 0, {"config": {"vehicles_count": 3}, "other_speed": 20.0})
        assert env.unwrapped.config["vehicles_count"] == 3
    finally:
        env.close()


def test_a_crafted_space_is_shown_not_a_traceback():
    from tracecheck.episodes.summary import space_text

    assert space_text({"a": [1], "b": [0, 1]}, ["b"]) == "a {1}, b {0,1}"
    assert space_text({"a": [0.0, 1.0]}, []) == "a 0.0..1.0"
