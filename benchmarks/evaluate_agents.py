"""The short evaluation in models/agents/README.md: each bundled agent, with and without the
paper's shield, on the same 50 scenarios (seeds 1000-1049).

    python benchmarks/evaluate_agents.py [--episodes 50] [--seed 1000]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from pathlib import Path

from tracecheck.episodes import read_run
from tracecheck.interop.foxglove import FoxgloveChannels
from tracecheck.live.record import RecordSettings, record

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--seed", type=int, default=1000)
    args = parser.parse_args()
    print("| agent | shield | episodes | crashes | mean length (s) | mean total reward |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for agent in ("base", "higher_penalty"):
            profile = "base" if agent == "base" else "higher-penalty"
            for shield in ("none", "paper"):
                path = Path(tmp) / f"{agent}_{shield}.mcap"
                record(RecordSettings(agent=str(ROOT / "models" / "agents" / f"{agent}.zip"),
                                      shield=shield, episodes=args.episodes, seed=args.seed,
                                      profile=profile, workers=2), path,
                       channels=FoxgloveChannels)
                eps = read_run(path).episodes
                crashes = sum(e.end.crashed for e in eps)
                length = statistics.mean(e.end.steps for e in eps)
                reward = statistics.mean(e.end.total_reward for e in eps)
                print(f"| {agent} | {shield} | {len(eps)} | {crashes} ({crashes / len(eps):.0%}) "
                      f"| {length:.1f} | {reward:.2f} |")


if __name__ == "__main__":
    main()
