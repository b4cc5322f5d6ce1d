"""Worker processes of a command (recording, falsification, checking with ``--workers``):
started by fork where the system has it, quiet on Ctrl-C (it reaches the whole process group;
the command stops its workers itself), and ended with the command however it ends."""

from __future__ import annotations

import gc
import multiprocessing as mp
import os
import pickle
import signal
import threading
import weakref
from collections import deque
from contextlib import contextmanager
from typing import Any, Callable, Iterable, Iterator, Optional, TypeVar

from .errors import TracecheckError

__all__ = ["worker_context", "quiet_worker", "worker_pool", "in_order", "Worker", "Call",
           "WorkerDied", "carried"]

J = TypeVar("J")
H = TypeVar("H")
R = TypeVar("R")
_END = object()


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


@contextmanager
def _forking():
    """Processes started inside are forked with Ctrl-C ignored and SIGTERM at its default
    (in the main thread; elsewhere signals are the main thread's)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        yield
    finally:
        for s, handler in saved.items():
            signal.signal(s, handler)


@contextmanager
def _frozen_heap() -> Iterator[None]:
    """Processes forked inside leave what the command made before to itself: their garbage
    collector never walks it (``gc.freeze``; the command's own collector walks it again
    after). Walking it in each worker was a tenth of a grid-world recording's work there,
    and wrote to every page of it that the fork shared."""
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def worker_pool(workers: int, initializer=None, initargs: tuple = ()):
    """A pool of ``workers`` processes (:func:`worker_context`) that end at once when the
    command stops them: they are forked with Ctrl-C ignored and SIGTERM at its default, so
    a pool stopped before a worker ran its ``initializer`` does not leave that worker with
    the command's own handlers, waiting for ever (an import of a few traces hung so)."""
    with _forking(), _frozen_heap():
        return worker_context().Pool(workers, initializer=initializer, initargs=initargs)


class WorkerDied(TracecheckError):
    """A worker process ended while a call to it was unanswered (killed, or out of memory)."""


@contextmanager
def _starting():
    """Ctrl-C and SIGTERM held back, not lost, while a worker starts (in the main thread,
    where signal handlers run): held by the signal mask, which the worker starts with, and
    noted by handlers of their own (another thread may take a signal the mask holds back
    here); once started, the command's own handler is given one that came meanwhile. The
    worker sets its own handlers before it takes them (:func:`_serve`)."""
    if threading.current_thread() is not threading.main_thread() or \
            not hasattr(signal, "pthread_sigmask"):
        with _forking():
            yield
        return
    caught: list[int] = []
    saved = {s: signal.getsignal(s) for s in _SIGNALS}
    for s in saved:
        signal.signal(s, lambda signum, frame: caught.append(signum))
    held = signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)  # one held back is noted now
        try:  # the command's handlers back, both, whichever signal comes in between
            signal.signal(signal.SIGTERM, saved[signal.SIGTERM])
        finally:
            signal.signal(signal.SIGINT, saved[signal.SIGINT])
    if caught:
        handler = saved[caught[0]]
        if callable(handler):
            handler(caught[0], None)
        elif handler == signal.SIG_DFL:
            if caught[0] == signal.SIGINT:
                raise KeyboardInterrupt
            os.kill(os.getpid(), caught[0])  # its default: the end of the command


_SIGNALS = {signal.SIGINT, signal.SIGTERM}

#: the command's ends of the pipes of its workers: a worker forked later closes its copies,
#: so that each worker sees its own pipe close when the command closes it
_ENDS: "weakref.WeakSet" = weakref.WeakSet()


