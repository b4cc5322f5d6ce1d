"""Shared fixtures: tiny machines, and the paper's traces from ../shared (skipped if absent)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tracecheck.b.machine import load_machine, load_machine_text
from tracecheck.b.values import parse_literal

ROOT = Path(__file__).resolve().parents[1]
PAPER_SHIELD = ROOT / "models" / "shields" / "paper.mch"
PAPER_TRACES = ROOT.parent / "shared" / "data" / "paper-traces"

COIN_TOSS = """
MACHINE CoinToss
SETS Side = {Heads, Tails, None}
VARIABLES lastToss
INVARIANT lastToss ∈ Side
INITIALISATION lastToss := None
OPERATIONS
  toss = lastToss :∈ {Heads, Tails}
END
"""


@pytest.fixture(scope="session")
def table1():
    """The paper's Table 1 shield over its state vocabulary."""
    return load_machine(PAPER_SHIELD)


@pytest.fixture(scope="session")
def coin_toss():
    return load_machine_text(COIN_TOSS, file="CoinToss.mch")


@pytest.fixture(scope="session")
def paper_traces() -> Path:
    if not PAPER_TRACES.is_dir():
        pytest.skip(f"the paper's traces are not at {PAPER_TRACES}")
    return PAPER_TRACES


def simb_states(path: Path) -> list[tuple[str, dict]]:
    """(operation, state after it) for each activation of a SimB trace that has a state."""
    data = json.loads(path.read_text())
    out = []
    for act in data["activations"]:
        if act.get("fixedVariables"):
            state = {k: parse_literal(v) for k, v in act["fixedVariables"].items()}
            out.append((act["execute"], state))
    return out
