"""SimB's external-simulation protocol: tracecheck answering agent scripts as ProB does.

The scripts are ours (tests/fixtures/external): a corridor with misbehaving modes, FrozenLake
on current Gymnasium, and two agents on a grid that take turns (one operation per move).
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.helpers import ROOT, run
from tracecheck.checking import load_shield, replay
from tracecheck.episodes import read_run
from tracecheck.episodes.reader import read_header
from tracecheck.live.external import ExternalError, ExternalSettings, external_episodes

HERE = ROOT / "tests" / "fixtures" / "external"
CORRIDOR = HERE / "Corridor.mch"
PY = sys.executable


def corridor(mode: str = "polite", episodes: int = 3, **kw) -> ExternalSettings:
    values = dict(command=(PY, "corridor_agent.py", mode), episodes=episodes, cwd=HERE,
                  step_timeout=5.0, connect_timeout=10.0)
    values.update(kw)
    return ExternalSettings(**values)


def scripts_running(name: str) -> list[int]:
    """The processes whose command line names ``name`` (none may be left behind)."""
    found = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
            status = Path(f"/proc/{pid}/stat").read_text().split()[2]
        except OSError:
            continue
        if name.encode() in cmdline and status != "Z":
            found.append(int(pid))
    return found


def record(capsys, *args):
    return run(capsys, "record", "--shield", CORRIDOR, "--episodes", 3, *args)


# ------------------------------------------------------------------ the protocol


def test_each_step_carries_what_the_machine_enabled():
    episodes = list(external_episodes(corridor(), load_shield(CORRIDOR)))
    assert [e.id for e in episodes] == [0, 1, 2]
    first = episodes[0]
    assert first.steps[0].action is None and first.steps[0].allowed_actions is None
    assert first.steps[0].state == {"pos": 1, "moves": 0, "Crash": False}
    # the machine computes `moves` and `Crash`; the script only sends `pos`
    assert [dict(s.state) for s in first.steps[1:3]] == [
        {"pos": 2, "moves": 1, "Crash": False}, {"pos": 3, "moves": 2, "Crash": False}]
    assert first.steps[1].allowed_actions == ("Left", "Right")
    assert [s.time for s in first.steps[:3]] == [0.0, 1.0, 2.0]  # delta 1000 ms each
    at_four = next(s for s in first.steps[1:] if s.state["pos"] == 4)
    after = first.steps[first.steps.index(at_four) + 1]
    assert after.allowed_actions == ("Left",) and after.action == "Left"  # it obeyed
    assert first.end.reason == "end-of-trace" and not first.end.crashed


def test_a_script_that_takes_blocked_actions_is_recorded_not_trusted(tmp_path, capsys):
    out = tmp_path / "greedy.mcap"
    code, stdout, _ = record(capsys, "--external", f"{PY} corridor_agent.py greedy",
                             "--cwd", HERE, "-o", out)
    assert code == 0, stdout
    assert "3 crash(es)" in stdout and "3 step(s) took an action Corridor did not enable" \
        in " ".join(stdout.split())
    report = replay([out], load_shield(CORRIDOR))
    assert (report.episodes, report.infeasible_steps, report.crashes,
            report.crashes_after_infeasible) == (3, 3, 3, 3)
    blocked = [s for e in read_run(out).episodes for s in e.steps[1:]
               if s.action not in s.allowed_actions]
    assert [(s.action, s.allowed_actions, s.crashed) for s in blocked] == [
        ("Right", ("Left",), True)] * 3


def test_run_header_names_the_command_the_script_and_the_machine(tmp_path, capsys):
    out = tmp_path / "run.mcap"
    assert record(capsys, "--external", f"{PY} corridor_agent.py", "--cwd", HERE,
                  "-o", out)[0] == 0
    header = read_header(out)
    assert header.source == "external"
    assert header.external_command == [PY, "corridor_agent.py"]
    assert header.external_script == str(HERE / "corridor_agent.py")
    assert header.external_script_sha256 == hashlib.sha256(
        (HERE / "corridor_agent.py").read_bytes()).hexdigest()
    assert header.external_cwd == str(HERE)
    assert (header.model_name, header.variables, header.actions) == (
        "Corridor", ["pos", "moves", "Crash"], ["Left", "Right"])
    assert header.base_seed is None and header.environment is None


def test_ending_time_cuts_episodes_and_the_script_goes_on(tmp_path):
    settings = corridor(episodes=3, ending_time_ms=2500)
    episodes = list(external_episodes(settings, load_shield(CORRIDOR)))
    assert [(e.end.steps, e.end.reason) for e in episodes] == [(3, "time-limit")] * 3
    settings = corridor(episodes=2, max_steps=2)
    assert [e.end.steps for e in external_episodes(settings, load_shield(CORRIDOR))] == [2, 2]


def test_frozenlake_on_current_gymnasium_is_feasible_under_its_shield(tmp_path, capsys):
    pytest.importorskip("gymnasium")
    out = tmp_path / "lake.mcap"
    code, stdout, _ = run(capsys, "record", "--external", f"{PY} frozenlake_agent.py 7",
                          "--cwd", HERE, "--shield", "frozenlake", "--episodes", 3, "-o", out)
    assert code == 0, stdout
    report = replay([out], load_shield("frozenlake"))
    assert report.episodes == 3 and report.steps > 0
    assert report.infeasible_steps == 0 and report.crashes == 0
    assert (report.postcondition_violations, report.invariant_violations) == (0, 0)


AUTHORS_LAKE = ROOT.parent / "shared" / "data" / "paper-models" / "FrozenLake" / "FrozenLake.mch"


@pytest.mark.skipif(not AUTHORS_LAKE.exists(), reason="the authors' machines are not in ../shared")
def test_the_authors_frozenlake_machine_answers_a_script_in_their_scripts_shape(tmp_path,
                                                                                capsys):
    pytest.importorskip("gymnasium")
    out = tmp_path / "lake.mcap"
    code, _, _ = run(capsys, "record", "--external", f"{PY} frozenlake_agent.py 3", "--cwd",
                     HERE, "--shield", AUTHORS_LAKE, "--episodes", 2, "-o", out)
    assert code == 0
    report = replay([out], load_shield(AUTHORS_LAKE))
    assert report.steps > 0 and report.infeasible_steps == 0
    assert (report.postcondition_violations, report.invariant_violations) == (0, 0)


def test_two_agents_take_turns_one_operation_per_move(tmp_path, capsys):
    out = tmp_path / "grid.mcap"
    shield = HERE / "TwoAgents.mch"
    code, _, _ = run(capsys, "record", "--external", f"{PY} two_agents.py 3", "--cwd", HERE,
                     "--shield", shield, "--episodes", 2, "-o", out)
    assert code == 0
    first = read_run(out).episodes[0]
    turns = [s.state["turn"] for s in first.steps]
    assert turns[:5] == [1, 2, 1, 2, 1]  # the machine's own variable, never sent
    moved = [s for s in first.steps[1:] if s.action in s.allowed_actions]
    assert moved and all(s.state["visited"] >= {tuple(p) for _, p in s.state["positions"]}
                         for s in moved)
    report = replay([out], load_shield(shield))
    blocked = sum(1 for e in read_run(out).episodes for s in e.steps[1:]
                  if s.action not in s.allowed_actions)
    # a stuck agent answers a blocked move and stays: infeasible, and no transition of the
    # operation leaves it where it is (a postcondition violation); all else is feasible
    assert report.infeasible_steps == blocked
    assert report.postcondition_violations == blocked


# ------------------------------------------------------------------ faults of the other side


@pytest.mark.parametrize("mode, message", [
    ("die", "episode 1, step 3: the script closed the connection (the script "),
    ("garbage", "episode 1, step 1: sent what is not JSON: 'this is not json'"),
    ("unknown", "episode 1, step 1: answered the operation 'Jump', which the machine "
                "Corridor does not have; it has Left, Right"),
    ("badpred", "episode 1, step 1: sent a predicate tracecheck cannot use"),
    ("hugedelta", "episode 1, step 1: 'delta' must be a time in milliseconds, 0 to one "
                  "year"),
    ("slowpred", "episode 1, step 1 (Right): --step-timeout: tracecheck's evaluation took "
                 "longer than 1 s; the script sent"),
    ("partial", "episode 1, initialisation ($initialise_machine): pos fixed neither by the "
                "predicate nor by the operation (its `pos :: …` chooses it); the script sent "
                "'moves = 0'"),
    ("hang", "episode 1, step 1: no answer within 1 s (--step-timeout; a script that "
             "writes through a buffer must flush after each answer)"),
    ("badinit", "episode 1, initialisation: the INITIALISATION of Corridor cannot give the "
                "initial state the script sent: 'pos = 4'"),
    ("liar", "episode 1, step 1 (Right): no state satisfies the predicate with the values "
             "Right gives the variables it does not fix; the script sent 'pos = 2 & moves > "
             "100'"),
], ids=["dies", "garbage", "unknown-operation", "bad-predicate", "huge-delta", "slow-predicate",
        "undetermined",
        "hangs",
        "impossible-start", "no-state-fits"])
def test_a_faulty_script_ends_cleanly_keeping_complete_episodes(tmp_path, capsys, mode,
                                                                message):
    out = tmp_path / f"{mode}.mcap"
    code, _, stderr = record(capsys, "--external", f"{PY} corridor_agent.py {mode}",
                             "--cwd", HERE, "--step-timeout", 1, "-o", out)
    text = " ".join(stderr.split())
    assert code == 2 and message in text, text
    assert "keeps the 1 episode(s) finished before" in text
    assert "Traceback" not in stderr
    assert [e.id for e in read_run(out).episodes] == [0]
    assert not scripts_running(f"corridor_agent.py {mode}")


def test_a_script_that_dies_is_quoted(tmp_path, capsys):
    code, _, stderr = record(capsys, "--external", f"{PY} corridor_agent.py die", "--cwd",
                             HERE, "-o", tmp_path / "x.mcap")
    assert code == 2 and "(the script " in stderr and "exited with status 3)" in stderr
    assert "stopped it" not in stderr
    assert "its last output:" in stderr and "agent: giving up" in stderr


def test_a_script_that_never_connects():
    started = time.monotonic()
    settings = corridor("silent", connect_timeout=1.0)
    with pytest.raises(ExternalError) as info:
        list(external_episodes(settings, load_shield(CORRIDOR)))
    message = " ".join(str(info.value).split())
    assert "the script did not connect to 127.0.0.1:" in message
    assert "within 1 s (the port is its last argument)" in message
    assert time.monotonic() - started < 20
    assert not scripts_running("corridor_agent.py silent")


def test_the_cli_waits_at_least_a_minute_for_the_connection_and_notes_unbounded_episodes(
        tmp_path, capsys):
    from tracecheck.cli.common import external_settings
    from tracecheck.cli.run_options import RunOptions

    settings, _ = external_settings(RunOptions.given(external="python3 agent.py",
                                                     shield=str(CORRIDOR), step_timeout=0.5), 1)
    assert (settings.step_timeout, settings.connect_timeout) == (0.5, 60.0)
    assert "neither --duration nor --ending-time" in capsys.readouterr().err
    settings, _ = external_settings(RunOptions.given(external="python3 agent.py",
                                                     shield=str(CORRIDOR), step_timeout=45,
                                                     duration=10), 1)
    assert settings.connect_timeout == 90 and settings.max_steps == 10
    assert capsys.readouterr().err == ""


def test_a_command_that_cannot_start(tmp_path, capsys):
    code, _, stderr = record(capsys, "--external", "no-such-program-here agent.py",
                             "-o", tmp_path / "x.mcap")
    assert code == 2 and "cannot start no-such-program-here agent.py" in stderr


def test_ctrl_c_keeps_episodes_and_stops_the_script(tmp_path):
    out = tmp_path / "hang.mcap"
    proc = subprocess.Popen([PY, "-m", "tracecheck", "record", "--external",
                             f"{PY} corridor_agent.py hang", "--cwd", str(HERE), "--shield",
                             str(CORRIDOR), "--episodes", "3", "--step-timeout", "60",
                             "-o", str(out)], stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (out.exists() and out.stat().st_size > 2000):
        time.sleep(0.2)
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=30)
    assert proc.returncode == 130, stderr
    assert f"interrupted: {out} keeps the 1 episode(s) finished before" in stderr
    assert [e.id for e in read_run(out).episodes] == [0]
    assert not scripts_running("corridor_agent.py hang")


# ------------------------------------------------------------------ options and downstream


@pytest.mark.parametrize("args, message", [
    (["--agent", ROOT / "models" / "agents" / "base.zip"], "--agent cannot be used with it"),
    (["--env", "frozenlake"], "--env cannot be used with it"),
    (["--seed", 3], "--seed cannot be used with it"),
    (["--seed", 1], "--seed cannot be used with it"),
    (["--workers", 2], "--workers cannot be used with it"),
], ids=["agent", "env", "seed", "seed-1", "workers"])
def test_options_of_a_tracecheck_agent_are_refused_with_external(tmp_path, capsys, args,
                                                                 message):
    code, _, stderr = record(capsys, "--external", f"{PY} corridor_agent.py", *args,
                             "-o", tmp_path / "x.mcap")
    assert code == 2 and message in " ".join(stderr.split())


def test_external_needs_a_machine_and_its_options_need_external(tmp_path, capsys):
    code, _, stderr = run(capsys, "record", "--external", "python3 x.py", "--episodes", 1,
                          "-o", tmp_path / "x.mcap")
    assert code == 2 and "--external needs --shield naming the machine" in stderr
    code, _, stderr = run(capsys, "record", "--agent", ROOT / "models" / "agents" / "base.zip",
                          "--cwd", HERE, "--episodes", 1, "-o", tmp_path / "x.mcap")
    assert code == 2 and "--cwd only applies to --external" in " ".join(stderr.split())
    code, _, stderr = run(capsys, "record", "--episodes", 1, "-o", tmp_path / "x.mcap")
    assert code == 2 and "--agent is required (or --external" in " ".join(stderr.split())


def test_the_output_is_never_the_script_or_the_machine(capsys):
    code, _, stderr = record(capsys, "--external", f"{PY} corridor_agent.py", "--cwd", HERE,
                             "-o", HERE / "corridor_agent.py", "--force")
    assert code == 2 and "writing it would destroy the input" in stderr
    assert (HERE / "corridor_agent.py").read_text().startswith('"""A corridor agent')


