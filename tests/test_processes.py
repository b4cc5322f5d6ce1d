"""Worker pools end at once when the command stops them, even before a worker has set
itself up (an import of a few traces once hung in the pool's join)."""

from __future__ import annotations

import signal
import threading
import time

from tracecheck.processes import worker_pool


def _slow_start() -> None:
    time.sleep(2.0)  # the command stops the pool before this worker's own setup


def test_a_pool_stopped_before_its_workers_started_ends_at_once():
    caught = []
    saved = signal.signal(signal.SIGTERM, lambda *a: caught.append(a))  # as a command has
    try:
        pool = worker_pool(2, _slow_start)
        started = time.perf_counter()
        done = threading.Event()

        def stop() -> None:
            pool.terminate()
            pool.join()
            done.set()
        threading.Thread(target=stop, daemon=True).start()
        assert done.wait(20.0), "the pool's workers kept the command's SIGTERM handler"
        assert time.perf_counter() - started < 1.5  # not after the workers' setup either
        assert not caught  # the command's own handler is back, and was not called
        assert signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
    finally:
        signal.signal(signal.SIGTERM, saved)
