"""The code keeps the ruff rules of pyproject.toml ([tool.ruff]), with the pinned ruff of the
``test`` extra."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.helpers import ROOT


def test_ruff_finds_nothing():
    pytest.importorskip("ruff", reason="ruff is not installed (pip install -e '.[test]')")
    proc = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache",
                           "tracecheck", "tests", "benchmarks"],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    if proc.returncode != 0:
        pytest.fail(proc.stdout + proc.stderr, pytrace=False)


def test_ruff_reads_the_configuration(tmp_path):
    """The rules are those of pyproject.toml: an unused import is found in a file of the
    repository, and a typer option as a default is not (bugbear told about typer)."""
    pytest.importorskip("ruff", reason="ruff is not installed (pip install -e '.[test]')")
    code = ("import os\nimport typer\n\n\ndef f(x: int = typer.Option(1)):\n"
            "    return x\n")
    proc = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache",
                           "--stdin-filename", "tracecheck/cli/example.py", "-"],
                          input=code, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 1 and "F401" in proc.stdout and "B008" not in proc.stdout, \
        proc.stdout + proc.stderr
