"""Commands that check recordings against shields: replay (with re-simulation), diff."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import InputError
from .common import (app, out, err, warn, Executor, FILE_EXECUTOR, RAY_ADDRESS, OutputFormat,
                     FailOn, SHIELD_HELP, ROWS, run_shield, SALVAGE, FORMAT, JSON, output_format,
                     progress, FORCE, run_adapter, WORKERS)


@app.command("replay")
def replay_cmd(
    runs: list[Path] = typer.Argument(..., help="MCAP run files."),
    salvage: bool = SALVAGE,
    shield: str = typer.Option(..., "--shield", "-s", help=SHIELD_HELP),
    as_json: bool = JSON,
    fmt: OutputFormat = FORMAT,
    all_rows: bool = typer.Option(False, "--all", help=f"List every episode that matters "
                                  f"(default: the first {ROWS})."),
    ltl: list[str] = typer.Option([], "--ltl", help="An LTL formula in ProB's syntax to check "
                                  "on every episode, e.g. 'G({Crash = FALSE})' (repeatable; "
                                  "see docs/statistics.md)."),
    ltl_assertions: bool = typer.Option(False, "--ltl-assertions", help="Check the shield "
                                        "machine's ASSERT_LTL definitions on every episode."),
    fail_on: list[FailOn] = typer.Option([], "--fail-on",
                                         help="Exit 1 when this occurs (repeatable); "
                                              "mismatch (with --resimulate): an episode did "
                                              "not reproduce the recording."),
    resimulate: bool = typer.Option(False, "--resimulate",
                                    help="Re-run each infeasible episode from its seed with the "
                                         "agent under the shield: was the crash prevented?"),
    agent: Optional[Path] = typer.Option(None, "--agent", help="The agent that recorded the "
                                         "episodes (default: the bundled agent of that name). "
                                         "Loading it runs code from the file."),
    env: Optional[str] = typer.Option(None, "--env", help="For --resimulate: the environment "
                                      "adapter (default: the installed one the file names)."),
    executor: Executor = FILE_EXECUTOR,
    ray_address: Optional[str] = RAY_ADDRESS,
    workers: int = WORKERS,
) -> None:
    """Replay episodes against a shield: where would it have blocked the recorded action?"""
    from ..checking.replaying import replay
    from ..live.resimulate import with_resimulation
    from ..render.emit import emit
    from ..render.text import ReplayOutput

    fmt = output_format(fmt, as_json)
    if FailOn.mismatch in fail_on and not resimulate:
        raise InputError("--fail-on mismatch needs --resimulate: only re-simulation finds "
                         "episodes that do not reproduce the recording")
    loaded = run_shield(shield, runs)
    report = replay(runs, loaded, executor=executor.value, ray_address=ray_address, ltl=ltl,
                    ltl_assertions=ltl_assertions, salvage=salvage, workers=workers)
    warn(report.warnings)
    if resimulate:
        todo = sum(e.first_infeasible is not None for e in report.per_episode)
        with progress("re-simulating under " + loaded.name, todo) as advance:
            report = with_resimulation(report, runs, loaded, agent=agent, env=env,
                                       salvage=salvage, progress=lambda r: advance())
    rows = len(report.per_episode) if all_rows else ROWS
    emit(ReplayOutput(report, rows), fmt.value, out)
    mismatches = report.resimulation["mismatches"] if report.resimulation else 0
    if mismatches:
        err.print(f"warning: {mismatches} of {report.resimulation['resimulated']} re-simulated "
                  "episode(s) did not reproduce the recording: their outcome is unknown",
                  highlight=False)
    counts = {FailOn.infeasible: report.infeasible_steps,
              FailOn.deadlock: report.deadlock_states,
              FailOn.postcondition: report.postcondition_violations,
              FailOn.invariant: report.invariant_violations,
              FailOn.mismatch: mismatches}
    failed = [f.value for f in fail_on if counts[f]]
    if failed:
        err.print(f"failing: {', '.join(failed)} found (--fail-on)")
        raise typer.Exit(1)



def _seconds(value: float) -> float:
    """The ``--timeout`` option: a finite number of seconds above 0."""
    from ..checking.proving import check_timeout

    return check_timeout(value, "--timeout")


#: the solver's options, declared once for ``prove`` and ``diff --symbolic``
SOLVER_TIMEOUT = typer.Option(10.0, "--timeout", callback=_seconds, help="Seconds the solver "
                              "may take per question (prove: each obligation, and whether any "
                              "state satisfies the invariant and assumptions; diff --symbolic: "
                              "each operation).")
COUNTEREXAMPLES = typer.Option(None, "--counterexamples", help="Write each counterexample "
                               "(prove) or differing state (diff --symbolic) as a state file "
                               "into this folder (a new or empty one, or --force).")


@app.command("diff")
def diff_cmd(
    runs: Optional[list[Path]] = typer.Argument(None, help="MCAP run files (none with "
                                                "--symbolic)."),
    salvage: bool = SALVAGE,
    shield: str = typer.Option(..., "--shield", "-s", help="The new shield. " + SHIELD_HELP),
    against: str = typer.Option(..., "--against", "-a",
                                help="The shield to compare with (old version, baseline)."),
    as_json: bool = JSON,
    fmt: OutputFormat = FORMAT,
    fail_on_change: bool = typer.Option(False, "--fail-on-change",
                                        help="Exit 1 when anything changed."),
    all_changes: bool = typer.Option(False, "--all", help="List every changed step and "
                                     "episode in CSV/JSON (default: the first 10 000 of "
                                     "each; the others are counted)."),
    symbolic: bool = typer.Option(False, "--symbolic", help="Compare over every state that "
                                  "satisfies both invariants, with an SMT solver: per "
                                  "operation, equivalent or a state where they differ."),
    timeout: float = SOLVER_TIMEOUT,
    counterexamples: Optional[Path] = COUNTEREXAMPLES,
    force: bool = FORCE,
    executor: Executor = FILE_EXECUTOR,
    ray_address: Optional[str] = RAY_ADDRESS,
    workers: int = WORKERS,
) -> None:
    """Compare two shields on every recorded state: which steps does the change block or allow?"""
    from ..checking.diffing import LISTED, diff
    from ..render.emit import emit
    from ..render.text import DiffOutput

    fmt = output_format(fmt, as_json)
    if symbolic:
        from ..checking.proving import symbolic_diff

        if runs:
            raise InputError("--symbolic compares the shields over every state: give no run "
                             "files")
        _check_counterexamples(counterexamples, [shield, against], force)
        a, b = run_shield(shield, []).machine, run_shield(against, []).machine
        _print_results(symbolic_diff(a, b, timeout_s=timeout,
                                     labels=_labels(shield, against, a, b),
                                     describe=_describe(a)), a, fmt, counterexamples)
        return
    if not runs:
        raise InputError("give run files to compare the shields on, or --symbolic")
    solver = [flag for flag, value, option in (("--timeout", timeout, SOLVER_TIMEOUT),
                                                ("--counterexamples", counterexamples,
                                                 COUNTEREXAMPLES))
              if value != option.default]
    if solver:
        raise InputError(f"{', '.join(solver)} only appl{'y' if len(solver) > 1 else 'ies'} to "
                         "--symbolic (the solver's "
                         "comparison over every state); on recorded states there is no "
                         "solver")
    report = diff(runs, run_shield(shield, runs), run_shield(against, runs),
                  executor=executor.value, ray_address=ray_address, salvage=salvage,
                  workers=workers,
                  listed=None if all_changes else LISTED)
    warn(report.warnings)
    if (report.changes_left_out or report.episodes_left_out) and fmt != OutputFormat.text:
        err.print(f"note: listed the first {report.listed} of {report.changed_steps} changed "
                  f"steps and of {report.episodes_changed} changed episodes (the counts are "
                  "all of them); --all lists every one", markup=False, highlight=False)
    emit(DiffOutput(report, ROWS), fmt.value, out)
    if fail_on_change and report.anything_changed:
        err.print("failing: the shields differ on these episodes (--fail-on-change)")
        raise typer.Exit(1)


def _labels(shield: str, against: str, a, b) -> tuple[str, str]:
    """How ``diff --symbolic`` names the two shields: as given (a file or a built-in name),
    with the MACHINE name when the two differ in it; two of the same name by their option."""
    la, lb = shield, against
    if a.name != b.name:
        la, lb = f"{la} (MACHINE {a.name})", f"{lb} (MACHINE {b.name})"
    if la == lb:
        la, lb = f"{la} (--shield)", f"{lb} (--against)"
    return la, lb


@app.command("prove")
def prove_cmd(
    shield: str = typer.Argument(..., help=SHIELD_HELP),
    deadlock_free: bool = typer.Option(False, "--deadlock-free", help="In every state that "
                                       "satisfies the invariant, some operation is enabled."),
    implies: list[str] = typer.Option([], "--implies", help="'OP => PREDICATE': whenever OP "
                                      "is enabled, the predicate holds (repeatable)."),
    well_defined: bool = typer.Option(False, "--well-defined", help="No guard is ill-defined "
                                      "(division by zero, a function outside its domain) in "
                                      "a state satisfying the invariant."),
    assume: list[str] = typer.Option([], "--assume", help="A predicate the states satisfy "
                                     "besides the invariant (repeatable)."),
    env: Optional[str] = typer.Option(None, "--env", help="Also assume the value ranges this "
                                      "environment's adapter declares."),
    obligations: Optional[Path] = typer.Option(None, "--obligations", help="A TOML file of "
                                               "obligations: deadlock_free, well_defined, "
                                               "assume = a list, implies tables of operation and "
                                               "predicate (see docs/prove.md)."),
    timeout: float = SOLVER_TIMEOUT,
    counterexamples: Optional[Path] = COUNTEREXAMPLES,
    force: bool = FORCE,
    as_json: bool = JSON,
    fmt: OutputFormat = FORMAT,
) -> None:
    """Prove properties of a shield over every state, with an SMT solver (z3): deadlock
    freedom, implications, well-definedness. Exit 0: all proved; 1: a counterexample; 3:
    unknown; 4: the solver and tracecheck's evaluator disagree; 5: vacuous, no state
    satisfies the invariant and assumptions (see docs/prove.md)."""
    from ..checking.obligations import Given, Obligations, implication, read_obligations
    from ..checking.proving import prove, unbounded_parameters
    from ..checking.shield import load_shield

    fmt = output_format(fmt, as_json)
    _check_counterexamples(counterexamples, [shield, obligations], force)
    machine = load_shield(shield).machine
    asked = Obligations(deadlock_free=deadlock_free, well_defined=well_defined,
                        assume=tuple(Given(a, "--assume") for a in assume))
    if obligations is not None:
        asked = asked.also(read_obligations(obligations, machine))
    adapter = run_adapter(env)
    if adapter is not None:
        asked = asked.also(Obligations(assume=tuple(Given(a, f"--env {env}")
                                                    for a in adapter.assumptions)))
    asked = asked.also(Obligations(implies=tuple(implication(item) for item in implies)))
    if asked.empty:
        raise InputError("nothing to prove: give --deadlock-free, --implies or --well-defined")
    bounds = None
    if adapter is not None and adapter.parameters:
        from ..live.continuous import action_bounds

        bounds = {op: b[:2] for op, b in action_bounds(adapter).items()}  # over the reals
    elif free := unbounded_parameters(machine):
        warn([f"{', '.join(free)} {'is' if len(free) == 1 else 'are'} bounded by no action "
              "space: the proof takes every real as an action (--env ENV takes the "
              "environment's action space, as the live shield does)"])
    results = prove(machine, deadlock_free=asked.deadlock_free, implies=asked.implies,
                    well_defined=asked.well_defined, assume=asked.assume, timeout_s=timeout,
                    describe=_describe(machine, adapter), bounds=bounds)
    _print_results(results, machine, fmt, counterexamples)


def _describe(machine, adapter=None):
    """How a counterexample reads: as ``adapter`` (``--env``) describes a state, else as
    the first installed adapter whose variables ``machine`` declares does (e.g. vehicles
    on a road); None: the state's values as they are."""
    from ..live.adapter import adapters

    found = ([adapter] if adapter is not None else []) + [
        info.adapter for info in adapters() if info.adapter is not None
        and info.adapter.variables and set(info.adapter.variables) <= set(machine.variables)]
    if not found:
        return None

    def describe(state: dict):
        return next((text for text in (a.describe(state) for a in found) if text is not None),
                    None)
    return describe


