"""What ``info``, ``envs``, ``check-model`` and ``guards`` print, as reports in every format
(:mod:`.emit`)."""

from __future__ import annotations

from typing import Optional

from ..episodes.summary import search_text
from ..errors import UnsupportedError
from .emit import Report
from .tables import TableData, fitted, plain, say, terminal_width

__all__ = ["InfoOutput", "EnvsOutput", "ModelOutput", "GuardsOutput", "allowed_json"]


class InfoOutput(Report):
    """``info``: per file its source, episodes, steps, crashes and machine; the totals."""

    def __init__(self, summary: dict) -> None:
        self.summary = summary

    def data(self):
        return self.summary

    def table(self) -> TableData:
        return TableData.of(["file", "source", "episodes", "steps", "crashes", "model"],
                            ([f["path"], f["source"], f["episodes"], f["steps"], f["crashes"],
                              f["model_name"]] for f in self.summary["files"]))

    def text(self, console) -> None:
        summary = self.summary
        for line in fitted(self.table(), terminal_width()):
            plain(line)
        rate = summary["crashes"] / summary["episodes"] if summary["episodes"] else 0.0
        lines = [f"total: {summary['episodes']} episode(s), {summary['steps']} step(s), "
                 f"{summary['crashes']} crash(es) ({rate:.1%})"]
        lines += [f"{key}: {('; ' if key == 'continuous' else ', ').join(summary[key])}"
                  for key in ("agents", "shields", "continuous") if summary[key]]
        lines += [f"{f['path']}: a search (falsify): {search_text(f['search'])}"
                  for f in summary["files"] if f.get("search")]
        for line in lines:
            say(line)


def _brings(row: dict) -> str:
    """The shields, property sets, profiles and reset parameters (what a search may set at
    the start of an episode) an environment brings, in one line."""
    parts = [f"{what} {', '.join(row.get(key) or ())}" for what, key in (
        ("shields", "shields"), ("property sets", "property_sets"), ("profiles", "profiles"),
        ("reset parameters", "reset_parameters")) if row.get(key)]
    return "; ".join(parts)


class EnvsOutput(Report):
    """``envs``: one row per installed environment (``problem``: why one cannot be loaded)."""

    def __init__(self, rows: list[dict]) -> None:
        self.rows = rows

    def data(self):
        return self.rows

    def table(self) -> TableData:
        return TableData.of(
            ["name", "environment", "actions", "variables", "shield", "installed",
             "description", "brings", "horizon"],
            ([r["name"], r["adapter"], "", "", "", f"no: {r['problem']}", "", "", ""]
             if r["problem"] else
             [r["name"], r["environment"],
              ", ".join(f"{op}({', '.join(r['parameters'][op])})"
                        if op in r.get("parameters", {}) else op for op in r["actions"]),
              ", ".join(r["variables"]), r["default_shield"] or "",
              "yes" if r["installed"] else "no: needs " + ", ".join(r["missing"]),
              r["description"], _brings(r), str(r["horizon"])]
             for r in self.rows))

    def text(self, console) -> None:
        for (name, environment, actions, variables, shield, installed, description, brings,
             horizon) in self.table().rows:
            if not actions:  # a block per environment, wrapped between items
                say(f"{name} ({environment}): {installed}")
                continue
            say(f"{name} ({environment}), shield {shield or '(none)'}, installed: {installed}")
            if description:
                say(f"  {description}", "    ")
            say(f"  actions: {actions}", "    ")
            say(f"  variables: {variables}", "    ")
            if brings:
                say(f"  brings: {brings}", "    ")
            say(f"  horizon: {horizon} steps", "    ")


def _clip(text: str, width: int = 100) -> str:
    return text if len(text) <= width else text[: width - 1] + "…"


