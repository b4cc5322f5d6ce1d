"""Shielded training on the highway: an agent trained with the shield in the loop, evaluated
with and without the shield, next to the bundled agent trained without it (the table in
models/agents/README.md).

    python benchmarks/compare_shielded_training.py [--episodes 100] [--seed 1000]
        [--agent models/agents/shielded_ppo.zip]

Each agent runs the same scenarios (seeds SEED .. SEED+N-1) under the paper's shield and with
none; the crash rates get 95 % Wilson intervals, and the two evaluations of an agent are
compared pair by pair (same seed) with the exact McNemar test of `tracecheck stats` (SAF1:
no collision).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from tracecheck.checking.replaying import replay
from tracecheck.checking.shield import load_shield
from tracecheck.interop.foxglove import FoxgloveChannels
from tracecheck.live.record import RecordSettings, record
from tracecheck.stats.estimates import statistics
from tracecheck.stats.properties import load_properties

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument("--agent", type=Path, default=ROOT / "models" / "agents" /
                        "shielded_ppo.zip")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    agents = {"base (trained without a shield)": ROOT / "models" / "agents" / "base.zip",
              f"{args.agent.stem} (trained under paper)": args.agent}
    saf1 = load_properties("highway").select(["SAF1"])
    print("| agent | shield at evaluation | episodes | crashes [95 % Wilson] | infeasible steps "
          "(replay against paper) | paired by seed (exact McNemar) |")
    print("|---|---|---|---|---|---|")
    paper = load_shield("paper")
    with tempfile.TemporaryDirectory() as tmp:
        for label, agent in agents.items():
            runs = []
            for shield in ("none", "paper"):
                path = Path(tmp) / f"{agent.stem}_{shield}.mcap"
                record(RecordSettings(agent=str(agent), shield=shield, episodes=args.episodes,
                                      seed=args.seed, workers=args.workers), path,
                       channels=FoxgloveChannels)
                runs.append(path)
            result = statistics(runs, saf1)
            infeasible = [replay([run], paper).infeasible_steps for run in runs]
            pair = result["comparisons"][0]["properties"]["SAF1"]
            for run, shield, blocked in zip(result["runs"], ("none", "paper"), infeasible):
                p = run["properties"]["SAF1"]
                n = run["episodes"]
                crashes = n - round(p["ratio"] * n)
                lo, hi = 1 - p["ci95"][1], 1 - p["ci95"][0]
                # SAF1 (no collision) held in only one of a seed's two episodes: only_second
                # = held only under the shield = crashed only without it
                paired = (f"crashed only without the shield: {pair['only_second']}, only with "
                          f"it: {pair['only_first']}; p = {pair['p_value']:.3g}"
                          if shield == "paper" else "")
                print(f"| {label} | {shield} | {n} | {crashes} ({crashes / n:.0%}) "
                      f"[{lo:.0%}, {hi:.0%}] | {blocked} | {paired} |")


if __name__ == "__main__":
    main()
