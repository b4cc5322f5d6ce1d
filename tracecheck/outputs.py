"""The output rule: how every command that writes a file or a folder writes it.

* An output is never one of the inputs: the same file (after resolving symbolic links, or a
  hard link to it), a path inside an input folder, or a folder that holds an input are
  refused (exit 2) — with or without ``--force``.
* An existing output is replaced only with ``--force``; an output that is a symbolic link is
  refused (tracecheck never writes through one), and so is a folder where a file is wanted,
  a device or pipe, and the other way round.
* A file is written to a temporary file beside it, created exclusively (``O_CREAT|O_EXCL|
  O_NOFOLLOW``, a random name, so a link planted there is never followed) and renamed into
  place only once complete; an error or Ctrl-C removes it and leaves the old file as it was.
* A folder is written as a fresh temporary folder beside it; only once it is complete is the
  old folder moved aside, the new one renamed into place and the old one removed. ``--force``
  replaces only a folder of tracecheck's own outputs (the file patterns a writer names).
* Names made from input text (metric names, operation names) go through :func:`safe_name`
  and :func:`inside`: a portable file name that stays inside its folder.

>>> check_output(Path("run.mcap"), [Path("traces")], force=False)  # doctest: +SKIP
>>> with atomic_file(Path("run.mcap")) as stream:  # doctest: +SKIP
...     stream.write(b"...")
"""

from __future__ import annotations

import fnmatch
import os
import re
import secrets
import shutil
import stat
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO, Iterator, Literal, Optional, Sequence

from .errors import InputError

__all__ = ["check_output", "input_paths", "atomic_file", "atomic_temp", "temp_file",
           "write_file", "atomic_folder", "open_new", "safe_name", "inside"]

Kind = Literal["file", "folder"]

_NEW = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | \
    getattr(os, "O_CLOEXEC", 0)
_TRIES = 100


def _within(path: str, folder: str) -> bool:
    return path == folder or path.startswith(folder.rstrip(os.sep) + os.sep)


def input_paths(*specs) -> list[Path]:
    """The specs that name existing files or folders (a shield given by name such as
    ``paper`` is no path), for :func:`check_output`'s ``inputs``."""
    paths = []
    for spec in specs:
        for item in spec if isinstance(spec, (list, tuple)) else [spec]:
            if item is not None and os.path.lexists(str(item)):
                paths.append(Path(str(item)))
    return paths


def check_output(out: Path, inputs: Sequence[Path] = (), *, force: bool = False,
                 kind: Kind = "file", what: str = "output", example: str = "",
                 contents: Sequence[str] = ()) -> Path:
    """Refuse ``out`` (an :class:`InputError`, exit 2) unless writing it is safe.

    Args:
        out: the file or folder to write.
        inputs: the files and folders the command reads.
        force: whether an existing output may be replaced.
        kind: ``"file"`` or ``"folder"``.
        what: how messages name the output (``"output"``, ``"--plot folder"``).
        example: a file name for the message about a folder given as a file.
        contents: for a folder, the patterns of the files the writer puts there; ``--force``
            replaces only a folder whose entries are all such files.

    Returns ``out``. Example: ``check_output(Path("RUN.mcap"), [Path("RUN.mcap")])`` raises
    "the output RUN.mcap is the input RUN.mcap".
    """
    out = Path(out)
    _not_an_input(out, inputs, kind, what)
    if os.path.islink(out):
        raise InputError(f"the {what} {out} is a symbolic link; tracecheck never writes "
                         "through one", hint="give the path of the file itself, or remove "
                                              "the link")
    _check_parent(out, what)
    if kind == "file":
        _check_file(out, force, what, example)
    else:
        _check_folder(out, force, what, contents)
    return out


def _not_an_input(out: Path, inputs: Sequence[Path], kind: Kind, what: str) -> None:
    real = os.path.realpath(out)
    for given in inputs:
        if not os.path.exists(given):
            continue
        source = os.path.realpath(given)
        if real == source or (os.path.exists(out) and os.path.samefile(out, given)):
            raise InputError(f"the {what} {out} is the input {given}; writing it would destroy "
                             "the input", hint="give another name")
        if os.path.isdir(source) and _within(real, source):
            raise InputError(f"the {what} {out} is inside the input folder {given}",
                             hint="give a name outside it")
        if kind == "folder" and _within(source, real):
            raise InputError(f"the input {given} is inside the {what} {out}, which would be "
                             "replaced", hint="give another folder")


