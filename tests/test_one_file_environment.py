"""Issue 41's "Done when": an environment is one module, its shield file and one entry-point
line. A corridor written in a temporary package (one module, one ``.mch`` beside it, a
dist-info whose ``entry_points.txt`` has one line) is seen in ``tracecheck envs``, in every
``--env``/``--shield``/``--properties`` help, and works in record, replay, stats, render and
report — by its own names (``--shield corridor``, its property set, its scene) — each step a
``tracecheck`` process as a user runs it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import ROOT

pytest.importorskip("gymnasium")

MODULE = '''
"""A corridor of seven cells: walk right to the exit, a pit at cell 0."""

from pathlib import Path

import gymnasium as gym
from gymnasium import spaces

from tracecheck.live.adapter import EnvAdapter
from tracecheck.live.scene import Box, Circle, Scene

PROPERTIES = """
[properties.EXIT]
predicate = "pos = 6"
kind = "eventually"
description = "reached the exit"
"""


class CorridorEnv(gym.Env):
    observation_space = spaces.Discrete(7)
    action_space = spaces.Discrete(2)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.pos = 2
        return self.pos, {}

    def step(self, action):
        self.pos += 1 if action == 1 else -1
        crashed = self.pos == 0
        return self.pos, (1.0 if self.pos == 6 else 0.0), crashed or self.pos == 6, False, \\
            {"crashed": crashed}


class Corridor(EnvAdapter):
    name = "corridor"
    description = "a corridor of seven cells with a pit at one end"
    env_id = "Corridor-v0"
    actions = ("Left", "Right")
    variables = ("pos",)
    model_name = "Corridor"
    default_shield = "corridor"
    shields = {"corridor": Path(__file__).with_name("corridor.mch")}
    property_sets = {"corridor": PROPERTIES}
    properties = "corridor"
    horizon = 12

    def make_env(self, config, render_mode=None):
        return CorridorEnv()

    def state(self, obs, info, reward, env, initial):
        return {"pos": int(obs)}

    def scene(self, step):
        cells = tuple(Box(x + 0.5, 0.5, 1.0, 1.0, fill=(0.2, 0.2, 0.2, 1.0) if x == 0
                          else (0.9, 0.9, 0.9, 1.0), label=f"cell {x}", group="cells")
                      for x in range(7))
        me = Circle(step.state["pos"] + 0.5, 0.5, 0.3, fill=(0.9, 0.1, 0.1, 1.0),
                    label="walker", group="walker")
        return Scene(cells + (me,), (0.0, 0.0, 7.0, 1.0), None, "the corridor from above")
'''

SHIELD = """MACHINE Corridor
VARIABLES pos
INVARIANT pos : 0..6
INITIALISATION pos := 2
OPERATIONS
  Left = SELECT pos > 1 THEN pos := pos - 1 END;
  Right = SELECT pos < 6 THEN pos := pos + 1 END
