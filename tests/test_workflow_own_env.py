"""Issue 23's "Done when", end to end: a researcher's own environment (the adaptive cruise
control of tests/fixtures/acc_env) through every command of the workflow, each a
``tracecheck`` process — once installed only as an entry point (``--env acc``), once given as
``--env acc_cruise:ACC`` (the package importable, no entry point) — and the library on the
environment's float32 observations.

Each step asserts its exit code and what it must say, not only that it ran; the recordings
are shared between the steps of one test (small episode counts, the environment's own time
limit set with ``--env-config max_steps=…``).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import ACC_ENV, ACC_SPEC, ACC_V1, ACC_V2, ROOT

pytest.importorskip("stable_baselines3", reason="the agents extra is not installed")

#: a property file with an LTL property and the recorded crash flag
PROPERTIES = """
[metrics.gap]
expression = "Gap"
aggregate = "min"
description = "Smallest gap [m]"

[properties.SAFE]
predicate = "G({Gap > 0.0})"
kind = "ltl"
description = "the gap never closes"

[properties.UNCRASHED]
predicate = "crashed = FALSE"
kind = "invariant"
description = "never crashed"
"""


def tracecheck(*args, cwd: Path, env: dict, code: int = 0) -> tuple[str, str]:
    """``tracecheck ARGS`` as its own process; (stdout, stderr), the exit code checked."""
    return together({"": (args, code)}, cwd=cwd, env=env)[""]


def together(commands: dict, *, cwd: Path, env: dict) -> dict[str, tuple[str, str]]:
    """Independent ``tracecheck`` processes at once ({name: (args, exit code)}; each starts
    Python, most torch: the start-up is most of their time); {name: (stdout, stderr)}, each
    exit code checked. No traceback ever."""
    running = {name: (args, code, subprocess.Popen(
        [sys.executable, "-m", "tracecheck.cli", *map(str, args)], cwd=cwd, env=env,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
        for name, (args, code) in commands.items()}
    done = {}
    for name, (args, code, proc) in running.items():
        out, err = proc.communicate(timeout=180)
        assert proc.returncode == code, (args, out, err)
        assert "Traceback" not in err, err
        done[name] = (out, err)
    return done


def flat(text: str) -> str:
    """Text as one line (a terminal's line breaks are not the tests' business)."""
    return " ".join(text.split())


def processes(pythonpath: list[Path]) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(PYTHONPATH=os.pathsep.join(map(str, pythonpath)), COLUMNS="80",
               NO_COLOR="1")
    return env


# ------------------------------------------------------------------ reading replay's output

LINE = re.compile(r"^  episode (\d+) \(seed \d+\): (prevented|not prevented|new crash|"
                  r"did not reproduce)\b")
COUNTS = re.compile(r"re-simulated (\d+) infeasible episode\(s\) under \S+: (\d+) crash\(es\) "
                    r"prevented, (\d+) not prevented, (\d+) new crash\(es\), (\d+) without a "
                    r"crash either way, (\d+) did not reproduce")


#: the columns of replay's text table (render/text.py's SHORT_HEADERS, either crash column)
COLUMNS = ("file", "ep.", "steps", "first", "allowed", "instead", "blocked", "crash",
           "after block", "re-simulated", "other")


def episode_table(text: str) -> dict[int, dict[str, str]]:
    """The rows of replay's text table of one file, by episode: {column: cell}, the columns
    cut where the header's words start."""
    lines = text.splitlines()
    at = next(i for i, line in enumerate(lines) if line.lstrip().startswith("ep. "))
    header = lines[at] + " "
    names = [n for n in COLUMNS if f" {n} " in header]
    starts = [header.index(f" {n} ") + 1 for n in names]
    rows = {}
    for line in lines[at + 1:]:
        if not line.startswith(" ") or not line.strip() or not line[1].isdigit():
            break
        cells = [line[a:b].strip() for a, b in zip(starts, starts[1:] + [len(line)])]
        rows[int(cells[0])] = dict(zip(names, cells))
    return rows