class ModelOutput(Report):
    """``check-model``: a machine's sets, constants, variables and operations."""

    def __init__(self, machine, file: str) -> None:
        from ..b.values import format_value

        self.machine, self.file = machine, file
        types, described = machine.types, machine.descriptions
        self.described = described
        self.summary = {
            "machine": machine.name,
            "file": file,
            "sha256": machine.sha256,
            "sets": {n: [str(e) for e in elems] for n, elems in machine.sets.items()},
            "constants": {n: format_value(v) for n, v in machine.constants.items()},
            # constants the PROPERTIES leave without one value, and why
            "unset_constants": dict(machine.unset_constants),
            "assertions": [{"assertion": text, "value": None if value is None else
                            ("TRUE" if value else "FALSE"), "why": why}
                           for text, value, why in machine.constant_assertions()],
            "variables": {v: {"type": types.get(v), "description": described.get(v)}
                          for v in machine.variables},
            "operations": {
                name: {"guard": op.guard_source, "parameters": list(op.params),
                       "description": op.description}
                for name, op in machine.operations.items()
            },
            # every /*@desc …*/ of the machine: sets, constants, variables and operations
            "descriptions": {**described, **{n: op.description for n, op in
                                             machine.operations.items() if op.description}},
        }

    def data(self):
        return self.summary

    def table(self) -> TableData:
        """One row per set, constant, variable and operation."""
        summary, described = self.summary, self.described
        return TableData.of(["kind", "name", "value or type", "guard", "description"], [
            *(["set", n, "{" + ", ".join(e) + "}", "", described.get(n, "")]
              for n, e in summary["sets"].items()),
            *(["constant", n, v, "", described.get(n, "")]
              for n, v in summary["constants"].items()),
            *(["constant", n, f"no value: {why}", "", described.get(n, "")]
              for n, why in summary["unset_constants"].items()),
            *(["assertion", a["assertion"], a["value"] or a["why"], "", ""]
              for a in summary["assertions"]),
            *(["variable", n, i["type"] or "?", "", i["description"] or ""]
              for n, i in summary["variables"].items()),
            *(["operation", n + (f"({', '.join(i['parameters'])})" if i["parameters"] else ""),
               "", i["guard"] or "TRUE", i["description"] or ""]
              for n, i in summary["operations"].items())])

    def text(self, console) -> None:
        from rich.markup import escape
        from rich.table import Table

        from .text import literal_row

        machine, summary, described = self.machine, self.summary, self.described
        console.print(f"[bold]MACHINE {escape(machine.name)}[/bold]  ({escape(self.file)}, "
                      f"sha256 {machine.sha256[:12]}…)", markup=True)

        def desc(name: str) -> str:
            return f" — {described[name]}" if name in described else ""

        for name, elems in summary["sets"].items():
            console.print(f"  set {name} = {{{', '.join(elems)}}}{desc(name)}", markup=False)
        for name, value in summary["constants"].items():
            console.print(f"  constant {name} = {value}{desc(name)}", markup=False)
        for name, why in summary["unset_constants"].items():
            plain(f"  constant {name}: no value — {why}{desc(name)}")
        for a in summary["assertions"]:
            plain(f"  assertion {a['assertion']}: {a['value'] or 'cannot tell: ' + a['why']}"
                  if a["value"] or not a["why"].startswith("reads ") else
                  f"  assertion {a['assertion']}: {a['why']}")
        table = Table("variable", "type", "description", box=None, pad_edge=False)
        for name, info in summary["variables"].items():
            literal_row(table, [name, info["type"] or "?", info["description"] or ""])
        if machine.variables:
            console.print(table)
        for name, info in summary["operations"].items():
            guard = info["guard"] or "TRUE"
            params = f"({', '.join(info['parameters'])})" if info["parameters"] else ""
            about = f" ({info['description']})" if info["description"] else ""
            plain(_clip(f"  operation {name}{params}{about}: guard {guard}", terminal_width()))
        verdicts = [a["value"] for a in summary["assertions"]
                    if a["value"] or not a["why"].startswith("reads ")]
        status = ("[red]FALSE[/red]: an assertion over the constants is false; "
                  if "FALSE" in verdicts else
                  "[yellow]unknown[/yellow]: an assertion tracecheck cannot decide; "
                  if None in verdicts else "[green]ok[/green]: ")
        console.print(f"{status}{len(machine.operations)} operation(s), "
                      f"{len(machine.variables)} variable(s)", markup=True)


