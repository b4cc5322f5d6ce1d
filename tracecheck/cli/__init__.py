"""The ``tracecheck`` command: a thin Typer layer over the library, one module per group of
commands (model, episodes, checking, stats, live, render) sharing :mod:`.common`.

Exit codes: 0 ok, 1 a check found problems when asked to fail, 2 bad input.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path
from typing import Any, Optional

from ..errors import TracecheckError
from .common import DEBUG, app, err, escape
from .heap import steady_heap

# each module registers its commands on `app`, in the order `tracecheck --help` lists them
from . import model  # noqa: E402,F401  check-model, eval, guards
from . import episodes  # noqa: E402,F401  import, export, info
from . import checking  # noqa: E402,F401  replay, diff
from . import stats  # noqa: E402,F401  stats, simulate
from . import live  # noqa: E402,F401  envs, train, record
from . import render  # noqa: E402,F401  render, report
from . import project  # noqa: E402,F401  project
from . import search  # noqa: E402,F401  falsify
from . import tuning  # noqa: E402,F401  tune, repair

__all__ = ["app", "main"]


def main(argv: Optional[list[str]] = None) -> Any:
    """Entry point: run the app and turn tracecheck errors into exit code 2."""
    from ..limits import deep_recursion, long_integers

    _stop_on_sigterm()
    steady_heap()
    DEBUG["on"] = False
    try:
        # a command reads, prints and evaluates B: integers of up to 310 000 digits (in JSON
        # too) and formulas nested up to 2000 levels, for as long as it runs
        with warnings.catch_warnings(), long_integers(), deep_recursion():
            warnings.simplefilter("ignore", DeprecationWarning)
            return app(args=_formulas_as_written(argv), standalone_mode=True)
    except TracecheckError as exc:
        err.print("[red]error[/red]: " + escape(exc.render()), markup=True, highlight=False)
        if DEBUG["on"] and exc.__cause__ is not None:  # the user's own code: its traceback
            import traceback

            sys.stderr.write("".join(traceback.format_exception(exc.__cause__)))
        sys.exit(exc.exit_code)
    except KeyboardInterrupt:
        err.print("interrupted")
        sys.exit(130)
    except SystemExit as exc:  # Typer turns Ctrl-C into a silent exit 130: say so
        if exc.code == 130 and _from_interrupt(exc):
            err.print("interrupted")
        if exc.code == 1 and _closed_pipe(exc):  # `tracecheck diff … | head`: Typer says 1,
            sys.exit(CLOSED_PIPE)  # the code of --fail-on-change; a shell says 141
        raise
    except RecursionError:
        err.print("[red]error[/red]: the input is nested too deeply for tracecheck "
                  "(a formula or value with thousands of levels); split it up", markup=True)
        sys.exit(2)


def _formulas_as_written(argv: Optional[list[str]]) -> Optional[list[str]]:
    """``tracecheck eval '-7 mod 2'``: a formula that starts with a minus is a formula, not
    options (``-7 mod 2`` read as ``-m 'od 2'`` said "no such model file: od 2"). An
    argument of ``eval`` that starts with ``-`` and is none of its options (``-mFILE`` is one
    where FILE exists), nor an option's value, is given to it with a space before it (B
    skips it; ``--`` before the formulas does the same)."""
    args = list(sys.argv[1:] if argv is None else argv)
    first = next((i for i, a in enumerate(args) if not a.startswith("-")), None)
    if first is None or args[first] != "eval":
        return argv
    import typer.main

    command = typer.main.get_command(app).commands["eval"]  # type: ignore[attr-defined]
    takes = {o: not p.is_flag for p in command.params if p.param_type_name == "option"
             for o in (*p.opts, *p.secondary_opts)}
    takes["--help"] = False
    out, i = args[:first + 1], first + 1
    while i < len(args):
        arg = args[i]
        if arg == "--":
            out += args[i:]
            break
        if not arg.startswith("--") and takes.get(arg[:2]) and len(arg) > 2 and \
                Path(arg[2:]).exists():  # -mM.mch: a short option and its file; -floor(x)
            out.append(arg)              # and -max(s) are formulas
            i += 1
            continue
        name = arg.split("=", 1)[0]
        if name in takes:
            value = takes[name] and "=" not in arg and i + 1 < len(args)
            out += args[i:i + 1 + value]
            i += 1 + value
            continue
        out.append(" " + arg if arg.startswith("-") and len(arg) > 1 else arg)
        i += 1
    return out


#: the exit status when the reader of standard output stopped reading (``| head``): what a
#: shell reports for a program a closed pipe ended (128 + SIGPIPE), never a finding's code
CLOSED_PIPE = 141


def _closed_pipe(exc: BaseException) -> bool:
    """Whether ``exc`` ends a command whose output pipe was closed (Typer exits 1 then)."""
    import errno

    context = exc.__context__
    return isinstance(context, OSError) and context.errno == errno.EPIPE


def _from_interrupt(exc: BaseException) -> bool:
    """Whether a KeyboardInterrupt caused ``exc`` (a command that says what it kept raises
    its exit 130 from None)."""
    seen = 0
    while exc is not None and seen < 10:
        if isinstance(exc, KeyboardInterrupt):
            return True
        exc = exc.__cause__ or (None if exc.__suppress_context__ else exc.__context__)
        seen += 1
    return False


def _stop_on_sigterm() -> None:
    """SIGTERM (a job scheduler, `kill`) stops a command the way Ctrl-C does: what it was
    writing is closed or left as it was, worker processes are ended."""
    import signal
    import threading

    def stop(signum, frame):
        raise KeyboardInterrupt

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, stop)
