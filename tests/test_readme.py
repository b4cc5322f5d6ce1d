"""The README is true: its ``pycon`` blocks give the outputs they show (one ``doctest``
session, the repository as the working directory), each of its Python blocks runs (a fresh
interpreter), and each ``tracecheck`` command in its shell blocks names a real command with
real options (checked against the command line's own parser, not run)."""

from __future__ import annotations

import contextlib
import doctest
import os
import re
import shlex
import subprocess
import sys
import traceback
from pathlib import Path

import pytest
import typer.main

from tests.helpers import ROOT
from tracecheck.cli import app

README = ROOT / "README.md"
FENCE = re.compile(r"^```(\w*)\s*$")


def blocks(text: str, language: str) -> list[tuple[int, str]]:
    """(line of the block's first line, its text) for every fenced block in ``language``."""
    found, inside, start, lines = [], None, 0, []
    for number, line in enumerate(text.splitlines(), 1):
        fence = FENCE.match(line)
        if fence and inside is None:
            inside, start, lines = fence.group(1), number + 1, []
        elif inside is not None and line.startswith("```"):
            if inside == language:
                found.append((start, "\n".join(lines) + "\n"))
            inside = None
        elif inside is not None:
            lines.append(line)
    return found


# ------------------------------------------------------------------ the sessions print what they show


class _Collecting(doctest.DocTestRunner):
    """A doctest runner that keeps each failure as ``README.md:LINE: …`` (the README's line)."""

    def __init__(self, name: str):
        super().__init__(verbose=False)
        self.name, self.found = name, []

    def _where(self, test, example) -> str:
        return f"{self.name}:{test.lineno + example.lineno + 1}: >>> {example.source.strip()}"

    def report_failure(self, out, test, example, got):
        self.found.append(f"{self._where(test, example)}\nexpected:\n{example.want}"
                          f"got:\n{got}")

    def report_unexpected_exception(self, out, test, example, exc_info):
        self.found.append(f"{self._where(test, example)}\nraised:\n"
                          + "".join(traceback.format_exception_only(*exc_info[:2])))


def pycon_failures(readme: Path, cwd: Path) -> list[str]:
    """The ``pycon`` blocks of ``readme`` run by ``doctest`` in ``cwd``, in order and sharing
    one namespace (as a reader types them into one session): each example whose output is not
    the one shown, or that raises, with its line in ``readme``."""
    parser = doctest.DocTestParser()
    runner = _Collecting(readme.name)
    globs: dict = {"__name__": "__readme__"}
    with contextlib.chdir(cwd):
        for line, code in blocks(readme.read_text(encoding="utf-8"), "pycon"):
            test = parser.get_doctest(code, globs, readme.name, str(readme), line - 1)
            runner.run(test, clear_globs=False)
            globs = test.globs  # (a DocTest works on a copy of the names it is given)
    return runner.found


def test_the_readme_has_pycon_blocks():
    assert blocks(README.read_text(encoding="utf-8"), "pycon")


def test_every_pycon_block_of_the_readme_prints_what_it_shows():
    failures = pycon_failures(README, ROOT)
    assert not failures, "\n".join(failures)