def resimulation_agrees(text: str) -> dict[int, str]:
    """Replay --resimulate's text: the lines above the table and its `re-simulated` column
    say the same, episode by episode and in total; {episode: outcome}."""
    table = episode_table(text)
    outcomes = {ep: row["re-simulated"] for ep, row in table.items()}
    lines = {int(m.group(1)): m.group(2) for m in map(LINE.match, text.splitlines()) if m}
    assert lines, text
    for ep, said in lines.items():
        assert outcomes[ep] == said, (ep, said, outcomes[ep])
    total, prevented, not_prevented, new, neither, mismatch = map(
        int, COUNTS.search(flat(text)).groups())
    cells = list(outcomes.values())
    assert (cells.count("prevented"), cells.count("not prevented"), cells.count("new crash"),
            cells.count("no crash"), cells.count("did not reproduce")) == (
        prevented, not_prevented, new, neither, mismatch), (text, cells)
    assert prevented + not_prevented + new + neither + mismatch <= total
    return outcomes


def scenes(run: Path) -> int:
    """How many Foxglove scenes ``run`` holds (with at least one entity)."""
    from mcap.reader import make_reader

    with open(run, "rb") as f:
        return sum(1 for _, channel, message in make_reader(f).iter_messages()
                   if channel.topic == "/foxglove/scene" and message.data)


def viewer_data(page: str) -> dict:
    script = page[page.index("const DATA = ") + len("const DATA = "):]
    return json.loads(script[:script.index(";\nconst ACTIONS")])


def report_cells(page: str, run: str) -> list[str]:
    """The crash column of one run's table of episodes in the report."""
    part = page[page.index(f"<h3>{run}</h3>", page.index("Episodes that matter")):]
    part = part[:part.find("<h3>", 4)] if part.find("<h3>", 4) > 0 else part
    return re.findall(r"<td class='\w*'>([^<]*)</td><td class='pic'>", part)


# ------------------------------------------------------------------ the whole workflow

