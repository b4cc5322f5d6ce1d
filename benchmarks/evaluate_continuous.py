"""Shielded vs unshielded evaluation of the bundled continuous highway agent (SAC on
highway-continuous, models/agents/highway_continuous_sac.zip): the same scenarios (seeds
1000, 1001, …) without a shield and under the built-in ``highway_continuous`` shield
(projection), crashes with 95 % Wilson intervals and the paired comparison by seed (exact
McNemar on the seeds where one run crashed and the other did not), the unshielded run's
infeasible steps (replayed against the shield) and the shield's interventions.

    python benchmarks/evaluate_continuous.py [--episodes 50] [--seed 1000] [--workers 2]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from tracecheck.checking.replaying import replay
from tracecheck.checking.shield import load_shield
from tracecheck.live.record import RecordSettings, record
from tracecheck.stats.estimates import statistics
from tracecheck.stats.properties import load_properties

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--agent", type=Path,
                        default=ROOT / "models" / "agents" / "highway_continuous_sac.zip")
    args = parser.parse_args()
    saf1 = load_properties("highway").select(["SAF1"])
    shield = load_shield("highway_continuous")
    with tempfile.TemporaryDirectory() as tmp:
        runs = []
        for spec in ("none", "highway_continuous"):
            path = Path(tmp) / f"{spec}.mcap"
            record(RecordSettings(agent=str(args.agent), shield=spec, episodes=args.episodes,
                                  seed=args.seed, workers=args.workers,
                                  env="highway-continuous"), path)
            runs.append(path)
        result = statistics(runs, saf1)
        blocked = replay([runs[0]], shield)
        pair = result["comparisons"][0]["properties"]["SAF1"]
        print("| shield at evaluation | episodes | crashes [95 % Wilson] | interventions | "
              "mean projection distance |\n|---|---|---|---|---|")
        for run, spec in zip(result["runs"], ("none", "highway_continuous")):
            p = run["properties"]["SAF1"]
            n = run["episodes"]
            crashes = n - round(p["ratio"] * n)
            lo, hi = 1 - p["ci95"][1], 1 - p["ci95"][0]
            moved = run.get("continuous") or {}
            rate = moved.get("interventions", {})
            dist = moved.get("projection_distance", {})
            print(f"| {spec} | {n} | {crashes} ({crashes / n:.0%}) [{lo:.0%}, {hi:.0%}] | "
                  f"{_share(rate)} | {_mean(dist)} |")
        print(f"\npaired by seed (exact McNemar): crashed only without the shield "
              f"{pair['only_second']}, only with it {pair['only_first']}; "
              f"p = {pair['p_value']:.3g}")
        print(f"the unshielded run replayed against highway_continuous: "
              f"{blocked.infeasible_steps} infeasible steps of {blocked.steps}, in "
              f"{blocked.infeasible_episodes} of {blocked.episodes} episodes; "
              f"{blocked.crashes_after_infeasible} of its {blocked.crashes} crashes came at "
              "or after a step the shield would have changed")


def _share(entry: dict) -> str:
    if not entry:
        return "—"
    return f"{entry.get('ratio', 0):.1%} of steps"


def _mean(entry: dict) -> str:
    if not entry:
        return "—"
    return f"{entry.get('mean', 0):.3g}"


if __name__ == "__main__":
    main()
