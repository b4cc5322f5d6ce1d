"""docs/continuous.md is true: its walkthrough's files (the user's ``rover.py`` and the two
shields) are taken from the page itself, every ``tracecheck`` command of its shell blocks
names real commands and options, the outputs it shows of the commands that need no agent
(``check-model``, ``guards``, ``prove``, ``diff --symbolic``) are what those commands print,
and the recording part of the walkthrough tells the same story with a tiny agent of constant
full throttle (the page's own agent takes a minute to train)."""

from __future__ import annotations

import re
import shlex
import sys
from pathlib import Path

import pytest
import typer.main

from tests.helpers import ROOT, run
from tracecheck.cli import app

DOC = ROOT / "docs" / "continuous.md"
FENCE = re.compile(r"^```(\w*)\s*$")
#: commands whose shown output is checked here: they need only the page's files
QUICK = ("check-model", "guards", "prove", "diff")


def blocks(text: str) -> list[tuple[str, int, list[str]]]:
    """(language, line of the first line, lines) of every fenced block, nested ones (in a
    list item) included."""
    found, inside, start, lines = [], None, 0, []
    for number, line in enumerate(text.splitlines(), 1):
        fence = FENCE.match(line.strip())
        if fence and inside is None:
            inside, start, lines, indent = fence.group(1), number + 1, [], \
                len(line) - len(line.lstrip())
        elif inside is not None and line.strip().startswith("```"):
            found.append((inside, start, lines))
            inside = None
        elif inside is not None:
            lines.append(line[indent:])
    return found


def walkthrough_files(text: str) -> dict[str, str]:
    """The files the walkthrough has the reader write: a Python block opening with ``#
    NAME.py``, a machine opening with ``/* NAME.mch:``."""
    files = {}
    for language, _, lines in blocks(text):
        first = lines[0] if lines else ""
        named = re.fullmatch(r"# (\w+\.py)", first) if language == "python" else \
            re.match(r"/\* (\w+\.mch):", first)
        if named:
            files[named.group(1)] = "\n".join(lines) + "\n"
    return files


def shell_lines(text: str) -> list[tuple[int, str]]:
    """(line, text) of each command line of the shell blocks."""
    return [(start + k, line) for language, start, lines in blocks(text) if language == "bash"
            for k, line in enumerate(lines) if line.strip() and not line.startswith("#")]


def tracecheck_args(line: str) -> list[str] | None:
    words = shlex.split(line, comments=True)
    return words[1:] if words and words[0] == "tracecheck" else None


def misused(args: list[str]) -> list[str]:
    """What the command line's parser would refuse in ``tracecheck ARGS``: an unknown
    command or option, a value outside an option's choices."""
    command, path, args, problems = typer.main.get_command(app), "tracecheck", list(args), []
    while hasattr(command, "commands"):
        if not args or args[0] not in command.commands:
            return [f"{path} has no command {args[0] if args else '(none)'}"]
        command, path = command.commands[args[0]], f"{path} {args.pop(0)}"
    options = {o: p for p in command.params if p.param_type_name == "option"
               for o in (*p.opts, *p.secondary_opts)}
    while args:
        word = args.pop(0)
        if not word.startswith("-") or word == "-":
            continue
        name, _, value = word.partition("=")
        param = options.get(name)
        if param is None:
            problems.append(f"{path} has no option {name}")
            continue
        if not param.is_flag and not value:
            value = args.pop(0) if args else ""
        choices = getattr(param.type, "choices", None)
        if choices and value not in choices:
            problems.append(f"{path} {name} {value}: not one of {', '.join(choices)}")
    return problems


def shown_outputs(text: str) -> list[tuple[int, list[str], list[str]]]:
    """(line, arguments, output lines) of each ``$ tracecheck …`` of the text blocks, the
    output being the lines up to the next ``$``."""
    found = []
    for language, start, lines in blocks(text):
        if language != "text":
            continue
        for k, line in enumerate(lines):
            if line.startswith("$ tracecheck "):
                shown = []
                for later in lines[k + 1:]:
                    if later.startswith("$ "):
                        break
                    shown.append(later)
                found.append((start + k, shlex.split(line[2:])[1:], shown))
    return found


TEXT = DOC.read_text(encoding="utf-8")


def test_the_page_has_its_files_and_commands():
    assert set(walkthrough_files(TEXT)) == {"rover.py", "rover_v1.mch", "rover_v2.mch"}
    assert len([a for _, line in shell_lines(TEXT) if (a := tracecheck_args(line))]) >= 15
    assert len(shown_outputs(TEXT)) >= 8


@pytest.mark.parametrize("line,args", [
    pytest.param(line, args, id=f"line{line}-{args[0]}")
    for line, text in shell_lines(TEXT) if (args := tracecheck_args(text)) is not None])
