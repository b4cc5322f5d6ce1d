"""Benchmark: live shield decisions against environment steps, and recording with 1 vs 2 workers.

Targets (issue 5): the shield's decision on a live state (all five guards) <= 50 µs median,
reported next to the environment's step time; two workers >= 1.8x the episodes per second of
one worker on this 2-core machine.

    python benchmarks/bench_record.py [--episodes 16] [--duration 60]

Records the bundled base agent under the paper shield (seeds 0..N-1) with one worker, then
with two, and reads the shield decision times stored with every step.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from tracecheck.episodes import read_run
from tracecheck.live.envs.highway import make_env
from tracecheck.interop.foxglove import FoxgloveChannels
from tracecheck.live.record import RecordSettings, record

ROOT = Path(__file__).resolve().parents[1]
AGENT = ROOT / "models" / "agents" / "base.zip"


def env_step_ms(steps: int = 300) -> float:
    env = make_env()
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    times = []
    for _ in range(steps):
        t = time.perf_counter()
        _, _, terminated, truncated, _ = env.step(int(rng.integers(5)))
        times.append((time.perf_counter() - t) * 1000)
        if terminated or truncated:
            env.reset(seed=int(rng.integers(1000)))
    return statistics.median(times)


def cold_and_warm_us(steps: int = 200) -> tuple[float, float]:
    """The paper shield's decision right after an environment step (as when recording), and
    the same decision again at once (caches warm): medians in µs."""
    from tracecheck.checking.shield import load_shield
    from tracecheck.live.wrapper import ShieldWrapper

    env = ShieldWrapper(make_env(), load_shield("paper"))
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    cold, warm = [], []
    for k in range(steps):
        _, _, terminated, truncated, _ = env.step(int(rng.integers(5)))
        cold.append(env.decision_us)
        env._decide()
        warm.append(env.decision_us)
        if terminated or truncated:
            env.reset(seed=k)
    return statistics.median(cold), statistics.median(warm)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=16)
    parser.add_argument("--duration", type=int, default=60)
    args = parser.parse_args()
    rates = {}
    with tempfile.TemporaryDirectory() as tmp:
        for workers in (1, 2):
            path = Path(tmp) / f"w{workers}.mcap"
            settings = RecordSettings(agent=str(AGENT), shield="paper", episodes=args.episodes,
                                      seed=0, duration=args.duration, workers=workers)
            start = time.perf_counter()
            n, steps, _ = record(settings, path, channels=FoxgloveChannels)
            took = time.perf_counter() - start
            rates[workers] = (n / took, steps / took, took)
        decisions = [s.shield_time_us for e in read_run(Path(tmp) / "w1.mcap").episodes
                     for s in e.steps[1:]]
    step_ms = env_step_ms()
    cold, warm = cold_and_warm_us()
    print(f"{args.episodes} episodes of up to {args.duration} steps, base agent, paper shield")
    print(f"shield decision (five guards, live state): median {statistics.median(decisions):.1f} "
          f"µs over {len(decisions)} steps; target <= 50 µs")
    print(f"without the agent: {cold:.1f} µs right after a random environment step, "
          f"{warm:.1f} µs deciding the same state again at once (caches warm)")
    print(f"environment step (highway-fast-v0): median {step_ms:.1f} ms — the shield adds "
          f"{statistics.median(decisions) / (step_ms * 1000):.2%}")
    for workers, (eps, sps, took) in rates.items():
        print(f"{workers} worker(s): {eps:.2f} episodes/s, {sps:.0f} steps/s ({took:.1f} s)")
    print(f"2 workers / 1 worker: {rates[2][0] / rates[1][0]:.2f}x; target >= 1.8x")


if __name__ == "__main__":
    main()
