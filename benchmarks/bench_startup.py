"""Start-up of short commands, as whole processes, next to ``python -c "import numpy"`` measured
in the same run (interleaved, so a busy machine slows both alike).

    python benchmarks/bench_startup.py [--repeat 11]

Prints the median wall time of each command and its ratio to the numpy baseline (issue 14's
targets: ``eval '1 = 1'`` at most 3x the baseline, ``--help`` at most 0.2 s).
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path


def _tracecheck() -> list[str]:
    script = Path(sys.executable).with_name("tracecheck")
    if script.exists():
        return [str(script)]
    found = shutil.which("tracecheck")
    if found is None:
        raise SystemExit("tracecheck is not installed next to this Python or on PATH")
    return [found]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=11)
    args = parser.parse_args()
    tc = _tracecheck()
    commands = {
        'python -c "import numpy"': [sys.executable, "-c", "import numpy"],
        "tracecheck eval '1 = 1'": [*tc, "eval", "1 = 1"],
        "tracecheck --help": [*tc, "--help"],
    }
    times: dict[str, list[float]] = {name: [] for name in commands}
    for _ in range(args.repeat):
        for name, cmd in commands.items():
            start = time.perf_counter()
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
            times[name].append(time.perf_counter() - start)
    base = statistics.median(next(iter(times.values())))
    for name, values in times.items():
        median = statistics.median(values)
        print(f"{name:28} median {median:.3f} s  ({median / base:.1f}x the numpy import)")


if __name__ == "__main__":
    main()