def test_every_command_names_real_commands_and_options(line, args):
    problems = misused(args)
    assert not problems, f"docs/continuous.md:{line}: tracecheck {shlex.join(args)}\n" + \
        "\n".join(problems)


def test_a_wrong_option_is_found():
    assert misused(["replay", "r.mcap", "--format", "html", "--sheild", "x"]) == [
        "tracecheck replay --format html: not one of text, md, csv, json",
        "tracecheck replay has no option --sheild"]
    assert misused(["frobnicate"]) == ["tracecheck has no command frobnicate"]


@pytest.fixture
def walkthrough(tmp_path, monkeypatch):
    """A fresh folder with the page's files and state files, the current directory, its
    module importable as the page says (``--env rover:Rover``)."""
    for name, text in walkthrough_files(TEXT).items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    for _, line in shell_lines(TEXT):
        echo = re.fullmatch(r"echo '(.*)' > (\w+\.json)", line.strip())
        if echo:
            (tmp_path / echo.group(2)).write_text(echo.group(1), encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "100")
    monkeypatch.syspath_prepend(str(tmp_path))
    sys.modules.pop("rover", None)
    yield tmp_path
    sys.modules.pop("rover", None)


def _flat(text: str) -> str:
    return " ".join(text.split())


@pytest.mark.parametrize("line,args,shown", [
    pytest.param(line, args, shown, id=f"line{line}-{args[0]}")
    for line, args, shown in shown_outputs(TEXT) if args[0] in QUICK and
    (args[0] != "diff" or "--symbolic" in args)])
def test_the_shown_output_is_what_the_command_prints(walkthrough, capsys, line, args, shown):
    code, out, err = run(capsys, *args)
    printed = _flat(out + err)
    for expected in shown:
        expected = _flat(expected)
        if expected.endswith("…"):  # cut to the terminal's width
            expected = expected[:-1]
        assert expected in printed, f"docs/continuous.md:{line}: {expected!r} not in\n{out}{err}"
    assert code == (1 if any("counterexample" in s for s in shown) else 0)


def test_the_walkthrough_with_an_agent_of_full_throttle(walkthrough, capsys):
    """The story of sections 5-10: unshielded the rover hits the wall, under v1 it takes the
    fallback where nothing is allowed, v2 allows exactly those brakings."""
    pytest.importorskip("stable_baselines3", reason="the agents extra is not installed")
    import stable_baselines3 as sb3
    import torch

    from rover import RoverEnv  # the page's own module

    agent = sb3.PPO("MlpPolicy", RoverEnv(), policy_kwargs={"net_arch": [4]}, seed=0,
                    n_steps=64, batch_size=64, device="cpu")
    with torch.no_grad():
        agent.policy.action_net.weight.zero_()
        agent.policy.action_net.bias.fill_(2.0)
    agent.save("throttle.zip")
    for shield, out in (("none", "none.mcap"), ("rover_v1.mch", "v1.mcap"),
                        ("rover_v2.mch", "v2.mcap")):
        code, _, err = run(capsys, "record", "--env", "rover:Rover", "--agent", "throttle.zip",
                           "--shield", shield, "-n", "3", "-o", out)
        assert code == 0, err

    code, out, _ = run(capsys, "replay", "none.mcap", "--shield", "rover_v2.mch")
    flat = _flat(out)
    assert code == 0 and "crashes: 3, of which 3 at or after the first infeasible step" in flat
    assert "continuous actions at the first infeasible step" in flat
    assert re.search(r"ACCELERATE\(a=2\): a ∈ [\[{(]-3\.0.*, [0-9.]+ from the nearest allowed value", flat), flat

    code, out, _ = run(capsys, "replay", "v1.mcap", "--shield", "rover_v1.mch")
    flat = _flat(out)
    assert code == 0 and "crashes: 0" in flat and "ACCELERATE(a=-3): a ∈ ∅, nothing allowed" in flat
    deadlocks = int(re.search(r"deadlock states: (\d+)", flat).group(1))
    assert deadlocks > 0

    code, out, _ = run(capsys, "diff", "v1.mcap", "--shield", "rover_v2.mch", "--against",
                       "rover_v1.mch")
    assert code == 0
    assert f"newly blocked 0, newly allowed {deadlocks}" in _flat(out)

    code, out, _ = run(capsys, "stats", "none.mcap", "v1.mcap", "v2.mcap")
    flat = _flat(out)
    assert code == 0
    for row in ("Intervention rate", "On the allowed set's boundary", "Fallback taken",
                "Projection distance"):
        assert row in flat
    assert f"({deadlocks} of " in flat  # v1's fallback steps

    code, out, _ = run(capsys, "render", "v1.mcap", "--episode", "0", "-o", "ep0.html")
    assert code == 0 and Path("ep0.html").stat().st_size > 10_000
