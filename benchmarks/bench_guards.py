"""Benchmark: five Table-1-style guards on one 5-vehicle state (scalar) and on many (batch).

Targets (issue 2): <= 50 µs per state on the scalar path, >= 10^6 states/s on the batch path.

    python benchmarks/bench_guards.py [--repeat 7] [--rows 1000000]

The state is the first state of the paper's trace ``simb/base/Timed_Simulation_1.json`` when
``../shared/data/paper-traces`` is present, else a fixed synthetic one. The batch rows are
that state and variations of it (random positions and speeds, fixed seed). Prints medians.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np

from tracecheck.b.machine import load_machine
from tracecheck.b.notation import parse_literal
from tracecheck.b.values import FuncValue
from tracecheck.b.columns import Columns

ROOT = Path(__file__).resolve().parents[1]
SHIELD = ROOT / "models" / "shields" / "paper.mch"
TRACE = ROOT.parent / "shared" / "data" / "paper-traces" / "simb" / "base" / \
    "Timed_Simulation_1.json"


def first_state(machine) -> dict:
    if TRACE.exists():
        acts = json.loads(TRACE.read_text())["activations"]
        fixed = next(a["fixedVariables"] for a in acts if a.get("fixedVariables"))
        return {k: parse_literal(v) for k, v in fixed.items()}
    vs = machine.sets["Vehicles"]
    fn = lambda xs: FuncValue(dict(zip(vs, xs)))  # noqa: E731
    return {"Crash": False, "PresentVehicles": frozenset(vs), "Reward": 0.0,
            "VehiclesX": fn([150.0, 21.9, 44.8, 68.4, 91.5]),
            "VehiclesY": fn([8.0, 0.0, -4.0, 0.0, -8.0]),
            "VehiclesVx": fn([25.0, -2.8, -3.0, -3.2, -1.7]),
            **{k: fn([0.0] * 5) for k in ("VehiclesVy", "VehiclesAx", "VehiclesAy")}}


def columns(machine, state: dict, rows: int) -> Columns:
    base = Columns.from_states([state], machine.sets["Vehicles"])
    rng = np.random.default_rng(0)
    k = len(base.elements)
    cols = Columns(n=rows, elements=base.elements)
    cols.booleans = {n: np.repeat(a, rows) for n, a in base.booleans.items()}
    cols.numbers = {n: np.repeat(a, rows) for n, a in base.numbers.items()}
    cols.masks = {n: np.repeat(a, rows, axis=0) for n, a in base.masks.items()}
    for name, (vals, defined) in base.functions.items():
        noise = rng.normal(0.0, 20.0 if name in ("VehiclesX",) else 2.0, size=(rows, k))
        cols.functions[name] = (vals + noise, np.repeat(defined, rows, axis=0))
    return cols


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--rows", type=int, default=1_000_000)
    args = parser.parse_args()
    machine = load_machine(SHIELD)
    state = first_state(machine)
    assert len(machine.operations) == 5
    machine.enabled(state)  # compile once

    per_state = []
    inner = 2000
    for _ in range(args.repeat):
        t = time.perf_counter()
        for _ in range(inner):
            machine.enabled(state)
        per_state.append((time.perf_counter() - t) / inner * 1e6)

    cols = columns(machine, state, args.rows)
    machine.enabled_batch(columns(machine, state, 10))  # plan once
    batch = []
    for _ in range(args.repeat):
        t = time.perf_counter()
        machine.enabled_batch(cols)
        batch.append(args.rows / (time.perf_counter() - t))

    scalar_med, batch_med = statistics.median(per_state), statistics.median(batch)
    print(f"state source: {'paper trace' if TRACE.exists() else 'synthetic'}; "
          f"guards: {', '.join(machine.operations)}; repeats: {args.repeat}")
    print(f"scalar: median {scalar_med:.1f} µs per state for all five guards "
          f"(min {min(per_state):.1f}, max {max(per_state):.1f}); target <= 50 µs")
    print(f"batch:  median {batch_med:,.0f} states/s over {args.rows:,} states "
          f"(min {min(batch):,.0f}, max {max(batch):,.0f}); target >= 1,000,000")
    print(f"batch speed-up over scalar: {batch_med * scalar_med / 1e6:.0f}x")


if __name__ == "__main__":
    main()
