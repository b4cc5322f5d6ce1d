"""The check behind fuzzing run files (tests/episodes/test_fuzz.py, and as many cases as asked
in benchmarks/fuzz_files.py): every reading command run on a recording gives the intact file's
answer, the answer for a prefix of its episodes where it warns that the file is damaged, or
exit 2 with a message — never another answer with exit 0, never a traceback."""

from __future__ import annotations

import contextlib
import io
import json
import shutil
import warnings
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from tests.helpers import PAPER_TRACES

SIMB = PAPER_TRACES / "simb"

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
        from tracecheck.live.envs.highway import HIGHWAY
        from tracecheck.episodes.writer import new_header

        write_run(self.run, new_header("imported-simb", model_name=HIGHWAY.name,
                                       variables=list(HIGHWAY.variables),
                                       actions=list(HIGHWAY.actions)), import_simb(sources, vocab=HIGHWAY),
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
