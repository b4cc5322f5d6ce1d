"""ProB's published answers (the output cells of the notebooks of hhu-stups/prob2_jupyter_kernel)
against ``tracecheck eval``: how many formulas get ProB's value, how many are refused, and
that none gets another value.

    python -m tests.b.prob_answers [--list same|refused|different|excluded|gave-up|platform]

The answers are in ``corpus/notebooks.jsonl``: one formula evaluation per line, as the
notebook shows it (the cell's source, ProB's printed output or error, the machine loaded at
that point, whether it had been animated, the preferences set before it), each with the
notebook, its commit and the cell. The machines the notebooks load are in
``corpus/notebook_machines/``. A formula that depends on ProB's own state is left out of the
count, with the reason: a preference set before it, ``MAXINT``/``MININT`` (a preference),
a random or hash function, an animated machine (its state is whatever the animator reached),
a name from ``:let``, a cell whose output is from another run of the notebook ("stale"), a
machine that is not published.

Every other formula is one of:

* ``same``: ProB's value (for a predicate solved for its free identifiers: the same TRUE or
  FALSE, the solution re-checked by tracecheck; which solution is shown may differ, where
  ProB's is a solution for tracecheck too); ProB's error and a tracecheck error of the same
  kind (type, scope, well-definedness);
* ``platform``: two floats from transcendental functions a last bit apart (each platform's
  C library rounds its own way): listed, not counted;
* ``refused``: ProB gives a value and tracecheck refuses (a located error, or unknown);
* ``gave-up``: ProB gives no value (an enumeration warning, a time-out, an internal error):
  tracecheck's answer, if any, is listed but not counted;
* ``different``: anything else — tracecheck's value is not ProB's, or a value where ProB
  found an error in the formula. Never allowed.
"""

from __future__ import annotations

import argparse
import json
import re
from collections import Counter
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any, Optional

CORPUS = Path(__file__).with_name("corpus")
ANSWERS = CORPUS / "notebooks.jsonl"
MACHINES = CORPUS / "notebook_machines"
_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


@dataclass(frozen=True)
class Case:
    notebook: str
    commit: str
    cell: int
    command: str
    formula: str
    output: Optional[str]
    error: Optional[str]
    machine: Optional[str]
    animated: bool
    prefs: dict
    lets: tuple
    flags: tuple

    @property
    def id(self) -> str:
        return f"{Path(self.notebook).stem}#{self.cell}"


def load() -> list[Case]:
    cases = []
    for line in ANSWERS.read_text(encoding="utf-8").splitlines():
        r = json.loads(line)
        cases.append(Case(r["notebook"], r["commit"], r["cell"], r["command"], r["formula"],
                          r["output"], r["error"], r["machine"], r["animated"], r["prefs"],
                          tuple(r["lets"]), tuple(r["flags"])))
    return cases


def excluded(case: Case) -> Optional[str]:
    """Why ``case`` depends on ProB's own state (None: it does not)."""
    names = set(_IDENT.findall(case.formula))
    if case.prefs:
        return "preferences set: " + ", ".join(f"{k}={v}" for k, v in case.prefs.items())
    if names & {"MAXINT", "MININT"}:
        return "MAXINT/MININT (a preference)"
    if "library:LibraryMeta.def" in case.flags or case.formula.startswith(
            ("PROB_INFO_STR", "PROB_STATISTICS", "PROJECT_STATISTICS", "PROJECT_INFO",
             "MACHINE_INFO")):
        return "ProB's own state (LibraryMeta.def: its version, statistics, loaded files)"
    for flag in ("random", "hash", "stale", "no-output"):
        if flag in case.flags:
            return {"stale": "output from another run of the notebook",
                    "no-output": "no output"}.get(flag, f"a {flag} function")
    if case.animated:
        return "the machine was animated (its state is the animator's)"
    if case.machine and (case.machine.startswith("missing:")
                         or not (MACHINES / case.machine).exists()):
        return f"machine not published ({case.machine})"
    used = names & set(case.lets)
    if used:
        return "a name from :let (" + ", ".join(sorted(used)) + ")"
    other = _refuted_by_prob(case)
    if other is not None:
        return (f"ProB's Kodkod backend (bounded integers) answers {case.output.split()[0]}, "
                f"ProB's own solver {other} for the same formula in this notebook")
    return None