def test_downstream_commands_on_an_external_run(tmp_path, capsys):
    out = tmp_path / "greedy.mcap"
    assert record(capsys, "--external", f"{PY} corridor_agent.py greedy", "--cwd", HERE,
                  "-o", out)[0] == 0
    code, stdout, _ = run(capsys, "replay", out, "--shield", CORRIDOR, "--ltl",
                          "G({Crash = FALSE})", "--json")
    data = json.loads(stdout)
    assert code == 0 and data["infeasible_steps"] == 3
    code, _, stderr = run(capsys, "replay", out, "--shield", CORRIDOR, "--resimulate")
    assert code == 2 and "cannot be re-simulated" in stderr
    assert "(--external)" in stderr
    code, stdout, _ = run(capsys, "stats", out, "--format", "json")
    assert code == 0 and json.loads(stdout)["runs"][0]["episodes"] == 3
    assert run(capsys, "diff", out, "--shield", CORRIDOR, "--against", "none")[0] == 0
    assert run(capsys, "render", out, "--episode", 0, "--shield", CORRIDOR,
               "-o", tmp_path / "e.html")[0] == 0
    assert run(capsys, "export", "simb", out, "-o", tmp_path / "simb")[0] == 0
    assert run(capsys, "import", "simb", tmp_path / "simb", "--model", CORRIDOR,
               "-o", tmp_path / "back.mcap")[0] == 0
    again = replay([tmp_path / "back.mcap"], load_shield(CORRIDOR))
    assert (again.episodes, again.infeasible_steps, again.crashes) == (3, 3, 3)
    assert run(capsys, "export", "prob2trace", out, "--episode", 1,
               "-o", tmp_path / "e1.prob2trace")[0] == 0