def test_the_workflow_on_an_environment_installed_as_an_entry_point(acc_env, acc_agent,
                                                                      tmp_path):
    (tmp_path / "props.toml").write_text(PROPERTIES)
    limit = ("--env-config", "max_steps=30")
    # what needs nothing but the environment: training (DQN and PPO, no --shield none
    # needed), recording with and without the shield (the always-ACCEL agent)
    first = together({
        "dqn": (("train", "--env", "acc", "--algorithm", "dqn", "--steps", "300", *limit, "-o",
                 "dqn.zip"), 0),
        "ppo": (("train", "--env", "acc", "--algorithm", "ppo", "--steps", "300", *limit, "-o",
                 "ppo.zip"), 0),
        "none": (("record", "--env", "acc", *limit, "--agent", acc_agent, "--shield", "none",
                  "-n", "6", "-o", "none.mcap"), 0),
        "v2": (("record", "--env", "acc", *limit, "--agent", acc_agent, "--shield", ACC_V2,
                "-n", "6", "-o", "v2.mcap"), 0),
    }, cwd=tmp_path, env=processes([ACC_ENV, ROOT]))
    for algorithm, name in (("dqn", "DQN"), ("ppo", "PPO")):
        assert f"trained {algorithm}.zip ({name} on acc, 300 steps, seed 0)" in \
            flat(first[algorithm][0])
        card = json.loads((tmp_path / f"{algorithm}.json").read_text())
        assert (card["environment"], card["steps"]) == ("acc", 300)
        assert (tmp_path / f"{algorithm}.curve.png").stat().st_size > 1000
    assert re.search(r"recorded 6 episode\(s\), \d+ step\(s\), 6 crash\(es\) with shield "
                     "none", flat(first["none"][0]))
    assert "6 episode(s), 180 step(s), 0 crash(es)" in flat(first["v2"][0])

    # everything else, on those files and agents
    second = together({
        "info": (("info", "none.mcap", "v2.mcap"), 0),
        "resim": (("replay", "none.mcap", "--shield", ACC_V2, "--resimulate", "--agent",
                   acc_agent, "--all"), 0),
        "replay": (("replay", "none.mcap", "--shield", ACC_V2), 0),
        "diff": (("diff", "none.mcap", "v2.mcap", "--shield", ACC_V2, "--against", ACC_V1), 0),
        "symbolic": (("diff", "--symbolic", "--shield", ACC_V2, "--against", ACC_V1), 1),
        "stats": (("stats", "none.mcap", "v2.mcap", "--json"), 0),
        "props": (("stats", "none.mcap", "v2.mcap", "--properties", "props.toml", "--json"), 0),
        "simulate": (("simulate", "--env", "acc", "--env-config", "max_steps=20", "--agent",
                      "ppo.zip", "--shield", ACC_V2, "-n", "40", "--until-ci-width", "0.5",
                      "--properties", "props.toml", "-o", "sim.mcap"), 0),
        "model": (("check-model", ACC_V1), 0),
        "render": (("render", "none.mcap", "--episode", "1", "--shield", ACC_V2, "-o",
                    "ep.html"), 0),
        "report": (("report", "none.mcap", "v2.mcap", "--shield", ACC_V2, "--resimulate",
                    "--agent", acc_agent, "-o", "report.html"), 0),
    }, cwd=tmp_path, env=processes([ACC_ENV, ROOT]))
    assert "shields: acc_v2, none" in second["info"][0]

    # replay --resimulate: every crash prevented, and the table says so episode by episode
    out, err = second["resim"]
    assert err == ""
    assert resimulation_agrees(out) == {ep: "prevented" for ep in range(6)}
    assert "6 crash(es) prevented, 0 not prevented, 0 new crash(es)" in flat(out)
    assert max(map(len, out.splitlines())) <= 80
    out, _ = second["replay"]  # without re-simulation: never "prevented"
    assert "prevented" not in out
    assert {row["after block"] for row in episode_table(out).values()} == {"yes"}

    # diff of two versions, on the recordings and over every state
    out, _ = second["diff"]
    assert out.startswith("Shield acc_v2 (") and " against acc_v1 (" in flat(out)
    assert "[bold]" not in out and "newly blocked 3" in flat(out)
    out, _ = second["symbolic"]
    assert out.startswith("KEEP: equivalent\nACCEL: counterexample")
    assert f"{ACC_V2} and {ACC_V1} decide ACCEL differently" in flat(out)
    assert f"{ACC_V2} enables it, {ACC_V1} blocks it" in flat(out)  # BRAKE: v1 deadlocks
    assert "ACCShield" not in out

    # stats: the generic set plus the adapter's own; then a property file with LTL
    result = json.loads(second["stats"][0])
    assert result["properties_set"] == "generic+acc"
    none, v2 = (r["properties"] for r in result["runs"])
    assert (none["CRASH"]["ratio"], v2["CRASH"]["ratio"]) == (1.0, 0.0)
    assert (none["NO_CRASH"]["ratio"], v2["NO_CRASH"]["ratio"]) == (0.0, 1.0)  # acc's LTL
    assert (none["TIME_LIMIT"]["ratio"], v2["TIME_LIMIT"]["ratio"]) == (0.0, 1.0)
    assert result["runs"][1]["metrics"]["episode_length"]["mean"] == 30
    none, v2 = (r["properties"] for r in json.loads(second["props"][0])["runs"])
    assert (none["SAFE"]["ratio"], v2["SAFE"]["ratio"]) == (0.0, 1.0)
    assert (none["UNCRASHED"]["ratio"], v2["UNCRASHED"]["ratio"]) == (0.0, 1.0)

    # simulate until the intervals are narrow, an LTL property among them
    sequential_stop(*second["simulate"], tmp_path / "sim.mcap", limit=40)

    # check-model: every /*@desc*/
    out, _ = second["model"]
    assert "distance to the lead car [m]" in out
    assert "operation BRAKE: guard EgoSpeed > 0.0" in out

    # render: the episode's variables over time, blocked steps marked, no highway caption
    page = (tmp_path / "ep.html").read_text()
    data = viewer_data(page)
    assert {s["name"] for s in data["series"]} >= {"Gap", "EgoSpeed", "LeadSpeed"}
    assert data["blocked"] and data["crash_step"] is not None and data["environment"] == "acc"
    assert "5 m × 2 m" not in page and "vehicles are drawn" not in page
    # no --env: the installed environment the run names draws it (its scene hook)
    assert data["scene"]["caption"] == "The ego car (blue, red once crashed) behind the lead car."

    # report: the runs side by side, the headline, the table that agrees with it
    page = (tmp_path / "report.html").read_text()
    assert "Re-simulation: shield acc_v2 would have prevented 6 of 6 crashes; 0 new." in page
    assert report_cells(page, "none.mcap") == ["prevented"] * 6
    assert "No episode crashed or had a blocked step." in page  # v2.mcap
    assert "Re-simulation: nothing to re-run, acc_v2 would have blocked no step." in page
    assert "The share of episodes that satisfy CRASH" in page and "McNemar" in page