def _refuted_by_prob(case: Case) -> Optional[str]:
    """ProB's own answer where ``case`` is an answer of its Kodkod backend that ProB's own
    solver, asked the same formula in the same notebook, contradicts (None otherwise)."""
    if "kodkod" not in (case.command or "") or not case.output:
        return None
    for other in _all_cases():
        if other.notebook == case.notebook and other.formula == case.formula and \
                "kodkod" not in (other.command or "") and other.output and \
                other.output.split()[0] != case.output.split()[0]:
            return other.output.split()[0]
    return None


@cache
def _all_cases() -> tuple:
    return tuple(load())


# -- ProB's side
def _normal(text: str) -> str:
    """ProB's pretty-printed value in the notation tracecheck reads: outside strings its
    minus sign U+2212 as '-', and a record field's '∈' (the Unicode printing of
    ``rec(a:1)`` in the notebooks) as ':'."""
    out, in_string, escaped = [], False, False
    for ch in text:
        if ch == '"' and not escaped:
            in_string = not in_string
        escaped = in_string and ch == "\\" and not escaped
        if not in_string:
            ch = {"\u2212": "-", "\u2208": ":"}.get(ch, ch)
        out.append(ch)
    return "".join(out)


def prob_answer(case: Case) -> tuple:
    """("value", text) | ("solved", "TRUE"/"FALSE", {name: text}) | ("error", kind)."""
    if case.error is not None:
        e = case.error
        if case.command == ":assert":
            m = re.match(r":assert: Assertion is not true: (.*)\Z", e, re.S)
            if m:
                return ("value", m.group(1).strip())
        if "NOT-WELL-DEFINED" in e or "not well-defined" in e.lower():
            return ("error", "wd")
        if "Type mismatch" in e or "Could not infer type" in e or "type error" in e.lower():
            return ("error", "type")
        if "Unknown identifier" in e:
            return ("error", "scope")
        if "Parse error" in e or "parse error" in e or "Syntax error" in e:
            return ("error", "syntax")
        return ("error", "gave-up")
    text = case.output or ""
    if case.command.startswith(":time") and text.startswith("Execution time"):
        text = text.split("\n", 1)[1] if "\n" in text else ""
    if case.command == ":assert":
        return ("value", "TRUE")
    lines = text.split("\n")
    if lines[0] in ("TRUE", "FALSE") and len(lines) > 1 and "Solution:" in text:
        sol = {}
        for line in lines[lines.index("Solution:") + 1:]:
            if line.startswith("\t") and " = " in line:
                name, value = line.strip().split(" = ", 1)
                sol[name] = value
        return ("solved", lines[0], sol)
    return ("value", text.strip())


# -- tracecheck's side
@cache
def _evaluator(machine: Optional[str]):
    from tracecheck.cli.model import _evaluator as make

    return make(MACHINES / machine if machine else None, None,
                {"timeout_s": 10.0, "limit": 100, "all_solutions": False})