def test_a_wrong_output_or_an_exception_in_a_session_is_reported_with_its_line(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text("# A project\n\n```pycon\n>>> x = 2\n>>> x + 1\n3\n```\n\nText.\n\n"
                      "```pycon\n>>> x * 2\n5\n>>> {'a': x}['b']\nNone\n```\n",
                      encoding="utf-8")
    assert [line for line, _ in blocks(readme.read_text(), "pycon")] == [4, 12]
    assert pycon_failures(readme, tmp_path) == [
        "README.md:12: >>> x * 2\nexpected:\n5\ngot:\n4\n",
        "README.md:14: >>> {'a': x}['b']\nraised:\nKeyError: 'b'\n"]


# ------------------------------------------------------------------ the Python blocks run


def python_failures(readme: Path, cwd: Path) -> list[str]:
    """Each Python block of ``readme`` run by itself in a fresh interpreter in ``cwd``: where
    one fails, its place and what it wrote to stderr."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    failures = []
    for line, code in blocks(readme.read_text(encoding="utf-8"), "python"):
        proc = subprocess.run([sys.executable, "-c", code], cwd=cwd, env=env,
                              capture_output=True, text=True, timeout=300)
        if proc.returncode != 0:
            failures.append(f"{readme.name}:{line}: the Python block exits with "
                            f"{proc.returncode}:\n{proc.stderr}")
    return failures


def test_every_python_block_of_the_readme_runs():
    failures = python_failures(README, ROOT)
    assert not failures, "\n".join(failures)


def test_a_failing_block_is_reported_with_its_line_and_stderr(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text("# A project\n\n```python\nimport tracecheck\nprint('fine')\n```\n\n"
                      "Text.\n\n```bash\nexit 1\n```\n\n```python\nx = 1\nraise SystemExit("
                      "f'broken {x}')\n```\n", encoding="utf-8")
    assert [line for line, _ in blocks(readme.read_text(), "python")] == [4, 15]
    assert python_failures(readme, tmp_path) == [
        "README.md:15: the Python block exits with 1:\nbroken 1\n"]


# ------------------------------------------------------------------ the shell commands exist


def tracecheck_commands(text: str) -> list[tuple[int, list[str]]]:
    """(line, arguments) of every ``tracecheck …`` command in the shell blocks of ``text``
    (after ``&&``, ``;`` or ``|`` too), without redirections and comments."""
    found = []
    for start, code in blocks(text, "bash"):
        for offset, line in enumerate(code.splitlines()):
            lexer = shlex.shlex(line, posix=True, punctuation_chars=True)
            lexer.whitespace_split = True
            words = list(lexer)
            command: list[str] | None = None
            for word in words + [";"]:
                if word in ("&&", ";", "|", "||", "&") or word.startswith((">", "<")):
                    if command is not None:
                        found.append((start + offset, command))
                    command = None
                elif command is not None:
                    command.append(word)
                elif word == "tracecheck" or word.endswith("/tracecheck"):
                    command = []
    return found


# typer carries its own copy of click (typer._click): its classes are recognised by what they
# have, not by isinstance against the click package


def _is_group(command) -> bool:
    return hasattr(command, "commands")


def _takes_value(option) -> bool:
    return not option.is_flag and not option.count


def misused(args: list[str]) -> list[str]:
    """What is wrong with ``tracecheck ARGS`` for the command line's parser: an unknown
    command or option, a value outside an option's choices, too many arguments."""
    command = typer.main.get_command(app)
    path = ["tracecheck"]
    args = list(args)
    problems = []
    while True:
        options = {o: p for p in command.params for o in (*p.opts, *p.secondary_opts)
                   if p.param_type_name == "option"}
        positional: list[str] = []
        while args:
            word = args.pop(0)
            if word == "--help":
                continue
            if word.startswith("-") and len(word) > 1:
                name, _, value = word.partition("=")
                param = options.get(name)
                if param is None:
                    problems.append(f"{' '.join(path)} has no option {name}")
                    continue
                if _takes_value(param) and not value:
                    value = args.pop(0) if args else ""
                    if not value:
                        problems.append(f"{' '.join(path)} {name} needs a value")
                choices = getattr(param.type, "choices", None)
                if choices and value and value not in choices:
                    problems.append(f"{' '.join(path)} {name} {value}: not one of "
                                    f"{', '.join(map(str, choices))}")
            elif _is_group(command):
                positional.append(word)
                break
            else:
                positional.append(word)
        if _is_group(command):
            if not positional:
                return problems + [f"{' '.join(path)} needs a command"]
            sub = command.commands.get(positional[0])
            if sub is None:
                return problems + [f"{' '.join(path)} has no command {positional[0]}"]
            command, path = sub, [*path, positional[0]]
            continue
        arguments = [p for p in command.params if p.param_type_name == "argument"]
        if all(p.nargs >= 0 for p in arguments) and \
                len(positional) > sum(p.nargs for p in arguments):
            problems.append(f"{' '.join(path)} takes {sum(p.nargs for p in arguments)} "
                            f"argument(s), not {len(positional)}: {positional}")
        return problems


def test_the_readme_has_tracecheck_commands():
    """The "More to try" block, with the quick start's: more than a handful."""
    assert len(tracecheck_commands(README.read_text(encoding="utf-8"))) >= 10


@pytest.mark.parametrize("line,args", [
    pytest.param(line, args, id=f"line{line}-{k}-{args[0] if args else ''}")
    for k, (line, args) in enumerate(tracecheck_commands(README.read_text(encoding="utf-8")))])
def test_every_readme_command_names_real_commands_and_options(line, args):
    problems = misused(args)
    assert not problems, f"README.md:{line}: tracecheck {shlex.join(args)}\n" + \
        "\n".join(problems)


def test_a_wrong_command_or_option_is_found():
    text = ("```bash\n"
            ".venv/bin/tracecheck replay runs/a.mcap --shield paper --format csv > x.csv  # ok\n"
            "tracecheck replay a.mcap --sheild paper && tracecheck import simb x -o y.mcap\n"
            "tracecheck replay a.mcap --format html\n"
            "tracecheck import sim x -o y.mcap; tracecheck frobnicate\n"
            "tracecheck check-model paper extra\n"
            "```\n")
    found = tracecheck_commands(text)
    assert [line for line, _ in found] == [2, 3, 3, 4, 5, 5, 6]
    assert found[0][1] == ["replay", "runs/a.mcap", "--shield", "paper", "--format", "csv"]
    assert [misused(args) for _, args in found] == [
        [], ["tracecheck replay has no option --sheild"], [],
        ["tracecheck replay --format html: not one of text, md, csv, json"],
        ["tracecheck import has no command sim"], ["tracecheck has no command frobnicate"],
        ["tracecheck check-model takes 1 argument(s), not 2: ['paper', 'extra']"]]
