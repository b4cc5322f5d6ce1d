"""ProB's side of SimB's external-simulation protocol: an agent script drives, the shield
machine answers.

The paper's agents (and every case study of the authors' repository) run in their own
Python script, which talks to ProB over a loopback socket. tracecheck takes ProB's place:
it listens on a free port of 127.0.0.1, starts the script with the port number as its last
argument, and for each step

1. sends ``{"finished": 0, "enabledOperations": "A,B", "externalValues": {}}`` — the
   operations the machine enables in the current state (``$initialise_machine`` before an
   episode starts), one JSON object per line;
2. reads the answer ``{"op": "A", "delta": 1000, "predicate": "x = 1 & …", "done":
   "false"}``: the operation the agent chose, the milliseconds until it, the state after it
   as a B predicate, and whether the episode is over;
3. finds the state after, as ProB does (:func:`tracecheck.b.transitions.successor`):
   variables the predicate fixes take its values, the others the operation's.

An episode ends when the script answers ``"done": true``; one that reaches an ending
condition first (``max_steps`` operations after the initialisation, or ``ending_time_ms`` on
the script's clock) is cut with ``{"finished": 1, …}``, which the authors' scripts take as
"leave this episode and wait for the next request" — ``finished`` where an episode would
start ends the simulation. Each step is recorded with the operations that were enabled, so replay shows an action the
machine blocked as an infeasible step and a predicate no transition satisfies as a
postcondition violation — the script is never trusted. After the last episode tracecheck
sends ``{"finished": 1, …}`` and stops the script (terminate, then kill after a grace
period: scripts may spin on the closed socket).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shlex
import signal
import socket
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Optional, Sequence

from ..episodes.model import Episode, StepRecord, make_end
from ..b.clock import time_limit
from ..errors import InputError, TracecheckError, printable

__all__ = ["ExternalSettings", "ExternalError", "external_episodes", "split_command",
           "script_of", "check_external", "external_header", "record_external", "INIT",
           "SETUP"]

INIT = "$initialise_machine"
SETUP = "$setup_constants"
#: the longest answer line read (a state of a few hundred thousand values)
MAX_LINE = 64 * 1024 * 1024
#: seconds the script has to end by itself once the socket is closed, then after SIGTERM
GRACE_S = 1.0


@dataclass(frozen=True)
class ExternalSettings:
    """How to run one external simulation.

    ``command`` is the script's command line (the port is appended); ``ending_time_ms``
    and ``max_steps`` are SimB's ending conditions (the episode is cut with ``finished: 1``
    once either is reached; None: until the script says ``done``); ``crash`` a predicate
    that marks a crashed state (default: the machine's ``Crash`` variable, if any).
    """

    command: tuple[str, ...]
    episodes: int
    cwd: Optional[Path] = None
    ending_time_ms: Optional[float] = None
    max_steps: Optional[int] = None
    step_timeout: float = 30.0
    connect_timeout: float = 60.0
    crash: Optional[str] = None


class ExternalError(InputError):
    """The script broke the protocol, died, hung or sent what tracecheck cannot use."""


def split_command(text: str) -> tuple[str, ...]:
    """A command line split as a POSIX shell would (quotes, backslashes), run without one."""
    try:
        argv = tuple(shlex.split(text))
    except ValueError as exc:
        raise InputError(f"--external {text!r}: {exc}") from None
    if not argv:
        raise InputError("--external needs a command, e.g. --external 'python3 agent.py'")
    return argv


def script_of(command: Sequence[str], cwd: Optional[Path]) -> Optional[Path]:
    """The script a command runs: its first argument after the program that is a file
    (``python3 agent.py``), else the program itself when it is a file there."""
    base = Path(cwd or ".")
    for arg in [*command[1:], command[0]]:
        path = base / arg
        if not arg.startswith("-") and path.is_file():
            return path
    return None


def sha256_of(path: Optional[Path]) -> Optional[str]:
    if path is None:
        return None
    return hashlib.sha256(path.read_bytes()).hexdigest()


def external_episodes(settings: ExternalSettings, shield) -> Iterator[Episode]:
    """Run the script and yield its episodes as they finish, states in ``shield``'s
    machine (a :class:`~tracecheck.checking.shield.Shield` with a machine).

    Raises :class:`ExternalError` naming the episode and step, and quoting what the script
    sent, when it breaks the protocol; the episodes yielded before stay valid. The script is
    stopped however the generator ends (an error, Ctrl-C, the caller stopping early).
    """
    if shield.machine is None:
        raise InputError("an external simulation needs a machine as its shield (a .mch file "
                         "or a built-in shield other than none)")
    if settings.episodes < 1:
        raise InputError("--episodes must be at least 1")
    with _Link(settings) as link:
        run = _Run(settings, shield.machine, link)
        for k in range(settings.episodes):
            yield run.episode(k)
        link.finish()


def check_external(settings: ExternalSettings, shield, out: Path, *, force: bool = False,
                   inputs: Sequence[Path] = ()) -> list[Path]:
    """What can be checked before the script starts: the settings, the shield (a machine)
    and the output (the output rule: never the script, the machine or another input); the
    inputs the output must not be."""
    from ..episodes.files import check_run_output
    from ..outputs import input_paths

    if shield.machine is None:
        raise InputError("--external needs --shield naming the machine that answers the "
                         "script (a .mch file, or a built-in shield other than none)")
    if settings.episodes < 1:
        raise InputError("--episodes must be at least 1")
    if settings.cwd is not None and not Path(settings.cwd).is_dir():
        raise InputError(f"--cwd {settings.cwd}: no such folder")
    if not settings.step_timeout > 0 or not settings.connect_timeout > 0:
        raise InputError("--step-timeout must be more than 0 seconds")
    script = script_of(settings.command, settings.cwd)
    given = [*input_paths(shield.path, *([script] if script else [])), *inputs]
    check_run_output(out, given, force=force)
    return given


def external_header(settings: ExternalSettings, shield):
    """The run header of an external simulation: the command, the script and its sha256,
    the folder it ran in, the machine; no environment and no seed (it cannot be
    re-simulated)."""
    from ..episodes.writer import new_header

    machine = shield.machine
    script = script_of(settings.command, settings.cwd)
    return new_header(
        "external", shield_name=shield.name, shield_sha256=shield.sha256,
        model_name=machine.name, variables=list(machine.variables),
        actions=list(machine.operations), horizon=settings.max_steps,
        external_command=list(settings.command),
        external_cwd=str(Path(settings.cwd or ".").resolve()),
        external_script=str(script.resolve()) if script is not None else None,
        external_script_sha256=sha256_of(script))


def record_external(settings: ExternalSettings, shield, out: str | Path,
                    progress=None, *, force: bool = False, channels=None
                    ) -> tuple[int, int, int]:
    """Record the script's episodes into ``out`` (as :func:`tracecheck.live.record.record`
    does an agent's): (episodes, steps, crashes). Every episode the script finished before
    an error or an interrupt is kept; the error is raised after the file is closed."""
    from ..episodes.files import record_episodes

    out = Path(out)
    given = check_external(settings, shield, out, force=force)
    return record_episodes(out, external_header(settings, shield),
                           external_episodes(settings, shield), progress, force=force,
                           channels=channels, inputs=given)


class _Link:
    """The socket and the process: started, spoken to line by line, stopped."""

    def __init__(self, settings: ExternalSettings) -> None:
        self.settings = settings
        self.server: Optional[socket.socket] = None
        self.conn: Optional[socket.socket] = None
        self.proc: Optional[subprocess.Popen] = None
        self.log = tempfile.TemporaryFile()
        self.buffer = b""
        self.finished = False
        self.mark = ""  # MARK=value in the script's environment (set when it starts)

    def __enter__(self) -> "_Link":
        try:
            self._start()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _start(self) -> None:
        self.server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.server.bind(("127.0.0.1", 0))
        self.server.listen(1)
        port = self.server.getsockname()[1]
        argv = [*self.settings.command, str(port)]
        self.mark = f"{MARK}={os.getpid()}-{port}-{time.monotonic_ns()}"
        env = dict(os.environ, **dict([self.mark.split("=", 1)]))
        try:
            self.proc = subprocess.Popen(argv, cwd=self.settings.cwd, stdin=subprocess.DEVNULL,
                                         stdout=self.log, stderr=subprocess.STDOUT,
                                         start_new_session=True, env=env)
        except OSError as exc:
            raise ExternalError(f"cannot start {shlex.join(self.settings.command)}"
                                f"{' in ' + str(self.settings.cwd) if self.settings.cwd else ''}"
                                f": {exc.strerror or exc}") from None
        deadline = time.monotonic() + self.settings.connect_timeout
        self.server.settimeout(0.1)
        while self.conn is None:
            try:
                self.conn, _ = self.server.accept()
            except TimeoutError:
                if self.proc.poll() is not None:
                    raise self.error("the script ended before it connected") from None
                if time.monotonic() > deadline:
                    raise self.error(f"the script did not connect to 127.0.0.1:{port} within "
                                     f"{self.settings.connect_timeout:g} s (the port is "
                                     "its last argument)") from None
        self.conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    # -- speaking
    def send(self, enabled: str, finished: bool = False) -> None:
        message = json.dumps({"finished": int(finished), "enabledOperations": enabled,
                              "externalValues": {}}, separators=(",", ":")) + "\n"
        try:
            assert self.conn is not None
            self.conn.sendall(message.encode("utf-8"))
        except OSError:
            raise self.error("the script closed the connection") from None

    def receive(self, where: str) -> str:
        """The next line the script sends (without its newline), within the step timeout."""
        assert self.conn is not None
        deadline = time.monotonic() + self.settings.step_timeout
        while b"\n" not in self.buffer:
            if len(self.buffer) > MAX_LINE:
                raise self.error(f"{where}: sent more than {MAX_LINE // 2**20} MiB without a "
                                 "newline")
            left = deadline - time.monotonic()
            if left <= 0:
                raise self.error(f"{where}: no answer within {self.settings.step_timeout:g} s "
                                 "(--step-timeout; a script that writes through a buffer "
                                 "must flush after each answer)")
            self.conn.settimeout(min(left, 0.5))
            try:
                data = self.conn.recv(1 << 16)
            except TimeoutError:
                continue
            except OSError:
                data = b""
            if not data:
                raise self.error(f"{where}: the script closed the connection"
                                 + (f" after sending {_quote(self.buffer)}" if self.buffer
                                    else ""))
            self.buffer += data
        line, self.buffer = self.buffer.split(b"\n", 1)
        try:
            return line.decode("utf-8").rstrip("\r")
        except UnicodeDecodeError:
            raise self.error(f"{where}: sent bytes that are not UTF-8: {_quote(line)}") \
                from None

    def finish(self) -> None:
        """Tell the script the simulation is over (once)."""
        if not self.finished:
            self.finished = True
            try:
                self.send("", finished=True)
            except ExternalError:
                pass  # it may already be gone: nothing more is wanted of it

    def error(self, what: str) -> ExternalError:
        """An error about the script, with its exit status and the end of its output."""
        name = shlex.join(self.settings.command)
        status = "was still running: tracecheck stopped it"
        if self.proc is not None:
            try:
                status = f"exited with status {self.proc.wait(timeout=0.2)}"
            except subprocess.TimeoutExpired:
                pass
        return ExternalError(f"{what} (the script {name} {status})", hint=self.output_tail())

    def output_tail(self, lines: int = 8) -> Optional[str]:
        try:
            self.log.flush()
            self.log.seek(0, os.SEEK_END)
            size = self.log.tell()
            self.log.seek(max(0, size - 4000))
            text = self.log.read().decode("utf-8", "replace")
        except (OSError, ValueError):
            return None
        tail = [line for line in text.splitlines() if line.strip()][-lines:]
        return ("its last output:\n    " + "\n    ".join(printable(t) for t in tail)) \
            if tail else None

    # -- stopping
    def close(self) -> None:
        for sock in (self.conn, self.server):
            if sock is not None:
                try:
                    sock.close()
                except OSError:
                    pass
        self.conn = self.server = None
        proc = self.proc
        if proc is not None and proc.poll() is None:
            try:
                proc.wait(timeout=GRACE_S)
            except subprocess.TimeoutExpired:
                _signal_group(proc, signal.SIGTERM)
                try:
                    proc.wait(timeout=GRACE_S)
                except subprocess.TimeoutExpired:
                    _signal_group(proc, signal.SIGKILL)
                    proc.wait()
        if proc is not None:  # children it left behind in its session
            _signal_group(proc, signal.SIGKILL)
            _kill_marked(self.mark)  # … and those it detached (setsid, a double fork)
        self.log.close()


#: the variable set in the script's environment, with a value of this run's own: every
#: process the script starts inherits it, also one that leaves the script's session
MARK = "TRACECHECK_EXTERNAL_RUN"


def _kill_marked(mark: str) -> list[int]:
    """Kill the processes whose environment holds ``mark`` (this run's value of
    :data:`MARK`, whole): a script's descendants that left its session — whatever they are
    (a daemon the script started is ended too). Each is pinned by a pidfd before its
    environment is read, so a pid reused meanwhile is never signalled; the scan is repeated
    while it finds some (a marked process may fork while it runs). Linux's ``/proc``; where
    there is none, nothing is found. Returns the pids killed."""
    killed: list[int] = []
    if not mark.startswith(MARK + "=") or len(mark) <= len(MARK) + 1:
        return killed  # never an empty or foreign pattern
    wanted = mark.encode()
    for _ in range(5):
        found = [pid for pid in _pids() if pid != os.getpid() and _kill_if(pid, wanted)]
        killed += [pid for pid in found if pid not in killed]  # one still dying is seen again
        if not found:
            break
    return killed


def _pids() -> list[int]:
    try:
        return [int(p) for p in os.listdir("/proc") if p.isdigit()]
    except OSError:
        return []


def _kill_if(pid: int, wanted: bytes) -> bool:
    """SIGKILL ``pid`` if its environment holds ``wanted``; whether it did."""
    try:
        fd = os.pidfd_open(pid)  # the process itself from now on, not whoever gets its pid
    except (OSError, AttributeError):
        fd = None
        if hasattr(os, "pidfd_open"):
            return False  # gone (or not ours)
    try:
        with open(f"/proc/{pid}/environ", "rb") as f:
            if wanted not in f.read().split(b"\0"):
                return False
        if fd is not None:
            signal.pidfd_send_signal(fd, signal.SIGKILL)
        else:
            os.kill(pid, signal.SIGKILL)
        return True
    except (OSError, ProcessLookupError):  # gone, or another user's
        return False
    finally:
        if fd is not None:
            os.close(fd)


def _signal_group(proc: subprocess.Popen, sig: int) -> None:
    try:
        os.killpg(proc.pid, sig)
    except (ProcessLookupError, PermissionError):
        pass


def _quote(data: Any, limit: int = 200) -> str:
    text = data.decode("utf-8", "replace") if isinstance(data, bytes) else str(data)
    text = printable(text)
    return repr(text if len(text) <= limit else text[:limit] + " …")


@dataclass
class _Answer:
    op: str
    delta_ms: float
    predicate: str
    done: bool


class _Run:
    """The episodes of one simulation: the protocol's steps and the states they lead to."""

    def __init__(self, settings: ExternalSettings, machine, link: _Link) -> None:
        self.settings = settings
        self.machine = machine
        self.link = link
        self.order = list(machine.operations)
        self.crash = None
        if settings.crash is not None:
            node = machine.check_formula(settings.crash, file="--crash")
            self.crash = machine.compile(node, source=settings.crash)
        kinds = machine.types
        self.crash_var = "Crash" if kinds.get("Crash") == "BOOL" else None
        self.reward_var = "Reward" if kinds.get("Reward") in ("REAL", "INTEGER") else None
        self.literals: dict = {}  # variable -> (its last literal, the value read from it)
        self.cut = False  # the last episode was cut with finished: 1

    def episode(self, k: int) -> Episode:
        where = f"episode {k}, initialisation"
        answer = self._ask(INIT, where)
        while answer.op == SETUP:  # the constants are the machine's own: check, ask again
            if not self._holds_on_constants(answer, where):
                raise self.link.error(f"{where}: its $setup_constants predicate does not hold "
                                      f"for the machine's constants: {_quote(answer.predicate)}")
            answer = self._ask(INIT, where)
        if answer.op != INIT:
            after_cut = (" — the previous episode was cut with finished: 1, which a script "
                         "must take as 'leave this episode'" if self.cut else "")
            raise self.link.error(f"{where}: answered {_quote(answer.op)} where the episode "
                                  f"starts; the first answer must be {INIT}{after_cut}")
        self.cut = False
        state = self._after(None, {}, answer, where)
        steps = [self._record(0, 0.0, None, state, None)]
        clock_ms = 0.0
        done, reason = answer.done, None
        while not done:
            if self._ending(len(steps) - 1, clock_ms):
                self.link.send("", finished=True)
                self.cut = True
                reason = "time-limit"
                break
            n = len(steps)
            where = f"episode {k}, step {n}"
            try:
                with time_limit(self.settings.step_timeout, "--step-timeout"):
                    allowed = self.machine.enabled(state)
            except TracecheckError as exc:
                raise self.link.error(f"{where}: the guards of {self.machine.name} cannot be "
                                      f"evaluated in the state before it: {exc.message}") \
                    from None
            enabled = tuple(op for op in self.order if op in allowed)
            answer = self._ask(",".join(enabled), where)
            if answer.op not in self.machine.operations:
                raise self.link.error(
                    f"{where}: answered the operation {_quote(answer.op)}, which the machine "
                    f"{self.machine.name} does not have; it has {', '.join(self.order)}")
            clock_ms += answer.delta_ms
            state = self._after(answer.op, state, answer, where)
            steps.append(self._record(n, clock_ms / 1000.0, answer.op, state, enabled))
            done = answer.done
        steps_t = tuple(steps)
        end = make_end(steps_t, reason)
        return Episode(id=k, steps=steps_t, end=end, origin=f"external simulation {k}")

    def _ending(self, steps: int, clock_ms: float) -> bool:
        s = self.settings
        return ((s.max_steps is not None and steps >= s.max_steps)
                or (s.ending_time_ms is not None and clock_ms >= s.ending_time_ms))

    def _ask(self, enabled: str, where: str) -> _Answer:
        self.link.send(enabled)
        line = self.link.receive(where)
        return self._answer(line, where)

    def _answer(self, line: str, where: str) -> _Answer:
        try:
            data = json.loads(line)
        except (json.JSONDecodeError, RecursionError):
            raise self.link.error(f"{where}: sent what is not JSON: {_quote(line)}") from None
        if not isinstance(data, dict):
            raise self.link.error(f"{where}: sent {_quote(line)}; an answer is a JSON object "
                                  '{"op", "delta", "predicate", "done"}')
        missing = [k for k in ("op", "predicate") if k not in data]
        if missing:
            raise self.link.error(f"{where}: its answer has no {' or '.join(missing)}: "
                                  f"{_quote(line)}")
        op, predicate = data["op"], data["predicate"]
        if not isinstance(op, str) or not isinstance(predicate, str):
            raise self.link.error(f"{where}: 'op' and 'predicate' must be strings: "
                                  f"{_quote(line)}")
        return _Answer(op, self._delta(data.get("delta", 0), line, where), predicate,
                       self._done(data.get("done", False), line, where))

    def _delta(self, value: Any, line: str, where: str) -> float:
        try:
            if isinstance(value, bool):
                raise ValueError
            ms = float(value)
        except (TypeError, ValueError, OverflowError):  # 401 digits: no float
            ms = math.nan
        if not 0.0 <= ms <= 365 * 24 * 3600 * 1000:
            raise self.link.error(f"{where}: 'delta' must be a time in milliseconds, 0 to "
                                  f"one year: {_quote(line)}")
        return ms

    def _done(self, value: Any, line: str, where: str) -> bool:
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.strip().lower() in ("true", "false"):
            return value.strip().lower() == "true"
        if value in (0, 1) and not isinstance(value, float):
            return bool(value)
        raise self.link.error(f"{where}: 'done' must be true or false: {_quote(line)}")

    def _parse(self, answer: _Answer, where: str):
        text = answer.predicate.strip() or "TRUE = TRUE"
        try:
            return self.machine.check_formula(text, file=f"the predicate of {where}")
        except TracecheckError as exc:
            raise self.link.error(f"{where}: sent a predicate tracecheck cannot use "
                                  f"({exc.message}): {_quote(answer.predicate)}") from None

    def _holds_on_constants(self, answer: _Answer, where: str) -> bool:
        """Whether the script's ``$setup_constants`` predicate holds for the machine's
        constants (an error where tracecheck cannot evaluate it: not "does not hold")."""
        node = self._parse(answer, where)
        try:
            with time_limit(self.settings.step_timeout, "--step-timeout"):
                return bool(self.machine.compile(node)(dict(self.machine.base_env)))
        except TracecheckError as exc:
            raise self.link.error(f"{where}: tracecheck cannot evaluate its $setup_constants "
                                  f"predicate ({exc.message}): {_quote(answer.predicate)}"
                                  ) from None

    def _after(self, op: Optional[str], state: dict, answer: _Answer, where: str) -> dict:
        from ..b.transitions import equations

        try:  # the common shape (`v = literal & …`) read fast, typed as the grammar would
            fixed = equations(self.machine, answer.predicate, self.literals)
        except TracecheckError as exc:
            raise self.link.error(f"{where}: sent a predicate tracecheck cannot use "
                                  f"({exc.message}): {_quote(answer.predicate)}") from None
        node = self._parse(answer, where) if fixed is None else None
        try:  # --step-timeout bounds tracecheck's own evaluation of the answer too
            with time_limit(self.settings.step_timeout, "--step-timeout"):
                after = self.machine.successor(op, state, node, fixed=fixed)
        except TracecheckError as exc:
            raise self.link.error(f"{where} ({op or INIT}): {exc.message}; the script sent "
                                  f"{_quote(answer.predicate)}") from None
        if not after.satisfies:  # no state to record truthfully
            raise self.link.error(
                f"{where} ({op or INIT}): no state satisfies the predicate with the values "
                f"{op or INIT} gives the variables it does not fix; the script sent "
                f"{_quote(answer.predicate)}")
        if op is None and not after.possible:  # ProB could not even start
            raise self.link.error(
                f"{where}: the INITIALISATION of {self.machine.name} cannot give the "
                f"initial state the script sent: {_quote(answer.predicate)}")
        return dict(after.state)

    def _record(self, n: int, t: float, op: Optional[str], state: dict,
                enabled: Optional[tuple[str, ...]]) -> StepRecord:
        crashed = False
        if self.crash is not None:
            try:
                with time_limit(self.settings.step_timeout, "--step-timeout"):
                    crashed = bool(self.crash(self.machine.env(state)))
            except TracecheckError as exc:  # the episodes so far are kept, as for any fault
                raise self.link.error(f"step {n}: --crash cannot be evaluated in the state "
                                      f"the script sent ({exc.message})") from None
        elif self.crash_var is not None:
            crashed = bool(state[self.crash_var])
        reward = 0.0
        if self.reward_var is not None and n > 0:
            reward = float(state[self.reward_var])
        return StepRecord(step=n, time=round(t, 9), action=op, state=state, reward=reward,
                          crashed=crashed, allowed_actions=enabled,
                          deadlock=None if enabled is None else not enabled)