def ours(case: Case) -> tuple:
    """("value", value) | ("solved", status, solution or None, reason) | ("error", kind,
    message)."""
    from tracecheck import errors as E
    from tracecheck.cli.model import _Solved
    from tracecheck.limits import deep_recursion, long_integers

    kinds = [(E.BTypeError, "type"), (E.BScopeError, "scope"), (E.BSyntaxError, "syntax"),
             (E.WellDefinednessError, "wd"), (E.UnsupportedError, "refused"),
             (E.ModelError, "model")]
    try:
        with long_integers(), deep_recursion():
            evaluate = _evaluator(case.machine if case.machine else None)
            value = evaluate(case.formula, "<notebook>")
    except E.EvaluationError as exc:
        kind = "wd" if _is_wd(exc) else "refused"
        return ("error", kind, exc.message)
    except E.TracecheckError as exc:
        kind = next((k for cls, k in kinds if isinstance(exc, cls)), "refused")
        if exc.message.startswith("not supported"):  # valid B tracecheck does not take
            kind = "refused"
        return ("error", kind, exc.message)
    if isinstance(value, _Solved):
        a = value.answer
        return ("solved", a.status, a.solutions[0] if a.solutions else None, a.reason)
    return ("value", value)


def _is_wd(exc) -> bool:
    text = exc.message.lower()
    return any(w in text for w in ("not well-defined", "division by zero", "outside its domain",
                                   "empty set", "empty sequence", "negative", "not defined"))


def _same_value(prob_text: str, value: Any) -> Optional[bool]:
    """Whether ProB's printed value is ``value`` (None: ProB's text is not a value tracecheck
    reads, e.g. a symbolic lambda)."""
    from tracecheck import errors as E
    from tracecheck.b.notation import parse_literal
    from tracecheck.b.values import format_value

    try:
        theirs = parse_literal(_normal(prob_text), where="ProB's answer: ")
    except E.TracecheckError:
        return None
    if theirs == value:
        return True
    try:
        return format_value(theirs) == format_value(value)
    except Exception:  # noqa: BLE001 - values of different shapes: not the same
        return False


def judge(case: Case) -> tuple[str, str]:
    """(verdict, detail) for one case (see the module docstring)."""
    why = excluded(case)
    if why:
        return "excluded", why
    theirs = prob_answer(case)
    mine = ours(case)
    if theirs[0] == "error":
        kind = theirs[1]
        if kind == "gave-up":
            return "gave-up", f"ours: {_show(mine)}"
        if mine[0] == "error" and mine[1] == kind:
            return "same", f"both an error ({kind}; ours: {mine[2][:80]})"
        if mine[0] == "error" and mine[1] == "refused":
            return "refused", f"ProB: {kind} error; ours refused: {mine[2][:80]}"
        if mine[0] == "solved" and mine[1] == "unknown":
            return "refused", f"ProB: {kind} error; ours: unknown ({mine[3][:80]})"
        return "different", f"ProB: {kind} error; ours: {_show(mine)}"
    if mine[0] == "error":
        return "refused", f"{mine[1]}: {mine[2][:120]}"
    if theirs[0] == "solved":
        if mine[0] != "solved":
            same = _same_value(theirs[1], mine[1])
            return ("same" if same else "different" if same is False else "refused",
                    f"ProB: {theirs[1]} (solved); ours: {_show(mine)}")
        if mine[1] == "unknown":
            return "refused", f"unknown: {mine[3]}"
        if mine[1] != theirs[1]:
            return "different", f"ProB: {theirs[1]}; ours: {mine[1]}"
        note = _solution_note(theirs[2], mine[2])
        if note.startswith("another solution") and _prob_s_solution_fails(case, theirs[2]):
            verdict = "platform" if _TRANSCENDENTAL.search(case.formula) else "different"
            return verdict, note + ": ProB's is no solution here"
        return "same", note
    # ProB printed a value
    if mine[0] == "solved":
        if mine[1] == "unknown":
            return "refused", f"unknown: {mine[3]}"
        if theirs[1] in ("TRUE", "FALSE"):
            return ("same" if theirs[1] == mine[1] else "different",
                    f"ProB: {theirs[1]}; ours: {mine[1]}")
        return "different", f"ProB: {theirs[1][:80]}; ours: {mine[1]}"
    same = _same_value(theirs[1], mine[1])
    if same is None:
        return "refused", f"ProB's value is not one tracecheck reads: {theirs[1][:80]}"
    if not same and _platform_floats(case, theirs[1], mine[1]):
        return "platform", (f"ProB: {theirs[1]}; ours: {_show(mine)} (the C library of the "
                            "machine that ran the notebook, a last bit apart)")
    return ("same" if same else "different",
            f"ProB: {theirs[1][:80]}; ours: {_show(mine)[:80]}")


