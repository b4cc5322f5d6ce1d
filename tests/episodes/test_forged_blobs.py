"""Run blobs forged with valid checksums: a blob whose checksums are those of the real
episodes but whose columns say otherwise is not taken over the episodes — each episode's
own columns are checked against the blob's rows for it — and every command gives the answer
of the episodes (the one render and export give), with a warning naming the block, the
episode and what differs."""

from __future__ import annotations

import copy
import dataclasses
import json

import numpy as np
import pytest

from tests.helpers import episode, from_blobs, run, walking
from tracecheck.episodes import EpisodeWriter, codec, new_header, read_columns
from tracecheck.episodes.blobs import BlobDisagrees, blob_records, verified_block
from tracecheck.episodes.records import mapped

CRASHES = 4  # episodes 0, 3, 6, 9 of the 12 crash


def write(path, forge=None, monkeypatch=None):
    """12 episodes in blocks of 20 states or more (0–3, 4–7, 8–11), each block's run blob
    written with ``forge(run)`` done to its columns (the spans and checksums the real
    episodes')."""
    if forge is not None:
        real = codec.encode_run_columns

        def forged(run, *args, **kw):
            run = dataclasses.replace(run, states=copy.deepcopy(run.states))
            forge(run)
            return real(run, *args, **kw)

        monkeypatch.setattr(codec, "encode_run_columns", forged)
    with EpisodeWriter(path, new_header("recorded", model_name="HighwayEnvironment"),
                       block_rows=20) as out:
        for i in range(12):
            out.write(episode(i, 3 + i % 5, crash_at_end=i % 3 == 0, live=i % 2 == 0))
    if monkeypatch is not None:
        monkeypatch.undo()
    return path


def disagreement(path) -> str:
    """What block 0's run blob and its episodes differ in ("" where they agree)."""
    with mapped(path) as buf:
        view = memoryview(buf)
        try:
            verified_block(buf, view, blob_records(buf), 0)
        except BlobDisagrees as exc:
            return str(exc)
        finally:
            view.release()
    return ""


def no_crash(run):
    run.crashed = np.zeros_like(run.crashed)


def moved(run):
    x, defined = run.states.functions["VehiclesX"]
    run.states.functions["VehiclesX"] = (x + 0.5, defined)


def other_reasons(run):
    run.reasons = ["time-limit"] * len(run.reasons)


def other_seeds(run):
    run.seeds = [99] * len(run.seeds)


def extra_column(run):
    run.parameters = {"a": np.full(run.n, np.nan)}


FORGERIES = [
    (no_crash, "episode 0: its column crashed does not hold the blob's rows for it"),
    (moved, "episode 0: its column fun:VehiclesX does not hold the blob's rows for it"),
    (other_reasons, "episode 0: its columns say it ended by 'crashed', the blob by "
                    "'time-limit'"),
    (other_seeds, "episode 0: its columns say seed 1000, the blob 99"),
    (extra_column, "the blob has a column par:a none of its episodes has"),
]


def test_the_episodes_hold_their_seeds_and_reasons(tmp_path):
    path = write(tmp_path / "run.mcap")
    assert disagreement(path) == "" and from_blobs(path)
    cols = read_columns(path)
    assert cols.seeds[0] == 1000 and cols.reasons[0] == "crashed"
    assert int(np.count_nonzero(cols.crashed[cols.starts[1:] - 1])) == CRASHES


@pytest.mark.parametrize("forge,why", FORGERIES, ids=[f.__name__ for f, _ in FORGERIES])
def test_a_forged_blob_is_not_taken_over_its_episodes(tmp_path, monkeypatch, forge, why):
    path = write(tmp_path / "run.mcap", forge, monkeypatch)
    assert disagreement(path) == why
    assert not from_blobs(path)
    cols = read_columns(path)
    assert cols.warnings == [
        f"{path}: the run blob of block 0 holds otherwise than its episodes' own columns "
        f"({why}); they were read one by one instead, as render and export read them — the "
        "blob was edited after the file was written, or written otherwise than this "
        "tracecheck writes blobs"]
    assert int(np.count_nonzero(cols.crashed[cols.starts[1:] - 1])) == CRASHES
    walking(monkeypatch)
    walked = read_columns(path)
    for key in ("episode_ids", "starts", "time", "action", "reward", "crashed", "values"):
        assert np.array_equal(getattr(cols, key), getattr(walked, key), equal_nan=True), key
    assert cols.seeds == walked.seeds and cols.reasons == walked.reasons
    assert cols.parameters == walked.parameters == {}
    assert [cols.states.row(i) for i in range(cols.n)] == \
        [walked.states.row(i) for i in range(walked.n)]


@pytest.mark.parametrize("command", [["info", "--json"], ["stats", "--json"],
                                     ["replay", "--shield", "paper", "--json"]])
def test_every_command_answers_as_the_episodes_say(tmp_path, monkeypatch, capsys, command):
    """The audit's case: a blob saying no episode crashed, over episodes of which 4 did."""
    path = write(tmp_path / "run.mcap", no_crash, monkeypatch)

    def answer():
        code, out, err = run(capsys, command[0], path, *command[1:])
        assert code in (0, 1) and "Traceback" not in err, err
        return {k: v for k, v in json.loads(out).items()
                if k not in ("elapsed_s", "statistics_s", "steps_per_s", "warnings")}, err

    got, err = answer()
    assert "the run blob of block 0 holds otherwise than its episodes' own columns " \
           "(episode 0: its column crashed does not hold the blob's rows for it)" in err
    if command[0] == "info":
        assert got["crashes"] == CRASHES and got["episodes"] == 12
    walking(monkeypatch)
    assert answer()[0] == got


def test_episodes_with_tables_of_their_own_agree_with_their_blob(tmp_path, monkeypatch):
    """Episodes of one block with their own actions (more come later), set elements,
    literal tables, number types (an int column in one, float in another) and action values
    in one of them: each is compared through its own tables, and the block is read from its
    blob — as the walk reads it."""
    from tracecheck.b.values import Elem, FuncValue
    from tracecheck.episodes.model import Episode, StepRecord, make_end

    def ep(i):
        elements = [Elem("A"), Elem("B")] if i % 2 else [Elem("B"), Elem("C")]
        steps = tuple(StepRecord(
            k, float(k), None if k == 0 else ["GO", "STOP", "WAIT"][(i + k) % (2 + (i > 2))],
            {"Map": frozenset({1, i % 3 + k}), "x": k if i % 2 else float(k),
             "Pos": FuncValue({e: float(k + i) for e in elements})},
            0.5, False, action_values={"GO": 1.0} if i == 4 else None) for k in range(4))
        return Episode(i, steps, make_end(steps))

    path = tmp_path / "run.mcap"
    with EpisodeWriter(path, new_header("recorded"), block_rows=8) as out:
        for i in range(7):
            out.write(ep(i))
    assert disagreement(path) == "" and from_blobs(path)
    cols = read_columns(path)
    assert cols.action_names == ("STOP", "GO", "WAIT") and not cols.warnings
    walking(monkeypatch)
    walked = read_columns(path)
    assert [cols.states.row(i) for i in range(cols.n)] == \
        [walked.states.row(i) for i in range(walked.n)]
    assert np.array_equal(cols.values, walked.values, equal_nan=True)
    assert np.array_equal(cols.action, walked.action)
