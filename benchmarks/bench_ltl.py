"""Benchmark: LTL formulas over a 1000-episode file, against the position-by-position
reference semantics on the same episodes (the same run).

    python benchmarks/bench_ltl.py [--episodes 1000] [--repeat 5]

The file holds the paper's SimB traces imported round-robin (see bench_replay.py). The
formula has three nested temporal operators over state atoms, an action and a shield atom.
Its atoms are evaluated once for the reference (which then walks positions in Python), so the
comparison is between the scans and the plain definition. Target (issue 15): >= 200 000
steps/s for the scans.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_replay import build  # noqa: E402

from tracecheck.checking.ltl import _Rows, _evaluator, check_ltl, parse_ltl, reference_ltl  # noqa: E402,E501
from tracecheck.checking.shield import load_shield  # noqa: E402
from tracecheck.episodes import read_columns  # noqa: E402

FORMULA = "G({Crash = FALSE} => (F[0,5] X e(FASTER) or ({Crash = FALSE} U [SLOWER])))"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    shield = load_shield("paper")
    machine = shield.machine
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.mcap"
        build(path, args.episodes)
        cols = read_columns(path)
    f = parse_ltl(FORMULA, machine)
    enabled = machine.enabled_batch(cols.states)
    times = []
    for _ in range(args.repeat):
        start = time.perf_counter()
        result = check_ltl("bench", FORMULA, f, cols, machine, enabled)
        times.append(time.perf_counter() - start)
    steps = cols.n - len(cols.episode_ids)
    # the reference on the same episodes: atoms from the same values, positions in Python
    ev = _evaluator(_Rows(cols.starts), cols, machine, enabled)
    crash_free = ev(f.args[0].args[0])
    start = time.perf_counter()
    satisfied = 0
    for i in range(len(cols.episode_ids)):
        lo, hi = int(cols.starts[i]), int(cols.starts[i + 1])
        trace = [{"atoms": {"Crash = FALSE": bool(crash_free[r])},
                  "action": cols.action_names[cols.action[r]] if cols.action[r] >= 0 else None,
                  "enabled": {o for o in enabled if enabled[o][r]}, "before_after": {}}
                 for r in range(lo, hi)]
        satisfied += reference_ltl(f, trace)[0]
    reference_s = time.perf_counter() - start
    assert satisfied == result.satisfied, (satisfied, result.satisfied)
    med = statistics.median(times)
    print(f"{result.episodes} episodes, {steps} steps; {FORMULA}: {result.satisfied} satisfy it")
    print(f"scans:     median {steps / med:,.0f} steps/s over {args.repeat} runs "
          f"({med * 1000:.1f} ms); target >= 200,000")
    print(f"reference: {steps / reference_s:,.0f} steps/s (one run): the scans are "
          f"{reference_s / med:.0f}x faster, same answer")


if __name__ == "__main__":
    main()
