"""import, export and info on the command line."""

from __future__ import annotations

import json

import pytest

from tests.helpers import episode, run
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
    import tracecheck.interop as interop

    def interrupted(paths, **kw):
        yield episode(0)
        raise KeyboardInterrupt

    monkeypatch.setattr(interop, "import_simb", interrupted)
    target = tmp_path / "out.mcap"
    if existing:
        target.write_bytes(b"old")
    trace = tmp_path / "t.json"
    trace.write_text("{}")
    code, _, err = run(capsys, "import", "simb", str(trace), "--env", "highway", "-o",
                       str(target), *(["--force"] if existing else []))
    assert code == 130
    assert err.strip() == f"interrupted: {target} was not {'changed' if existing else 'written'}"
    assert (target.read_bytes() == b"old") if existing else not target.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == (["out.mcap"] if existing else []) + \
        ["t.json"]  # no temporary file left behind


def test_an_interrupt_typer_catches_is_reported(capsys, monkeypatch):
    """Typer turns Ctrl-C into a silent exit 130; tracecheck says it was interrupted."""
    def interrupted(runs, **options):
        raise KeyboardInterrupt

    monkeypatch.setattr("tracecheck.episodes.summary.summarise", interrupted)
    code, _, err = run(capsys, "info", "x.mcap")
    assert code == 130 and err.strip() == "interrupted"
