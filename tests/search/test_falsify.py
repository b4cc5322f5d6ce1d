"""tracecheck falsify on FrozenLake with the bundled Q-table: the search's figures, every
evaluation an episode with its point that replays and re-simulates (its own settings
honoured), a search that reproduces from its seed, and bad input refused before any
episode."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.helpers import ROOT, run
from tracecheck.episodes.reader import read_header, read_run
from tracecheck.errors import InputError
from tracecheck.live.rollout import RecordSettings
from tracecheck.search.falsify import FalsifySettings, falsify

pytest.importorskip("gymnasium")

AGENT = ROOT / "models" / "agents" / "frozenlake.npy"
BASE = ["falsify", "--agent", AGENT, "--env", "frozenlake", "--shield", "none"]
#: the agent reaches the goal's corner on some maps, never on others
PROPERTY = "G({not(x = 3 & y = 3)})"


@pytest.fixture(scope="module")
def searched(tmp_path_factory) -> tuple[Path, dict]:
    import contextlib
    import io

    from tracecheck.cli import main

    out = tmp_path_factory.mktemp("falsify") / "f.mcap"
    text = io.StringIO()
    with contextlib.redirect_stdout(text), pytest.raises(SystemExit):
        main([str(a) for a in BASE + ["--param", "seed=0..9999", "--param",
                                       "is_slippery={True,False}", "--property", PROPERTY,
                                       "--budget", "12", "--repeat", "2", "--optimizer",
                                       "halton", "-o", out, "--json"]])
    return out, json.loads(text.getvalue())


def test_the_figures_per_optimizer_and_their_episodes(searched):
    out, data = searched
    assert [s["optimizer"] for s in data["optimizers"]] == ["halton", "random"]
    assert data["space"] == {"seed": [0, 9999], "is_slippery": [True, False]}
    run_ = read_run(out)
    assert len(run_.episodes) == 12 * 2 * 2
    for summary in data["optimizers"]:
        reps = [r for r in data["repetitions"] if r["optimizer"] == summary["optimizer"]]
        firsts = [r["first_violation"] for r in reps if r["first_violation"] is not None]
        assert summary["falsified"] == len(firsts) and summary["rate"] == len(firsts) / 2
        assert summary["violations"] == sum(ep.search.violated for ep in run_.episodes
                                            if ep.search.optimizer == summary["optimizer"])
    for ep in run_.episodes:  # its point: the seed it ran, the settings it had
        assert ep.seed == ep.search.parameters["seed"]
        assert ep.config == {"is_slippery": ep.search.parameters["is_slippery"]}
        reached = any(s.state["x"] == 3 and s.state["y"] == 3 for s in ep.steps)
        assert ep.search.violated == reached and ep.search.objective == (-1.0 if reached
                                                                           else 1.0)
    header = read_header(out)
    assert header.search.optimizer == "halton" and header.search.baseline == "random"
    assert header.search.property == PROPERTY and header.search.budget == 12


def test_every_episode_re_simulates_with_its_own_settings(searched, capsys, monkeypatch):
    from tracecheck.live import rollout

    out, _ = searched
    episodes = {ep.id: ep for ep in read_run(out).episodes}
    assert {ep.config["is_slippery"] for ep in episodes.values()} == {True, False}
    ran = []  # (episode, the environment's is_slippery) of each re-run
    original = rollout.run_episode

    def spy(session, index, **kw):
        ran.append((index, session.config["is_slippery"]))
        return original(session, index, **kw)
    monkeypatch.setattr(rollout, "run_episode", spy)
    code, text, _ = run(capsys, "replay", out, "--shield", "frozenlake", "--resimulate",
                        "--json")
    resim = json.loads(text)["resimulation"]
    assert code == 0 and resim["resimulated"] == len(ran) > 0 and resim["mismatches"] == 0
    assert {slippery for _, slippery in ran} == {True, False}
    assert all(slippery == episodes[i].config["is_slippery"] for i, slippery in ran)


def test_a_search_reproduces_from_its_seed(tmp_path):
    settings = FalsifySettings(RecordSettings(agent=str(AGENT), shield="none", episodes=1,
                                              env="frozenlake"),
                               ("seed=0..9999",), PROPERTY, budget=6, optimizer="tpe")
    points = []
    for name in ("a", "b"):
        falsify(settings, tmp_path / f"{name}.mcap")
        points.append([ep.search.parameters for ep in read_run(tmp_path / f"{name}.mcap")
                       .episodes])
    assert points[0] == points[1] and len(points[0]) == 12


def test_an_interrupted_search_keeps_every_finished_episode(tmp_path):
    settings = FalsifySettings(RecordSettings(agent=str(AGENT), shield="none", episodes=1,
                                              env="frozenlake"),
                               ("seed=0..9999",), None, budget=10, optimizer="random")
    seen = []

    def stop(ep):
        seen.append(ep)
        if len(seen) == 3:
            raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        falsify(settings, tmp_path / "cut.mcap", stop)
    assert [ep.search.evaluation for ep in read_run(tmp_path / "cut.mcap").episodes] == \
        [0, 1, 2]


@pytest.mark.parametrize("extra,message", [
    (["--param", "seed=5..1"], "from a lower to a higher"),
    (["--param", "density=0..1"],
     "the environment frozenlake has no setting nor reset parameter 'density'"),
    (["--param", "seed=0..9", "--property", "G({nowhere > 1})"], "--property"),
    (["--param", "seed=0..9", "--optimizer", "anneal"], "unknown optimizer 'anneal'"),
    ([], "give what the search varies"),
])
def test_bad_input_is_refused_before_any_episode(tmp_path, capsys, extra, message):
    out = tmp_path / "bad.mcap"
    code, _, err = run(capsys, *BASE, *extra, "-o", out)
    assert code == 2 and message in " ".join(err.split()) and not out.exists()


def test_the_library_refuses_bad_settings_too(tmp_path):
    settings = FalsifySettings(RecordSettings(agent=str(AGENT), shield="none", episodes=1,
                                              env="frozenlake"), ("seed=0..9",), budget=0)
    with pytest.raises(InputError, match="--budget must be at least 1"):
        falsify(settings, tmp_path / "x.mcap")


def test_the_violating_episodes_are_listed(searched, capsys):
    out, data = searched
    violating = [ep for ep in read_run(out).episodes if ep.search.violated]
    assert [v["episode"] for v in data["violations"]] == [ep.id for ep in violating]
    for v, ep in zip(data["violations"], violating):
        assert v["parameters"] == ep.search.parameters and v["optimizer"] == ep.search.optimizer


def test_the_recorded_crash_flag_is_a_property_s_variable(tmp_path, capsys):
    code, text, err = run(capsys, *BASE, "--param", "seed=0..99", "--property",
                          "G({crashed = FALSE})", "--budget", "3", "--no-baseline",
                          "-o", tmp_path / "c.mcap", "--json")
    assert code == 0, err
    assert json.loads(text)["logic"] == "LTL"


def test_seed_twice_is_refused(tmp_path, capsys):
    code, _, err = run(capsys, *BASE, "--seed", "3", "--param", "seed=0..9",
                       "-o", tmp_path / "s.mcap")
    assert code == 2 and "give one of the two" in err


def test_an_stl_robustness_of_zero_is_decided_by_the_formula_s_truth(tmp_path):
    from tests.search import corridor
    from tracecheck.checking.shield import load_shield
    from tracecheck.search.objective import load_objective

    shield_file = tmp_path / "open.mch"
    shield_file.write_text(corridor.OPEN)
    settings = RecordSettings(agent=corridor.agent_file(tmp_path), shield=str(shield_file),
                              episodes=1, env="tests.search.corridor:Corridor")
    from tracecheck.live.rollout import Session

    shield = load_shield(str(shield_file), actions=corridor.Corridor.actions)
    episode = Session(settings, shield=shield).episode(0)  # walks 0 … 5 (the pit)
    actions = corridor.Corridor.actions
    assert load_objective("G({pos <= 5})", shield.machine, actions).value(episode) == \
        (0.0, False)  # the largest pos is 5: holds, on the boundary
    assert load_objective("G({pos < 5})", shield.machine, actions).value(episode) == \
        (0.0, True)
    assert load_objective("G({pos <= 4})", shield.machine, actions).value(episode) == \
        (-1.0, True)


def test_a_property_without_a_machine_says_what_to_give(tmp_path, capsys):
    from tests.search import corridor

    code, _, err = run(capsys, "falsify", "--agent", corridor.agent_file(tmp_path), "--env",
                       "tests.search.corridor:Corridor", "--shield", "none", "--param",
                       "start=0..3", "--property", "G({pos < 5})", "-o", tmp_path / "x.mcap")
    assert code == 2 and "names no default_shield" in " ".join(err.split())


def test_the_objective_over_the_search_is_drawn(tmp_path, capsys):
    out, plot = tmp_path / "f.mcap", tmp_path / "objective.png"
    args = [*BASE, "--param", "seed=0..99", "--property", PROPERTY, "--budget", "4",
            "--repeat", "2", "--optimizer", "halton", "-o", out, "--plot", plot]
    code, text, err = run(capsys, *args)
    assert code == 0, err
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and f"-> {plot}" in text
    code, _, err = run(capsys, *args)  # both exist now: refused without --force
    assert code == 2 and "--force" in err
    code, _, err = run(capsys, *BASE, "--param", "seed=0..9", "-o", tmp_path / "g.mcap",
                       "--plot", tmp_path / "objective.pdf")
    assert code == 2 and "a plot is written as .png or .svg" in err
    assert not (tmp_path / "g.mcap").exists()


def test_workers_run_the_same_episodes_where_the_points_do_not_depend_on_values(tmp_path):
    """Random sampling asks the same points however many at a time: the same file with 1
    and 2 workers; a guided optimiser is asked a batch per round (its own points)."""
    runs = {}
    for workers in (1, 2):
        settings = FalsifySettings(
            RecordSettings(agent=str(AGENT), shield="frozenlake", episodes=1,
                           env="frozenlake", workers=workers),
            ("seed=0..9999", "is_slippery={True,False}"), PROPERTY, budget=7,
            optimizer="random", repeat=2, baseline=False)
        result = falsify(settings, tmp_path / f"w{workers}.mcap")
        runs[workers] = [(ep.id, ep.seed, ep.config, ep.search, [s.action for s in ep.steps])
                         for ep in read_run(tmp_path / f"w{workers}.mcap").episodes]
        assert len(runs[workers]) == 14 and result.summaries[0].evaluations == 14
    assert runs[1] == runs[2]
    settings = FalsifySettings(
        RecordSettings(agent=str(AGENT), shield="frozenlake", episodes=1, env="frozenlake",
                       workers=2), ("seed=0..9999",), PROPERTY, budget=5, optimizer="tpe",
        baseline=False)
    falsify(settings, tmp_path / "tpe.mcap")
    assert [ep.search.evaluation for ep in read_run(tmp_path / "tpe.mcap").episodes] == \
        [0, 1, 2, 3, 4]


def test_info_names_the_search(searched, capsys):
    out, _ = searched
    code, text, _ = run(capsys, "info", out, "--json")
    assert code == 0 and json.loads(text)["files"][0]["search"]["optimizer"] == "halton"
    code, text, _ = run(capsys, "info", out)
    assert "a search (falsify): halton beside random, 2 search(es) of 12 episode(s), " \
        f"property {PROPERTY}, guided by the shield's margins; space seed 0..9999, " \
        "is_slippery {True,False}" in " ".join(text.split())


def test_a_search_can_end_at_its_first_violation(tmp_path, capsys):
    """--stop-at-first (ARCH-COMP's protocol): each search's figures are those of the whole
    budget (Halton asks the same points), and no episode after its first violation runs."""
    runs = {}
    for stop in (False, True):
        out = tmp_path / f"stop{stop}.mcap"
        code, text, err = run(capsys, *BASE, "--param", "seed=0..9999", "--param",
                              "is_slippery={True,False}", "--property", PROPERTY, "--budget",
                              25, "--repeat", 3, "--optimizer", "halton", "-o", out, "--json",
                              *(["--stop-at-first"] if stop else []))
        assert code == 0, err
        runs[stop] = (json.loads(text), read_run(out).episodes)
    whole, stopped = runs[False][0], runs[True][0]
    assert [(s["falsified"], s["first_median"], s["first_min"], s["first_max"])
            for s in whole["optimizers"]] == \
        [(s["falsified"], s["first_median"], s["first_min"], s["first_max"])
         for s in stopped["optimizers"]]
    assert any(s["falsified"] for s in stopped["optimizers"])
    for rep in stopped["repetitions"]:
        episodes = [ep for ep in runs[True][1] if ep.search.optimizer == rep["optimizer"]
                    and ep.search.repetition == rep["repetition"]]
        assert len(episodes) == rep["evaluations"] == (rep["first_violation"] or 25)
    assert read_header(tmp_path / "stopTrue.mcap").search.stop_at_first is True
    code, text, _ = run(capsys, "info", tmp_path / "stopTrue.mcap")
    assert "each ended at its first violation" in " ".join(text.split())