_TRANSCENDENTAL = re.compile(r"\bR(SIN|COS|TAN|SINH|COSH|TANH|ASIN|ACOS|ATAN|ASINH|ACOSH|"
                            r"ATANH|EXP|LOGe|LOG|POW)\(")


def _platform_floats(case: Case, prob_text: str, value: Any) -> bool:
    """Two floats at most two steps apart, from transcendental functions, which each
    platform's C library rounds its own way (docs/b-language.md, LibraryReals)."""
    import math

    try:
        theirs = float(_normal(prob_text))
    except ValueError:
        return False
    return (type(value) is float and bool(_TRANSCENDENTAL.search(case.formula))
            and abs(theirs - value) <= 2 * math.ulp(max(abs(theirs), abs(value))))


def _prob_s_solution_fails(case: Case, theirs: dict) -> bool:
    """Whether ProB's solution, bound as it is, makes the predicate false for tracecheck
    (another solution is as good, unless ProB's is not one: then the two differ on a value).
    False where ProB's values are not ones tracecheck reads (not checked)."""
    from tracecheck import errors as E
    from tracecheck.b.notation import parse_literal
    from tracecheck.b.values import format_value

    bound = []
    for name, text in theirs.items():
        try:
            bound.append(f"{name} = {format_value(parse_literal(_normal(text)))}")
        except E.TracecheckError:
            return False
    fixed = Case(**{**case.__dict__, "formula": " & ".join(bound + [f"({case.formula})"])})
    mine = ours(fixed)
    return mine[0] == "solved" and mine[1] == "FALSE"


def _solution_note(theirs: dict, mine: Optional[dict]) -> str:
    if not mine:
        return "FALSE both"
    from tracecheck.b.values import format_value

    shown = {k: format_value(v) for k, v in mine.items()}
    agree = all(_same_value(t, mine[k]) for k, t in theirs.items() if k in mine)
    return ("the same solution" if agree else
            f"another solution (ours {shown}, ProB {theirs})")


def _show(mine: tuple) -> str:
    from tracecheck.b.values import format_value

    if mine[0] == "value":
        return format_value(mine[1])
    if mine[0] == "solved":
        return f"{mine[1]} {mine[2] if mine[2] else ''}"
    return f"error ({mine[1]}): {mine[2][:80]}"


def results() -> list[tuple[Case, str, str]]:
    return [(case, *judge(case)) for case in load()]


def main() -> None:
    ap = argparse.ArgumentParser(description="ProB's notebook answers against tracecheck eval")
    ap.add_argument("--list", choices=["same", "refused", "different", "excluded", "gave-up",
                                       "platform"],
                    action="append", default=[])
    args = ap.parse_args()
    rows = results()
    counts = Counter(v for _, v, _ in rows)
    for case, verdict, detail in rows:
        if verdict in args.list:
            print(f"{verdict:9} {case.id:28} {case.formula[:60]!r:64} {detail}")
    counted = counts["same"] + counts["refused"] + counts["different"]
    print(f"\n{len(rows)} formulas from {len({c.notebook for c in load()})} notebooks: "
          f"{counts['excluded']} depend on ProB's state, {counts['gave-up']} ProB gave no "
          f"value, {counts['platform']} platform floats; of the other {counted}: "
          f"{counts['same']} ProB's answer "
          f"({counts['same'] / max(counted, 1):.0%}), {counts['refused']} refused, "
          f"{counts['different']} different")


if __name__ == "__main__":
    main()
