"""Fuzzing run files: flip random bytes of a recording, or cut it at a random offset, and run
the commands that read it. Each must give the intact file's answer, or — where it warns that
the file is damaged — the answer for the episodes it says it read (a prefix of the file), or
stop with exit 2 and a message. Never exit 0 with another answer, never a traceback.

    python benchmarks/fuzz_files.py [--cases 10000] [--seed 0]

The recording is the paper's SimB traces imported (real ProB output; needs ../shared), so it
is written by this version of tracecheck. The test suite runs a few hundred cases of the same
check (tests/episodes/test_fuzz.py; the check itself is tests/damaged_files.py); this script
runs as many as asked and prints how the cases ended.
"""

from __future__ import annotations

import argparse
import random
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.damaged_files import COMMANDS, Fuzzer  # noqa: E402


def mutate(data: bytes, rng: random.Random) -> bytes:
    """Flip 1–8 random bits, or cut the file at a random offset."""
    if rng.random() < 0.3:
        return data[:rng.randrange(len(data))]
    out = bytearray(data)
    for _ in range(rng.randint(1, 8)):
        at = rng.randrange(len(out))
        out[at] ^= 1 << rng.randrange(8)
    return bytes(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=10_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--foxglove", action="store_true",
                        help="the recording also carries Foxglove's channels")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        fuzzer = Fuzzer(Path(tmp), foxglove=args.foxglove)
        print(f"recording: {len(fuzzer.intact):,} bytes, {len(fuzzer.prefix)} episodes; "
              f"commands: {', '.join(COMMANDS)}")
        totals: Counter = Counter()
        start = time.perf_counter()
        for case in range(args.cases):
            data = mutate(fuzzer.intact, rng)
            try:
                totals += fuzzer.check(data)
            except AssertionError as exc:
                bad = Path(f"fuzz-failure-{args.seed}-{case}.mcap")
                bad.write_bytes(data)
                print(f"case {case}: FAILED, kept as {bad}: {exc}")
                sys.exit(1)
            if (case + 1) % 500 == 0:
                print(f"{case + 1} cases, {time.perf_counter() - start:.0f} s: {dict(totals)}",
                      flush=True)
    print(f"{args.cases} cases ({args.cases * len(COMMANDS)} command runs) in "
          f"{time.perf_counter() - start:.0f} s, none wrong: {dict(totals)}")


if __name__ == "__main__":
    main()
