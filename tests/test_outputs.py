"""The output rule (tracecheck/outputs.py): outputs that are inputs, links, existing files,
exclusive temporary files, folders replaced only once complete, names made safe."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tracecheck.errors import InputError
from tracecheck.outputs import (atomic_file, atomic_folder, check_output, inside, open_new,
                                safe_name, write_file)


@pytest.fixture
def data(tmp_path) -> Path:
    path = tmp_path / "in.mcap"
    path.write_bytes(b"the input")
    return path


def _refused(match: str, *args, **kwargs) -> None:
    with pytest.raises(InputError, match=match):
        check_output(*args, **kwargs)


# ------------------------------------------------------------------ check_output
def test_an_output_that_is_an_input_is_refused_even_with_force(data, tmp_path):
    _refused(r"the output .*in.mcap is the input .*in.mcap; writing it would destroy",
             data, [data], force=True)
    link = tmp_path / "link.mcap"
    link.symlink_to(data)
    _refused(r"the output .*link.mcap is the input .*in.mcap", link, [data], force=True)
    _refused(r"the output .*in.mcap is the input .*link.mcap", data, [link], force=True)
    hard = tmp_path / "hard.mcap"
    os.link(data, hard)
    _refused(r"the output .*hard.mcap is the input", hard, [data], force=True)
    assert data.read_bytes() == b"the input"


def test_an_output_inside_an_input_folder_or_holding_an_input_is_refused(data, tmp_path):
    _refused(r"the input .*in.mcap is inside the output .*, which would be replaced",
             tmp_path, [data], force=True, kind="folder")
    sub = tmp_path / "traces"
    sub.mkdir()
    _refused(r"the output .*traces/Timed_Simulation_1.json is inside the input folder",
             sub / "Timed_Simulation_1.json", [sub], force=True)


def test_a_symbolic_link_is_never_written_through(tmp_path):
    target = tmp_path / "target"
    target.write_bytes(b"keep")
    link = tmp_path / "out.mcap"
    link.symlink_to(target)
    _refused("is a symbolic link; tracecheck never writes through one", link, force=True)
    dangling = tmp_path / "dangling"
    dangling.symlink_to(tmp_path / "nowhere")
    _refused("is a symbolic link", dangling, kind="folder", force=True)
    assert target.read_bytes() == b"keep"


def test_an_existing_file_needs_force_and_the_right_kind(data, tmp_path):
    _refused(r"in.mcap exists; give another name, or --force to replace it", data)
    assert check_output(data, force=True) == data
    _refused("is a folder; give a file name such as run.mcap", tmp_path, force=True,
             example="run.mcap")
    _refused("is a file; give a folder", data, kind="folder", force=True)
    _refused("is not a regular file", Path("/dev/null"), force=True)


def test_a_folder_needs_force_and_then_holds_only_what_the_writer_writes(tmp_path):
    folder = tmp_path / "plots"
    folder.mkdir()
    assert check_output(folder, kind="folder") == folder  # empty: nothing is lost
    (folder / "a.png").write_bytes(b"")
    _refused(r"the --plot folder .*plots is not empty", folder, kind="folder",
             what="--plot folder", contents=("*.png",))
    check_output(folder, kind="folder", force=True, contents=("*.png",))
    (folder / "notes.txt").write_text("mine")
    (folder / "b.png").symlink_to(tmp_path)
    _refused(r"holds b.png, notes.txt, which tracecheck does not write there; --force "
             r"replaces only a folder of its own outputs \(\*.png\)", folder, kind="folder",
             force=True, contents=("*.png",))


def test_a_parent_that_is_a_file_is_refused(data):
    _refused(r"cannot write the output .*in.mcap/deeper/out.json: .*in.mcap is not a folder",
             data / "deeper" / "out.json")
    _refused("is not a folder", data / "cx", kind="folder")


def test_the_current_folder_is_not_replaced(tmp_path, monkeypatch):
    (tmp_path / "a.png").write_bytes(b"")
    monkeypatch.chdir(tmp_path)
    _refused("is the current folder or holds it", Path("."), kind="folder", force=True,
             contents=("*.png",))


# ------------------------------------------------------------------ writing files
def _names(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


@pytest.mark.parametrize("error", [RuntimeError, KeyboardInterrupt])
def test_an_error_while_writing_keeps_the_old_file_and_leaves_nothing(tmp_path, error):
    out = tmp_path / "out.json"
    out.write_bytes(b"old")
    with pytest.raises(error):
        with atomic_file(out) as stream:
            stream.write(b"half")
            raise error()
    assert out.read_bytes() == b"old" and _names(tmp_path) == ["out.json"]
    write_file(out, "new ✓")
    assert out.read_text(encoding="utf-8") == "new ✓" and _names(tmp_path) == ["out.json"]


def test_a_link_planted_at_the_old_temporary_name_is_not_followed(tmp_path):
    target = tmp_path / "target"
    target.write_bytes(b"keep")
    out = tmp_path / "out.json"
    (tmp_path / "out.json.part").symlink_to(target)
    write_file(out, "new")
    assert target.read_bytes() == b"keep" and out.read_text() == "new"
    assert not out.is_symlink()


def test_the_temporary_file_is_new_and_has_the_usual_permissions(tmp_path):
    umask = os.umask(0o022)
    os.umask(umask)
    with atomic_file(tmp_path / "out") as stream:
        tmp = Path(f"/proc/self/fd/{stream.fileno()}").resolve()
        assert tmp.parent == tmp_path and tmp.name.startswith(".out.") and \
            tmp.name.endswith(".part")
    assert (tmp_path / "out").stat().st_mode & 0o777 == 0o666 & ~umask


def test_open_new_refuses_whatever_is_there_and_never_follows_a_link(tmp_path):
    target = tmp_path / "target"
    target.write_bytes(b"keep")
    link = tmp_path / "x.json"
    link.symlink_to(target)
    with pytest.raises(InputError, match="x.json exists"):
        open_new(link)
    (tmp_path / "d").mkdir()
    with pytest.raises(InputError, match="d exists"):
        open_new(tmp_path / "d")
    assert target.read_bytes() == b"keep"


# ------------------------------------------------------------------ writing folders
def test_a_folder_is_replaced_only_once_the_new_one_is_complete(tmp_path):
    out = tmp_path / "simb"
    out.mkdir()
    (out / "old.json").write_text("old")
    with pytest.raises(InputError, match="broken"):
        with atomic_folder(out) as tmp:
            (tmp / "new.json").write_text("new")
            raise InputError("broken")
    assert _names(out) == ["old.json"] and _names(tmp_path) == ["simb"]
    with atomic_folder(out) as tmp:
        assert tmp.parent == tmp_path and tmp.name.startswith(".simb.")
        (tmp / "new.json").write_text("new")
        assert _names(out) == ["old.json"]  # not yet
    assert _names(out) == ["new.json"] and _names(tmp_path) == ["simb"]
    with atomic_folder(tmp_path / "a" / "fresh") as tmp:
        pass
    assert (tmp_path / "a" / "fresh").is_dir()


# ------------------------------------------------------------------ names
@pytest.mark.parametrize("text, name", [
    ("velocity", "velocity"),
    ("x/../../escaped", "x_._._escaped"),
    ("../../etc/passwd", "etc_passwd"),
    ("..", "unnamed"),
    ("", "unnamed"),
    (".hidden", "hidden"),
    ("a\\b\0c\nd\x1b[2J", "a_b_c_d_2J"),
    ("Inc => x = 2", "Inc_x_2"),
    ("NUL", "_NUL"),
    ("con.txt", "_con.txt"),
    ("Geschwindigkeit ö", "Geschwindigkeit"),
    ("a" * 300, "a" * 80),
], ids=lambda v: repr(v)[:20])
def test_safe_names(text, name):
    assert safe_name(text) == name
    assert inside(Path("/tmp"), safe_name(text)) == Path("/tmp") / name


def test_colliding_names_are_told_apart_ignoring_case():
    taken: set = set()
    assert [safe_name(t, taken) for t in ("a/b", "a_b", "A_B", "a b")] == \
        ["a_b", "a_b-2", "A_B-3", "a_b-4"]


@pytest.mark.parametrize("name", ["..", ".", "", "a/b", "a\\b", "x\0y", "../up"])
def test_inside_refuses_a_name_that_leaves_the_folder(tmp_path, name):
    with pytest.raises(InputError, match="would leave the folder"):
        inside(tmp_path, name)
