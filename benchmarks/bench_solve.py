"""``tracecheck eval`` solving for free identifiers (issue 27): SEND+MORE=MONEY and a few
smaller problems, each a whole fresh process, next to ``eval '1 = 1'`` (no solver: z3 is
not imported) measured in the same run.

    python benchmarks/bench_solve.py [--repeat 3]

Prints the median wall time of each command (target: SEND+MORE under 10 s) and checks the
answer it printed.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

SEND_MORE = ("{S,E,N,D,M,O,R,Y} <: 0..9 & card({S,E,N,D,M,O,R,Y}) = 8 & S /= 0 & M /= 0 & "
             "S*1000+E*100+N*10+D + M*1000+O*100+R*10+E = M*10000+O*1000+N*100+E*10+Y")

#: name: (arguments of eval, what the output starts with)
PROBLEMS = {
    "eval '1 = 1' (no solver)": (["1 = 1"], "TRUE"),
    "x*x = 100 & x < 0 (z3)": (["x*x = 100 & x < 0"], "TRUE\nx = -10"),
    "x : 1..1000 & x*x = 2401 (walk)": (["x : 1..1000 & x*x = 2401"], "TRUE\nx = 49"),
    "SEND+MORE=MONEY": ([SEND_MORE], "TRUE\nS = 9\nE = 5\nN = 6\nD = 7\nM = 1\nO = 0\nR = 8\n"
                                     "Y = 2"),
    "SEND+MORE=MONEY --all": ([SEND_MORE, "--all"], "TRUE\nS = 9 & E = 5 & N = 6 & D = 7 & "
                                                    "M = 1 & O = 0 & R = 8 & Y = 2\n"
                                                    "1 solution: all of them"),
}


def _tracecheck() -> list[str]:
    script = Path(sys.executable).with_name("tracecheck")
    if script.exists():
        return [str(script)]
    found = shutil.which("tracecheck")
    return [found] if found else [sys.executable, "-m", "tracecheck"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    tc = _tracecheck()
    times: dict[str, list[float]] = {name: [] for name in PROBLEMS}
    for _ in range(args.repeat):
        for name, (argv, expected) in PROBLEMS.items():
            start = time.perf_counter()
            proc = subprocess.run([*tc, "eval", *argv], capture_output=True, text=True)
            times[name].append(time.perf_counter() - start)
            if proc.returncode != 0 or not proc.stdout.startswith(expected):
                raise SystemExit(f"{name}: exit {proc.returncode}, printed\n{proc.stdout}"
                                 f"{proc.stderr}")
    for name, values in times.items():
        print(f"{name:36} median {statistics.median(values):.2f} s  "
              f"(of {len(values)}: {', '.join(f'{v:.2f}' for v in values)})")


if __name__ == "__main__":
    main()
