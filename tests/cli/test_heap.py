"""A command fixes glibc's mmap threshold, unless the user set it; the library does not."""

from __future__ import annotations

import os
import platform
import subprocess
import sys

import pytest

from tracecheck.cli import heap

GLIBC = sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc"


def _run(code: str, **env: str) -> str:
    environ = {k: v for k, v in os.environ.items() if k != "MALLOC_MMAP_THRESHOLD_"}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**environ, **env}, check=True).stdout.strip()


@pytest.mark.skipif(not GLIBC, reason="glibc's malloc only")
def test_steady_heap_sets_the_threshold_once_asked():
    assert _run("from tracecheck.cli.heap import steady_heap; print(steady_heap())") == "True"
    assert _run("from tracecheck.cli.heap import steady_heap; print(steady_heap())",
                MALLOC_MMAP_THRESHOLD_="131072") == "False"


def test_steady_heap_asks_mallopt_for_the_threshold(monkeypatch):
    calls = []

    class Mallopt:
        def __call__(self, param, value):
            calls.append((param, value))
            return 1

    class Libc:
        mallopt = Mallopt()

    monkeypatch.setattr(heap.sys, "platform", "linux")
    monkeypatch.delenv("MALLOC_MMAP_THRESHOLD_", raising=False)
    monkeypatch.setattr(heap.ctypes, "CDLL", lambda name: Libc())
    assert heap.steady_heap() is True
    assert calls == [(-3, heap.MMAP_THRESHOLD)]


def test_the_cli_fixes_it_and_importing_the_library_does_not(monkeypatch):
    called = []
    monkeypatch.setattr("tracecheck.cli.steady_heap", lambda: called.append(1))
    from tracecheck.cli import main

    with pytest.raises(SystemExit):
        main(["--help"])
    assert called == [1]
    assert _run("import tracecheck, tracecheck.episodes, tracecheck.checking, sys; "
                "print('tracecheck.cli.heap' in sys.modules)") == "False"


def test_steady_heap_leaves_a_user_s_tunables_and_other_c_libraries_alone(monkeypatch):
    monkeypatch.setattr(heap.sys, "platform", "linux")
    monkeypatch.delenv("MALLOC_MMAP_THRESHOLD_", raising=False)
    monkeypatch.setenv("GLIBC_TUNABLES", "glibc.malloc.mmap_threshold=65536")
    monkeypatch.setattr(heap.ctypes, "CDLL", lambda name: pytest.fail("asked the C library"))
    assert heap.steady_heap() is False
    monkeypatch.delenv("GLIBC_TUNABLES")

    class NoMallopt:  # musl and others: no such function
        pass

    monkeypatch.setattr(heap.ctypes, "CDLL", lambda name: NoMallopt())
    assert heap.steady_heap() is False

    def unloadable(name):
        raise OSError("no C library")

    monkeypatch.setattr(heap.ctypes, "CDLL", unloadable)
    assert heap.steady_heap() is False
    monkeypatch.setattr(heap.sys, "platform", "darwin")
    assert heap.steady_heap() is False
