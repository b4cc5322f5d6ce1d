"""What test modules share (no test module imports another): the repository's paths, the
in-process command runner, hand-made episodes, the user's own environment of
tests/fixtures/acc_env installed for a while, and a headless browser."""

from __future__ import annotations

import datetime as _datetime
import json
import shutil
from contextlib import contextmanager
from pathlib import Path

import pytest

from tracecheck.b.notation import parse_literal
from tracecheck.b.values import Elem, FuncValue
from tracecheck.cli import main
from tracecheck.episodes.model import Episode, StepRecord, make_end

ROOT = Path(__file__).resolve().parents[1]
PAPER_SHIELD = ROOT / "models" / "shields" / "paper.mch"
PAPER_TRACES = ROOT.parent / "shared" / "data" / "paper-traces"


# ------------------------------------------------------------------ the command line


def run(capsys, *args):
    """(exit code, stdout, stderr) of ``tracecheck ARGS`` run in this process (paths and
    numbers as their text)."""
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    captured = capsys.readouterr()
    return info.value.code or 0, captured.out, captured.err


def record_runs(folder: Path, env: str, agent: Path, shields: dict, *,
                 episodes: int = 4, max_steps: int = 40) -> dict[str, Path]:
    """``folder/NAME.mcap`` recorded by ``tracecheck record`` in ``env`` for each ``NAME:
    (shield, extra options)`` of ``shields`` (the environment installed by the caller)."""
    runs = {}
    for name, (shield, extra) in shields.items():
        runs[name] = folder / f"{name}.mcap"
        with pytest.raises(SystemExit) as stop:
            main(["record", "--env", env, "--env-config", f"max_steps={max_steps}", "--agent",
                  str(agent), "--shield", str(shield), "-n", str(episodes), "-o",
                  str(runs[name]), *extra])
        assert stop.value.code in (0, None)
    return runs


def untimed(data):
    """A report without its timings (they differ between runs)."""
    if isinstance(data, dict):
        return {k: untimed(v) for k, v in data.items()
                if not (k.endswith("_s") or k.endswith("_per_s"))}
    if isinstance(data, list):
        return [untimed(v) for v in data]
    return data


def strict_json(text: str):
    """``text`` read as JSON, failing on the constants Python writes but JSON lacks
    (NaN, Infinity)."""
    def refuse(name):
        raise AssertionError(f"{name} is not JSON")

    return json.loads(text, parse_constant=refuse)


# ------------------------------------------------------------------ hand-made episodes


#: The three vehicles of the hand-made highway states.
VS = [Elem("EgoVehicle"), Elem("Vehicles2"), Elem("Vehicles3")]


def state(x: float, crash: bool = False, reward: float = 0.0) -> dict:
    """A highway state of three vehicles, the ego vehicle at ``x``."""
    f = lambda *vals: FuncValue(dict(zip(VS, vals)))  # noqa: E731
    return {"Crash": crash, "PresentVehicles": frozenset(VS), "VehiclesX": f(x, 20.0, -10.0),
            "VehiclesY": f(4.0, 0.0, 4.0), "VehiclesVx": f(25.0, -1.0, 2.0),
            "VehiclesVy": f(0.0, 0.0, 0.0), "VehiclesAx": f(0.0, 0.0, 0.0),
            "VehiclesAy": f(0.0, 0.0, 0.0), "Reward": reward}


def episode(eid: int, n: int = 3, crash_at_end: bool = False, live: bool = False) -> Episode:
    """Episode ``eid`` of ``n`` IDLE steps (seed 1000 + eid); ``live`` adds what a live
    recording carries (observation, preferred action, Q-values, allowed actions)."""
    steps = []
    for k in range(n + 1):
        crash = crash_at_end and k == n
        extra = {}
        if live and k > 0:
            extra = dict(observation=((1.0, 0.5, 0.0, 0.2, 0.0),), preferred_action="FASTER",
                         action_values={"IDLE": 0.1, "FASTER": 0.9},
                         allowed_actions=("IDLE", "SLOWER"), shield_time_us=12.5)
        steps.append(StepRecord(step=k, time=float(k), action=None if k == 0 else "IDLE",
                                state=state(100.0 + 25 * k + eid, crash, 0.5 if k else 0.0),
                                reward=0.5 if k else 0.0, crashed=crash, **extra))
    steps = tuple(steps)
    return Episode(id=eid, steps=steps, end=make_end(steps), seed=1000 + eid)


#: A highway shield of three vehicles for replay's tests: FASTER only before x = 150, SLOWER
#: never speeds up, a negative reward a deadlock, a reward over 10 breaks the invariant.
TOY = """
MACHINE Toy
SETS Vehicles = {EgoVehicle, Vehicles2, Vehicles3}
VARIABLES Crash, PresentVehicles, VehiclesX, VehiclesY, VehiclesVx, VehiclesVy, VehiclesAx,
          VehiclesAy, Reward
INVARIANT Crash : BOOL & PresentVehicles <: Vehicles & VehiclesX : Vehicles --> REAL &
    VehiclesY : Vehicles --> REAL & VehiclesVx : Vehicles --> REAL &
    VehiclesVy : Vehicles --> REAL & VehiclesAx : Vehicles --> REAL &
    VehiclesAy : Vehicles --> REAL & Reward : REAL & Reward <= 10.0
DEFINITIONS
    OK == Reward >= 0.0;
    FREE == Crash :: BOOL || PresentVehicles :: POW(Vehicles) ||
        VehiclesX :: Vehicles --> REAL || VehiclesY :: Vehicles --> REAL ||
        VehiclesVy :: Vehicles --> REAL || VehiclesAx :: Vehicles --> REAL ||
        VehiclesAy :: Vehicles --> REAL || Reward :: REAL
INITIALISATION FREE || VehiclesVx :: Vehicles --> REAL
OPERATIONS
    IDLE = SELECT OK THEN FREE || VehiclesVx :: Vehicles --> REAL END;
    LANE_LEFT = SELECT OK THEN FREE || VehiclesVx :: Vehicles --> REAL END;
    LANE_RIGHT = SELECT OK THEN FREE || VehiclesVx :: Vehicles --> REAL END;
    FASTER = SELECT OK & VehiclesX(EgoVehicle) < 150.0 THEN
        FREE || VehiclesVx :: Vehicles --> REAL END;
    SLOWER = SELECT OK THEN FREE ||
        VehiclesVx : (VehiclesVx : Vehicles --> REAL &
                      VehiclesVx(EgoVehicle) <= VehiclesVx$0(EgoVehicle)) END
END
"""



