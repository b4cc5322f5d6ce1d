"""Benchmark: statistics over 4 runs x 1000 episodes with the highway property set.

Target (issue 6): <= 2 s after the files are read.

    python benchmarks/bench_stats.py [--episodes 1000] [--repeat 3]

The four files hold the paper's 40 SimB traces copied round-robin (real ProB output).
Prints the median time spent reading the files and the median time of everything else
(evaluating the 11 formulas of the set on every state, aggregating, intervals, tests, the
paired comparisons).
"""

from __future__ import annotations

import argparse
import statistics as st
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_replay import SIMB, build  # noqa: E402

from tracecheck.episodes import read_columns  # noqa: E402
from tracecheck.stats.properties import load_properties  # noqa: E402

HIGHWAY_SET = load_properties("highway")
from tracecheck.stats.estimates import statistics  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    if not SIMB.is_dir():
        raise SystemExit(f"the paper's traces are not at {SIMB}")
    with tempfile.TemporaryDirectory() as tmp:
        paths = []
        for i in range(4):
            path = Path(tmp) / f"run{i}.mcap"
            build(path, args.episodes)
            paths.append(path)
        statistics(paths, HIGHWAY_SET)  # plan the formulas once
        reads, after = [], []
        for _ in range(args.repeat):
            t = time.perf_counter()
            cols = [read_columns(p) for p in paths]
            reads.append(time.perf_counter() - t)
            result = statistics(paths, HIGHWAY_SET, columns=cols)
            after.append(result["statistics_s"])
    read, rest = st.median(reads), st.median(after)
    episodes = sum(r["episodes"] for r in result["runs"])
    print(f"4 runs, {episodes} episodes, {len(result['comparisons'])} paired comparison(s)")
    print(f"reading the files: median {read:.2f} s")
    print(f"statistics after reading: median {rest:.2f} s; target <= 2 s")


if __name__ == "__main__":
    main()
