"""A short command starts fast: it imports only what it uses (checked in a fresh process)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.helpers import ROOT

HEAVY = {"scipy", "matplotlib", "torch", "gymnasium", "highway_env", "stable_baselines3",
         "ray", "pandas", "mcap", "numpy", "orjson"}
SCRIPT = """
import json, sys
from tracecheck.cli import main
try:
    main({args!r})
except SystemExit:
    pass
print(json.dumps(sorted({{m.split('.')[0] for m in sys.modules}})), file=sys.stderr)
"""


def imported(*args: str) -> set[str]:
    proc = subprocess.run([sys.executable, "-c", SCRIPT.format(args=list(args))],
                          capture_output=True, text=True, cwd=ROOT, timeout=120)
    return set(json.loads(proc.stderr.strip().splitlines()[-1]))


@pytest.mark.parametrize("args,allowed", [
    (("eval", "1 = 1"), set()),
    (("--help",), set()),
    (("replay", "sample_traces/base_paper.mcap", "--shield", "paper"),
     {"numpy", "orjson"}),
], ids=["eval", "help", "replay"])
def test_a_command_imports_only_what_it_needs(args, allowed):
    heavy = imported(*args) & HEAVY
    assert heavy <= allowed, sorted(heavy - allowed)


def test_eval_imports_neither_pydantic_nor_rich():
    """~60 ms of a 0.2 s start: typer 0.29 validates options with pydantic (so typer is held
    below 0.29), and rich is made only when something is printed through it."""
    modules = imported("eval", "1 = 1")
    assert not modules & {"pydantic", "pydantic_core", "rich"}, sorted(modules)


def test_python_dash_m_tracecheck_is_the_command_line():
    """``python -m tracecheck`` was 'No module named tracecheck.__main__'."""
    proc = subprocess.run([sys.executable, "-m", "tracecheck", "eval", "1 + 1 = 2"],
                          capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert (proc.returncode, proc.stdout, proc.stderr) == (0, "TRUE\n", "")