class Worker:
    """One worker process (:func:`worker_context`, quiet as :func:`quiet_worker` makes it)
    spoken to through a pipe by the one thread that uses it, with no thread of its own — a
    pool's three threads per pool cost a recording's writer a tenth of its time. Calls run
    one after another in the order they are made; a call's :meth:`Call.get` reads the
    answers up to its own, and raises what the call raised (with the worker's traceback as
    its cause, as a pool gives it). A worker that dies is said (:class:`WorkerDied`), not
    waited for; :meth:`close` ends it at once.

    >>> with Worker() as w:  # doctest: +SKIP
    ...     w.call(pow, 2, 10).get()
    1024
    """

    #: what a call counts for in the backlog besides its bytes: the system's own per send
    #: (Linux charges about 1 KB for each message on a socket, however small)
    PER_CALL = 2048

    def __init__(self, initializer: Optional[Callable] = None, initargs: tuple = ()) -> None:
        context = worker_context()
        self._conn, theirs = context.Pipe()
        #: bytes of calls sent and not yet answered before the next call first waits for an
        #: answer: a call never waits on a full pipe while the worker waits to send its
        #: answer (a quarter of what the pipe holds, as the system says)
        self.backlog = _room(self._conn) // 4
        self._process = context.Process(target=_serve, args=(theirs, initializer, initargs),
                                        daemon=True)
        self._sent: deque[tuple[Call, int]] = deque()  # calls not yet answered, their sizes
        self._backlog = 0
        self._closed = False
        _ENDS.add(self._conn)  # before the fork: its copy in the worker is closed there
        try:
            with _starting(), _frozen_heap():
                self._process.start()
                theirs.close()
        except BaseException:  # a Ctrl-C held back while it started comes here
            theirs.close()
            if self._process.pid is not None:  # started: ended at once
                self.close()
            raise

    def __enter__(self) -> "Worker":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def call(self, fn: Callable, *args: Any) -> "Call":
        """Run ``fn(*args)`` in the worker after the calls made before (``fn`` and ``args``
        pickled: a module-level function)."""
        data = pickle.dumps((fn, args), protocol=pickle.HIGHEST_PROTOCOL)
        size = len(data) + self.PER_CALL
        while self._sent and self._backlog + size > self.backlog:
            self._receive()
        try:
            self._conn.send_bytes(data)
        except OSError:  # a broken pipe: the worker is gone
            raise self._died() from None
        handle = Call(self)
        self._sent.append((handle, size))
        self._backlog += size
        return handle

    @property
    def busy(self) -> int:
        """The calls not yet answered."""
        self._received()
        return len(self._sent)

    def _received(self) -> None:
        """The answers that have come read, without waiting for more."""
        while self._sent and self._conn.poll():
            self._receive()

    def _receive(self) -> None:
        handle, size = self._sent[0]
        try:
            data = self._conn.recv_bytes()
        except (EOFError, OSError):
            raise self._died() from None
        self._sent.popleft()
        self._backlog -= size
        try:
            ok, value = pickle.loads(data)
        except Exception as exc:  # noqa: BLE001 - the worker checks its exceptions load
            ok, value = False, RuntimeError(f"a worker's answer does not unpickle: {exc}")
        handle._set(ok, value)

    def _died(self) -> WorkerDied:
        self._process.join(1)
        code = self._process.exitcode
        how = (f"killed by signal {-code}" if code is not None and code < 0
               else "still running" if code is None else f"exit status {code}")
        return WorkerDied(f"a worker process ended before it answered ({how})",
                          hint="out of memory, or killed; run again (fewer --workers needs "
                               "less memory)")

    def stop(self) -> None:
        """Ask the worker to end, without waiting (:meth:`close` waits): an idle one ends
        when its pipe closes, a busy one is terminated."""
        if self._closed:
            return
        self._closed = True
        self._conn.close()
        self._sent.clear()
        if self._process.is_alive():
            self._process.terminate()

    def close(self) -> None:
        """End the worker at once (what it was running is not needed): :meth:`stop`, then
        killed if it stays a second (its code handles SIGTERM itself)."""
        self.stop()
        self._process.join(1.0)
        if self._process.is_alive():
            self._process.kill()
        self._process.join()


def _room(conn) -> int:
    """The bytes the pipe ``conn`` holds one way, made at least 1 MiB where the system lets
    it (a socket on Unix), else what it says; 16 KiB where it says nothing."""
    import socket

    try:
        sock = socket.socket(fileno=os.dup(conn.fileno()))
    except (OSError, AttributeError, ValueError):
        return 16 * 1024
    try:
        for option in (socket.SO_SNDBUF, socket.SO_RCVBUF):
            if sock.getsockopt(socket.SOL_SOCKET, option) < 1 << 20:
                sock.setsockopt(socket.SOL_SOCKET, option, 1 << 20)
        return min(sock.getsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF),
                   sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF))
    except OSError:
        return 16 * 1024
    finally:
        sock.close()


