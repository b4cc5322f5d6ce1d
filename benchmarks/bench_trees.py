"""Benchmark: two source trees of tracecheck on the same work, interleaved — for a change
that should not change speed (a refactoring), the old tree is the baseline of the same run.

    python benchmarks/bench_trees.py --before /path/to/old/checkout [--after .]
        [--episodes 10000] [--repeat 5] [--only TASK …]

Each measurement is a fresh process with ``PYTHONPATH`` set to one tree (the trees take
turns, so machine noise falls on both): ``tracecheck replay RUN --shield paper --json`` and
``tracecheck stats RUN --json`` on a campaign-sized file (``--episodes`` of the paper's SimB
traces, written once by the new tree), reading its columns alone, and the start-up of
``tracecheck eval '1 = 1'``. Printed per task: the median wall time and peak resident memory
of each tree, and after / before. The run file is written with the new tree and read by
both (the format did not change).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: each task: the code a process runs (RUN is the run file); it prints nothing we read
TASKS = {
    "replay --shield paper": "from tracecheck.cli import main\n"
                             "main(['replay', RUN, '--shield', 'paper', '--json'])",
    "stats": "from tracecheck.cli import main\nmain(['stats', RUN, '--json'])",
    "read the columns": "from tracecheck.episodes import read_columns\nread_columns(RUN)",
    "eval '1 = 1' (start-up)": "from tracecheck.cli import main\nmain(['eval', '1 = 1'])",
}

#: runs the task in this process and reports its wall time and peak memory on stderr
WRAPPER = """
import json, resource, sys, time
RUN = sys.argv[1]
start = time.perf_counter()
try:
    exec(compile(sys.argv[2], "<task>", "exec"))
except SystemExit:
    pass
wall = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
print(json.dumps({"wall": wall, "peak_kib": peak}), file=sys.stderr)
"""


def measure(tree: Path, code: str, run: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree)}
    proc = subprocess.run([sys.executable, "-c", WRAPPER, str(run), code], env=env,
                          cwd=tree, capture_output=True, text=True, timeout=900)
    if proc.returncode:
        raise SystemExit(f"{tree}: the task failed:\n{proc.stderr[-2000:]}")
    return json.loads(proc.stderr.strip().splitlines()[-1])


def build(tree: Path, run: Path, episodes: int) -> None:
    code = ("import sys; sys.path.insert(0, 'benchmarks'); from bench_replay import build; "
            f"from pathlib import Path; build(Path({str(run)!r}), {episodes})")
    subprocess.run([sys.executable, "-c", code], cwd=tree, check=True,
                   env={**os.environ, "PYTHONPATH": str(tree)})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path, required=True, help="the baseline checkout")
    parser.add_argument("--after", type=Path, default=ROOT, help="the new checkout")
    parser.add_argument("--episodes", type=int, default=10_000)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--only", choices=list(TASKS), action="append",
                        help="only these tasks (default: all)")
    args = parser.parse_args()
    trees = {"before": args.before.resolve(), "after": args.after.resolve()}
    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "campaign.mcap"
        build(trees["after"], run, args.episodes)
        print(f"{args.episodes} episodes, {run.stat().st_size / 1e6:.0f} MB; medians of "
              f"{args.repeat} interleaved runs per tree")
        print(f"{'task':26} {'before':>9} {'after':>9} {'ratio':>6}   peak memory before / "
              "after (ratio)")
        for name, code in TASKS.items():
            if args.only and name not in args.only:
                continue
            got: dict[str, list[dict]] = {"before": [], "after": []}
            for _ in range(args.repeat):
                for which, tree in trees.items():
                    got[which].append(measure(tree, code, run))
            wall = {w: statistics.median(r["wall"] for r in got[w]) for w in got}
            peak = {w: statistics.median(r["peak_kib"] for r in got[w]) / 1024 for w in got}
            print(f"{name:26} {wall['before']:8.3f}s {wall['after']:8.3f}s "
                  f"{wall['after'] / wall['before']:6.2f}   {peak['before']:.0f} / "
                  f"{peak['after']:.0f} MiB ({peak['after'] / peak['before']:.2f})")


if __name__ == "__main__":
    main()
