"""Shielded vs unshielded evaluation of continuous highway agents — the bundled SAC agent
(models/agents/highway_continuous_sac.zip) and a reckless one that always asks for full
acceleration and straight wheels (a PPO file whose action network is set to that constant,
made here) — on the same scenarios (seeds 1000, 1001, …) without a shield and under the
built-in ``highway_continuous`` shield (projection), crashes with 95 % Wilson intervals and the paired comparison by seed (exact
McNemar on the seeds where one run crashed and the other did not), the unshielded run's
infeasible steps (replayed against the shield) and the shield's interventions.

    python benchmarks/evaluate_continuous.py [--episodes 50] [--seed 1000] [--workers 2]
"""

from __future__ import annotations

import argparse
import json
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
    # the environment as the agent was trained in it (its model card says how)
    card = json.loads(args.agent.with_suffix(".json").read_text())
    config = {k: v for k, v in card["environment_config"].items() if k != "duration"}
    print("| agent | shield at evaluation | episodes | crashes [95 % Wilson] | interventions "
          "| mean projection distance | paired by seed (exact McNemar) |\n"
          "|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        agents = {"SAC (bundled)": args.agent,
                  "full throttle": reckless(Path(tmp) / "full_throttle.zip", config)}
        notes = []
        for label, agent in agents.items():
            runs = []
            for spec in ("none", "highway_continuous"):
                path = Path(tmp) / f"{agent.stem}_{spec}.mcap"
                record(RecordSettings(agent=str(agent), shield=spec, episodes=args.episodes,
                                      seed=args.seed, workers=args.workers,
                                      env="highway-continuous", env_config=config), path)
                runs.append(path)
            result = statistics(runs, saf1)
            pair = result["comparisons"][0]["properties"]["SAF1"]
            for run, spec in zip(result["runs"], ("none", "highway_continuous")):
                p = run["properties"]["SAF1"]
                n = run["episodes"]
                crashes = n - round(p["ratio"] * n)
                lo, hi = 1 - p["ci95"][1], 1 - p["ci95"][0]
                moved = run.get("continuous") or {}
                paired = (f"crashed only without the shield: {pair['only_second']}, only with "
                          f"it: {pair['only_first']}; p = {pair['p_value']:.3g}"
                          if spec != "none" else "")
                print(f"| {label} | {spec} | {n} | {crashes} ({crashes / n:.0%}) "
                      f"[{lo:.0%}, {hi:.0%}] | {_share(moved.get('interventions', {}))} | "
                      f"{_mean(moved.get('projection_distance', {}))} | {paired} |")
            blocked = replay([runs[0]], shield)
            notes.append(f"{label}, unshielded, replayed against highway_continuous: "
                         f"{blocked.infeasible_steps} infeasible steps of {blocked.steps} in "
                         f"{blocked.infeasible_episodes} of {blocked.episodes} episodes; "
                         f"{blocked.crashes_after_infeasible} of its {blocked.crashes} "
                         "crashes at or after a step the shield would have changed")
        print()
        for note in notes:
            print(note)


def reckless(path: Path, config: dict) -> Path:
    """A PPO file for highway-continuous whose deterministic action is always full
    acceleration with straight wheels (its action network's last layer a constant)."""
    import stable_baselines3 as sb3
    import torch

    from tracecheck.live.adapter import get_adapter

    adapter = get_adapter("highway-continuous")
    env = adapter.make_env(adapter.config(config))
    model = sb3.PPO("MlpPolicy", env, policy_kwargs={"net_arch": [4]}, seed=0, n_steps=64,
                    batch_size=64, device="cpu")
    with torch.no_grad():
        model.policy.action_net.weight.zero_()
        model.policy.action_net.bias.copy_(torch.tensor([1.0, 0.0]))
    model.save(str(path))
    env.close()
    return path


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
