"""Benchmark: recording and replaying a grid world (frozenlake), with baselines from the same run.

Targets (issue 12): 50 frozenlake episodes record in <= 10 s; replay of a 1000-episode
frozenlake file runs at >= 50 000 steps/s.

    python benchmarks/bench_environments.py [--episodes 1000] [--repeat 5]

Recording: the bundled Q-table on the slippery lake, unshielded and under the ``frozenlake``
shield, 50 episodes each (one worker); baseline: the same agent's episodes in the bare
environment, without tracecheck (no states, no shield, no file). Replay: a file of
``--episodes`` episodes against ``frozenlake`` (reading + checking, as ``elapsed_s`` counts
it); baseline: the same guards state by state with the scalar evaluator. Prints medians.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from tracecheck.live.adapter import get_adapter
from tracecheck.interop.foxglove import FoxgloveChannels
from tracecheck.live.record import RecordSettings, record
from tracecheck.checking.replaying import replay
from tracecheck.checking.shield import load_shield

ROOT = Path(__file__).resolve().parents[1]
AGENT = ROOT / "models" / "agents" / "frozenlake.npy"
CONFIG = {"is_slippery": True}


def bare_episodes(n: int) -> float:
    """Seconds for n episodes of the bare environment with the same greedy Q-table."""
    adapter = get_adapter("frozenlake")
    env = adapter.make_env(adapter.config(CONFIG))
    table = np.load(AGENT)
    start = time.perf_counter()
    for i in range(n):
        obs, _ = env.reset(seed=i)
        for _ in range(adapter.horizon):
            obs, reward, terminated, truncated, _ = env.step(int(np.argmax(table[obs])))
            if terminated:
                break
    return time.perf_counter() - start


def record_seconds(folder: Path, shield: str, n: int, name: str) -> tuple[float, Path]:
    out = folder / f"{name}.mcap"
    settings = RecordSettings(agent=str(AGENT), shield=shield, episodes=n, env="frozenlake",
                              env_config=CONFIG)
    start = time.perf_counter()
    record(settings, out, channels=FoxgloveChannels)
    return time.perf_counter() - start, out


def per_state_steps(path: Path, shield) -> float:
    from tracecheck.episodes.columns import read_columns

    cols = read_columns(path)
    machine = shield.machine
    start = time.perf_counter()
    for i in range(cols.n):
        machine.enabled(cols.states.row(i))
    return cols.n / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    shield = load_shield("frozenlake")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        bare = statistics.median(bare_episodes(50) for _ in range(3))
        none_s = statistics.median(record_seconds(folder, "none", 50, f"n{i}")[0]
                                   for i in range(3))
        shielded_s = statistics.median(record_seconds(folder, "frozenlake", 50, f"s{i}")[0]
                                       for i in range(3))
        print(f"record 50 episodes, unshielded: median {none_s:.2f} s (target <= 10 s); "
              f"under frozenlake: {shielded_s:.2f} s")
        print(f"bare environment, same agent, 50 episodes: {bare:.3f} s "
              f"(recording costs {none_s / bare:.0f}x the bare episodes)")
        _, big = record_seconds(folder, "none", args.episodes, "big")
        rates = []
        for _ in range(args.repeat):
            report = replay([big], shield)
            rates.append(report.steps / report.elapsed_s)
        rate = statistics.median(rates)
        scalar = per_state_steps(big, shield)
        print(f"replay of {args.episodes} episodes ({report.steps} steps) against frozenlake: "
              f"median {rate:,.0f} steps/s (min {min(rates):,.0f}); target >= 50,000")
        print(f"per-state scalar guards on the same states: {scalar:,.0f} steps/s "
              f"(replay is {rate / scalar:.0f}x)")


if __name__ == "__main__":
    main()
