"""What Foxglove's channels cost a writer: the same episodes written with and without them,
interleaved, in one run.

    python benchmarks/bench_foxglove.py [--run sample_traces/base_paper.mcap] [--repeat 5]

Prints the median time per step of each and the file sizes.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from tracecheck.episodes.reader import read_run
from tracecheck.episodes.writer import EpisodeWriter
from tracecheck.interop.foxglove import FoxgloveChannels

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--run", type=Path, default=ROOT / "sample_traces" / "base_paper.mcap")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    result = read_run(args.run)
    steps = sum(len(e.steps) for e in result.episodes)
    times = {False: [], True: []}
    sizes = {}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeat):
            for foxglove in (False, True):
                path = Path(tmp) / f"fox-{foxglove}.mcap"
                start = time.perf_counter()
                with EpisodeWriter(path, result.header,
                                   FoxgloveChannels if foxglove else None) as out:
                    for episode in result.episodes:
                        out.write(episode)
                times[foxglove].append(time.perf_counter() - start)
                sizes[foxglove] = path.stat().st_size
    plain, fox = (statistics.median(times[k]) for k in (False, True))
    print(f"{len(result.episodes)} episodes, {steps} states of {args.run.name}")
    print(f"without Foxglove channels: {plain / steps * 1e6:.0f} µs per state, "
          f"{sizes[False] / 1e6:.1f} MB")
    print(f"with them:                 {fox / steps * 1e6:.0f} µs per state, "
          f"{sizes[True] / 1e6:.1f} MB ({sizes[True] / sizes[False]:.1f}x the size; "
          f"+{(fox - plain) / steps * 1e6:.0f} µs per state)")


if __name__ == "__main__":
    main()