def _check_file(out: Path, force: bool, what: str, example: str) -> None:
    try:
        mode = out.stat().st_mode
    except FileNotFoundError:
        return
    except OSError as exc:
        raise InputError(f"cannot write the {what} {out}: {exc.strerror or exc}") from None
    if stat.S_ISDIR(mode):
        raise InputError(f"the {what} {out} is a folder; give a file name"
                         + (f" such as {example}" if example else ""))
    if not stat.S_ISREG(mode):
        raise InputError(f"the {what} {out} is not a regular file (a device, a pipe or a "
                         "socket); give a file name")
    if not force:
        raise InputError(f"{out} exists; give another name, or --force to replace it (it is "
                         "replaced only once the new one is complete)")


def _check_folder(out: Path, force: bool, what: str, contents: Sequence[str]) -> None:
    if not os.path.exists(out):
        return
    if not out.is_dir():
        raise InputError(f"the {what} {out} is a file; give a folder")
    if _within(os.path.realpath(os.getcwd()), os.path.realpath(out)):
        raise InputError(f"the {what} {out} is the current folder or holds it; give a new "
                         "folder")
    try:
        entries = sorted(os.scandir(out), key=lambda e: e.name)
    except OSError as exc:
        raise InputError(f"cannot read the {what} {out}: {exc.strerror or exc}") from None
    if not entries:
        return
    if not force:
        raise InputError(f"the {what} {out} is not empty",
                         hint="give a new or empty folder, or --force to replace its contents "
                              "(removed only once the new ones are complete)")
    foreign = [e.name for e in entries if not (e.is_file(follow_symlinks=False) and any(
        fnmatch.fnmatchcase(e.name, p) for p in contents))]
    if foreign:
        listed = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more" if foreign[3:] else "")
        raise InputError(f"the {what} {out} holds {listed}, which tracecheck does not write "
                         f"there; --force replaces only a folder of its own outputs "
                         f"({', '.join(contents) or 'none'})",
                         hint="remove them, or give another folder")


def _check_parent(out: Path, what: str) -> None:
    folder = Path(os.path.abspath(out)).parent
    while not os.path.exists(folder) and folder != folder.parent:
        if os.path.islink(folder):  # a dangling link
            break
        folder = folder.parent
    if not folder.is_dir():
        raise InputError(f"cannot write the {what} {out}: {folder} is not a folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"cannot write the {what} {out}: no permission to write in {folder}")


def _make_parent(out: Path) -> None:
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot write {out}: cannot create the folder {out.parent}: "
                         f"{exc.strerror or exc}") from None


def _beside(out: Path, suffix: str) -> str:
    """A random name beside ``out`` that starts with a dot (hidden, short enough)."""
    return str(out.with_name(f".{out.name[:80]}.{secrets.token_hex(6)}{suffix}"))


def open_new(path: Path) -> BinaryIO:
    """``path`` created for writing; an :class:`InputError` if anything (a file, a link) is
    already there. For files in a folder tracecheck has just made, and for a recording
    that is written in place."""
    try:
        return os.fdopen(os.open(path, _NEW, 0o666), "wb")
    except FileExistsError:
        raise InputError(f"{path} exists (it appeared while tracecheck was writing); give "
                         "another name") from None
    except OSError as exc:
        raise InputError(f"cannot write {path}: {exc.strerror or exc}") from None


def temp_file(out: Path) -> tuple[BinaryIO, Path]:
    """A new file beside ``out`` with a random name, created exclusively: (stream, path)."""
    _make_parent(out)
    for _ in range(_TRIES):
        tmp = _beside(out, ".part")
        try:
            return os.fdopen(os.open(tmp, _NEW, 0o666), "wb"), Path(tmp)
        except FileExistsError:
            continue
        except OSError as exc:
            raise InputError(f"cannot write {out}: {exc.strerror or exc}") from None
    raise InputError(f"cannot write {out}: no free temporary name beside it")


@contextmanager
def atomic_temp(out: Path) -> Iterator[tuple[BinaryIO, Path]]:
    """``(stream, temporary path)``: as :func:`atomic_file`, for writers that also read back
    what they wrote (the run writer's columns)."""
    out = Path(out)
    stream, tmp = temp_file(out)
    try:
        with stream:
            yield stream, tmp
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(tmp, out)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise InputError(f"cannot write {out}: {exc.strerror or exc}") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