def _print_results(results, machine, fmt: OutputFormat, folder: Optional[Path]) -> None:
    """Print proof or symbolic-diff results and write the counterexamples. Exit 0: all
    proved (equivalent); 1: a counterexample, a claim not well-defined (a difference, an
    operation only one shield has); 3: unknown (a construct that cannot be translated, a
    timeout); 4: the solver and tracecheck's evaluator disagree; 5: vacuous (no state
    satisfies the invariants and assumptions: nothing was proved)."""
    from ..checking.proving import UNKNOWN, VACUOUS
    from ..errors import Disagreement
    from ..render.emit import emit
    from ..render.prove_text import ProveOutput

    written = {} if folder is None else _write_counterexamples(results, machine, folder)
    emit(ProveOutput(results, written), fmt.value, out)
    bad = [r for r in results if r.disagreement]
    if bad:
        raise Disagreement(f"{bad[0].obligation}: {bad[0].disagreement}",
                           hint="please report this: the solver's model and tracecheck's "
                                "evaluator should agree")
    if any(r.failed for r in results):
        raise typer.Exit(1)
    if any(r.status == UNKNOWN for r in results):
        raise typer.Exit(3)
    if any(r.status == VACUOUS for r in results):
        raise typer.Exit(5)


def _check_counterexamples(folder: Optional[Path], inputs, force: bool) -> None:
    """The output rule for a --counterexamples folder, before anything is proved: not an
    input's folder, a new or empty one, or with --force one of state files (.json)."""
    if folder is not None:
        from ..outputs import check_output, input_paths

        check_output(folder, input_paths(*inputs), force=force, kind="folder",
                     what="--counterexamples folder", contents=("*.json",))


def _write_counterexamples(results, machine, folder: Path) -> dict[int, str]:
    """Each counterexample state as MACHINE-N-OBLIGATION.json (a safe name), written into a
    new folder that replaces ``folder`` once all are written; {result index: path}."""
    from ..b.notation import to_json
    from ..outputs import atomic_folder, inside, open_new, safe_name
    from ..jsontext import json_text

    written, taken = {}, set()
    with atomic_folder(folder) as tmp:
        for i, r in enumerate(results):
            if r.state is None:
                continue
            name = safe_name(f"{machine.name}-{i + 1}-{r.obligation[:40]}", taken) + ".json"
            with open_new(inside(tmp, name)) as stream:
                stream.write((json_text({k: to_json(v) for k, v in r.state.items()},
                                         indent=1) + "\n").encode("utf-8"))
            written[i] = str(folder / name)
    return written
