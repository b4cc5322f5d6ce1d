"""Benchmark: replay and diff of a 1000-episode file, each figure against a baseline measured
in the same run (shared machines are noisy; ratios are what carries over).

    python benchmarks/bench_replay.py [--episodes 1000] [--repeat 5]

The file holds the paper's 40 SimB traces imported round-robin (real ProB output). Figures:
replay (reading + checking, as ``elapsed_s`` counts it) with ``paper``, ``strict`` and the
authors' ``HighwayEnvironment2.mch`` and ``HighwayEnvironment_RSS_v2.mch`` (from ../shared,
where present) relative to ``paper``; diff relative to replay; replay relative to the
hand-written check of the same guards on the same episodes (``handwritten_check.py``, over
their SimB JSON), in process and as whole processes; the batch path relative to the scalar
path state by state. Medians of interleaved runs.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from itertools import cycle, islice
from pathlib import Path

import handwritten_check as handwritten
from tracecheck.episodes import read_columns, read_run
from tracecheck.episodes.files import write_run
from tracecheck.episodes.writer import new_header
from tracecheck.live.envs.highway import HIGHWAY
from tracecheck.interop import export_simb, import_simb
from tracecheck.checking.diffing import diff
from tracecheck.checking.replaying import replay
from tracecheck.checking.shield import load_shield

ROOT = Path(__file__).resolve().parents[1]
SIMB = ROOT.parent / "shared" / "data" / "paper-traces" / "simb"


def build(path: Path, episodes: int) -> None:
    sources = list(import_simb([SIMB / "base", SIMB / "base_shield"], vocab=HIGHWAY))
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


AUTHORS = ROOT.parent / "shared" / "data" / "paper-models" / "HighwayEnvironment"


def _wall(cmd: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    if not SIMB.is_dir():
        raise SystemExit(f"the paper's traces are not at {SIMB}")
    shields = {"paper": load_shield("paper"), "strict": load_shield("strict")}
    for name in ("HighwayEnvironment2", "HighwayEnvironment_RSS_v2"):
        if (AUTHORS / f"{name}.mch").exists():
            shields[name] = load_shield(str(AUTHORS / f"{name}.mch"))
    none = load_shield("none")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.mcap"
        build(path, args.episodes)
        folder = Path(tmp) / "simb"
        export_simb(read_run(path).episodes, folder, HIGHWAY.name)
        reports = {name: replay([path], sh) for name, sh in shields.items()}  # compile once
        steps, infeasible = handwritten.check(folder)
        assert (steps, infeasible) == (reports["paper"].steps,
                                       reports["paper"].infeasible_steps), "not the same check"
        speed: dict[str, list[float]] = {name: [] for name in shields}
        diffs, hand, proc_tc, proc_hand = [], [], [], []
        tracecheck = [sys.executable, "-m", "tracecheck.cli", "replay", str(path),
                      "--shield", "paper"]
        script = [sys.executable, str(ROOT / "benchmarks" / "handwritten_check.py"),
                  str(folder)]
        for _ in range(args.repeat):  # interleaved, so that noise hits every figure alike
            for name, sh in shields.items():
                r = replay([path], sh)
                speed[name].append(r.steps / r.elapsed_s)
            d = diff([path], shields["paper"], none)
            diffs.append(d.steps / d.elapsed_s)
            start = time.perf_counter()
            handwritten.check(folder)
            hand.append(steps / (time.perf_counter() - start))
            proc_tc.append(_wall(tracecheck))
            proc_hand.append(_wall(script))
        per_state_steps, scalar_s = per_state(path, shields["paper"])
    med = {name: statistics.median(v) for name, v in speed.items()}
    paper = med["paper"]
    print(f"{reports['paper'].episodes} episodes, {steps} steps, {infeasible} infeasible under "
          f"paper; medians of {args.repeat} interleaved runs, each against its baseline")
    print(f"replay paper (read + check):   {paper:,.0f} steps/s")
    for name in shields:
        if name != "paper":
            print(f"replay {name + ':':<27}{med[name]:,.0f} steps/s = {med[name] / paper:.0%} "
                  f"of paper")
    print(f"diff paper vs none:            {statistics.median(diffs):,.0f} steps/s = "
          f"{statistics.median(diffs) / paper:.0%} of replay paper")
    print(f"hand-written check, in process: {statistics.median(hand):,.0f} steps/s (reading the "
          f"SimB JSON + Table 1 in plain Python): replay paper is "
          f"{paper / statistics.median(hand):.0f}x that")
    print(f"per-state scalar path:          {per_state_steps / scalar_s:,.0f} steps/s: the batch "
          f"path is {paper / (per_state_steps / scalar_s):.0f}x that")
    print(f"whole process: tracecheck replay {statistics.median(proc_tc):.2f} s, the hand-written "
          f"script {statistics.median(proc_hand):.2f} s: "
          f"{statistics.median(proc_hand) / statistics.median(proc_tc):.1f}x")


if __name__ == "__main__":
    main()