def sequential_stop(out: str, err: str, path: Path, *, limit: int) -> None:
    """``simulate --until-ci-width 0.5``: it looked every 10 episodes, and stopped either
    at the limit or early with every interval narrower than asked."""
    from tracecheck.episodes.columns import read_columns

    looks = int(re.search(r"(\d+) look\(s\)", err).group(1))
    assert len(read_columns(path).episode_ids) == min(limit, 10 * looks)
    assert "SAFE" in out and "UNCRASHED" in out
    if "stopped early" in err:
        widths = [float(w) for w in re.findall(r"(?:SAFE|UNCRASHED) ([\d.]+)", err)]
        assert len(widths) == 2 and max(widths) < 0.5


def test_the_workflow_with_the_adapter_given_as_a_module_path(acc_agent, tmp_path):
    """The package importable but not installed (no entry point): ``--env acc_cruise:ACC``
    wherever the environment matters; without it, what needs it says how to give it, and
    stats falls back to generic statistics with a note."""
    shutil.copytree(ACC_ENV / "acc_cruise", tmp_path / "mod" / "acc_cruise")
    env = processes([tmp_path / "mod", ROOT])
    (tmp_path / "props.toml").write_text(PROPERTIES)
    shield = tmp_path / "mod" / "acc_cruise" / "acc_v2.mch"
    given = ("--env", ACC_SPEC)
    limit = ("--env-config", "max_steps=20")
    first = together({
        "unknown": (("record", "--env", "acc", "--agent", acc_agent, "--shield", "none", "-n",
                     "1", "-o", "x.mcap"), 2),
        "train": (("train", *given, "--algorithm", "dqn", "--steps", "256", *limit, "-o",
                   "dqn.zip"), 0),
        "none": (("record", *given, *limit, "--agent", acc_agent, "--shield", "none", "-n", "4",
                  "-o", "none.mcap"), 0),
        "v2": (("record", *given, *limit, "--agent", acc_agent, "--shield", shield, "-n", "4",
                "-o", "v2.mcap"), 0),
    }, cwd=tmp_path, env=env)
    err = flat(first["unknown"][1])
    assert "unknown environment 'acc'" in err and "--env package.module:Class" in err
    assert "(DQN on acc, 256 steps" in flat(first["train"][0])
    # the adapter given draws Foxglove's scene at every step: its name in the header alone
    # would not find it (no entry point), nor would a later command import it
    assert scenes(tmp_path / "v2.mcap") == 4 * 21

    resim = ("replay", "none.mcap", "--shield", shield, "--resimulate", "--agent", acc_agent)
    second = together({
        "without": (resim, 2),
        "resim": ((*resim, *given), 0),
        "generic": (("stats", "none.mcap", "v2.mcap", "--json"), 0),
        "props": (("stats", "none.mcap", "v2.mcap", *given, "--properties", "props.toml",
                   "--json"), 0),
        "simulate": (("simulate", *given, *limit, "--agent", "dqn.zip", "--shield", shield,
                      "-n", "30", "--until-ci-width", "0.5", "--properties", "props.toml",
                      "-o", "sim.mcap"), 0),
        "render": (("render", "none.mcap", "--episode", "0", "--shield", shield, *given, "-o",
                    "ep.html"), 0),
        "report": (("report", "none.mcap", "v2.mcap", "--shield", shield, *given,
                    "--resimulate", "--agent", acc_agent, "-o", "report.html"), 0),
        "export": (("export", "foxglove", "none.mcap", *given, "-o", "fox.mcap"), 0),
        "export_bare": (("export", "foxglove", "none.mcap", "-o", "bare.mcap"), 0),
    }, cwd=tmp_path, env=env)
    err = flat(second["without"][1])
    assert "unknown environment 'acc'" in err and "--env package.module:Class" in err
    assert resimulation_agrees(second["resim"][0]) == {ep: "prevented" for ep in range(4)}
    out, err = second["generic"]
    assert json.loads(out)["properties_set"] == "generic"
    assert "the environment acc of these runs is not installed here" in flat(err)
    none, v2 = (r["properties"] for r in json.loads(second["props"][0])["runs"])
    assert (none["SAFE"]["ratio"], v2["SAFE"]["ratio"]) == (0.0, 1.0)
    sequential_stop(*second["simulate"], tmp_path / "sim.mcap", limit=30)
    assert scenes(tmp_path / "sim.mcap") > 0
    data = viewer_data((tmp_path / "ep.html").read_text())
    assert {s["name"] for s in data["series"]} >= {"Gap", "EgoSpeed"} and data["blocked"]
    # the adapter given: its own scene() hook draws the two cars
    assert data["scene"]["caption"] == ("The ego car (blue, red once crashed) behind the lead "
                                        "car.")
    page = (tmp_path / "report.html").read_text()
    assert "would have prevented 4 of 4 crashes; 0 new" in page
    assert report_cells(page, "none.mcap") == ["prevented"] * 4
    # export foxglove draws the scene by the adapter given; without it, says it has none
    assert scenes(tmp_path / "fox.mcap") == scenes(tmp_path / "none.mcap") > 0
    assert scenes(tmp_path / "bare.mcap") == 0
    assert "the environment acc of none.mcap is not installed here: the copy has no 3D " \
           "scene (give its adapter with --env package.module:Class)" in \
        flat(second["export_bare"][1])


