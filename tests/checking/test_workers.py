"""Replay, diff and stats in worker processes of their own (``--workers N``): a block of episodes
per task, the same answers as one process, errors and damaged blocks as one process has them."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.helpers import ROOT
from tracecheck.checking.diffing import diff
from tracecheck.checking.executors import file_blocks
from tracecheck.checking.replaying import replay
from tracecheck.checking.shield import load_shield
from tracecheck.episodes import EpisodeWriter, read_run
from tracecheck.episodes import writer as W
from tracecheck.errors import InputError
from tracecheck.stats.estimates import statistics
from tracecheck.stats.properties import load_properties

SOURCE = ROOT / "sample_traces" / "base_none.mcap"


def _blocks(path, monkeypatch, compress=True):
    """The sample run written again in blocks of 150 states (several blocks per file)."""
    run = read_run(SOURCE)
    monkeypatch.setattr(W, "BLOCK_ROWS", 150)
    with EpisodeWriter(path, run.header, compress=compress) as out:
        for ep in run.episodes:
            out.write(ep)
    return run


def test_workers_take_blocks_and_give_the_answers_of_one_process(tmp_path, monkeypatch):
    path = tmp_path / "blocks.mcap"
    run = _blocks(path, monkeypatch)
    units = file_blocks([path], "local", workers=2)
    assert len(units) > 4 and all(u[2] is not None for u in units)
    assert [u[2] for u in file_blocks([path], "local")] == [None]  # one process: whole files
    paper, none = load_shield("paper"), load_shield("none")
    a, b = replay([path, SOURCE], paper), replay([path, SOURCE], paper, workers=2)
    assert a.per_episode == b.per_episode and len(a.per_episode) == 2 * len(run.episodes)
    assert (a.infeasible_steps, a.crashes_after_infeasible) == (b.infeasible_steps,
                                                                b.crashes_after_infeasible)
    da, db = diff([path], paper, none), diff([path], paper, none, workers=2)
    assert (da.changed_steps, da.changes, da.episodes) == (db.changed_steps, db.changes,
                                                           db.episodes) and da.changed_steps
    props = load_properties("highway")
    assert statistics([path], props)["runs"] == statistics([path], props, workers=2)["runs"]


def test_a_damaged_block_in_a_worker_is_read_as_one_process_reads_it(tmp_path, monkeypatch):
    path, good = tmp_path / "damaged.mcap", tmp_path / "good.mcap"
    run = _blocks(path, monkeypatch, compress=False)
    _blocks(good, monkeypatch, compress=False)
    data = bytearray(path.read_bytes())
    data[data.find(b'"episode":7,"step":3') + 30] ^= 1
    path.write_bytes(bytes(data))
    paper = load_shield("paper")
    errors = []
    for workers in (1, 2):
        with pytest.raises(InputError, match="damaged.mcap, episode 7") as got:
            replay([good, path], paper, workers=workers)
        errors.append((type(got.value), got.value.render(), got.value.hint))
    assert errors[0] == errors[1]  # the worker's error whole: its class, place and hint
    a = replay([good, path], paper, salvage=True)
    b = replay([good, path], paper, salvage=True, workers=2)
    assert a.per_episode == b.per_episode and a.warnings == b.warnings
    assert len(a.per_episode) == 2 * len(run.episodes) - 1


def test_the_cli_reports_the_same_with_two_workers(tmp_path, monkeypatch):
    path = tmp_path / "blocks.mcap"
    _blocks(path, monkeypatch)
    reports = []
    for workers in ("1", "2"):
        done = subprocess.run([sys.executable, "-m", "tracecheck", "replay", str(path),
                               "--shield", "paper", "--json", "--workers", workers],
                              capture_output=True, text=True, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        report = json.loads(done.stdout)
        reports.append({k: v for k, v in report.items() if k not in ("elapsed_s",
                                                                     "steps_per_s")})
    assert reports[0] == reports[1] and reports[0]["episodes"] == 24


def test_a_shield_joined_from_several_files_goes_to_the_workers_whole(tmp_path, monkeypatch):
    # a machine that SEES another is one text joined from both (errors placed in either):
    # it must travel to a worker and back as it is
    import pickle

    from tracecheck.errors import EvaluationError, JoinedText

    text = (ROOT / "models" / "shields" / "paper.mch").read_text()
    (tmp_path / "Base.mch").write_text("MACHINE Base\nCONSTANTS Unused\n"
                                       "PROPERTIES Unused = 1\nEND\n")
    sees = tmp_path / "PaperSees.mch"
    sees.write_text(text.replace("MACHINE PaperShield\n", "MACHINE PaperSees\nSEES Base\n", 1),
                    encoding="utf-8")
    shield = load_shield(sees)
    assert isinstance(shield.machine.source, JoinedText)
    path = tmp_path / "blocks.mcap"
    _blocks(path, monkeypatch)
    one, two = replay([path], shield), replay([path], shield, workers=2)
    assert one.per_episode == two.per_episode and one.infeasible_steps
    joined = shield.machine.source
    error = pickle.loads(pickle.dumps(EvaluationError("boom", source=joined)))
    assert error.render() == EvaluationError("boom", source=joined).render()
    assert pickle.loads(pickle.dumps(joined)).parts == joined.parts
