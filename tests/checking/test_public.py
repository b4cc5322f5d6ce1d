"""The public face of tracecheck.checking: its names are the functions and classes of their
modules, whatever was imported before, and loading one does not load the others."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

import tracecheck.checking as checking
from tests.helpers import ROOT


@pytest.mark.parametrize("name", checking.__all__)
def test_each_name_is_its_module_s(name):
    import importlib

    module = importlib.import_module(f"tracecheck.checking.{checking._WHERE[name]}")
    assert getattr(checking, name) is getattr(module, name)
    assert name in dir(checking)


def _fresh(code: str) -> dict:
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_a_submodule_imported_first_does_not_hide_its_function():
    """``diff`` imports ``replay``'s module, the CLI imports ``prove``'s: the package's
    names stay the functions."""
    got = _fresh("import json, tracecheck.checking.diffing, tracecheck.checking.proving\n"
                 "from tracecheck.checking import diff, prove, replay\n"
                 "print(json.dumps([type(f).__name__ for f in (diff, prove, replay)]))")
    assert got == ["function"] * 3


def test_replay_through_the_package_loads_no_solver():
    got = _fresh("import json, sys\n"
                 "from tracecheck.checking import load_shield, replay\n"
                 "r = replay(['sample_traces/base_paper.mcap'], load_shield('paper'))\n"
                 "print(json.dumps([r.episodes, sorted({'z3', 'torch', 'gymnasium'}"
                 " & set(sys.modules)), 'tracecheck.checking.proving' in sys.modules]))")
    assert got == [24, [], False]


def test_prove_and_symbolic_diff_take_a_shield_as_replay_and_diff_do():
    pytest.importorskip("z3")
    from tracecheck.checking import load_shield, prove, symbolic_diff

    paper, strict = load_shield("paper"), load_shield("strict")
    by_shield = [(r.obligation, r.status) for r in prove(paper, deadlock_free=True, timeout_s=30)]
    assert by_shield == [(r.obligation, r.status)
                         for r in prove(paper.machine, deadlock_free=True, timeout_s=30)]
    assert by_shield == [("deadlock-free", "proved")]
    assert [r.status for r in symbolic_diff(strict, paper, timeout_s=30)] == \
        [r.status for r in symbolic_diff(strict.machine, paper.machine, timeout_s=30)]