def test_simulate_external_validates_as_it_records(tmp_path, capsys):
    out = tmp_path / "sim.mcap"
    code, stdout, _ = run(capsys, "simulate", "--external", f"{PY} corridor_agent.py greedy",
                          "--cwd", HERE, "--shield", CORRIDOR, "--episodes", 4,
                          "--format", "json", "-o", out)
    assert code == 0
    result = json.loads(stdout)
    crash = result["runs"][0]["properties"]["CRASH"]
    assert (crash["holds"], crash["episodes"]) == (4, 4)
    assert len(read_run(out).episodes) == 4


def test_the_library_stops_the_script_when_the_caller_stops_early():
    gen = external_episodes(corridor("polite", episodes=50), load_shield(CORRIDOR))
    next(gen)
    gen.close()
    assert not scripts_running("corridor_agent.py polite")



def test_the_minimal_script_of_the_docs_runs(tmp_path, capsys):
    import re

    text = (ROOT / "docs" / "simb-external.md").read_text()
    script = tmp_path / "minimal.py"
    script.write_text(re.search(r"```python\n(.*?)```", text, re.S).group(1))
    out = tmp_path / "min.mcap"
    code, stdout, _ = record(capsys, "--external", f"{PY} {script}", "-o", out)
    assert code == 0 and "0 step(s) took an action Corridor did not enable" in \
        " ".join(stdout.split())
    report = replay([out], load_shield(CORRIDOR))
    assert (report.episodes, report.steps, report.infeasible_steps) == (3, 12, 0)