# ------------------------------------------------------------------ the library

def test_the_shield_on_float32_observations(acc_env):
    """Bug 10: Machine.enabled takes a Gymnasium observation's float32 values, each the
    float it is (0.1 as float32 is 0.10000000149011612: above 0.1); ShieldWrapper finds
    the adapter from the env's id and decides on the same values."""
    import gymnasium as gym

    import acc_cruise
    from tracecheck.b.machine import load_machine_text
    from tracecheck.checking.shield import load_shield
    from tracecheck.live.wrapper import ShieldWrapper

    machine = load_shield(str(ACC_V2)).machine
    state = {"Gap": np.float32(30.0), "EgoSpeed": np.float32(20.0),
             "LeadSpeed": np.float32(20.0)}
    assert machine.enabled(state) == {"KEEP", "BRAKE"}
    tiny = load_machine_text("MACHINE T\nVARIABLES g\nINVARIANT g : REAL\nINITIALISATION "
                             "g := 0.0\nOPERATIONS\n  Up = SELECT g > 0.1 THEN skip END\nEND\n")
    assert tiny.enabled({"g": np.float32(0.1)}) == {"Up"}
    assert tiny.enabled({"g": np.float64(0.1)}) == set()

    gym.register(id="ACCCruise-v0", entry_point=acc_cruise.CruiseEnv)
    try:
        env = ShieldWrapper(gym.make("ACCCruise-v0", max_steps=15), load_shield(str(ACC_V2)))
        obs, info = env.reset(seed=3)
        rng = np.random.default_rng(0)
        for _ in range(15):
            assert obs.dtype == np.float32
            raw = dict(zip(("Gap", "EgoSpeed", "LeadSpeed"), obs))
            assert set(info["shield"]["allowed"]) == machine.enabled(raw)
            assert info["b_state"]["Gap"] == float(obs[0])
            obs, _, terminated, truncated, info = env.step(int(rng.integers(3)))
            if terminated or truncated:
                break
    finally:
        gym.registry.pop("ACCCruise-v0", None)