END
"""


@pytest.fixture(scope="module")
def corridor(tmp_path_factory) -> tuple[Path, dict]:
    """The package (one module, its shield, one entry-point line) and a process environment
    in which it is installed; a Q-table agent that always walks left."""
    root = tmp_path_factory.mktemp("corridor")
    package = root / "corridor_env"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "corridor.py").write_text(MODULE)
    (package / "corridor.mch").write_text(SHIELD)
    info = root / "corridor_env-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: corridor-env\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[tracecheck.environments]\ncorridor = corridor_env.corridor:Corridor\n")
    table = np.zeros((7, 2))
    table[:, 0] = 1.0  # always Left
    np.save(root / "left.npy", table)
    env = dict(os.environ, COLUMNS="200", PYTHONPATH=os.pathsep.join(
        [str(root), str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    return root, env


def run(corridor, *args, code: int = 0) -> str:
    root, env = corridor
    done = subprocess.run([sys.executable, "-m", "tracecheck.cli", *map(str, args)], cwd=root,
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == code, (args, done.stdout, done.stderr)
    assert "Traceback" not in done.stderr
    return done.stdout + done.stderr


def test_it_is_listed_with_what_it_brings(corridor):
    rows = {r["name"]: r for r in json.loads(run(corridor, "envs", "--json"))}
    row = rows["corridor"]
    assert row["description"] == "a corridor of seven cells with a pit at one end"
    assert row["shields"] == ["corridor"] and row["property_sets"] == ["corridor"]
    assert row["actions"] == ["Left", "Right"] and row["problem"] is None


@pytest.mark.parametrize("command,option", [
    ("record", "--env"), ("record", "--shield"), ("simulate", "--env"),
    ("simulate", "--shield"), ("simulate", "--properties"), ("stats", "--properties"),
    ("replay", "--shield"), ("diff", "--shield"), ("check-model", "model"),
    ("train", "--env"), ("report", "--properties"), ("render", "--shield")])
def test_every_help_names_it(corridor, command, option):
    text = " ".join(run(corridor, command, "--help").split())
    assert option in text
    assert "corridor" in text, f"{command} --help does not name the corridor"


def test_record_replay_stats_render_report(corridor):
    root, _ = corridor
    out = run(corridor, "record", "--env", "corridor", "--agent", "left.npy", "--shield",
              "none", "--episodes", "3", "-o", "none.mcap")
    assert "crash" in out
    out = run(corridor, "record", "--env", "corridor", "--agent", "left.npy", "--shield",
              "corridor", "--episodes", "3", "-o", "shielded.mcap")
    # the crashes the corridor's own shield would have prevented, by its name
    replay = json.loads(run(corridor, "replay", "none.mcap", "--shield", "corridor", "--json"))
    assert replay["episodes"] == 3 and replay["crashes_after_infeasible"] == 3
    # with workers (which also draw the scene for Foxglove's channels): the same episodes
    run(corridor, "record", "--env", "corridor", "--agent", "left.npy", "--shield", "none",
        "--episodes", "3", "--workers", "2", "-o", "two.mcap")
    again = json.loads(run(corridor, "replay", "two.mcap", "--shield", "corridor", "--json",
                           "--workers", "2"))
    timing = ("files", "elapsed_s", "steps_per_s", "per_episode")
    assert {k: v for k, v in again.items() if k not in timing} == {
        k: v for k, v in replay.items() if k not in timing}
    assert [{**e, "file": None} for e in again["per_episode"]] == [
        {**e, "file": None} for e in replay["per_episode"]]
    from mcap.reader import make_reader

    with open(root / "two.mcap", "rb") as f:  # the corridor's own scene, drawn by a worker
        scenes = [m.data for _, c, m in make_reader(f).iter_messages()
                  if c.topic == "/foxglove/scene"]
    assert scenes and any(b"walker" in data for data in scenes)
    # the environment's own property set is taken without --properties
    stats = run(corridor, "stats", "none.mcap", "shielded.mcap", "--format", "md")
    assert "EXIT" in stats and "reached the exit" in stats
    assert "EXIT" in run(corridor, "stats", "none.mcap", "--properties", "corridor")
    run(corridor, "check-model", "corridor")
    # drawn by its own scene hook, not by another environment's picture
    run(corridor, "render", "none.mcap", "-e", "0", "-o", "view.html")
    view = (root / "view.html").read_text()
    assert "the corridor from above" in view and "walker" in view
    run(corridor, "report", "none.mcap", "--shield", "corridor", "-o", "report.html")
    report = (root / "report.html").read_text()
    assert "walker" in report and "cell 0" in report  # the scene's shapes, by their labels


def test_no_command_falls_back_to_another_environment(corridor):
    """Without --env, record takes the environment the agent's model card names, and says
    so; an agent without a card is refused with what to give."""
    root, _ = corridor
    out = run(corridor, "record", "--agent", "left.npy", "--episodes", "1", "-o", "x.mcap",
              code=2)
    assert "no --env given" in out and "corridor" in out
    (root / "left.json").write_text(json.dumps({"agent": "left.npy", "environment": "corridor"}))
    try:
        out = run(corridor, "record", "--agent", "left.npy", "--episodes", "1", "-o", "y.mcap")
        assert "environment corridor, as the model card" in out
    finally:
        (root / "left.json").unlink()


def test_a_run_of_an_environment_not_installed_is_drawn_without_a_picture(corridor, tmp_path):
    """The corridor's run, read where the corridor is not installed: no other
    environment's picture, the time series instead."""
    root, env = corridor
    if not (root / "none.mcap").exists():
        run(corridor, "record", "--env", "corridor", "--agent", "left.npy", "--shield", "none",
            "--episodes", "3", "-o", "none.mcap")
    bare = dict(env, PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-m", "tracecheck.cli", "render",
                           str(root / "none.mcap"), "-e", "0", "-o", str(tmp_path / "v.html")],
                          env=bare, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    page = (tmp_path / "v.html").read_text()
    assert "the corridor from above" not in page and "holes or cliffs" not in page


