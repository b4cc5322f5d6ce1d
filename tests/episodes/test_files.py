"""Run files written by the output rule (tracecheck/episodes/files.py): never over an input,
never through a link planted where a temporary or lock file goes; a recording's lock."""

from __future__ import annotations

import pytest

from tests.helpers import episode
from tracecheck.episodes.columns import read_columns
from tracecheck.episodes.files import recording_into, write_run
from tracecheck.episodes.writer import new_header
from tracecheck.errors import InputError


@pytest.fixture
def target(tmp_path):
    path = tmp_path / "precious"
    path.write_bytes(b"keep")
    return path


def test_write_run_never_follows_a_link_at_the_old_temporary_name(tmp_path, target):
    out = tmp_path / "run.mcap"
    (tmp_path / "run.mcap.part").symlink_to(target)
    assert write_run(out, new_header("imported-simb"), [episode(0)]) == (1, 3, 0)
    assert target.read_bytes() == b"keep" and len(read_columns(out).episode_ids) == 1
    out.write_bytes(b"old")
    with pytest.raises(InputError, match="run.mcap exists; give another name, or --force"):
        write_run(out, new_header("imported-simb"), [episode(0)])
    with pytest.raises(InputError, match="run.mcap is the input"):
        write_run(out, new_header("imported-simb"), [episode(0)], force=True, inputs=[out])
    assert out.read_bytes() == b"old"


def test_a_recording_never_follows_a_link_at_its_temporary_or_lock_name(tmp_path, target):
    out = tmp_path / "run.mcap"
    out.write_bytes(b"old")
    (tmp_path / "run.mcap.part").symlink_to(target)
    with recording_into(out, new_header("recorded"), force=True) as writer:
        writer.write(episode(0))
    assert target.read_bytes() == b"keep" and len(read_columns(out).episode_ids) == 1
    (tmp_path / "new.mcap.lock").symlink_to(target)
    with pytest.raises(InputError, match="another tracecheck is writing .*new.mcap"):
        with recording_into(tmp_path / "new.mcap", new_header("recorded")):
            pass
    assert target.read_bytes() == b"keep"


def test_a_new_recording_is_created_exclusively_in_place(tmp_path, target):
    """A new file is written in place (finished episodes readable while recording) — but
    a link there is an existing output, refused, and never written through."""
    out = tmp_path / "run.mcap"
    with recording_into(out, new_header("recorded")) as writer:
        writer.write(episode(0))
        assert len(read_columns(out).episode_ids) == 1  # readable while recording
    link = tmp_path / "link.mcap"
    link.symlink_to(target)
    with pytest.raises(InputError, match="is a symbolic link"):
        with recording_into(link, new_header("recorded"), force=True):
            pass
    assert target.read_bytes() == b"keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.mcap", "precious", "run.mcap"]