def test_a_script_that_does_not_leave_a_cut_episode_is_told_why(tmp_path, capsys):
    code, _, stderr = record(capsys, "--external", f"{PY} corridor_agent.py deaf", "--cwd",
                             HERE, "--duration", 2, "-o", tmp_path / "x.mcap")
    text = " ".join(stderr.split())
    assert code == 2 and "episode 1, initialisation: answered 'Left' where the episode " \
        "starts; the first answer must be $initialise_machine — the previous episode was " \
        "cut with finished: 1, which a script must take as 'leave this episode'" in text
    assert [e.end.reason for e in read_run(tmp_path / "x.mcap").episodes] == ["time-limit"]


def test_stats_on_a_script_run_says_where_its_properties_come_from(tmp_path, capsys):
    out = tmp_path / "run.mcap"
    assert record(capsys, "--external", f"{PY} corridor_agent.py", "--cwd", HERE,
                  "-o", out)[0] == 0
    code, stdout, stderr = run(capsys, "stats", out)
    assert "— (not finite)" in stdout
    assert "Interventions (share of steps), run: not finite: of 3 episodes, 3 nan (the " \
        "agent's action values were not recorded" in " ".join(stdout.split())
    text = " ".join(stderr.split())
    assert code == 0 and "the runs come from an agent script (states of Corridor): generic " \
        "statistics (give --properties FILE for the machine's own properties)" in text
    assert "not installed" not in text


