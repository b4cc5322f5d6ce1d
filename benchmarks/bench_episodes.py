"""Benchmark: import 1000 SimB traces, and read a 1000-episode file into the columnar view.

Targets (issue 3): import of 1000 SimB traces (~65 MB of JSON, ~40 000 steps) <= 20 s;
reading a 1000-episode MCAP file into the columnar view <= 0.5 s.

    python benchmarks/bench_episodes.py [--traces 1000] [--repeat 5]

The 1000 traces are the paper's 40 SimB traces (../shared/data/paper-traces/simb) copied
round-robin into a temporary folder, so they are real ProB output. Prints medians.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from tracecheck.episodes import read_columns, read_run
from tracecheck.episodes.files import write_run
from tracecheck.episodes.writer import new_header
from tracecheck.live.envs.highway import HIGHWAY
from tracecheck.interop import import_simb

ROOT = Path(__file__).resolve().parents[1]
SIMB = ROOT.parent / "shared" / "data" / "paper-traces" / "simb"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--traces", type=int, default=1000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    sources = sorted(SIMB.glob("*/*.json"))
    if not sources:
        raise SystemExit(f"the paper's traces are not at {SIMB}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "traces"
        folder.mkdir()
        for i in range(args.traces):
            shutil.copy(sources[i % len(sources)], folder / f"Timed_Simulation_{i + 1}.json")
        size = sum(p.stat().st_size for p in folder.iterdir()) / 1e6
        out = Path(tmp) / "run.mcap"
        header = new_header("imported-simb", model_name=HIGHWAY.name,
                            variables=list(HIGHWAY.variables), actions=list(HIGHWAY.actions))
        imports = []
        for _ in range(max(1, args.repeat // 2)):
            t = time.perf_counter()
            episodes, steps, _ = write_run(out, header, import_simb([folder], vocab=HIGHWAY), force=True)
            imports.append(time.perf_counter() - t)
        reads = []
        for _ in range(args.repeat):
            t = time.perf_counter()
            cols = read_columns(out)
            reads.append(time.perf_counter() - t)
        t = time.perf_counter()
        run = read_run(out)
        full = time.perf_counter() - t
        mb = out.stat().st_size / 1e6
    assert cols.n == steps + episodes and len(run.episodes) == episodes
    print(f"{args.traces} SimB traces, {size:.1f} MB of JSON, {steps} steps -> {mb:.1f} MB MCAP")
    print(f"import:        median {statistics.median(imports):.2f} s over {len(imports)} run(s) "
          f"(min {min(imports):.2f}); target <= 20 s")
    print(f"columnar view: median {statistics.median(reads) * 1000:.0f} ms over {args.repeat} "
          f"reads (min {min(reads) * 1000:.0f} ms) for {cols.n} states; target <= 500 ms")
    print(f"full decode of every step message (read_run): {full:.2f} s")


if __name__ == "__main__":
    main()
