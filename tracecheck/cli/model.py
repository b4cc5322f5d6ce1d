"""Commands on B machines and formulas: check-model, eval, guards."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from ..errors import EvaluationError, InputError, TracecheckError
from .common import app, out, load_model


@app.command("check-model")
def check_model(
    model: Path = typer.Argument(..., help="A classical B machine (.mch), or none, paper, "
                                           "strict."),
    as_json: bool = typer.Option(False, "--json", help="Print a JSON summary."),
) -> None:
    """Parse and check a B machine; list its sets, constants, variables and operations."""
    from ..b.values import format_value

    machine = load_model(model)
    types = machine.types
    summary = {
        "machine": machine.name,
        "file": str(model),
        "sha256": machine.sha256,
        "sets": {n: [str(e) for e in elems] for n, elems in machine.sets.items()},
        "constants": {n: format_value(v) for n, v in machine.constants.items()},
        "variables": {v: {"type": types.get(v), "description": machine.descriptions.get(v)}
                      for v in machine.variables},
        "operations": {
            name: {"guard": op.guard_source, "parameters": list(op.params)}
            for name, op in machine.operations.items()
        },
    }
    if as_json:
        out.print_json(json.dumps(summary))
        return
    out.print(f"[bold]MACHINE {machine.name}[/bold]  ({model}, sha256 {machine.sha256[:12]}…)")
    for name, elems in summary["sets"].items():
        out.print(f"  set {name} = {{{', '.join(elems)}}}", markup=False)
    for name, value in summary["constants"].items():
        out.print(f"  constant {name} = {value}", markup=False)
    table = Table("variable", "type", "description", box=None, pad_edge=False)
    for name, info in summary["variables"].items():
        table.add_row(name, info["type"] or "?", info["description"] or "")
    if machine.variables:
        out.print(table)
    for name, info in summary["operations"].items():
        guard = info["guard"] or "TRUE"
        params = f"({', '.join(info['parameters'])})" if info["parameters"] else ""
        out.print(f"  operation {name}{params}: guard {_clip(guard)}", markup=False)
    out.print(f"[green]ok[/green]: {len(machine.operations)} operation(s), "
              f"{len(machine.variables)} variable(s)")


def _clip(text: str, width: int = 100) -> str:
    return text if len(text) <= width else text[: width - 1] + "…"


@app.command("eval", context_settings={"ignore_unknown_options": True})
def eval_(
    expr: str = typer.Argument(..., help="A B predicate or expression."),
    model: Optional[Path] = typer.Option(None, "--model", "-m",
                                         help="Evaluate in this machine's scope."),
    state: Optional[Path] = typer.Option(None, "--state", "-s",
                                         help="JSON file: variable name -> B literal."),
    as_json: bool = typer.Option(False, "--json", help="Print the value as JSON."),
) -> None:
    """Evaluate a predicate or expression and print its value in B notation."""
    from ..b.evaluate import Compiler
    from ..b.parser import parse_formula
    from ..b.scope import check_kind, expand, kind_of
    from ..b.state import read_state_file
    from ..b.typecheck import type_of_value, typecheck_formula
    from ..b.values import format_value, to_json

    machine = load_model(model) if model is not None else None
    values = read_state_file(state) if state is not None else {}
    if machine is not None:
        machine.check_state(values, where=str(state))
    try:
        node = parse_formula(expr, file="<expr>")
        if machine is not None:
            node = expand(node, machine.definitions)
        kind = kind_of(node)
        check_kind(node, kind, source=expr, context="the formula")
        names = dict(machine.type_objects) if machine is not None else {}
        owners = machine.element_sets() if machine is not None else {}
        for name, value in values.items():
            names.setdefault(name, type_of_value(value, owners))
        typecheck_formula(node, names, kind=kind, source=expr, file="<expr>")
        env = machine.env(values) if machine is not None else dict(values)
        value = Compiler(source=expr, file="<expr>").compile(node)(env)
    except TracecheckError as exc:
        raise exc.located(file="<expr>", source=expr) from None
    if as_json:
        out.print_json(json.dumps({"expression": expr, "value": format_value(value),
                                   "json": to_json(value)}))
    else:
        out.print(format_value(value), markup=False)


@app.command("guards")
def guards(
    model: Path = typer.Argument(..., help="A classical B machine (.mch)."),
    state: Path = typer.Option(..., "--state", "-s", help="JSON file: variable -> B literal."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """List the operations whose guard holds in a state."""
    from ..b.state import read_state_file

    machine = load_model(model)
    values = read_state_file(state)
    machine.check_state(values, where=str(state))
    missing = [v for v in machine.variables if v not in values]
    try:
        enabled = machine.enabled(values)
    except EvaluationError as exc:
        name = next((v for v in missing if exc.message == f"{v} has no value here"), None)
        if name is None:
            raise
        raise InputError(f"the state gives no value for {name}, a variable of {machine.name} "
                         f"that a guard reads ({exc.location})", file=str(state),
                         hint=f'add "{name}": … to the state file') from None
    ordered = [op for op in machine.operations if op in enabled]
    blocked = [op for op in machine.operations if op not in enabled]
    if as_json:
        out.print_json(json.dumps({"machine": machine.name, "enabled": ordered,
                                   "disabled": blocked, "missing_variables": missing}))
        return
    out.print(f"enabled: {', '.join(ordered) or '(none: deadlock)'}")
    out.print(f"disabled: {', '.join(blocked) or '(none)'}")