def simb_states(path: Path) -> list[tuple[str, dict]]:
    """(operation, state after it) for each activation of a SimB trace that has a state."""
    data = json.loads(path.read_text())
    out = []
    for act in data["activations"]:
        if act.get("fixedVariables"):
            state = {k: parse_literal(v) for k, v in act["fixedVariables"].items()}
            out.append((act["execute"], state))
    return out


# ------------------------------------------------------------------ a user's own environment

#: A user's environment package outside tracecheck (1-D adaptive cruise control): an adapter
#: ``acc_cruise:ACC`` registered as the entry point ``acc``, two shields (v1 may deadlock).
ACC_ENV = ROOT / "tests" / "fixtures" / "acc_env"
ACC_SPEC = "acc_cruise:ACC"
ACC_V1 = ACC_ENV / "acc_cruise" / "acc_v1.mch"
ACC_V2 = ACC_ENV / "acc_cruise" / "acc_v2.mch"


def forget_acc() -> None:
    """Forget what was found of the acc package (its module, the entry points scanned)."""
    import importlib
    import sys

    from tracecheck import registry

    for name in [m for m in sys.modules if m == "acc_cruise" or m.startswith("acc_cruise.")]:
        del sys.modules[name]
    importlib.invalidate_caches()
    registry.entry_points.cache_clear()


@contextmanager
def acc_installed(monkeypatch: pytest.MonkeyPatch):
    """The acc environment installed while inside: on ``sys.path`` (its dist-info makes the
    entry point ``acc``) and on ``PYTHONPATH`` for subprocesses."""
    import os

    monkeypatch.syspath_prepend(str(ACC_ENV))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(
        [str(ACC_ENV), str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]))
    forget_acc()
    try:
        yield
    finally:
        forget_acc()


# ------------------------------------------------------------------ in a real browser


def open_browser():
    """A headless Chromium driven by selenium, logging the page's console (skips the test
    where selenium, Chromium or ChromeDriver is missing)."""
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.skip("selenium is not installed (pip install -e '.[test]')")
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if not chromium or not driver:
        pytest.skip("no Chromium/ChromeDriver here (Debian: apt-get install chromium "
                    "chromium-driver; .ci/run installs them)")
    opts = webdriver.ChromeOptions()
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--window-size=1300,900"):
        opts.add_argument(arg)
    opts.binary_location = chromium
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver), options=opts)


def browser_errors(browser) -> list:
    """The page's console errors so far."""
    return [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]


def from_blobs(path: Path) -> bool:
    """Whether every block of ``path`` is read from its run blob (not walked)."""
    from tracecheck.episodes.blobs import BlobDisagrees, blob_records, verified_block
    from tracecheck.episodes.records import mapped

    with mapped(path) as buf:
        view = memoryview(buf)
        try:
            index = blob_records(buf)
            return index is not None and all(
                verified_block(buf, view, index, k) is not None for k in range(len(index.runs)))
        except BlobDisagrees:
            return False
        finally:
            view.release()


def walking(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make readers walk files episode by episode, as if no run blob fitted."""
    import tracecheck.episodes.columns as C

    monkeypatch.setattr(C, "blob_records", lambda buf: None)


def write_report(runs, out, *, max_pages: int = 20, force: bool = False, **validate_options):
    """``tracecheck report`` from Python: validate the runs (replay, re-simulation,
    statistics), then draw them; (report, pages written)."""
    from tracecheck.render.report import render_report
    from tracecheck.stats.validation import validate

    return render_report(validate(runs, **validate_options), out, max_pages=max_pages,
                         force=force)


def solved(text: str, machine=None, **options):
    """``tracecheck.checking.solving.solve`` of the predicate ``text`` for its free
    identifiers (typed as ``eval`` types them), in ``machine``'s scope if one is given."""
    from tracecheck.b.btypes import Var, resolve_all
    from tracecheck.b.parser import parse_formula
    from tracecheck.b.typecheck import check_formula
    from tracecheck.checking.solving import free_identifiers, solve

    names = dict(machine.type_objects) if machine else {}
    free = free_identifiers(parse_formula(text, file="<t>"), names)
    typed = {**names, **{n: Var() for n in free}}
    node, _ = check_formula(text, typed, file="<t>", kind="predicate")
    types = {n: resolve_all(typed[n]) for n in free}
    env = machine.env({}) if machine else {}
    return solve(node, types, env, sets=machine.sets if machine else {}, source=text,
                 file="<t>", **options)


class FixedDate:
    """Stands for the ``datetime`` module where a run header is stamped (patch
    ``tracecheck.episodes.writer._dt``): one creation time, so that two writes of the same
    run are the same bytes."""

    timezone = _datetime.timezone

    class datetime:
        @staticmethod
        def now(tz=None):
            return _datetime.datetime(2026, 1, 1, tzinfo=_datetime.timezone.utc)
