"""Fuzzing run files: flip random bytes of a recording, or cut it at a random offset, and run
the commands that read it. Each must give the intact file's answer, or — where it warns that
the file is damaged — the answer for the episodes it says it read (a prefix of the file), or
stop with exit 2 and a message. Never exit 0 with another answer, never a traceback.

    python benchmarks/fuzz_files.py [--cases 10000] [--seed 0]

The recording is the paper's SimB traces imported (real ProB output; needs ../shared), so it
is written by this version of tracecheck. The test suite runs a few hundred cases of the same
check (tests/episodes/test_fuzz.py); this script runs as many as asked and prints how the
cases ended.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import random
import shutil
import sys
import tempfile
import time
import warnings
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SIMB = ROOT.parent / "shared" / "data" / "paper-traces" / "simb"

#: The commands run on every case: what they print (JSON) or write is their answer.
COMMANDS = {
    "info": ["info", "{run}", "--json"],
    "replay": ["replay", "{run}", "--shield", "paper", "--json"],
    "stats": ["stats", "{run}", "--json"],
    "export": ["export", "simb", "{run}", "-o", "{out}", "--force"],
    "render": ["render", "{run}", "--episode", "0", "-o", "{out}/page.html"],
}
_NOISE = {"elapsed_s", "statistics_s", "steps_per_s", "warnings", "savedAt"}  # not answers


@dataclass(frozen=True)
class Outcome:
    code: int
    answer: str
    err: str


def _clean(value):
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items() if k not in _NOISE}
    if isinstance(value, list):
        return [_clean(v) for v in value]
    return value


def run_command(name: str, run: Path, out: Path) -> Outcome:
    """One command in this process: its exit code, its answer, its stderr."""
    from tracecheck.cli import main

    if out.exists():
        shutil.rmtree(out)
    out.mkdir()
    args = [a.format(run=run, out=out) for a in COMMANDS[name]]
    stdout, stderr = io.StringIO(), io.StringIO()
    code = 0
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr), \
            warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            main(args)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        except BaseException as exc:  # noqa: BLE001 - a traceback is what is looked for
            import traceback

            return Outcome(-1, "", "".join(traceback.format_exception(exc)))
    text = stdout.getvalue()
    if code == 0:
        if name in ("info", "replay", "stats"):
            text = json.dumps(_clean(json.loads(text)), sort_keys=True)
        elif name == "export":
            text = json.dumps({p.name: _clean(json.loads(p.read_text()))
                               for p in sorted(out.glob("*.json"))}, sort_keys=True)
        elif name == "render":
            text = (out / "page.html").read_text()
    return Outcome(code, text, stderr.getvalue())


class Fuzzer:
    """The intact recording's answers, and those of each prefix of its episodes."""

    def __init__(self, folder: Path, traces: int = 4, foxglove: bool = False) -> None:
        from tracecheck.episodes import EpisodeWriter, read_header, read_run
        from tracecheck.interop import import_simb
        from tracecheck.interop.foxglove import FoxgloveChannels

        self.folder = folder
        self.run = folder / "run.mcap"
        self.out = folder / "out"
        sources = sorted(SIMB.glob("*/*.json"))[:traces]
        if not sources:
            raise SystemExit(f"the paper's traces are not at {SIMB}")
        from tracecheck.episodes.files import write_run
        from tracecheck.episodes.model import HIGHWAY
        from tracecheck.episodes.writer import new_header

        write_run(self.run, new_header("imported-simb", model_name=HIGHWAY.name,
                                       variables=list(HIGHWAY.variables),
                                       actions=list(HIGHWAY.actions)), import_simb(sources),
                  channels=FoxgloveChannels if foxglove else None)
        self.intact = self.run.read_bytes()
        header, episodes = read_header(self.run), read_run(self.run).episodes
        # the answers for the first k episodes, k = 0 … n (a file cut after episode k)
        self.prefix: dict[int, dict[str, Outcome]] = {}
        for k in range(len(episodes) + 1):
            with EpisodeWriter(self.run, header, FoxgloveChannels if foxglove else None) as w:
                for e in episodes[:k]:
                    w.write(e)
            self.prefix[k] = {name: run_command(name, self.run, self.out) for name in COMMANDS}
        self.run.write_bytes(self.intact)
        self.expected = {name: run_command(name, self.run, self.out) for name in COMMANDS}
        assert all(o.code == 0 for o in self.expected.values()), self.expected

    def check(self, data: bytes) -> Counter:
        """Run every command on ``data``; raises AssertionError on a wrong answer or a
        traceback, else counts how each command ended."""
        self.run.write_bytes(data)
        ended = Counter()
        for name in COMMANDS:
            got = run_command(name, self.run, self.out)
            want = self.expected[name]
            assert got.code != -1 and "Traceback" not in got.err, (name, got.err)
            if got.code == 2:
                assert "\nerror: " in "\n" + got.err, (name, got.err)
                ended["exit 2"] += 1
            elif got.code == 0 and got.answer == want.answer:
                ended["same answer"] += 1
            elif got.code == 0 and "damaged or ends early" in got.err:
                same = [k for k, o in self.prefix.items() if o[name].answer == got.answer]
                assert same, (name, "a damaged file read as no prefix of its episodes",
                              got.err)
                ended["complete episodes of a damaged file"] += 1
            else:
                raise AssertionError((name, got.code, got.err, "a different answer"))
        return ended


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