def test_a_grid_of_an_environment_not_installed_gets_no_other_grid_picture(tmp_path):
    """A MiniGrid-like run (x, y and a map keyed by (x, y), as the grid worlds' states are)
    of an environment not installed here: no grid world's picture and caption, the time
    series instead (it was drawn as FrozenLake, 'dark cells are holes or cliffs')."""
    from tracecheck.b.values import Elem, FuncValue
    from tracecheck.episodes import EpisodeWriter, new_header
    from tracecheck.episodes.model import Episode, StepRecord, make_end

    field = FuncValue({(x, y): Elem("LAVA" if x == 2 else "FLOOR")
                       for x in range(4) for y in range(3)})
    steps = tuple(StepRecord(step=k, time=float(k), action=None if k == 0 else "forward",
                             state={"x": k, "y": 1, "field": field}, reward=0.0,
                             crashed=k == 2) for k in range(3))
    path = tmp_path / "lava.mcap"
    with EpisodeWriter(path, new_header("recorded", environment="minigrid-lava",
                                        variables=["x", "y", "field"],
                                        actions=["forward"])) as out:
        out.write(Episode(id=0, steps=steps, end=make_end(steps), seed=0))
    done = subprocess.run([sys.executable, "-m", "tracecheck.cli", "render", str(path), "-e",
                           "0", "-o", str(tmp_path / "v.html")], capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=300)
    assert done.returncode == 0, done.stderr
    page = (tmp_path / "v.html").read_text()
    assert "holes or cliffs" not in page and "The grid world from above" not in page
    assert '"scene": null' in page or '"scene":null' in page


def test_what_a_new_user_got_wrong_is_said_plainly(corridor, tmp_path):
    """A misspelled property set lists the sets; render with another environment's --env is
    refused, as stats and report refuse it; an option that does not apply reads well."""
    root, _ = corridor
    if not (root / "none.mcap").exists():
        run(corridor, "record", "--env", "corridor", "--agent", "left.npy", "--shield", "none",
            "--episodes", "3", "-o", "none.mcap")
    out = run(corridor, "stats", "none.mcap", "--properties", "coridor", code=2)
    assert "unknown property set 'coridor': give one of generic," in out and "corridor" in out
    out = run(corridor, "render", "none.mcap", "-e", "0", "--env", "frozenlake", "-o",
              tmp_path / "m.html", code=2)
    assert "the runs come from the environment corridor, but --env gives" in " ".join(out.split())
    out = run(corridor, "record", "--env", "corridor", "--agent", "left.npy", "--cwd", ".",
              "-n", "1", "-o", tmp_path / "c.mcap", code=2)
    assert "--cwd only applies to --external" in " ".join(out.split())
    help_text = " ".join(run(corridor, "replay", "--help").split())
    assert "--env" in help_text and "corridor" in help_text