@contextmanager
def atomic_file(out: Path) -> Iterator[BinaryIO]:
    """A binary stream whose bytes replace ``out`` when the block ends without an error.

    The stream is a temporary file beside ``out`` (see the module docstring); an error or
    Ctrl-C in the block removes it and leaves ``out`` as it was. Check ``out`` first with
    :func:`check_output`.
    """
    with atomic_temp(out) as (stream, _):
        yield stream


def write_file(out: Path, data: bytes | str) -> Path:
    """Write ``data`` (text as UTF-8) to ``out`` through :func:`atomic_file`; ``out``."""
    with atomic_file(out) as stream:
        stream.write(data.encode("utf-8") if isinstance(data, str) else data)
    return Path(out)


@contextmanager
def atomic_folder(out: Path) -> Iterator[Path]:
    """A fresh folder beside ``out`` to write into; when the block ends without an error it
    replaces ``out`` (an existing ``out`` is moved aside first and removed after). An error
    or Ctrl-C removes the new folder and leaves ``out`` as it was. Check ``out`` first with
    :func:`check_output` (``kind="folder"``)."""
    out = Path(os.path.abspath(out))
    _make_parent(out)
    tmp = _temp_folder(out)
    try:
        yield tmp
        _swap(tmp, out)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise InputError(f"cannot write the folder {out}: {exc.strerror or exc}") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _temp_folder(out: Path) -> Path:
    for _ in range(_TRIES):
        tmp = _beside(out, ".new")
        try:
            os.mkdir(tmp, 0o777)
            return Path(tmp)
        except FileExistsError:
            continue
        except OSError as exc:
            raise InputError(f"cannot write the folder {out}: {exc.strerror or exc}") from None
    raise InputError(f"cannot write the folder {out}: no free temporary name beside it")


def _swap(new: Path, out: Path) -> None:
    if os.path.islink(out):
        raise InputError(f"{out} became a symbolic link while tracecheck was writing; "
                         "nothing was replaced")
    if not os.path.lexists(out):
        os.rename(new, out)
        return
    old = _beside(out, ".old")
    os.rename(out, old)
    try:
        os.rename(new, out)
    except BaseException:
        os.rename(old, out)
        raise
    shutil.rmtree(old, ignore_errors=True)


#: Names Windows reserves for devices, in any case and with any extension.
_RESERVED = {"CON", "PRN", "AUX", "NUL", *(f"COM{i}" for i in range(10)),
             *(f"LPT{i}" for i in range(10))}


def safe_name(text: str, taken: Optional[set] = None, *, max_len: int = 80) -> str:
    """A portable file name made from ``text`` (a metric name, an operation name, …).

    Only ASCII letters, digits, ``_``, ``-`` and single dots survive (every other run of
    characters — ``/``, ``\\``, NUL, control characters, spaces — becomes ``_``); no leading
    or trailing dot, no ``..``, at most ``max_len`` characters, never empty, never a Windows
    device name. With ``taken`` (a set kept by the caller), a name already given — ignoring
    case — gets ``-2``, ``-3``, … appended.

    >>> safe_name("x/../../escaped")
    'x_._._escaped'
    >>> taken = set()
    >>> safe_name("Speed", taken), safe_name("speed", taken), safe_name("CON.txt")
    ('Speed', 'speed-2', '_CON.txt')
    """
    name = re.sub(r"[^A-Za-z0-9_.-]+", "_", text)
    name = re.sub(r"\.{2,}", ".", name).strip("._-")[:max_len].rstrip("._-") or "unnamed"
    if name.split(".")[0].upper() in _RESERVED:
        name = "_" + name
    if taken is not None:
        base, n = name, 2
        while name.casefold() in taken:
            name, n = f"{base}-{n}", n + 1
        taken.add(name.casefold())
    return name


def inside(folder: Path, name: str) -> Path:
    """``folder / name``, refused (exit 2) unless ``name`` is one plain component that stays
    inside ``folder``: no separator, NUL, ``.`` or ``..``.

    >>> inside(Path("plots"), "speed.svg").as_posix()
    'plots/speed.svg'
    >>> inside(Path("plots"), "../escaped.svg")
    Traceback (most recent call last):
    tracecheck.errors.InputError: the file name '../escaped.svg' would leave the folder plots
    """
    bad = (not name or name in (".", "..") or "/" in name or "\\" in name or "\0" in name
           or os.sep in name)
    path = Path(folder) / name
    if bad or os.path.realpath(path.parent) != os.path.realpath(folder):
        raise InputError(f"the file name {name!r} would leave the folder {folder}")
    return path
