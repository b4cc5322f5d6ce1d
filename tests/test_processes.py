"""Worker pools end at once when the command stops them, even before a worker has set
itself up (an import of a few traces once hung in the pool's join)."""

from __future__ import annotations

import signal
import threading
import time

import pytest

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


def _answer(n: int) -> bytes:
    return bytes([n % 256]) * 1_000_000  # bigger than any pipe's buffer


def _echo(data: bytes) -> bytes:
    return data


def _fail(text: str) -> None:
    raise ValueError(text)


def _die() -> None:
    import os

    os.kill(os.getpid(), signal.SIGKILL)


def _small(n: int) -> bytes:
    return bytes([n % 256]) * 100_000


def _exits() -> None:
    import sys

    sys.exit(3)


def _no_init() -> None:
    raise RuntimeError("no simulator licence in this worker")


def _stays() -> None:
    signal.signal(signal.SIGTERM, lambda *a: None)  # a simulator's own handler


def test_a_worker_answers_its_calls_in_order_however_many_are_sent_ahead():
    """Calls sent before any answer is read, each answer a megabyte: no deadlock on full
    pipes (the calls sent wait for answers once they exceed the backlog), every answer in
    its call's order, and one read out of order gives its own."""
    from tracecheck.processes import Worker

    with Worker() as worker:
        calls = [worker.call(_answer, n) for n in range(40)]
        assert calls[7].get() == _answer(7)
        assert [c.get() for c in calls] == [_answer(n) for n in range(40)]
        assert worker.busy == 0
        big = [bytes([n]) * 1_000_000 for n in range(5)]  # big calls, big answers
        got: list = []

        def run() -> None:
            calls = [worker.call(_echo, data) for data in big]
            got.extend(c.get() for c in calls)
            # tiny calls, each charged ~1 KB by the system however small, big answers
            calls = [worker.call(_small, n) for n in range(1000)]
            got.append(all(c.get() == _small(n) for n, c in enumerate(calls)))
        thread = threading.Thread(target=run, daemon=True)
        thread.start()
        thread.join(60.0)
        assert not thread.is_alive(), "a call waited on a full pipe while the worker waited"
        assert got == [*big, True]


def test_a_call_that_raises_raises_where_it_is_waited_for_and_the_worker_goes_on():
    """With the worker's traceback as its cause (what --debug shows, as a pool gives it); a
    SystemExit in the worker is an error, not the command's quiet end."""
    import pytest

    from tracecheck.processes import Worker

    with Worker() as worker:
        failing, after = worker.call(_fail, "bad seed"), worker.call(pow, 2, 10)
        with pytest.raises(ValueError, match="bad seed") as info:
            failing.get()
        assert "in _fail" in str(info.value.__cause__)  # the remote traceback
        assert after.get() == 1024
        with pytest.raises(RuntimeError, match=r"^SystemExit\(3\) in a worker process$"):
            worker.call(_exits).get()
        assert worker.call(pow, 3, 2).get() == 9


def test_a_worker_whose_set_up_failed_says_so_at_every_call():
    import pytest

    from tracecheck.processes import Worker

    with Worker(_no_init) as worker:
        for _ in range(2):
            with pytest.raises(RuntimeError, match="no simulator licence"):
                worker.call(pow, 2, 10).get()


def test_a_worker_that_dies_is_said_not_waited_for():
    """A worker killed mid-call (out of memory, say): the call raises WorkerDied at once,
    with how it ended and what to do."""
    import pytest

    from tracecheck.processes import Worker, WorkerDied

    with Worker() as worker:
        call = worker.call(_die)
        started = time.perf_counter()
        with pytest.raises(WorkerDied) as info:
            call.get()
        assert time.perf_counter() - started < 5.0
        assert info.value.message == ("a worker process ended before it answered (killed by "
                                      "signal 9)")
        assert "fewer --workers" in info.value.hint
        with pytest.raises(WorkerDied):  # a call to it: not a broken pipe (a closed stdout)
            worker.call(pow, 2, 10)


def test_a_worker_closed_mid_call_ends_at_once():
    """Even one whose code handles SIGTERM itself (killed after a second)."""
    from tracecheck.processes import Worker

    for start in (_slow_start, _stays):
        worker = Worker(start)
        worker.call(time.sleep, 30.0)
        time.sleep(0.2)
        started = time.perf_counter()
        worker.close()
        assert time.perf_counter() - started < 3.0
        assert not worker._process.is_alive()


def test_idle_workers_end_when_their_pipes_close():
    """Each forked worker closes its copies of the command's ends of the pipes (its own and
    those of workers made before it), so an idle worker sees its pipe close and ends by
    itself — at once, even one whose code handles SIGTERM."""
    from tracecheck.processes import Worker

    workers = [Worker(_stays) for _ in range(3)]
    for w in workers:
        assert w.call(pow, 2, 3).get() == 8
    started = time.perf_counter()
    for w in workers:
        w.stop()
    for w in workers:
        w.close()
    assert time.perf_counter() - started < 0.9  # none waited for a kill
    assert [w._process.exitcode for w in workers] == [0, 0, 0]


def test_a_ctrl_c_while_a_worker_starts_is_held_back_then_raised():
    """Not lost, not raised inside the start (where a half-started worker would be left):
    raised once it started, with the command's own handlers back."""
    import os

    import pytest

    from tracecheck.processes import _starting

    term = signal.getsignal(signal.SIGTERM)
    reached = []
    with pytest.raises(KeyboardInterrupt):
        with _starting():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)
            reached.append(True)
    assert reached == [True]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert signal.getsignal(signal.SIGTERM) is term


def test_a_forked_workers_collector_leaves_what_the_command_made_before_it():
    """gc.freeze() around the fork: the worker's garbage collector does not walk the
    command's objects (a tenth of a recording's work there), and the command's own collector
    walks them again after."""
    import gc

    from tracecheck.processes import Worker, worker_context

    if worker_context().get_start_method() != "fork":
        pytest.skip("a spawned worker starts with nothing of the command's")
    kept = [[i] for i in range(20_000)]  # the command's own objects, tracked
    with Worker() as worker:
        frozen = worker.call(gc.get_freeze_count).get()
        tracked = worker.call(_walked_objects).get()
    assert frozen >= len(kept)
    assert tracked < len(kept)
    assert gc.get_freeze_count() == 0
    assert gc.is_tracked(kept[0])


def _walked_objects() -> int:
    """The objects a worker's collector walks (called in the worker)."""
    import gc

    return len(gc.get_objects())


def test_a_call_says_whether_its_answer_has_come_without_waiting():
    from tracecheck.processes import Worker

    with Worker() as worker:
        slow, quick = worker.call(time.sleep, 1.0), worker.call(abs, -3)
        assert not slow.ready() and not quick.ready()  # answered in order: not yet
        deadline = time.monotonic() + 20.0
        while not quick.ready():
            assert time.monotonic() < deadline
            time.sleep(0.05)
        assert slow.ready() and quick.get() == 3 and slow.get() is None
