"""Benchmark: how the cost of each command grows with the number of episodes.

    python benchmarks/bench_scale.py [--sizes 1000 10000 100000] [--repeat 1] [--keep DIR]
                                     [--reuse]

For each size N it lays out a folder of N SimB traces (the paper's 40 real ProB traces from
../shared, linked round-robin under new names: ``Timed_Simulation_<k>.json``), then runs each
command as a fresh process and measures its wall time and peak memory (the child's maximum
resident set, from ``wait4``):

- ``import simb`` of the folder into one run file (its size per step is printed too);
- ``replay --shield paper`` (text), ``replay --shield paper --json``;
- ``diff --shield strict --against paper``; ``stats``; ``info``;
- the baseline: the hand-written per-state script a user would write
  (``handwritten_check.py``) over the same folder.

``--reuse`` takes the folders and run files an earlier ``--keep DIR`` left (no import row).
Each row prints time and peak memory next to the baseline's at the same size (a ratio), and
the growth from the smallest size, so the README can say how cost grows with the work.
Medians over ``--repeat`` interleaved runs. The processes run with Python's bytecode cache
(as an installed tracecheck has it, even where ``PYTHONDONTWRITEBYTECODE`` is set here).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SIMB = ROOT.parent / "shared" / "data" / "paper-traces" / "simb"
BIN = Path(sys.executable).parent / "tracecheck"
HANDWRITTEN = ROOT / "benchmarks" / "handwritten_check.py"


def lay_out(folder: Path, episodes: int) -> None:
    """``episodes`` SimB traces in ``folder``: the paper's 40, linked round-robin."""
    sources = sorted((SIMB / "base").glob("*.json")) + sorted((SIMB / "base_shield").glob("*.json"))
    if not sources:
        raise SystemExit(f"no SimB traces under {SIMB}")
    folder.mkdir(parents=True)
    for k in range(episodes):
        os.symlink(sources[k % len(sources)], folder / f"Timed_Simulation_{k + 1}.json")


def measure(argv: list[str]) -> tuple[float, float]:
    """(seconds, peak MiB) of one fresh process; its output is thrown away."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    start = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    elapsed = time.perf_counter() - start
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    code = os.waitstatus_to_exitcode(status)
    if code not in (0, 1):
        raise SystemExit(f"{' '.join(argv)} exited {code}:\n{err[-2000:]}")
    return elapsed, usage.ru_maxrss / 1024


def commands(folder: Path, run: Path) -> dict[str, list[str]]:
    tc = str(BIN)
    return {
        "replay": [tc, "replay", "--shield", "paper", str(run)],
        "replay --json": [tc, "replay", "--shield", "paper", "--json", str(run)],
        "diff": [tc, "diff", "--shield", "strict", "--against", "paper", str(run)],
        "stats": [tc, "stats", str(run)],
        "info": [tc, "info", str(run)],
        "hand-written script": [sys.executable, str(HANDWRITTEN), str(folder)],
    }


def written(run: Path, n: int) -> None:
    """The run file of ``n`` episodes written in this process (the 40 traces imported once,
    then written round-robin with new ids) — for sizes where timing the import itself would
    take too long (``--no-import``)."""
    import dataclasses
    from itertools import cycle, islice

    from tracecheck.episodes.files import write_run
    from tracecheck.live.envs.highway import HIGHWAY
    from tracecheck.episodes.writer import new_header
    from tracecheck.interop import import_simb

    sources = list(import_simb([SIMB / "base", SIMB / "base_shield"], vocab=HIGHWAY))
    episodes = (dataclasses.replace(e, id=k) for k, e in enumerate(islice(cycle(sources), n)))
    write_run(run, new_header("imported-simb", variables=list(HIGHWAY.variables),
                              actions=list(HIGHWAY.actions)), episodes)


def one_size(work: Path, n: int, repeat: int, timed_import: bool = True,
             reuse: bool = False) -> dict[str, tuple[float, float]]:
    folder, run = work / f"traces-{n}", work / f"run-{n}.mcap"
    rows = {}
    if reuse:
        if not (folder.is_dir() and run.is_file()):
            raise SystemExit(f"--reuse: no {folder} and {run} (make them with --keep)")
    elif timed_import:
        lay_out(folder, n)
        imports = []
        for _ in range(repeat):
            run.unlink(missing_ok=True)
            imports.append(measure([str(BIN), "import", "simb", str(folder), "-o", str(run)]))
        rows["import simb"] = _median(imports)
    else:  # in a process of its own: a large parent would count in each child's peak memory
        lay_out(folder, n)
        subprocess.run([sys.executable, __file__, "--write", str(run), str(n)], check=True)
    steps = _steps(run)
    print(f"  {n} episodes, {steps} steps, file {run.stat().st_size / 1e6:.1f} MB "
          f"({run.stat().st_size / steps:.0f} B per step)", flush=True)
    cmds = commands(folder, run)
    samples: dict[str, list] = {name: [] for name in cmds}
    for _ in range(repeat):  # interleaved: a slow moment hits every command alike
        for name, argv in cmds.items():
            samples[name].append(measure(argv))
    rows.update({name: _median(s) for name, s in samples.items()})
    rows["_bytes_per_step"] = (run.stat().st_size / steps, 0.0)
    return rows


def _steps(run: Path) -> int:
    out = subprocess.run([str(BIN), "info", "--json", str(run)], capture_output=True,
                         text=True, check=True).stdout
    import json

    return int(json.loads(out)["steps"])


def _median(samples: list[tuple[float, float]]) -> tuple[float, float]:
    return (statistics.median(t for t, _ in samples), statistics.median(m for _, m in samples))


def report(results: dict[int, dict[str, tuple[float, float]]]) -> None:
    sizes = sorted(results)
    first = sizes[0]
    print("\n| command | episodes | time s | peak MiB | hand-written's time / this | "
          f"time growth from {first} | memory growth from {first} |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    names = [k for k in results[first] if not k.startswith("_")
             and all(k in results[n] for n in sizes)]
    for name in names:
        for n in sizes:
            t, m = results[n][name]
            base = results[n]["hand-written script"][0]
            t0, m0 = results[first][name]
            print(f"| {name} | {n} | {t:.2f} | {m:.0f} | {base / t:.1f}x | "
                  f"{t / t0:.1f}x | {m / m0:.2f}x |")
    for n in sizes:
        print(f"file size at {n} episodes: {results[n]['_bytes_per_step'][0]:.0f} B per step")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--keep", type=Path, help="build the files here and keep them")
    ap.add_argument("--no-import", action="store_true",
                    help="write the files in this process instead of timing the import")
    ap.add_argument("--reuse", action="store_true",
                    help="with --keep: take the folders and files an earlier run left there")
    ap.add_argument("--write", nargs=2, metavar=("RUN", "N"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.reuse and args.keep is None:
        ap.error("--reuse needs --keep DIR")
    if args.write:
        written(Path(args.write[0]), int(args.write[1]))
        return
    work = args.keep or Path(tempfile.mkdtemp(prefix="bench-scale-"))
    work.mkdir(parents=True, exist_ok=True)
    results = {}
    try:
        for n in args.sizes:
            print(f"size {n}:", flush=True)
            results[n] = one_size(work, n, args.repeat, timed_import=not args.no_import,
                                  reuse=args.reuse)
    finally:
        if args.keep is None:
            shutil.rmtree(work, ignore_errors=True)
    report(results)


if __name__ == "__main__":
    main()