class Call:
    """A call made to a :class:`Worker`: :meth:`get` waits for its answer."""

    def __init__(self, worker: Worker) -> None:
        self._worker: Optional[Worker] = worker
        self._answer: Optional[tuple[bool, Any]] = None

    def _set(self, ok: bool, value: Any) -> None:
        self._answer, self._worker = (ok, value), None

    def ready(self) -> bool:
        """Whether the answer has come (read without waiting, with the answers before it)."""
        if self._answer is None and self._worker is not None:
            self._worker._received()
        return self._answer is not None

    def get(self) -> Any:
        """What the call returned, or the exception it raised, raised here."""
        while self._answer is None:
            assert self._worker is not None
            self._worker._receive()
        ok, value = self._answer
        if not ok:
            raise value
        return value


def carried(exc: BaseException):
    """``exc`` made to cross to another process with the traceback it has here (as its
    ``__cause__`` there, as a pool's are); a RuntimeError saying what it was where it is no
    Exception (a SystemExit in a worker must not end the command that waits for it
    quietly) or would not be rebuilt there (an exception whose arguments are not those it
    was made with)."""
    from multiprocessing.pool import ExceptionWithTraceback

    trace = exc.__traceback__
    if not isinstance(exc, Exception):
        exc = RuntimeError(f"{type(exc).__name__}({exc}) in a worker process")
    try:
        pickle.loads(pickle.dumps(exc, protocol=pickle.HIGHEST_PROTOCOL))
    except Exception:  # noqa: BLE001 - any reason it does not cross
        exc = RuntimeError(f"{type(exc).__name__}: {exc}"[:4000])
    return ExceptionWithTraceback(exc, trace)


def _serve(conn, initializer, initargs) -> None:
    """A :class:`Worker`'s process: its calls, answered in order, until the pipe closes
    (an ``initializer`` that fails: every call answered with its exception)."""
    for end in list(_ENDS):  # forked: the command's ends of the pipes, copies it holds
        end.close()
    quiet_worker()
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _SIGNALS)
    failed = None
    if initializer is not None:
        try:
            initializer(*initargs)
        except BaseException as exc:  # noqa: BLE001 - said by every call
            failed = carried(exc)
    while True:
        try:
            data = conn.recv_bytes()
        except (EOFError, OSError):
            return
        if failed is not None:
            answer = (False, failed)
        else:
            try:
                fn, args = pickle.loads(data)
                answer = (True, fn(*args))
            except BaseException as exc:  # noqa: BLE001 - raised where the call is waited for
                answer = (False, carried(exc))
        try:
            out = pickle.dumps(answer, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as exc:  # noqa: BLE001 - an answer that does not pickle
            out = pickle.dumps((False, carried(RuntimeError(
                f"a worker's answer does not pickle ({type(exc).__name__}: {exc})"[:4000]))))
        try:
            conn.send_bytes(out)
        except OSError:  # the command closed the pipe
            return


def in_order(submit: Callable[[J], H], jobs: Iterable[J], limit: int,
             result: Callable[[H], R]) -> Iterator[R]:
    """``result(submit(job))`` for each of ``jobs``, in order, with at most ``limit`` jobs
    submitted and not yet given (``submit`` starts a job and returns a handle; ``result``
    waits for it). The writer is often slower than the workers, and a finished job waits in
    this process until it is written: an unbounded queue held 2.4 GB after 5000 grid-world
    episodes."""
    if limit < 1:
        raise ValueError(f"limit must be at least 1, not {limit}")
    ahead: deque[H] = deque()
    jobs = iter(jobs)
    while True:
        while len(ahead) < limit:
            job = next(jobs, _END)
            if job is _END:
                break
            ahead.append(submit(job))
        if not ahead:
            return
        yield result(ahead.popleft())