def test_a_process_the_script_detaches_is_ended_with_it(tmp_path, capsys):
    """A child that calls setsid() and forks again is in no process group of the script's:
    it outlived record; the run's mark in its environment finds it."""
    out = tmp_path / "daemon.mcap"
    code, _, err = record(capsys, "--external", f"{PY} corridor_agent.py daemon", "--cwd",
                          HERE, "-o", out)
    assert code == 0, err
    deadline = time.monotonic() + 5
    while scripts_running("corridor_agent.py daemon") and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not scripts_running("corridor_agent.py daemon")


def test_only_the_processes_with_this_runs_mark_are_killed():
    from tracecheck.live.external import MARK, _kill_marked

    mark = f"{MARK}=test-{os.getpid()}-{time.monotonic_ns()}"
    def start(env_value):
        env = dict(os.environ)
        env.pop(MARK, None)
        if env_value is not None:
            env[MARK] = env_value
        return subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"],
                                env=env)
    marked = start(mark.split("=", 1)[1])
    others = [start(None), start(mark.split("=", 1)[1] + "0"), start(mark.split("=", 1)[1][:-1])]
    try:
        time.sleep(0.3)
        assert _kill_marked(mark) == [marked.pid]
        assert marked.wait(timeout=5) == -signal.SIGKILL
        assert all(p.poll() is None for p in others)  # no mark, a longer or shorter one
        assert _kill_marked(f"{MARK}=") == [] and _kill_marked("") == []
    finally:
        for p in [marked, *others]:
            p.kill()
            p.wait()