def _solver_witness(allowed) -> Optional[dict]:
    """For a set the solver decides (a guard not linear in its parameters): {"witness": an
    allowed point the evaluator confirmed, or None where z3 proved nothing allowed; or
    "undecided": why}; None for an exact set."""
    from ..checking.solved_set import SolvedSet

    if not isinstance(allowed, SolvedSet):
        return None
    try:
        return {"witness": allowed.witness()}
    except UnsupportedError as exc:
        return {"undecided": exc.message}


def _solver_text(found: Optional[dict]) -> str:
    if found is None:
        return ""
    if "undecided" in found:
        return f"; {found['undecided']}"
    if found["witness"] is None:
        return "; nothing allowed (the solver proved it)"
    return "; allowed, e.g. " + ", ".join(f"{p} = {v!r}" for p, v in found["witness"].items())


def allowed_json(allowed) -> dict:
    """An allowed set in JSON: its parameters, its text, and in one dimension its intervals
    (bounds as numbers, exact where a float is)."""
    out: dict = {"parameters": list(allowed.params), "text": str(allowed)}
    found = _solver_witness(allowed)
    if found is not None:  # the solver's: an allowed point, none, or why it is not known
        out.update({"decided_by": "solver", "witness": found.get("witness"),
                    "undecided": found.get("undecided")})
    if allowed.intervals is not None:
        out["intervals"] = [{"low": None if i.low is None else float(i.low),
                             "high": None if i.high is None else float(i.high),
                             "low_open": i.low_open or i.low is None,
                             "high_open": i.high_open or i.high is None}
                            for i in allowed.intervals]
    return out


class GuardsOutput(Report):
    """``guards``: the operations a state enables, disables or leaves undecided, and for
    REAL parameters the values each allows."""

    def __init__(self, machine, enabled: set, undecided: dict[str, str], allowed: dict,
                 missing: list[str], broken: list[str],
                 unchecked: list[tuple[str, str]], bounds: Optional[dict] = None) -> None:
        self.machine, self.enabled, self.undecided = machine, enabled, undecided
        self.bounds = bounds or {}  # the action space's, where --env gave one
        self.allowed, self.missing, self.broken, self.unchecked = (allowed, missing, broken,
                                                                   unchecked)
        self.ordered = [op for op in machine.operations if op in enabled]
        self.blocked = [op for op in machine.operations
                        if op not in enabled and op not in undecided]

    def data(self):
        return {"machine": self.machine.name, "enabled": self.ordered,
                "disabled": self.blocked, "undecided": self.undecided,
                "allowed": {op: allowed_json(a) for op, a in self.allowed.items()},
                "action_space": {op: {"low": lo, "high": hi, "float_type": kind}
                                 for op, (lo, hi, kind) in self.bounds.items()} or None,
                "missing_variables": self.missing,
                "invariant_holds": False if self.broken else None if self.unchecked else True,
                "invariant_violations": self.broken,
                "invariant_unchecked": [{"conjunct": c, "reason": why}
                                        for c, why in self.unchecked]}

    def table(self) -> TableData:
        allowed = self.allowed
        extra = ["allowed"] if allowed else []  # a column only for REAL parameters
        return TableData.of(["operation", "enabled", *extra],
                            ([op, "yes" if op in self.enabled else
                              "undecided" if op in self.undecided else "no",
                              *([str(allowed.get(op, ""))] if allowed else [])]
                             for op in self.machine.operations))

    def text(self, console) -> None:
        none = "(none: deadlock)" if not self.undecided else "(none)"
        say(f"enabled: {', '.join(self.ordered) or none}")
        say(f"disabled: {', '.join(self.blocked) or '(none)'}")
        for op, why in self.undecided.items():
            say(f"undecided: {op} ({why})")
        for op, a in self.allowed.items():
            space = self.bounds.get(op)
            said = "within the action space" in str(a)  # the solver's set says it already
            within = "" if space is None or said else " (the action space: " + ", ".join(
                f"{p} ∈ [{space[0].get(p, '-inf')}, {space[1].get(p, 'inf')}] {space[2][p]}"
                for p in self.machine.operations[op].params) + ")"
            say(f"{op}: {a}{within}{_solver_text(_solver_witness(a))}")
