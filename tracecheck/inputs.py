"""Reading the files a user names (machines, states, traces, property and obligations
files): UTF-8 text of bounded size, strict JSON, and a located :class:`InputError` for each
way that fails.

>>> from tracecheck.inputs import read_text
>>> read_text("no/such/file.mch", "model file")
Traceback (most recent call last):
  ...
tracecheck.errors.InputError: no such model file: no/such/file.mch
"""

from __future__ import annotations

from pathlib import Path

from .errors import InputError

__all__ = ["MAX_TEXT_BYTES", "read_text", "read_json"]

#: The largest text file tracecheck reads (a machine, a state, a trace, a property file).
MAX_TEXT_BYTES = 64 << 20


def read_text(path, what: str, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """The UTF-8 text of ``path``; an :class:`InputError` naming ``what`` if it cannot be read
    or is larger than ``max_bytes``."""
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > max_bytes:
            raise InputError(f"the {what} {path} has {size:,} bytes; tracecheck reads at most "
                             f"{max_bytes:,} for a {what}",
                             hint="split it up: one state or one episode per file")
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"no such {what}: {path}") from None
    except IsADirectoryError:
        raise InputError(f"the {what} {path} is a folder, not a file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the {what} {path}: {exc}") from None


def read_json(path, what: str, max_bytes: int = MAX_TEXT_BYTES):
    """The JSON value in ``path``: at most ``max_bytes``, nested at most 1024 levels, no NaN
    or Infinity (each an :class:`InputError` with the line and column)."""
    import orjson

    text = read_text(path, what, max_bytes)
    try:
        return orjson.loads(text)
    except orjson.JSONDecodeError as exc:
        msg = exc.msg
        if text.startswith(("NaN", "Infinity", "-Infinity"), exc.pos):
            msg = "NaN and Infinity are not JSON numbers, and B reals are finite"
        raise InputError(f"not valid JSON: {msg}", file=str(path), line=exc.lineno,
                         column=exc.colno, source=text) from None
