"""Benchmark: tune's whole front (every value of a shield number at once) against one replay of
the same episodes, side by side in the same run (medians of interleaved runs: a ratio), with
peak memory, and how tune's cost grows with the episodes.

    python benchmarks/bench_tune.py [--episodes 1000] [--repeat 5]

Two files of ``--episodes`` episodes: the paper's 40 SimB traces imported round-robin (real
ProB output, as bench_replay.py; 1000 episodes are 25 copies of each, and tune computes a
state's set once), and the same with every position jittered by up to 1 mm (every state
distinct: the cost of states never seen before). Cases: the paper's FASTER distance (a
literal of one guard), its IDLE distance, and the RSS shield's vehicle length (a constant all
five guards read).
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import tempfile
import time
import tracemalloc
from itertools import cycle, islice
from pathlib import Path

import numpy as np

from tracecheck.b.values import FuncValue
from tracecheck.checking.replaying import replay
from tracecheck.checking.shield import load_shield
from tracecheck.episodes.files import write_run
from tracecheck.episodes.writer import new_header
from tracecheck.interop import import_simb
from tracecheck.live.envs.highway import HIGHWAY
from tracecheck.search.tune_target import resolve_target
from tracecheck.search.tuning import tune

ROOT = Path(__file__).resolve().parents[1]
SIMB = ROOT.parent / "shared" / "data" / "paper-traces" / "simb"
CASES = [("paper", {"literal": "FASTER:40.0"}, 20.0, 60.0),
         ("paper", {"literal": "IDLE:30.0"}, 10.0, 50.0),
         ("strict", {"param": "VehLen"}, 2.0, 8.0)]


def build(path: Path, episodes: int, jitter: bool) -> None:
    sources = list(import_simb([SIMB / "base", SIMB / "base_shield"], vocab=HIGHWAY))
    rng = np.random.default_rng(0)

    def moved(step):
        x = step.state["VehiclesX"]
        shifted = FuncValue({k: v + float(rng.uniform(-1e-3, 1e-3)) for k, v in x.map.items()})
        return dataclasses.replace(step, state={**step.state, "VehiclesX": shifted})

    eps = []
    for i, e in enumerate(islice(cycle(sources), episodes)):
        steps = tuple(moved(s) for s in e.steps) if jitter else e.steps
        eps.append(dataclasses.replace(e, id=i, steps=steps))
    write_run(path, new_header("imported-simb", variables=list(HIGHWAY.variables),
                               actions=list(HIGHWAY.actions)), eps)


def _peak(fn, *args) -> float:
    """The peak of Python's allocations (MiB) while ``fn(*args)`` runs."""
    tracemalloc.start()
    try:
        fn(*args)
        return tracemalloc.get_traced_memory()[1] / 2 ** 20
    finally:
        tracemalloc.stop()


def measure(path: Path, repeat: int) -> list[dict]:
    rows = []
    for shield_name, spec, low, high in CASES:
        shield = load_shield(shield_name)
        target = resolve_target(shield.machine, **spec)
        replay([path], shield)  # compiled once, as in a session
        rp, tn, pieces = [], [], 0
        for _ in range(repeat):  # interleaved: noise hits both alike
            start = time.perf_counter()
            replay([path], shield)
            rp.append(time.perf_counter() - start)
            start = time.perf_counter()
            result = tune([path], shield, target, low, high)
            tn.append(time.perf_counter() - start)
            pieces = len(result.pieces)
        rows.append({"case": f"{shield_name} {target.label} in {low:g}..{high:g}",
                     "replay_s": statistics.median(rp), "tune_s": statistics.median(tn),
                     "pieces": pieces, "front": len(result.front),
                     "replay_mib": _peak(replay, [path], shield),
                     "tune_mib": _peak(tune, [path], shield, target, low, high)})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    if not SIMB.is_dir():
        raise SystemExit(f"the paper's traces are not at {SIMB}")
    with tempfile.TemporaryDirectory() as tmp:
        for jitter in (False, True):
            path = Path(tmp) / f"run{int(jitter)}.mcap"
            build(path, args.episodes, jitter)
            kind = "every state distinct (jittered)" if jitter else "the paper's traces"
            print(f"{args.episodes} episodes, {kind}; medians of {args.repeat} interleaved runs")
            for r in measure(path, args.repeat):
                print(f"  {r['case']:<38} replay {r['replay_s']:.3f} s, tune (whole front, "
                      f"{r['pieces']} pieces) {r['tune_s']:.3f} s = "
                      f"{r['tune_s'] / r['replay_s']:.1f}x; peak {r['replay_mib']:.0f} / "
                      f"{r['tune_mib']:.0f} MiB")
        print("growth, every state distinct: tune's time by episodes")
        for n in (args.episodes // 4, args.episodes // 2, args.episodes):
            path = Path(tmp) / f"grow{n}.mcap"
            build(path, n, True)
            line = []
            for r in measure(path, max(1, args.repeat // 2)):
                line.append(f"{r['case'].split(' in ')[0]} {r['tune_s']:.2f} s "
                            f"({r['tune_s'] / r['replay_s']:.1f}x replay)")
            print(f"  {n:>5} episodes: " + "; ".join(line))


if __name__ == "__main__":
    main()
