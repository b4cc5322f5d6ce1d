"""Worker processes of a command (recording, falsification, checking with ``--workers``):
started by fork where the system has it, quiet on Ctrl-C (it reaches the whole process group;
the command stops its workers itself), and ended with the command however it ends."""

from __future__ import annotations

import multiprocessing as mp
import signal

__all__ = ["worker_context", "quiet_worker"]


def worker_context():
    """The multiprocessing context workers start in: fork (the command's modules and data
    are there already), else spawn."""
    return mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")


def quiet_worker() -> None:
    """In a worker, first: leave Ctrl-C to the command (which stops its pool), let SIGTERM
    end it, and ask Linux to end it when the command's process ends, SIGKILL included,
    instead of leaving it to fail writing to a closed pipe."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the pool's terminate() still ends it
        pass
