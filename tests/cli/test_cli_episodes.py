"""import, export and info on the command line."""

from __future__ import annotations

import json

import pytest

from tests.helpers import FixedDate, episode, run
from tracecheck.episodes import EpisodeWriter, new_header


def test_import_info_export(capsys, paper_traces, tmp_path):
    out_file = tmp_path / "base.mcap"
    code, out, _ = run(capsys, "import", "simb", str(paper_traces / "simb" / "base"),
                       "-o", str(out_file))
    assert code == 0
    assert out.strip() == f"imported 20 episode(s), 765 step(s), 9 crash(es) -> {out_file}"
    code, out, _ = run(capsys, "info", str(out_file), "--json")
    data = json.loads(out)
    assert (data["episodes"], data["steps"], data["crashes"]) == (20, 765, 9)
    assert data["sources"] == ["imported-simb"]
    code, out, _ = run(capsys, "info", str(out_file))
    assert "total: 20 episode(s), 765 step(s), 9 crash(es) (45.0%)" in out

    trace = tmp_path / "e3.prob2trace"
    code, out, _ = run(capsys, "export", "prob2trace", str(out_file), "--episode", "3",
                       "-o", str(trace))
    assert code == 0 and json.loads(trace.read_text())["metadata"]["fileType"] == "Trace"
    folder = tmp_path / "simb"
    code, out, _ = run(capsys, "export", "simb", str(out_file), "-o", str(folder))
    assert code == 0 and len(list(folder.glob("Timed_Simulation_*.json"))) == 20
    back = tmp_path / "back.mcap"
    code, out, _ = run(capsys, "import", "simb", str(folder), "-o", str(back))
    assert "imported 20 episode(s), 765 step(s), 9 crash(es)" in out


def test_import_prob2trace(capsys, paper_traces, tmp_path):
    target = tmp_path / "p.mcap"
    code, out, _ = run(capsys, "import", "prob2trace", str(paper_traces / "prob2trace"),
                       "-o", str(target))
    assert code == 0 and "imported 4 episode(s)" in out


def test_export_unknown_episode(capsys, tmp_path):
    path = tmp_path / "run.mcap"
    with EpisodeWriter(path, new_header("recorded")) as w:
        for i in (0, 1, 2, 5):
            w.write(episode(i))
    code, _, err = run(capsys, "export", "prob2trace", str(path), "--episode", "4", "-o",
                       str(tmp_path / "x.prob2trace"))
    assert code == 2 and f"{path} has no episode 4; it has 0, 1, 2, 5" in err


def test_bad_inputs(capsys, tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"activations": [}')
    out_file = tmp_path / "o.mcap"
    code, _, err = run(capsys, "import", "simb", str(bad), "-o", str(out_file))
    assert code == 2 and f"{bad}:1:18: not valid JSON" in err and "Traceback" not in err
    assert not out_file.exists()
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"\x00" * 100)
    code, _, err = run(capsys, "info", str(junk))
    assert code == 2 and "is not an MCAP file" in err


def test_damaged_tail_warns(capsys, tmp_path):
    path = tmp_path / "run.mcap"
    with EpisodeWriter(path, new_header("recorded"), compress=False) as w:  # cut in a message
        for i in range(3):
            w.write(episode(i))
    data = path.read_bytes()
    path.write_bytes(data[: data.find(b'"episode":2,"step":2')])
    code, out, err = run(capsys, "info", str(path), "--json")
    assert code == 0 and json.loads(out)["episodes"] == 2
    assert "warning" in err and "read 2 complete episode(s)" in err


@pytest.mark.parametrize("existing", [False, True])
def test_interrupted_import_says_what_it_kept(capsys, tmp_path, monkeypatch, existing):
    import tracecheck.interop.simb as simb

    calls = []

    def interrupted(path, episode_id, vocab, machine=None):
        calls.append(path)
        if len(calls) > 1:
            raise KeyboardInterrupt
        return episode(0)

    monkeypatch.setattr(simb, "read_simb", interrupted)
    target = tmp_path / "out.mcap"
    if existing:
        target.write_bytes(b"old")
    traces = tmp_path / "t"
    traces.mkdir()
    for name in ("Timed_Simulation_1.json", "Timed_Simulation_2.json"):
        (traces / name).write_text("{}")
    trace = traces
    code, _, err = run(capsys, "import", "simb", str(trace), "--env", "highway", "-o",
                       str(target), *(["--force"] if existing else []))
    assert code == 130
    assert err.strip() == f"interrupted: {target} was not {'changed' if existing else 'written'}"
    assert (target.read_bytes() == b"old") if existing else not target.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == (["out.mcap"] if existing else []) + \
        ["t"]  # no temporary file left behind
    assert len(calls) == 2


def test_an_interrupt_typer_catches_is_reported(capsys, monkeypatch):
    """Typer turns Ctrl-C into a silent exit 130; tracecheck says it was interrupted."""
    def interrupted(runs, **options):
        raise KeyboardInterrupt

    monkeypatch.setattr("tracecheck.episodes.summary.summarise", interrupted)
    code, _, err = run(capsys, "info", "x.mcap")
    assert code == 130 and err.strip() == "interrupted"


@pytest.mark.parametrize("kind, folder, model", [
    ("simb", "simb", "Corridor.mch"), ("prob2trace", "traces", "Corridor.mch")])
def test_import_with_workers_writes_the_same_file(capsys, tmp_path, kind, folder, model):
    """--workers reads and encodes the traces in worker processes: the same file, byte for
    byte (one clock and creation time), and a bad trace among them the same error."""
    import shutil
    from unittest import mock

    from tests.helpers import ROOT

    fixtures = ROOT / "tests" / "fixtures" / "prob2project"
    traces = tmp_path / "in"
    shutil.copytree(fixtures / folder, traces)
    for k in range(3):  # enough files for several tasks of the workers
        for f in sorted((fixtures / folder).iterdir()):
            shutil.copy(f, traces / f"copy{k}_{f.name}")
    from tracecheck.episodes import writer as writer_module

    files, here = [], []
    encode = writer_module.encode_episode

    def encoding(*args, **kw):  # counted in this process only
        here[-1] += 1
        return encode(*args, **kw)
    for workers in ("1", "2"):
        here.append(0)
        out = tmp_path / f"w{workers}.mcap"
        with mock.patch("time.time_ns", return_value=1_700_000_000_000_000_000), \
                mock.patch("tracecheck.episodes.writer._dt", FixedDate), \
                mock.patch.object(writer_module, "encode_episode", encoding):
            code, text, err = run(capsys, "import", kind, str(traces), "--model",
                                  str(fixtures / model), "-o", str(out), "--workers", workers)
        assert code == 0, err
        files.append(out.read_bytes())
    assert files[0] == files[1] and here[0] > 0 and here[1] == 0  # the workers encoded
    bad = traces / ("copy1_zz.json" if kind == "simb" else "copy1_zz.prob2trace")
    bad.write_text('{"activations": [}' if kind == "simb" else '{"transitionList": [}')
    out = tmp_path / "bad.mcap"
    code, _, err = run(capsys, "import", kind, str(traces), "--model", str(fixtures / model),
                       "-o", str(out), "--workers", "2")
    assert code == 2 and f"{bad}:1:" in err and "not valid JSON" in err
    assert "Traceback" not in err and not out.exists()
