"""Benchmark: replay and diff of a 1000-episode file, batch path against per-state path.

Targets (issue 4): replay with the ``paper`` shield at >= 200 000 steps/s (reading + checking,
as ``elapsed_s`` counts it) on a 1000-episode file, every guard evaluated on every state;
diff at least half that.

    python benchmarks/bench_replay.py [--episodes 1000] [--repeat 5]

The file holds the paper's 40 SimB traces imported round-robin (real ProB output). The
per-state path evaluates the same guards, invariant and postconditions with the scalar
evaluator, one state at a time, on the same file. Prints medians and the ratio.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from itertools import cycle, islice
from pathlib import Path

from tracecheck.episodes import read_columns
from tracecheck.episodes.files import write_run
from tracecheck.episodes.writer import new_header
from tracecheck.episodes.model import HIGHWAY
from tracecheck.interop import import_simb
from tracecheck.checking.replay import diff, replay
from tracecheck.checking.shield import load_shield

ROOT = Path(__file__).resolve().parents[1]
SIMB = ROOT.parent / "shared" / "data" / "paper-traces" / "simb"


def build(path: Path, episodes: int) -> None:
    sources = list(import_simb([SIMB / "base", SIMB / "base_shield"]))
    import dataclasses

    eps = (dataclasses.replace(e, id=i) for i, e in enumerate(islice(cycle(sources), episodes)))
    write_run(path, new_header("imported-simb", variables=list(HIGHWAY.variables),
                               actions=list(HIGHWAY.actions)), eps)


def per_state(path: Path, shield) -> tuple[int, float]:
    """The same checks, one state at a time with the scalar evaluator."""
    start = time.perf_counter()
    cols = read_columns(path)
    machine = shield.machine
    steps = 0
    for i in range(len(cols.episode_ids)):
        lo, hi = int(cols.starts[i]), int(cols.starts[i + 1])
        states = [cols.states.row(r) for r in range(lo, hi)]
        for k, state in enumerate(states):
            machine.enabled(state)
            machine.invariant(state)
            if k:
                steps += 1
                machine.effect_ok(cols.action_names[cols.action[lo + k]], states[k - 1], state)
    return steps, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    if not SIMB.is_dir():
        raise SystemExit(f"the paper's traces are not at {SIMB}")
    paper, none, strict = load_shield("paper"), load_shield("none"), load_shield("strict")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.mcap"
        build(path, args.episodes)
        replay([path], paper)  # compile once, as any long-lived use would
        diff([path], paper, none)
        batch, diffs = [], []
        for _ in range(args.repeat):
            report = replay([path], paper)
            batch.append(report.steps / report.elapsed_s)
            d = diff([path], paper, none)
            diffs.append(d.steps / d.elapsed_s)
        replay([path], strict)
        stricts = []
        for _ in range(args.repeat):
            r = replay([path], strict)
            stricts.append(r.steps / r.elapsed_s)
        steps, scalar_s = per_state(path, paper)
    scalar = steps / scalar_s
    med, dmed = statistics.median(batch), statistics.median(diffs)
    print(f"{report.episodes} episodes, {report.steps} steps, {report.infeasible_steps} "
          f"infeasible under paper")
    print(f"replay (batch):     median {med:,.0f} steps/s over {args.repeat} runs "
          f"(min {min(batch):,.0f}); target >= 200,000")
    print(f"diff paper vs none: median {dmed:,.0f} steps/s (min {min(diffs):,.0f}); "
          f"target >= {med / 2:,.0f} (half of replay)")
    print(f"replay (per state): {scalar:,.0f} steps/s (one run, {scalar_s:.1f} s)")
    print(f"replay with strict (RSS, nested quantifiers): median "
          f"{statistics.median(stricts):,.0f} steps/s")
    print(f"batch / per-state:  {med / scalar:.0f}x")


if __name__ == "__main__":
    main()
