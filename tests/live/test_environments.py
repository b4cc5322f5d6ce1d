"""Any Gymnasium environment under any B shield: adapters, recording, replay, re-simulation,
statistics and pictures for frozenlake, cliffwalking and a user's own toy environment."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.helpers import ROOT
from tracecheck.cli import main
from tracecheck.episodes.reader import read_episodes, read_header, read_run
from tracecheck.live.adapter import get_adapter, load_adapter
from tracecheck.errors import InputError

from tests.live.toy import SHIELD, left_leaning_table

TOY = "tests.live.toy:Corridor"
MODELS = ROOT.parent / "shared" / "data" / "paper-models"
AGENTS = ROOT / "models" / "agents"


def run(capsys, *args):
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    captured = capsys.readouterr()
    return info.value.code or 0, captured.out, captured.err


@pytest.fixture
def toy(tmp_path):
    shield = tmp_path / "corridor.mch"
    shield.write_text(SHIELD)
    agent = tmp_path / "left.npy"
    np.save(agent, left_leaning_table())
    return shield, agent


def test_envs_lists_the_builtin_adapters(capsys):
    code, out, _ = run(capsys, "envs", "--json")
    rows = {r["name"]: r for r in json.loads(out)}
    assert code == 0 and {"highway", "frozenlake", "cliffwalking"} <= set(rows)
    assert rows["frozenlake"]["actions"] == ["Move_Left", "Move_Down", "Move_Right", "Move_Up"]
    assert rows["cliffwalking"]["default_shield"] == "cliffwalking"
    assert rows["highway"]["variables"][0] == "Crash" and rows["highway"]["installed"]


def test_a_users_own_adapter_records_and_replays(toy, tmp_path, capsys):
    shield, agent = toy
    out = tmp_path / "toy.mcap"
    code, _, err = run(capsys, "record", "--env", TOY, "--agent", agent, "--shield", "none",
                       "-n", 6, "--seed", 0, "-o", out)
    assert code == 0, err
    header = read_header(out)
    assert header.environment == "corridor" and header.horizon == 20
    episodes = list(read_episodes(out))
    # the left-leaning agent walks into the pit every time
    assert all(e.end.crashed and e.steps[-1].state["pos"] == 0 for e in episodes)
    code, out_text, err = run(capsys, "replay", out, "--shield", shield, "--json")
    report = json.loads(out_text)
    assert code == 0 and report["crashes"] == 6 and report["crashes_after_infeasible"] == 6
    # under the shield it never falls
    shielded = tmp_path / "toy_shielded.mcap"
    code, _, err = run(capsys, "record", "--env", TOY, "--agent", agent, "--shield", shield,
                       "-n", 6, "--seed", 0, "-o", shielded)
    assert code == 0, err
    assert not any(e.end.crashed for e in read_episodes(shielded))


def test_an_adapter_named_in_a_file_is_never_imported(toy, tmp_path, capsys):
    shield, agent = toy
    out = tmp_path / "toy.mcap"
    run(capsys, "record", "--env", TOY, "--agent", agent, "--shield", "none", "-n", 2,
        "-o", out)
    code, _, err = run(capsys, "replay", out, "--shield", shield, "--resimulate",
                       "--agent", agent)
    assert code == 2 and "unknown environment 'corridor'" in err
    code, out_text, err = run(capsys, "replay", out, "--shield", shield, "--resimulate",
                              "--agent", agent, "--env", TOY, "--json")
    resim = json.loads(out_text)["resimulation"]
    assert code == 0 and resim["crashes_prevented"] == 2 and resim["mismatches"] == 0


@pytest.fixture(scope="module")
def frozen(tmp_path_factory):
    """A slippery frozenlake run of the bundled agent, unshielded, 20 episodes."""
    folder = tmp_path_factory.mktemp("frozen")
    out = folder / "fl.mcap"
    with pytest.raises(SystemExit) as stop:
        main(["record", "--env", "frozenlake", "--env-config", "is_slippery=true", "--agent",
              str(AGENTS / "frozenlake.npy"), "--shield", "none", "-n", "20", "--seed", "0",
              "-o", str(out)])
    assert stop.value.code in (0, None)
    return out


def test_frozenlake_states_follow_the_authors_conventions(frozen):
    (episode, *_) = read_episodes(frozen)
    first = episode.steps[0].state
    assert (first["x"], first["y"], first["goal_x"], first["goal_y"]) == (0, 0, 7, 7)
    field = first["field"].map
    assert len(field) == 64 and field[(3, 2)] == "HOLE" and field[(2, 3)] == "ICE"
    header = read_header(frozen)
    assert header.environment_config == {"map_name": "8x8", "is_slippery": True}
    assert header.actions == ["Move_Left", "Move_Down", "Move_Right", "Move_Up"]


def test_frozenlake_replay_resimulate_stats_render(frozen, tmp_path, capsys):
    code, out, err = run(capsys, "replay", frozen, "--shield", "frozenlake", "--resimulate",
                         "--json")
    report = json.loads(out)
    assert code == 0, err
    assert report["infeasible_steps"] > 0
    resim = report["resimulation"]
    assert resim["resimulated"] == report["infeasible_episodes"] and resim["mismatches"] == 0
    code, out, _ = run(capsys, "stats", frozen, "--json")
    stats = json.loads(out)
    assert code == 0 and stats["properties_set"] == "generic+frozenlake"
    assert set(stats["runs"][0]["properties"]) == {"CRASH", "TIME_LIMIT", "GOAL", "HOLE"}
    code, out, _ = run(capsys, "diff", frozen, "--shield", "frozenlake", "--against", "none")
    assert code == 0 and "newly blocked" in out
    page = tmp_path / "ep.html"
    code, _, err = run(capsys, "render", frozen, "-e", 0, "--shield", "frozenlake", "-o", page)
    assert code == 0, err
    text = page.read_text()
    data = json.loads(text.split("const DATA = ", 1)[1].split(";\nconst ACTIONS", 1)[0])
    from tracecheck.live.envs.grid_scene import GRID_CAPTION

    assert data["scene"]["caption"] == GRID_CAPTION
    tiles = {s["label"] for s in data["scene"]["shapes"] if s["kind"] == "box"}
    assert len(tiles - {"goal"}) == 64  # 8 x 8
    code, _, err = run(capsys, "report", frozen, "--shield", "frozenlake",
                       "-o", tmp_path / "r" / "report.html")
    assert code == 0, err


def test_export_import_replay_round_trip(frozen, tmp_path, capsys):
    traces = tmp_path / "simb"
    code, _, err = run(capsys, "export", "simb", frozen, "-o", traces)
    assert code == 2 and "a SimB timed trace has no place for the crash" in err
    assert "--lossy exports the states and actions anyway" in err and not traces.exists()
    code, _, err = run(capsys, "export", "simb", frozen, "-o", traces, "--lossy")
    assert code == 0 and "note: a SimB timed trace has no place for the crash" in err
    back = tmp_path / "back.mcap"
    assert run(capsys, "import", "simb", traces, "--model", "frozenlake", "-o", back)[0] == 0
    _, a, _ = run(capsys, "replay", frozen, "--shield", "frozenlake", "--json")
    _, b, _ = run(capsys, "replay", back, "--shield", "frozenlake", "--json")
    assert json.loads(a)["infeasible_steps"] == json.loads(b)["infeasible_steps"]


def test_one_and_two_workers_give_identical_files(tmp_path, capsys):
    files = []
    for workers in (1, 2):
        out = tmp_path / f"w{workers}.mcap"
        code, _, err = run(capsys, "record", "--env", "cliffwalking", "--env-config",
                           "is_slippery=true", "--agent", AGENTS / "cliffwalking.npy",
                           "--shield", "cliffwalking", "-n", 6, "--seed", 3, "-w", workers,
                           "-o", out)
        assert code == 0, err
        files.append([(e.seed, [(s.action, s.state, s.reward, s.crashed) for s in e.steps])
                      for e in read_episodes(out)])
    assert files[0] == files[1]


@pytest.mark.skipif(not MODELS.is_dir(), reason="the authors' machines are not in ../shared")
@pytest.mark.parametrize("env,machine", [("frozenlake", "FrozenLake/FrozenLake.mch"),
                                         ("cliffwalking", "CliffWalking/CliffWalking.mch")])
def test_the_authors_machines_replay_our_recordings(env, machine, tmp_path, capsys):
    out = tmp_path / f"{env}.mcap"
    code, _, err = run(capsys, "record", "--env", env, "--env-config", "is_slippery=true",
                       "--agent", AGENTS / f"{env}.npy", "--shield", "none", "-n", 5,
                       "-o", out)
    assert code == 0, err
    _, ours, _ = run(capsys, "replay", out, "--shield", env, "--json")
    code, theirs, err = run(capsys, "replay", out, "--shield", MODELS / machine, "--json")
    assert code == 0, err
    theirs, ours = json.loads(theirs), json.loads(ours)
    assert theirs["invariant_violations"] == 0
    # ours and theirs forbid the same moves: into holes / off the cliff, off the grid
    assert theirs["infeasible_steps"] == ours["infeasible_steps"]


def test_bad_input_stops_before_any_episode(toy, tmp_path, capsys):
    shield, agent = toy
    out = tmp_path / "x.mcap"
    cases = [
        (["--env", "frozenlake", "--agent", AGENTS / "base.zip", "--shield", "none"],
         "the agent has action space Discrete(5); frozenlake has 4 discrete actions"),
        (["--env", "cliffwalking", "--agent", AGENTS / "frozenlake.npy", "--shield", "none"],
         "the Q-table has 64 rows; the environment has 48 observations"),
        (["--env", "frozenlake", "--agent", AGENTS / "frozenlake.npy", "--shield", "paper"],
         "PaperShield lacks Move_Left, Move_Down, Move_Right, Move_Up"),
        (["--env", TOY, "--agent", agent, "--shield", "frozenlake"],
         "FrozenLakeShield lacks Left, Right"),
        (["--env", "nosuch", "--agent", agent, "--shield", "none"],
         "unknown environment 'nosuch'"),
    ]
    for args, message in cases:
        code, _, err = run(capsys, "record", *args, "-n", 1, "-o", out)
        assert code == 2 and message in " ".join(err.split()), (args, err)
        assert not out.exists() or out.stat().st_size == 0


def test_a_shield_that_does_not_fit_the_environments_states(tmp_path, capsys):
    extra = tmp_path / "extra.mch"
    extra.write_text(SHIELD.replace("VARIABLES pos", "VARIABLES pos, speed").replace(
        "INVARIANT pos : 0..5", "INVARIANT pos : 0..5 & speed : INTEGER").replace(
        "pos > 1", "pos > 1 & speed < 3").replace("pos := 2", "pos, speed := 2, 0"))
    fewer = tmp_path / "fewer.mch"
    fewer.write_text(SHIELD.replace("VARIABLES pos", "VARIABLES place").replace(
        "pos", "place"))
    agent = tmp_path / "left.npy"
    np.save(agent, left_leaning_table())
    code, _, err = run(capsys, "record", "--env", TOY, "--agent", agent, "--shield", extra,
                       "-n", 1, "-o", tmp_path / "a.mcap")
    line = next(k for k, x in enumerate(extra.read_text().splitlines(), 1) if "speed < 3" in x)
    assert code == 2 and f"{extra}:{line}:" in err and "the guard of Left in extra reads " \
                         "speed, which the environment corridor never gives (it gives pos): " \
                         "replay could not judge a recording's states by it" in \
                         " ".join(err.split())
    assert "hint: give speed in the adapter's variables and its state(), or leave it out " \
           "of the shield" in " ".join(err.split())
    # the invariant alone reads it: replay would refuse the recording (a new user's
    # thermostat was recorded under the shield its replay then refused)
    unread = tmp_path / "unread.mch"
    unread.write_text(SHIELD.replace("VARIABLES pos", "VARIABLES pos, speed").replace(
        "INVARIANT pos : 0..5", "INVARIANT pos : 0..5 & speed : INTEGER").replace(
        "pos := 2", "pos, speed := 2, 0"))
    code, _, err = run(capsys, "record", "--env", TOY, "--agent", agent, "--shield", unread,
                       "-n", 1, "-o", tmp_path / "u.mcap")
    assert code == 2 and f"{unread}:" in err and "the INVARIANT in unread reads speed, " \
                         "which the environment corridor never gives" in " ".join(err.split())
    code, _, err = run(capsys, "record", "--env", TOY, "--agent", agent, "--shield", fewer,
                       "-n", 1, "-o", tmp_path / "b.mcap")
    assert code == 2 and "the environment corridor gives the variable pos, which the shield " \
                         "fewer does not declare" in " ".join(err.split())


def test_q_learning_trains_in_seconds_with_a_model_card(tmp_path, capsys):
    out = tmp_path / "fl.npy"
    code, text, err = run(capsys, "train", "--env", "frozenlake", "--algorithm", "q-learning",
                          "--steps", 20000, "--seed", 0, "-o", out)
    assert code == 0, err
    card = json.loads(out.with_suffix(".json").read_text())
    assert card["algorithm"] == "q-learning" and card["steps"] == 20000
    table = np.load(out, allow_pickle=False)
    assert table.shape == (64, 4)
    again = tmp_path / "again.npy"
    run(capsys, "train", "--env", "frozenlake", "--algorithm", "q-learning", "--steps", 20000,
        "--seed", 0, "-o", again)
    assert np.array_equal(table, np.load(again))


def test_adapters_by_name_and_by_path():
    with pytest.raises(InputError, match="no environment named: give --env NAME"):
        get_adapter(None)  # no environment is anyone's default
    assert load_adapter(TOY).name == "corridor"
    with pytest.raises(InputError, match="cannot import the adapter module 'no_such_module'"):
        load_adapter("no_such_module:Thing")
    with pytest.raises(InputError, match="json:JSONDecoder is a class, not a tracecheck "
                                         "EnvAdapter"):
        load_adapter("json:JSONDecoder")


@pytest.mark.parametrize("spec,said,hint", [
    ("tests.live.toy.Corridor", "unknown environment 'tests.live.toy.Corridor'",
     "--env tests.live.toy:Corridor (a colon before the class)"),
    ("tests.live.toy.py:Corridor", "cannot import the adapter module 'tests.live.toy.py'",
     "name the module without .py: --env tests.live.toy:Corridor"),
    ("my_drone:Drone", "cannot import the adapter module 'my_drone'",
     "put the folder that holds my_drone.py (or the package my_drone/) on PYTHONPATH"),
    ("tests.live.toy:Corridorr", "the module tests.live.toy has no 'Corridorr'",
     "its adapters: BrokenCorridor, ByteCorridor, Corridor, Cruise"),
    ("json:Decoder", "the module json has no 'Decoder'", "it defines no EnvAdapter subclass"),
    ("tests.live.toy", "unknown environment 'tests.live.toy'",  # a module, no class
     "an adapter in the module tests.live.toy is --env tests.live.toy:YourAdapter"),
    ("tests.live.toy:CorridorEnv", "tests.live.toy:CorridorEnv is a Gymnasium environment, "
     "not a tracecheck EnvAdapter: --env takes the adapter", "its adapters: BrokenCorridor"),
    ("drone_adapter.py", "unknown environment 'drone_adapter.py'",
     "--env takes a module's name, not a file: --env drone_adapter:YourAdapter"),
    ("my_envs/drone.py:Drone", "--env 'my_envs/drone.py:Drone' is not an adapter",
     "for the file my_envs/drone.py: --env drone:Drone with PYTHONPATH=my_envs"),
])
def test_a_mistyped_adapter_says_what_it_would_be(spec, said, hint):
    """A new user's --env mistakes: a dot for the colon, the file's name, the folder not on
    PYTHONPATH, a class name off by a letter."""
    with pytest.raises(InputError) as info:
        load_adapter(spec)
    assert said in info.value.message and hint in (info.value.hint or ""), info.value.render()


def test_a_file_in_a_package_is_named_as_its_module(tmp_path, monkeypatch):
    """A new user's thermo/adapter.py in the package thermo/: the hint said --env
    adapter:Thermostat with PYTHONPATH=thermo, which cannot import it (No module named
    'thermo' from its relative imports)."""
    (tmp_path / "thermo").mkdir()
    (tmp_path / "thermo" / "__init__.py").write_text("")
    (tmp_path / "thermo" / "adapter.py").write_text("")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError) as info:
        load_adapter("thermo/adapter.py:Thermostat")
    assert info.value.hint == ("for the file thermo/adapter.py: --env thermo.adapter:Thermostat "
                               "with PYTHONPATH=.")


def test_states_of_python_values_record_train_and_replay_alike(tmp_path, capsys):
    """Issue 42: a str naming an element, a numpy array map, a Python set — converted by the
    machine's types on every path: record with the shield, record with ``--shield none``
    (the environment's own shield types the states), replay, the wrapper."""
    from tests.live.toy import LAVA_SHIELD, CorridorEnv, LavaCorridor
    from tracecheck.b.values import Elem, FuncValue
    from tracecheck.checking.shield import load_shield
    from tracecheck.live.wrapper import ShieldWrapper

    shield = tmp_path / "lava.mch"
    shield.write_text(LAVA_SHIELD)
    agent = tmp_path / "left.npy"
    np.save(agent, left_leaning_table())
    lava = "tests.live.toy:LavaCorridor"
    shielded = tmp_path / "shielded.mcap"
    code, _, err = run(capsys, "record", "--env", lava, "--agent", agent, "--shield", shield,
                       "-n", 3, "--seed", 0, "-o", shielded)
    assert code == 0, err
    episodes = list(read_episodes(shielded))
    assert not any(e.end.crashed for e in episodes)
    first = episodes[0].steps[0].state
    assert type(first["ahead"]) is Elem and type(first["cells"]) is FuncValue
    assert first["cells"].map[0] == Elem("Lava") and first["seen"] == frozenset({Elem("Floor")})
    # unshielded, typed by the environment's own shield: the same values, a crash replayed
    LavaCorridor.default_shield = str(shield)
    try:
        free = tmp_path / "free.mcap"
        code, _, err = run(capsys, "record", "--env", lava, "--agent", agent, "--shield",
                           "none", "-n", 3, "--seed", 0, "-o", free)
        assert code == 0, err
        assert type(next(iter(read_episodes(free))).steps[0].state["behind"]) is Elem
        code, out, err = run(capsys, "replay", free, "--shield", shield, "--json")
        assert code == 0, err
        assert json.loads(out)["crashes_after_infeasible"] == 3
    finally:
        del LavaCorridor.default_shield
    env = ShieldWrapper(CorridorEnv(slip=False), load_shield(shield), adapter=LavaCorridor())
    _, info = env.reset(seed=0)
    assert info["b_state"]["behind"] == Elem("Floor") and env.action_masks().tolist() == [True, True]
    env.step(0)
    assert env.action_masks().tolist() == [False, True]  # Lava behind


def test_a_state_of_the_wrong_type_is_refused_naming_state_and_the_variable(tmp_path, capsys):
    from tests.live.toy import LAVA_SHIELD

    shield = tmp_path / "lava.mch"
    shield.write_text(LAVA_SHIELD.replace("{Floor, Lava, Goal}", "{Floor, Lava, Exit}"))
    agent = tmp_path / "left.npy"
    np.save(agent, left_leaning_table())
    code, _, err = run(capsys, "record", "--env", "tests.live.toy:LavaCorridor", "--agent",
                       agent, "--shield", shield, "-n", 1, "-o", tmp_path / "x.mcap")
    assert code == 2
    assert ("state() of the adapter lavacorridor (the first state): ahead is of type CELL in "
            "LavaCorridor, but it is 'Goal' (a Python str)") in err
    assert "give the name of one of its elements as a str: Floor, Lava, Exit" in err
    assert not (tmp_path / "x.mcap").exists()


def test_a_misnamed_variable_does_not_recommend_the_shield_just_refused(tmp_path, capsys):
    from tests.live.toy import LAVA_SHIELD, LavaCorridor

    shield = tmp_path / "lava.mch"
    shield.write_text(LAVA_SHIELD.replace("seen", "visited"))
    agent = tmp_path / "left.npy"
    np.save(agent, left_leaning_table())
    LavaCorridor.default_shield = str(shield)
    try:
        code, _, err = run(capsys, "record", "--env", "tests.live.toy:LavaCorridor", "--agent",
                           agent, "--shield", shield, "-n", 1, "-o", tmp_path / "x.mcap")
    finally:
        del LavaCorridor.default_shield
    assert code == 2 and "gives the variable seen, which the shield lava does not declare" in err
    assert "hint: name the variables alike in the adapter's `variables`" in err
    assert "e.g." not in err


def test_shield_wrapper_on_a_toy_environment(tmp_path):
    """The wrapper without highway-env: masks, the decision in info, replaced actions and a
    fail-closed deadlock."""
    from tests.live.toy import Corridor, CorridorEnv
    from tracecheck.checking.shield import load_shield
    from tracecheck.live.wrapper import ShieldWrapper

    path = tmp_path / "corridor.mch"
    path.write_text(SHIELD)
    env = ShieldWrapper(CorridorEnv(slip=False), load_shield(path), adapter=Corridor())
    obs, info = env.reset(seed=0)
    assert obs == 2 and info["b_state"] == {"pos": 2}
    assert env.action_masks().tolist() == [True, True]
    obs, _, _, _, info = env.step(0)  # Left: 2 -> 1
    assert obs == 1 and env.action_masks().tolist() == [False, True]
    obs, _, _, _, info = env.step(0)  # Left again is blocked: replaced by Right
    assert obs == 2 and info["shield"]["replaced"] and info["shield"]["taken"] == "Right"
    closed = tmp_path / "closed.mch"
    closed.write_text(SHIELD.replace("pos > 1", "1 = 2").replace("pos < 5", "1 = 2"))
    env = ShieldWrapper(CorridorEnv(slip=False), load_shield(closed), fallback="Right",
                        adapter=Corridor())
    env.reset(seed=0)
    _, _, _, _, info = env.step(0)
    assert info["shield"]["deadlock"] and info["shield"]["taken"] == "Right"
    with pytest.raises(InputError, match="unknown fallback action 'Up'; the actions are Left, "
                                         "Right"):
        ShieldWrapper(CorridorEnv(), load_shield(path), fallback="Up", adapter=Corridor())


@pytest.mark.skipif(__import__("importlib").util.find_spec("Box2D") is None,
                    reason="LunarLander needs the box2d extra (pip install 'tracecheck[box2d]')")
def test_lunarlander_records_and_the_authors_machine_replays_it(tmp_path, capsys):
    import gymnasium as gym
    import stable_baselines3 as sb3

    agent = tmp_path / "lander.zip"
    sb3.DQN("MlpPolicy", gym.make("LunarLander-v3"), seed=0, device="cpu").save(agent)
    out = tmp_path / "lander.mcap"
    code, _, err = run(capsys, "record", "--env", "lunarlander", "--agent", agent, "--shield",
                       "none", "-n", 2, "--duration", 200, "-o", out)
    assert code == 0, err
    first = next(iter(read_episodes(out))).steps[0].state
    assert len(first["surface"].map) == 10 and isinstance(first["left_leg_on_ground"], bool)
    assert 0.0 < first["x"] < 600.0
    code, out_text, err = run(capsys, "stats", out, "--json")
    assert code == 0 and json.loads(out_text)["properties_set"] == "generic+lunarlander", err
    if MODELS.is_dir():
        code, out_text, err = run(capsys, "replay", out, "--shield",
                                  MODELS / "LunarLander" / "LunarLander.mch", "--json")
        report = json.loads(out_text)
        assert code == 0 and report["infeasible_steps"] == 0, err
        assert report["invariant_violations"] == 0


@pytest.mark.parametrize("env", ["frozenlake", "cliffwalking"])
def test_batch_replay_equals_state_by_state_replay(env, tmp_path, capsys):
    from tracecheck.episodes.columns import read_columns
    from tracecheck.checking.replaying import enabled_matrix
    from tracecheck.checking.shield import load_shield

    out = tmp_path / f"{env}.mcap"
    code, _, err = run(capsys, "record", "--env", env, "--env-config", "is_slippery=true",
                       "--agent", AGENTS / f"{env}.npy", "--shield", "none", "-n", 8,
                       "--seed", 5, "-o", out)
    assert code == 0, err
    cols = read_columns(out)
    shield = load_shield(env)
    matrix, ops = enabled_matrix(shield, cols)
    for i in range(cols.n):
        state = cols.states.row(i)
        assert {o for o, ok in zip(ops, matrix[i]) if ok} == shield.machine.enabled(state)
        assert shield.machine.invariant(state)


@pytest.mark.parametrize("config,message", [
    ({"map_name": "9x9", "is_slippery": True}, "the frozenlake environment rejects the run "
                                               "header's environment_config {'map_name': '9x9'"),
    ({"map_name": "8x8", "duration": "long"}, "the run header's environment_config has "
                                              "duration 'long', not a number of steps"),
])
def test_a_header_config_the_environment_rejects(frozen, tmp_path, capsys, config, message):
    """The environment configuration comes from the file: a wrong one is bad input (exit 2,
    naming the file), not a traceback from inside gymnasium."""
    from tracecheck.episodes import EpisodeWriter
    from tracecheck.episodes.reader import read_run

    run_ = read_run(frozen)
    header = run_.header.model_copy(update={"environment_config": config})
    bad = tmp_path / "bad.mcap"
    with EpisodeWriter(bad, header) as w:
        for e in run_.episodes:
            w.write(e)
    code, _, err = run(capsys, "replay", bad, "--shield", "frozenlake", "--resimulate")
    assert code == 2 and f"{bad}: {message}" in err and "Traceback" not in err


BROKEN = '''
from tests.live.toy import Corridor


class Fine(Corridor):
    pass


class InInit(Corridor):
    def __init__(self):
        raise ValueError("no config file")


class InMakeEnv(Corridor):
    def make_env(self, config, render_mode=None):
        raise RuntimeError("simulator down")


class InState(Corridor):
    def state(self, obs, info, reward, env, initial):
        raise ValueError("speed sensor missing")


class Twice(Corridor):
    actions = ("Left", "Left")


class Exits(Corridor):
    def state(self, obs, info, reward, env, initial):
        raise SystemExit(0)


class ExitsInInit(Corridor):
    def __init__(self):
        raise SystemExit(3)


class Interrupted(Corridor):
    def state(self, obs, info, reward, env, initial):
        raise KeyboardInterrupt
'''


@pytest.fixture
def broken(tmp_path, monkeypatch):
    """A module of adapters that fail in each hook, importable as ``broken_adapters``."""
    (tmp_path / "broken_adapters.py").write_text(BROKEN)
    (tmp_path / "raising_adapters.py").write_text("raise ValueError('bad import')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    return tmp_path


@pytest.mark.parametrize("spec,message", [
    ("raising_adapters:ACC", "the adapter raising_adapters:ACC raised ValueError when its "
                             "module was imported: bad import"),
    ("broken_adapters:InInit", "the adapter broken_adapters:InInit raised ValueError in its "
                               "constructor: no config file"),
    ("broken_adapters:InMakeEnv", "the adapter broken_adapters:InMakeEnv raised RuntimeError "
                                  "in make_env(): simulator down"),
    ("broken_adapters:InState", "the adapter broken_adapters:InState raised ValueError in "
                                "state(): speed sensor missing"),
    ("broken_adapters:Twice", "the adapter broken_adapters:Twice names the action 'Left' "
                              "twice in its actions ('Left', 'Left')"),
    ("broken_adapters:Exits", "the adapter broken_adapters:Exits raised SystemExit in "
                              "state(): 0"),
    ("broken_adapters:ExitsInInit", "the adapter broken_adapters:ExitsInInit raised "
                                    "SystemExit in its constructor: 3"),
    (":Corridor", "--env ':Corridor' is not an adapter: give an installed one's name"),
    ("tests.live.toy:", "--env 'tests.live.toy:' is not an adapter"),
])
def test_errors_in_a_users_adapter_name_the_adapter_and_the_hook(broken, toy, capsys, spec,
                                                                message):
    """Exit 2, no traceback; --debug shows the adapter's own traceback."""
    _, agent = toy
    args = ["record", "--env", spec, "--agent", agent, "-n", 1, "-o", broken / "x.mcap"]
    code, _, err = run(capsys, *args)
    assert code == 2 and message in " ".join(err.split()) and "Traceback" not in err
    assert not (broken / "x.mcap").exists()  # no run file without an episode
    if "raised" in message:
        assert "--debug" in err
        code, _, err = run(capsys, "--debug", *args, "--force")
        assert code == 2 and message in " ".join(err.split())
        assert "Traceback (most recent call last)" in err
        assert ("broken_adapters.py" in err) != ("raising_adapters.py" in err)


ATTRIBUTES = '''
from tests.live.toy import Corridor


class Raises(Corridor):
    @property
    def assumptions(self):
        raise ValueError("asm boom")
'''


@pytest.mark.parametrize("attribute, value, message", [
    ("horizon", "-1", "has horizon = -1; it must be a whole number of agent steps, at least 1"),
    ("horizon", "'abc'", "has horizon = 'abc'; it must be a whole number of agent steps"),
    ("horizon", "True", "has horizon = True; it must be a whole number"),
    ("assumptions", "'pos > 1'", "has assumptions = 'pos > 1'; it must be a tuple of B "
                                 "predicates (strings), e.g. (\"x : 0..7\",) — one string "
                                 "alone needs the comma"),
    ("properties", "5", "has properties = 5; it must be None or a property set's name or the "
                        "path of a property file"),
    ("default_shield", "3.5", "has default_shield = 3.5; it must be None or a shield's name"),
    ("variables", "('pos', 'pos')", "has variables = ('pos', 'pos'); it must be a tuple of B "
                                    "variable names (strings), each once"),
    ("fallback", "'Nope'", "has fallback = 'Nope'; it must be None or one of its actions "
                           "(Left, Right)"),
    ("seconds_per_step", "float('nan')", "has seconds_per_step = nan; it must be a finite "
                                         "number of seconds above 0"),
    ("name", "5", "has name = 5; it must be a string"),
    ("profiles", "{'a': 1}", "has profiles = {'a': 1}; it must be a dict of named "
                             "configurations"),
])
@pytest.mark.parametrize("command", ["record", "simulate", "prove"])
def test_an_adapter_s_attributes_are_checked_when_it_is_loaded(tmp_path, toy, capsys,
                                                              monkeypatch, attribute, value,
                                                              message, command):
    """Each was a TypeError where it was first used (``horizon = "abc"`` in record,
    ``properties = 5`` in simulate), or wrong (``assumptions = "pos > 1"`` read letter by
    letter; ``horizon = -1`` blamed a --duration nobody gave)."""
    shield, agent = toy
    module = f"attrs_{tmp_path.name.replace('-', '_').replace('[', '_').replace(']', '_')}"
    (tmp_path / f"{module}.py").write_text(f"from tests.live.toy import Corridor\n\n\n"
                                           f"class A(Corridor):\n    {attribute} = {value}\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = f"{module}:A"
    args = {"record": ["record", "--env", spec, "--agent", agent, "-n", 1, "-o",
                       tmp_path / "x.mcap"],
            "simulate": ["simulate", "--env", spec, "--agent", agent, "--shield", shield, "-n",
                         1, "-o", tmp_path / "x.mcap"],
            "prove": ["prove", shield, "--env", spec, "--deadlock-free"]}[command]
    code, out, err = run(capsys, *args)
    assert code == 2 and "Traceback" not in err and "--duration" not in err
    assert f"error: the adapter {spec} {message}" in " ".join(err.split()), err
    assert not (tmp_path / "x.mcap").exists()


def test_an_adapter_attribute_that_raises_is_reported_like_a_hook(tmp_path, toy, capsys,
                                                                 monkeypatch):
    shield, _ = toy
    (tmp_path / "raising_attrs.py").write_text(ATTRIBUTES)
    monkeypatch.syspath_prepend(str(tmp_path))
    code, _, err = run(capsys, "prove", shield, "--env", "raising_attrs:Raises",
                       "--deadlock-free")
    assert code == 2 and "Traceback" not in err
    assert "the adapter raising_attrs:Raises raised ValueError when its attribute assumptions " \
           "was read: asm boom" in " ".join(err.split())
    code, _, err = run(capsys, "--debug", "prove", shield, "--env", "raising_attrs:Raises",
                       "--deadlock-free")
    assert code == 2 and "Traceback (most recent call last)" in err and "asm boom" in err


def test_an_interrupt_in_an_adapter_stays_an_interrupt(broken, toy, capsys):
    """Ctrl-C (or KeyboardInterrupt from a hook) is exit 130, not reported as the
    adapter's error; a new file without a finished episode is not left behind."""
    _, agent = toy
    out = broken / "x.mcap"
    code, _, err = run(capsys, "record", "--env", "broken_adapters:Interrupted", "--agent",
                       agent, "-n", 1, "-o", out)
    assert code == 130 and "raised" not in err
    assert f"interrupted before an episode was finished: {out} was not written" in \
        " ".join(err.split())
    assert not out.exists() and not (broken / "x.mcap.lock").exists()


def test_a_working_user_adapter_is_not_changed_by_the_guard(broken, toy, tmp_path, capsys):
    _, agent = toy
    assert run(capsys, "record", "--env", "broken_adapters:Fine", "--agent", agent, "-n", 2,
               "-o", tmp_path / "a.mcap")[0] == 0
    assert run(capsys, "record", "--env", TOY, "--agent", agent, "-n", 2,
               "-o", tmp_path / "b.mcap")[0] == 0
    a, b = read_episodes(tmp_path / "a.mcap"), read_episodes(tmp_path / "b.mcap")
    assert [[s.state for s in e.steps] for e in a] == [[s.state for s in e.steps] for e in b]


@pytest.mark.parametrize("args,message", [
    (["record", "--env", "frozenlake", "--agent", AGENTS / "frozenlake.npy", "-n", 1,
      "--env-config", "nonsense=1"],
     "unknown setting 'nonsense' for the environment frozenlake; it takes desc, "
     "disable_env_checker, is_slippery, map_name"),
    (["record", "--env", "frozenlake", "--agent", AGENTS / "frozenlake.npy", "-n", 1,
      "--seed", -1], "--seed -1: episode i uses seed SEED + i, and a seed is 0 … 2^63 - 1"),
    (["record", "--env", "frozenlake", "--agent", AGENTS / "frozenlake.npy", "-n", 2,
      "--seed", 2**63 - 1], "--seed 9223372036854775807: episode i uses seed SEED + i"),
    (["train", "--env", "frozenlake", "--algorithm", "q-learning", "--steps", 10,
      "--env-config", "nonsense=1"], "unknown setting 'nonsense' for the environment "
                                     "frozenlake"),
    (["train", "--env", "frozenlake", "--algorithm", "q-learning", "--steps", 10, "--seed",
      -1], "Invalid value for '--seed': -1 is not in the range 0<=x<=4294967295"),
    (["train", "--env", "highway", "--steps", 10, "--env-config", "nonsense=1"],
     "unknown setting 'nonsense' for the environment highway; it takes action, "),
    (["train", "--steps", 10], "no environment named: give --env NAME (installed: "),
    (["train", "--steps", 10, "--seed", -1], "Invalid value for '--seed'"),
    (["record", "--env", "frozenlake", "--agent", AGENTS / "frozenlake.npy", "-n", 1,
      "--env-config", "is_slippery=maybe"], "the setting is_slippery='maybe' does not fit the "
                                            "environment frozenlake: is_slippery takes true or "
                                            "false hint: e.g. is_slippery=true on the command "
                                            "line, is_slippery=True from Python"),
    (["train", "--env", "frozenlake", "--algorithm", "q-learning", "--steps", 10,
      "--env-config", "is_slippery=0"], "the setting is_slippery=0 does not fit"),
    (["record", "--env", "frozenlake", "--agent", AGENTS / "frozenlake.npy", "-n", 1,
      "--env-config", "map_name=8"], "the setting map_name=8 does not fit the environment "
                                     "frozenlake: map_name takes a string"),
    (["train", "--env", "highway", "--steps", 10, "--env-config", "duration=x"],
     "the setting duration='x' does not fit the environment highway: duration takes a number"),
    (["train", "--env", "frozenlake", "--algorithm", "q-learning", "--steps", 200,
      "--env-config", "map_name=99x99"],
     "cannot make the environment frozenlake with map_name='99x99': KeyError: '99x99'"),
    (["record", "--env", "frozenlake", "--agent", AGENTS / "frozenlake.npy", "-n", 1,
      "--env-config", "disable_env_checker=3"],
     "the setting disable_env_checker=3 does not fit the environment frozenlake"),
    # the unwrapped environment ignored it: episodes ran 100 steps with max_episode_steps=3
    (["record", "--env", "frozenlake", "--agent", AGENTS / "frozenlake.npy", "-n", 1,
      "--env-config", "max_episode_steps=3"],
     "unknown setting 'max_episode_steps' for the environment frozenlake; it takes desc, "
     "disable_env_checker, is_slippery, map_name, reward_schedule, success_rate hint: "
     "tracecheck bounds "
     "episodes itself: --duration N"),
])
def test_bad_training_and_recording_options(tmp_path, capsys, args, message):
    """Refused before anything runs (highway-env would have ignored the setting silently;
    NumPy's seeding raised a traceback)."""
    out = tmp_path / ("x.zip" if "--algorithm" not in args else "x.npy")
    if args[0] == "record":
        out = tmp_path / "x.mcap"
    code, _, err = run(capsys, *args, "-o", out)
    assert code == 2 and message in " ".join(err.split()) and "Traceback" not in err
    assert not out.exists()


@pytest.mark.parametrize("spelling", ["False", "false"])
@pytest.mark.parametrize("command", ["record", "train"])
def test_env_config_values_are_typed_as_the_environment_takes_them(tmp_path, capsys, spelling,
                                                                   command):
    """``is_slippery=False`` was the string 'False' (true in Python): the lake was slippery
    and the header said 'False'. Now a boolean: every seed walks the same path."""
    if command == "train":
        out = tmp_path / "q.npy"
        code, _, err = run(capsys, "train", "--env", "frozenlake", "--algorithm", "q-learning",
                           "--steps", 50, "--env-config", f"is_slippery={spelling}", "-o", out)
        assert code == 0, err
        card = json.loads((tmp_path / "q.json").read_text())
        assert card["environment_config"]["is_slippery"] is False, card
        return
    out = tmp_path / "lake.mcap"
    code, _, err = run(capsys, "record", "--env", "frozenlake", "--agent",
                       AGENTS / "frozenlake.npy", "--shield", "frozenlake", "-n", 4, "--seed", 0,
                       "--env-config", f"is_slippery={spelling}", "-o", out)
    assert code == 0, err
    assert read_header(out).environment_config["is_slippery"] is False
    paths = {tuple(s.state["x"] * 10 + s.state["y"] for s in e.steps)
             for e in read_episodes(out)}
    assert len(paths) == 1  # deterministic: slippery, the seeds 0…3 walk apart


def test_a_setting_is_checked_against_its_annotation_and_default():
    from tracecheck.live.settings import parse_config, setting_kinds, typed_setting

    assert parse_config(["a=True", "b=false", "c=3", "d=0.5", "e=8x8", 'f="4"']) == \
        {"a": True, "b": False, "c": 3, "d": 0.5, "e": "8x8", "f": "4"}
    assert typed_setting("e", "rate", 1, setting_kinds(0.5, "float")) == 1.0
    assert isinstance(typed_setting("e", "rate", 1, setting_kinds(0.5, "float")), float)
    assert typed_setting("e", "r", [1, 0, 0], setting_kinds((1, 0, 0), "tuple[int, int, int]")) == (1, 0, 0)
    assert typed_setting("e", "any", "x", setting_kinds(None)) == "x"  # nothing known
    assert typed_setting("e", "n", None, setting_kinds(None, "int | None")) is None
    for value, kinds, takes in ((1.5, setting_kinds(3, "int"), "an integer"),
                                (True, setting_kinds(3), "a number"),
                                (5, setting_kinds(None, "str | None"), "null or a string")):
        with pytest.raises(InputError, match=f"does not fit the environment e: k takes {takes}"):
            typed_setting("e", "k", value, kinds)


def test_an_environment_refusing_its_settings_shows_its_traceback_with_debug(tmp_path, capsys):
    args = ["train", "--env", "frozenlake", "--algorithm", "q-learning", "--steps", 10,
            "--env-config", "map_name=99x99", "-o", tmp_path / "q.npy"]
    code, _, err = run(capsys, *args)
    assert code == 2 and "Traceback" not in err and "tracecheck --debug" in err
    code, _, err = run(capsys, "--debug", *args)
    assert code == 2 and "Traceback (most recent call last)" in err
    assert "KeyError: '99x99'" in err and not (tmp_path / "q.npy").exists()


def test_a_wrapper_whose_adapter_names_another_number_of_actions_is_refused(tmp_path):
    """Issue 42: 7 actions in the environment, 3 in the adapter: accepted, then step(6)
    raised IndexError."""
    import gymnasium as gym

    from tests.live.toy import SHIELD, Corridor, CorridorEnv
    from tracecheck.checking.shield import load_shield
    from tracecheck.live.wrapper import ShieldWrapper

    path = tmp_path / "corridor.mch"
    path.write_text(SHIELD)
    env = CorridorEnv()
    env.action_space = gym.spaces.Discrete(7)
    with pytest.raises(InputError, match=r"the environment's action space Discrete\(7\) has 7 "
                                         r"actions, but the adapter corridor names 2 \(Left, "
                                         r"Right\)") as info:
        ShieldWrapper(env, load_shield(path), adapter=Corridor())
    assert "one operation per action" in info.value.render()
    env.action_space = gym.spaces.Box(-1.0, 1.0, (1,))
    with pytest.raises(InputError, match="has 2 discrete actions") as info:
        ShieldWrapper(env, load_shield(path), adapter=Corridor())
    assert "parameters = " in info.value.render()


def test_an_observation_the_agent_cannot_act_on_is_refused_saying_where():
    from tracecheck.live.rollout import _finite

    _finite(np.array([1.0, 2.0], np.float32))
    _finite(3)
    with pytest.raises(InputError, match=r"the observation holds nan \(at index \[1, 0\]\), "
                                         "which the agent cannot act on"):
        _finite(np.array([[1.0], [np.nan]]))
    # a Dict or Tuple observation: where in it, by key (not its flattened index)
    import gymnasium as gym

    space = gym.spaces.Dict({"cell": gym.spaces.Discrete(6),
                             "lamps": gym.spaces.Box(0.0, 1.0, (2,), np.float32)})
    from tracecheck.live.rollout import flattening

    with pytest.raises(InputError, match=r"the observation holds inf \(at \['lamps'\]\[1\]\)"):
        _finite({"cell": 2, "lamps": np.array([0.5, np.inf], np.float32)}, flattening(space))
    pair = gym.spaces.Tuple((gym.spaces.Box(0.0, 1.0, (1,)), gym.spaces.Box(0.0, 1.0, (2, 2))))
    with pytest.raises(InputError, match=r"holds nan \(at \[1\]\[1\]\[0\]\)"):
        _finite((np.zeros(1), np.array([[0.0, 0.0], [np.nan, 0.0]])), flattening(pair))
    with pytest.raises(InputError, match=r"holds nan \(at \[1\]\[1\]\[0\]\)"):  # as a list
        _finite([np.zeros(1), np.array([[0.0, 0.0], [np.nan, 0.0]])], flattening(pair))


def test_a_setting_the_environment_does_not_take_names_the_settings_it_has(capsys, tmp_path):
    """A new user's thermostat: --env-config humidity=1 ended in make_env's TypeError alone."""
    table = tmp_path / "left.npy"
    np.save(table, left_leaning_table())
    code, _, err = run(capsys, "record", "--env", TOY, "--env-config", "humidity=1",
                       "--agent", table, "--shield", "none", "-n", 1, "-o",
                       tmp_path / "a.mcap")
    said = " ".join(err.split())
    assert code == 2 and "the adapter tests.live.toy:Corridor raised TypeError in make_env(): " \
                         "CorridorEnv.__init__() got an unexpected keyword argument " \
                         "'humidity'" in said
    assert "hint: humidity is no setting the environment takes; its default settings are " \
           "slip (the adapter's config_keys() would refuse it before making anything)" in said


def test_a_misspelt_operation_is_shown_where_it_is_declared(capsys, tmp_path):
    """A new user's `Haet` for Heat: record said "lacks Heat", no line, no word of Haet."""
    shield = tmp_path / "typo.mch"
    shield.write_text(SHIELD.replace("Right = SELECT", "Rigth = SELECT").replace(
        "OPERATIONS", "/* Rigth = the step to the right */\nOPERATIONS"))  # a comment first
    table = tmp_path / "left.npy"
    np.save(table, left_leaning_table())
    code, _, err = run(capsys, "record", "--env", TOY, "--agent", table, "--shield", shield,
                       "-n", 1, "-o", tmp_path / "a.mcap")
    line = next(k for k, x in enumerate(shield.read_text().splitlines(), 1)
                if "Rigth = SELECT" in x)
    assert code == 2 and f"{shield}:{line}:3: a shield needs one operation per action (Left, " \
                         "Right); CorridorShield lacks Right and has Rigth, which no action " \
                         "is" in " ".join(err.split())
    assert "hint: is the operation Rigth the action Right misspelt? An action and its " \
           "operation have one name." in " ".join(err.split())


def test_a_guard_the_live_shield_cannot_evaluate_is_recorded_with_why(toy, tmp_path, capsys):
    """Left's guard divides by zero: the live shield does not allow Left (it fails closed)
    — and now says so: each such step's shield_problem, and a warning after the summary
    (record exited 0 with nothing said, its steps claiming decisions the shield never made:
    a new user's warehouse)."""
    shield, agent = toy
    broken = tmp_path / "broken.mch"
    broken.write_text(SHIELD.replace("pos > 1", "pos > 1 + 12 / (pos - pos)"))
    out = tmp_path / "run.mcap"
    code, said, err = run(capsys, "record", "--env", TOY, "--agent", agent, "--shield", broken,
                          "-n", 2, "-o", out)
    assert code == 0 and "recorded 2 episode(s)" in said
    assert "the shield could not evaluate a guard, and did not allow its action (it failed " \
        "closed" in " ".join(err.split())
    assert "the first, episode 0 step 1: Left: division by zero" in " ".join(err.split())
    steps = [s for e in read_run(out).episodes for s in e.steps[1:]]
    assert steps and all("Left" not in s.allowed_actions for s in steps)
    assert all(s.shield_problem.startswith("Left: division by zero") for s in steps)
    code, said, err = run(capsys, "record", "--env", TOY, "--agent", agent, "--shield", shield,
                          "-n", 1, "-o", out, "--force")
    assert code == 0 and "could not evaluate" not in err
    assert all(s.shield_problem is None for e in read_run(out).episodes for s in e.steps)
