"""Benchmark: the Ray executor against the local executor, 20 episodes each.

Target (issue 8): on this 2-core machine the Ray executor reaches >= 80 % of the local
executor's episodes per second for 20 episodes.

    python benchmarks/bench_executors.py [--episodes 20] [--workers 2]
    python benchmarks/bench_executors.py --env frozenlake --episodes 100000

Both record the bundled base agent under the paper shield (``--env frozenlake``: the bundled
Q-table under the frozenlake shield on the slippery lake, a Monte Carlo campaign, with no
Foxglove channels), seeds 0..N-1, with 2 workers (local processes; a local Ray instance with
2 CPUs, started before the measurement as a cluster would be — its start-up time is printed
apart). Also the peak memory of this process (the workers' own are not counted).
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
from pathlib import Path

from tracecheck.interop.foxglove import FoxgloveChannels
from tracecheck.live.record import RecordSettings, record

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--env", choices=("highway", "frozenlake"), default="highway")
    args = parser.parse_args()
    if args.env == "frozenlake":
        run = dict(agent=str(ROOT / "models" / "agents" / "frozenlake.npy"),
                   shield="frozenlake", env="frozenlake", env_config={"is_slippery": True})
        channels = None
    else:
        run = dict(agent=str(ROOT / "models" / "agents" / "base.zip"), shield="paper")
        channels = FoxgloveChannels
    rates = {}
    with tempfile.TemporaryDirectory() as tmp:
        import ray

        start = time.perf_counter()
        ray.init(address="local", num_cpus=args.workers, include_dashboard=False,
                 log_to_driver=False, _node_ip_address="127.0.0.1")
        print(f"starting a local Ray instance: {time.perf_counter() - start:.1f} s "
              "(not counted: on a cluster Ray is already running)")
        for executor in ("local", "ray"):
            settings = RecordSettings(**run, episodes=args.episodes, seed=0,
                                      workers=args.workers, executor=executor)
            start = time.perf_counter()
            path = Path(tmp) / f"{executor}.mcap"
            n, steps, _ = record(settings, path, channels=channels)
            took = time.perf_counter() - start
            rates[executor] = n / took
            peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            print(f"{executor}: {n} episodes, {steps} steps in {took:.1f} s "
                  f"({n / took:.2f} episodes/s; file {path.stat().st_size / steps:.0f} B per "
                  f"step; peak memory of this process so far {peak:.0f} MiB)")
        ray.shutdown()
    print(f"ray / local: {rates['ray'] / rates['local']:.0%}; target >= 80 %")


if __name__ == "__main__":
    main()
