"""Commands on B machines and formulas: check-model, eval, guards."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import EvaluationError, InputError, TracecheckError, UnsupportedError
from .common import (app, out, load_model, plain, FORMAT, JSON, OutputFormat,
                     output_format, print_json, warn)


@app.command("check-model")
def check_model(
    model: Path = typer.Argument(..., help="A classical B machine (.mch), or a shield an "
                                           "installed environment brings ({shields})."),
    as_json: bool = JSON,
    fmt: OutputFormat = FORMAT,
) -> None:
    """Parse and check a B machine; list its sets, constants (those the PROPERTIES fix, set
    up by the solver where no equality does), variables and operations, and its ASSERTIONS
    over the constants: exit 1 where one is false, 3 where one cannot be decided."""
    from ..render.emit import emit
    from ..render.listing_text import ModelOutput

    fmt = output_format(fmt, as_json)
    machine = load_model(model, solving=True)  # constants the PROPERTIES fix: the solver's
    warn(f"{model}: {what}: {fix}" for what, fix in _untyped_reals(machine))
    emit(ModelOutput(machine, str(model)), fmt.value, out)
    values = [value for _, value, why in machine.constant_assertions()
              if not why.startswith("reads ")]
    if False in values:  # an assertion over the constants is false: exit 1, as a check fails
        raise typer.Exit(1)
    if None in values:  # one tracecheck cannot decide: unknown
        raise typer.Exit(3)


def _untyped_reals(machine) -> list[tuple[str, str]]:
    """Each parameter the guard makes a REAL without typing it ``p : REAL`` — tracecheck
    does not take its operation for continuous actions (``guards`` cannot enumerate it,
    ``record`` refuses it): (what is wrong, what to do)."""
    from ..b.typecheck import untyped_real_parameters

    return [(f"the parameter {p} of {op} is a REAL by its use, but its guard does not type it",
             f"add `{p} : REAL` (PRE {p} : REAL & …) so that tracecheck takes {op}'s values as "
             "continuous actions (docs/continuous.md)")
            for op, p in untyped_real_parameters(machine)]


def _state_warnings(machine, where: str, missing: list[str], broken: list[str],
                    unchecked: list[tuple[str, str]]) -> list[str]:
    """What ``guards`` warns of: a state the machine's invariant excludes (the guards then
    answer for a state the shield assumes never happens), variables without a value."""
    out = []
    unread = {f"{v} has no value here" for v in missing}
    if missing:
        skipped = [c for c, why in unchecked if why in unread]
        out.append(f"{where} gives no value for {', '.join(missing)} "
                   f"({'a variable' if len(missing) == 1 else 'variables'} of {machine.name}):"
                   " no guard reads " + ("it" if len(missing) == 1 else "them")
                   + (f"; the INVARIANT is not checked where it does ({'; '.join(skipped)})"
                      if skipped else ""))
    if broken:
        out.append(f"{where} breaks the INVARIANT of {machine.name}: {'; '.join(broken)} "
                   "does not hold (the guards are for states the invariant allows)")
    others = [f"{c} ({why})" for c, why in unchecked if why not in unread]
    if others:
        out.append(f"{where}: the INVARIANT of {machine.name} cannot be checked: "
                   f"{'; '.join(others)}")
    return out


@app.command("eval", context_settings={"ignore_unknown_options": True})
def eval_(
    exprs: Optional[list[str]] = typer.Argument(None, help="B predicates or expressions."),
    file: Optional[Path] = typer.Option(None, "--file", "-f", help="A file of formulas, one "
                                        "per line (blank lines and // comments skipped)."),
    model: Optional[Path] = typer.Option(None, "--model", "-m",
                                         help="Evaluate in this machine's scope."),
    state: Optional[Path] = typer.Option(None, "--state", "-s",
                                         help="JSON file: variable name -> B literal."),
    as_json: bool = typer.Option(False, "--json", help="Print the value as JSON."),
    all_solutions: bool = typer.Option(False, "--all", help="A predicate with free "
                                       "identifiers: list every solution (up to --limit)."),
    limit: int = typer.Option(100, "--limit", help="With --all: at most this many solutions."),
    timeout: float = typer.Option(10.0, "--timeout", help="Seconds the evaluation of one "
                                  "formula may take, a search for a solution of a predicate "
                                  "with free identifiers included."),
) -> None:
    """Evaluate predicates or expressions and print their values in B notation, one per line
    (the machine, the state and the grammar are loaded once for all of them). A predicate
    with identifiers nothing declares is solved for them, as ProB's :solve: TRUE and a
    solution, FALSE where there is none, or unknown and why (exit 3)."""
    from ..b.clock import time_limit
    from ..b.notation import to_json
    from ..b.values import format_value
    from ..inputs import read_text

    formulas = [(e.lstrip(), "<expr>" if len(exprs or ()) == 1 and file is None else  # the
                 f"<expr {i + 1}>", None) for i, e in enumerate(exprs or ())]  # space before -x
    if file is not None:
        text = read_text(file, "formula file")
        formulas += [(line, str(file), (k + 1, text)) for k, line in enumerate(text.splitlines())
                     if line.strip() and not line.strip().startswith("//")]
    if not formulas:
        raise InputError("give a formula to evaluate, or --file with formulas")
    if limit < 1:
        raise InputError(f"--limit must be at least 1, not {limit}")
    evaluate = _evaluator(model, state, {"timeout_s": timeout, "limit": limit,
                                         "all_solutions": all_solutions})
    results, texts = [], []
    for expr, where, line in formulas:
        try:
            with time_limit(timeout, "--timeout"):
                value = evaluate(expr, where)
        except TracecheckError as exc:
            if line is not None:  # a line of the file: point into the file
                exc.line, exc.source = line[0], line[1]
            raise exc.located(file=where, source=expr) from None
        if isinstance(value, _Solved):
            results.append(_solved_json(expr, value.answer, all_solutions))
            texts.append(_solved_text(value.answer, all_solutions))
            continue
        results.append({"expression": expr, "value": format_value(value),
                        "json": to_json(value)})
        texts.append([results[-1]["value"]])
    if as_json:
        print_json(results[0] if len(results) == 1 else results)
    else:
        for lines in texts:
            for text_line in lines:
                plain(text_line)
    notes = [r["note"] for r in results if r.get("note")]
    if notes:
        warn(notes)
    if any(r["value"] == "unknown" for r in results):
        raise typer.Exit(3)


class _Solved:
    """What ``evaluate`` gives for a predicate solved for its free identifiers."""

    def __init__(self, answer) -> None:
        self.answer = answer


def _solved_text(answer, all_solutions: bool) -> list[str]:
    """ProB's way: TRUE and the solution's identifiers one per line; with --all one
    solution per line and how many there are."""
    if answer.status == "unknown":
        return [f"unknown: {answer.reason}"]
    if answer.status == "FALSE":
        return ["FALSE"]
    if not all_solutions:
        return ["TRUE"] + [f"{n} = {v}" for n, v in answer.shown(answer.solutions[0]).items()]
    lines = ["TRUE"] + [" & ".join(f"{n} = {v}" for n, v in answer.shown(s).items())
                        for s in answer.solutions]
    n = len(answer.solutions)
    count = f"{n} solution{'s' if n != 1 else ''}"
    if answer.complete:
        lines.append(f"{count}: all of them")
    elif answer.more:
        lines.append(f"{count} (the limit): there are more")
    else:
        lines.append(f"{count}; there may be more ({answer.reason})")
    return lines


def _solved_json(expr: str, answer, all_solutions: bool) -> dict:
    from ..b.notation import to_json

    out = {"expression": expr, "value": answer.status, "method": answer.method}
    if answer.status == "unknown":
        out["reason"] = answer.reason
    shown = [answer.shown(s) for s in answer.solutions]
    values = [{n: to_json(v) for n, v in s.items()} for s in answer.solutions]
    if all_solutions:
        out.update(solutions=shown, json=values, complete=answer.complete, more=answer.more)
        if answer.reason and answer.status != "unknown":
            out["reason"] = answer.reason
    elif answer.status == "TRUE":
        out.update(solution=shown[0], json=values[0])
    if answer.note:
        out["note"] = answer.note
    return out


def _evaluator(model: Optional[Path], state: Optional[Path], solving: dict):
    """``evaluate(text, where)`` in the scope of ``model`` and the values of ``state``: a
    value, or a :class:`_Solved` for a predicate with free identifiers."""
    from ..b.evaluation import Compiler
    from ..b.state import read_state_file
    from ..b.typecheck import check_formula, type_of_value
    from ..errors import BScopeError

    machine = load_model(model, solving=True) if model is not None else None
    values = read_state_file(state) if state is not None else {}
    if machine is not None:
        machine.check_state(values, where=str(state))
    names = dict(machine.type_objects) if machine is not None else {}
    owners = machine.element_sets() if machine is not None else {}
    for name, value in values.items():
        names.setdefault(name, type_of_value(value, owners))
    env = machine.env(values) if machine is not None else dict(values)
    # without a machine, ProB's library functions as its console offers them (RSQRT, …)
    definitions = machine.definitions if machine else _console_library(values)

    def evaluate(expr: str, where: str):
        from ..checking.bound_solver import bound_solver

        try:
            node, _ = check_formula(expr, names, file=where, definitions=definitions)
        except BScopeError as exc:
            return _solve(expr, where, exc, names, env, machine, solving)
        compiler = Compiler(source=expr, file=where)
        compiler.unset = machine.unset_constants if machine else {}
        # bound variables nothing walks ({x | x*x = 100}): the solver's complete answer
        compiler.solver = bound_solver(names, machine.sets if machine else {}, source=expr,
                                       file=where, timeout_s=solving["timeout_s"])
        return compiler.compile(node)(env)

    return evaluate


def _console_library(values: dict) -> dict:
    """ProB's library functions, as its console offers them without an include (a name the
    state gives a value keeps it)."""
    from ..b.parser import library_definitions

    return {n: d for n, d in (library_definitions("*") or {}).items() if n not in values}


def _solve(expr: str, where: str, error, names: dict, env: dict, machine, solving: dict):
    """The predicate ``expr`` solved for the identifiers in it that nothing declares
    (``error``, the unknown identifier's, where it is not a predicate or has none)."""
    from ..b.btypes import Var, resolved_defaulting, show
    from ..b.parser import parse_formula
    from ..b.scope import expand, kind_of
    from ..b.typecheck import check_formula
    from ..checking.encoding import check_timeout
    from ..checking.bound_solver import bound_solver
    from ..checking.solving import free_identifiers, solve
    from ..errors import BTypeError

    definitions = machine.definitions if machine else _console_library(env)
    node = parse_formula(expr, file=where)
    if definitions:
        node = expand(node, definitions)
    free = free_identifiers(node, names)
    if kind_of(node) != "predicate" or not free:
        raise error
    timeout_s = check_timeout(solving["timeout_s"], "--timeout")
    typed = {**names, **{n: Var() for n in free}}
    node, _ = check_formula(expr, typed, file=where, definitions=definitions,
                            kind="predicate")
    types = resolved_defaulting(typed, free)
    for n, t in types.items():
        if "?" in show(t):
            raise BTypeError(f"cannot infer the type of {n}", file=where, source=expr,
                             hint=f"add a conjunct that types it, e.g. {n} : INTEGER")
    return _Solved(solve(node, types, env, sets=machine.sets if machine else {},
                         source=expr, file=where, timeout_s=timeout_s,
                         all_solutions=solving["all_solutions"], limit=solving["limit"],
                         inner=bound_solver))


@app.command("guards")
def guards(
    model: Path = typer.Argument(..., help="A classical B machine (.mch)."),
    state: Path = typer.Option(..., "--state", "-s", help="JSON file: variable -> B literal."),
    env: Optional[str] = typer.Option(None, "--env", help="An environment with continuous "
                                      "actions ({environments}, or package.module:Class): the "
                                      "values of REAL parameters are those its action space "
                                      "holds, as the live shield takes them."),
    as_json: bool = JSON,
    fmt: OutputFormat = FORMAT,
) -> None:
    """List the operations whose guard holds in a state."""
    from ..b.state import read_state_file
    from ..render.emit import emit
    from ..render.listing_text import GuardsOutput

    fmt = output_format(fmt, as_json)
    machine = load_model(model, solving=True)  # a guard not linear: the solver's set
    for what, fix in _untyped_reals(machine):  # it cannot enumerate the parameter
        raise InputError(what, file=str(model), hint=fix)
    values = read_state_file(state)
    machine.check_state(values, where=str(state))
    missing = [v for v in machine.variables if v not in values]
    undecided: dict[str, str] = {}  # operations whose guard it cannot decide here: why
    try:
        enabled = _enabled(machine, values, undecided)
    except EvaluationError as exc:
        name = next((v for v in missing if exc.message == f"{v} has no value here"), None)
        if name is None:
            raise
        raise InputError(f"the state gives no value for {name}, a variable of {machine.name} "
                         f"that a guard reads ({exc.location})", file=str(state),
                         hint=f'add "{name}": … to the state file') from None
    allowed = _allowed_sets(machine, values)
    bounds = _action_space(env)
    for op, space in bounds.items():  # what the live shield can take
        if op in allowed:
            if not hasattr(allowed[op], "within"):
                undecided[op] = ("its allowed set is the solver's, which is not cut to the "
                                 "action space here")
                enabled.discard(op)
                continue
            allowed[op] = allowed[op].within(*space)
            try:
                if allowed[op].witness() is None:
                    enabled.discard(op)
            except UnsupportedError as exc:  # none of the space's float type confirmed
                undecided[op] = exc.message
                enabled.discard(op)
    broken, unchecked = machine.invariant_check(values)
    warn(_state_warnings(machine, str(state), missing, broken, unchecked))
    emit(GuardsOutput(machine, enabled, undecided, allowed, missing, broken, unchecked,
                      bounds), fmt.value, out)
    if undecided:  # the answer is not complete: "cannot tell" is no "disabled"
        raise typer.Exit(3)


def _action_space(env: Optional[str]) -> dict:
    """The bounds of ``env``'s action space on each operation's REAL parameters (none
    without ``--env``, or for an environment of discrete actions)."""
    if env is None:
        return {}
    from ..live.adapter import load_adapter
    from ..live.continuous import action_bounds

    adapter = load_adapter(env)
    if not adapter.parameters:
        raise InputError(f"--env {env}: {adapter.name} takes discrete actions; --env bounds "
                         "the REAL parameters of continuous ones")
    return action_bounds(adapter)


def _enabled(machine, values, undecided: dict) -> set:
    """The operations enabled in ``values``; one whose guard tracecheck cannot decide there
    (an allowed set no float of which it could confirm) goes to ``undecided`` with why."""
    try:
        return machine.enabled(values)
    except UnsupportedError:
        found = set()
        for op in machine.operations:
            try:
                if machine.is_enabled(op, values):
                    found.add(op)
            except UnsupportedError as exc:
                undecided[op] = exc.message
        return found


def _allowed_sets(machine, values) -> dict:
    """For each operation with REAL parameters, the values its guard allows in the state."""
    from ..b.linear import real_parameters

    return {name: machine.allowed(name, values) for name, op in machine.operations.items()
            if real_parameters(op)}


