"""An obligation solved: its constraints asked of z3, a model read back as a B state and
confirmed by tracecheck's own evaluator before it is reported (:func:`obligation`) — the
machinery every question of :mod:`.proving` goes through. Where the solver and the evaluator
disagree, that is said (:attr:`Result.disagreement`); where rounding the solver's exact reals
to floats is why, that is no disagreement (:func:`holds_at`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Callable, Optional

from .deadline import interrupted_at
from ..errors import TracecheckError, UnsupportedError, WellDefinednessError
from .encoding import (MAX_TIMEOUT_S, ElementFunction, ElementSet, ElementTerm, FiniteFunction,
                       state_of_model)
from .shield import Shield
from .smt import Translator

__all__ = ["Result", "Describe", "Bounds", "Context", "Finding", "obligation", "check_satisfiable",
           "holds_at", "decides", "undefined", "reading", "guards_text", "machine_of",
           "PROVED", "EQUIVALENT", "COUNTEREXAMPLE", "NOT_DEFINED", "UNKNOWN", "VACUOUS",
           "ONLY_IN"]

PROVED, EQUIVALENT, COUNTEREXAMPLE = "proved", "equivalent", "counterexample"
NOT_DEFINED, UNKNOWN, VACUOUS = "not well-defined", "unknown", "vacuous"
ONLY_IN = "only in "  # + the shield: an operation the other shield does not have

#: How a counterexample state reads for people, in one line (None: as its variables'
#: values): an environment's :meth:`~tracecheck.live.adapter.EnvAdapter.describe`.
Describe = Callable[[dict], Optional[str]]
#: an action space's bounds of operations' REAL parameters: ``{op: ({p: low}, {p: high})}``
#: (a side without a bound left out), as the live shield and replay take them
Bounds = dict



@dataclass
class Result:
    """One obligation: proved, counterexample, not well-defined, unknown (with the solver's
    reason) or vacuous; for the diff equivalent or only in one shield."""

    obligation: str
    status: str
    reason: str = ""
    state: Optional[dict] = None  # the counterexample, as B values
    reading: str = ""
    disagreement: str = ""  # where tracecheck's evaluator does not confirm the solver
    extra: dict = field(default_factory=dict)

    @property
    def failed(self) -> bool:
        """A counterexample, a claim that is not well-defined, an operation one shield
        lacks: what makes ``prove`` and ``diff --symbolic`` exit 1."""
        return self.status in (COUNTEREXAMPLE, NOT_DEFINED) or self.status.startswith(ONLY_IN)


def milliseconds(seconds: float) -> int:
    return max(1, min(int(seconds * 1000), MAX_TIMEOUT_S * 1000))


# ------------------------------------------------------------------ the solver


@dataclass
class Context:
    """What every obligation of one run shares: the translation, the machines whose
    invariants a counterexample must satisfy, the constraints every state satisfies, how
    a counterexample reads."""

    translator: Translator
    machines: tuple
    base: list
    timeout_s: float
    describe: Optional[Describe] = None


@dataclass
class Finding:
    """What a model of an obligation's constraints shows, and how tracecheck's evaluator
    confirms it in the state (``confirm(state)``; it may raise for a state it cannot
    evaluate)."""

    status: str
    meaning: str
    confirm: Callable[[dict], bool]


def ask(z3, solver, seconds: float, add: Callable[[], None]) -> tuple[object, str]:
    """``add()`` the question to ``solver`` and check it, the two together within
    ``seconds`` of wall time: (verdict, why unknown).

    z3's own ``timeout`` counts only in ``check()``, but z3 already rewrites a term while it
    is asserted — for a huge term that alone took minutes and gigabytes — so a timer
    interrupts z3's context at the deadline, whatever it is doing then, and a question whose
    time went into asserting it is ``unknown (timeout)`` without a check.
    """
    deadline = time.monotonic() + seconds
    with interrupted_at(z3, seconds):
        try:
            add()
            left = deadline - time.monotonic()
            if left <= 0:
                return z3.unknown, "timeout"
            solver.set("timeout", milliseconds(left))
            verdict = solver.check()
            return verdict, "" if verdict in (z3.sat, z3.unsat) else why_unknown(solver)
        except z3.Z3Exception as exc:  # z3 canceled while asserting
            return z3.unknown, "timeout" if time.monotonic() >= deadline else str(exc)


def solve(translator: Translator, constraints: list, timeout_s: float):
    """Check ``constraints`` (with the translator's definitions) within ``timeout_s``. A
    model is then made smaller in what is left of that time (at most 1 s): as few set
    members (vehicles present) as possible, for an easier reading."""
    z3 = translator.z3
    deadline = time.monotonic() + timeout_s
    constraints = list({c.get_id(): c for c in constraints}.values())  # z3 shares equal terms
    solver = z3.Solver()
    verdict, why = ask(z3, solver, timeout_s,
                        lambda: solver.add(*constraints, *translator.side_conditions))
    if verdict != z3.sat:
        return verdict, None, why
    model = solver.model()
    counts = [z3.Sum([z3.If(c, 1, 0) for c in v.member.values()])
              for v in translator.variables.values() if isinstance(v, ElementSet) and v.member]
    left = min(deadline - time.monotonic(), 1.0)
    if counts and left > 0.05:
        z3.set_param("warning", False)  # z3's own notes to stderr (quantifiers, below)
        opt = z3.Optimize()

        def add():
            opt.add(*constraints, *translator.side_conditions)
            opt.minimize(z3.Sum(counts))
        if ask(z3, opt, left, add)[0] == z3.sat:
            fewer = opt.model()
            # with a quantifier (REAL parameters) z3 optimises without guarantees: the
            # smaller state is taken only where it satisfies every constraint
            if all(z3.is_true(fewer.eval(c, model_completion=True))
                   for c in (*constraints, *translator.side_conditions)):
                model = fewer
    return verdict, model, ""


def why_unknown(solver) -> str:
    """Why the solver gave up (z3 says "canceled" for a timeout it ran into)."""
    reason = solver.reason_unknown()
    return "timeout" if reason == "canceled" else reason or "the solver gave up"


def check_satisfiable(translator: Translator, parts: list[tuple[str, object]], timeout_s: float,
                 what: str) -> tuple[str, str]:
    """Whether some state satisfies every ``(label, constraint)`` of ``parts``: ``("sat",
    "")``, ``("unsat", why)`` naming the parts that contradict each other, or
    ``("unknown", the solver's reason)``."""
    z3 = translator.z3
    solver = z3.Solver()

    def add():
        solver.add(*translator.side_conditions)
        for i, (_, constraint) in enumerate(parts):
            solver.assert_and_track(constraint, z3.Bool(f"part#{i}"))
    verdict, reason = ask(z3, solver, timeout_s, add)
    if verdict == z3.sat:
        return "sat", ""
    if verdict != z3.unsat:
        return "unknown", reason
    core = {str(m) for m in solver.unsat_core()}
    labels = [label for i, (label, _) in enumerate(parts) if f"part#{i}" in core]
    why = f"no state satisfies {what}"
    if len(labels) == 1:
        why += f" ({labels[0]} alone is unsatisfiable)"
    elif labels:
        why += f" (these contradict each other: {'; '.join(labels)})"
    return "unsat", why


def obligation(name: str, build: Callable[[], list], ctx: Context,
                explain: Callable[[object], Finding], terms: list = ()) -> Result:
    """Solve ``build()``'s constraints under ``ctx.base``: unsat is proved; a model is read
    by ``explain`` and confirmed by tracecheck's evaluator."""
    translator = ctx.translator
    try:
        constraints = ctx.base + build()
    except UnsupportedError as exc:
        return Result(name, UNKNOWN, reason=exc.render())
    verdict, model, why = solve(translator, constraints, ctx.timeout_s)
    if verdict == translator.z3.unsat:
        return Result(name, PROVED)
    if verdict != translator.z3.sat:
        return Result(name, UNKNOWN, reason=why)
    state = state_of_model(translator.z3, translator.variables, model)
    finding = explain(model)
    result = Result(name, finding.status, state=state,
                    reading=f"{finding.meaning}: {reading(state, ctx.describe)}")
    try:
        ok_invariant = all(m.invariant(state) for m in ctx.machines)
        confirmed = ok_invariant and finding.confirm(state)
    except UnsupportedError as exc:  # the evaluator cannot decide it: not known either way
        return Result(name, UNKNOWN, state=state, reading=result.reading,
                      reason=("the solver's counterexample cannot be confirmed: tracecheck's "
                              f"evaluator does not decide it ({exc.message})"))
    except TracecheckError as exc:
        result.disagreement = f"tracecheck's evaluator cannot evaluate the state: {exc.message}"
        return result
    if not confirmed:
        holds = holds_at(translator, model, constraints + translator.side_conditions,
                          ctx.timeout_s, terms)
        if holds is None:  # the solver did not say in time: neither a finding nor a bug
            return Result(name, UNKNOWN, state=state, reading=result.reading,
                          reason=("tracecheck's evaluator does not confirm the solver's "
                                  "counterexample, and the solver did not decide in time "
                                  "whether rounding its exact reals to floats is why "
                                  "(a longer --timeout may)"))
        if not holds:
            # the solver's exact reals, rounded to floats, moved the state across a boundary:
            # a counterexample over the reals that floats cannot show — no disagreement
            result.reason = ("over the exact reals, at a boundary: the nearest float state "
                             "does not show it (see docs/prove.md, reals and floats)")
            return result
        failing = "the invariant fails" if not ok_invariant else finding.meaning + " is false"
        result.disagreement = ("tracecheck's evaluator does not confirm the counterexample "
                               f"({failing} there): the solver and the evaluator disagree")
    return result


def holds_at(translator: Translator, model, constraints: list,
              timeout_s: float, terms: list = ()) -> Optional[bool]:
    """Whether ``constraints`` still hold when every real of ``model`` is rounded to the
    nearest float (the state tracecheck's evaluator sees), fresh variables re-solved; None
    where the solver does not decide it within ``timeout_s``. Where rounding moves no value,
    they hold (the model itself is the answer): the solver is not asked, so that a
    disagreement is never hidden behind a question it could not answer in time."""
    z3 = translator.z3
    fixed = []
    moved = False
    for enc in [*translator.variables.values(), *terms]:  # terms: an action's values
        cells = enc.cells.values() if isinstance(enc, ElementFunction) else \
            [(None, v) for v in enc.member.values()] if isinstance(enc, ElementSet) else \
            [(None, enc.term)] if isinstance(enc, ElementTerm) else \
            [(None, enc.at(k)) for k in enc.keys] if isinstance(enc, FiniteFunction) else \
            [(None, enc)]
        for defined, value in cells:
            for var in ([defined] if defined is not None else []) + [value]:
                got = model.eval(var, model_completion=True)
                if z3.is_rational_value(got) or z3.is_algebraic_value(got):
                    algebraic = z3.is_algebraic_value(got)
                    if algebraic:
                        got = got.approx(20)
                    exact = Fraction(got.numerator_as_long(), got.denominator_as_long())
                    rounded = Fraction(float(exact))
                    moved = moved or algebraic or rounded != exact
                    got = z3.RealVal(rounded)
                fixed.append(var == got)
    if not moved:
        return True
    solver = z3.Solver()
    verdict = ask(z3, solver, timeout_s, lambda: solver.add(*constraints, *fixed))[0]
    return True if verdict == z3.sat else False if verdict == z3.unsat else None


def reading(state: dict, describe: Optional[Describe], limit: int = 6) -> str:
    """One line: what ``describe`` (an environment's, e.g. vehicles on the
    road) says of the state; otherwise its first variables."""
    text = describe(state) if describe is not None else None
    if text is not None:
        return text
    from ..b.values import format_value

    parts = [f"{k} = {_brief(format_value(v), v)}" for k, v in state.items()][:limit]
    return ", ".join(parts) + (", …" if len(state) > limit else "")


def _brief(text: str, value, width: int = 120) -> str:
    """A value's text for one line: a long one (a grid map) cut, saying how much is left
    out (JSON and --counterexamples keep the whole state)."""
    if len(text) <= width:
        return text
    size = f"{len(value)} entries, " if isinstance(value, frozenset) else ""
    return f"{text[:width]}… ({size}the whole value with --format json or --counterexamples)"


# ------------------------------------------------------------------ the evaluator's view


def decides(machine, op: str, state: dict, bounds: Optional[Bounds] = None
             ) -> Optional[bool]:
    """Whether ``op`` is enabled in ``state`` by tracecheck's evaluator; None where its
    guard is not well-defined there — which does not enable the operation. With
    ``bounds`` (an action space's), an operation with REAL parameters is enabled where its
    guard allows a value inside them: the live shield's decision."""
    try:
        if bounds and op in bounds:
            low, high = bounds[op][:2]  # over the reals, as a proof is
            return machine.allowed(op, state).within(low, high).witness() is not None
        return machine.is_enabled(op, state)
    except WellDefinednessError:
        return None


def undefined(translator: Translator, model, conditions: dict) -> list[str]:
    """The names whose well-definedness condition is false in ``model``."""
    z3 = translator.z3
    return [name for name, wd in conditions.items()
            if not z3.is_true(model.eval(wd, model_completion=True))]


def guards_text(ops) -> str:
    return ("the guard of " if len(ops) == 1 else "the guards of ") + ", ".join(ops)


# ------------------------------------------------------------------ prove


def machine_of(shield_or_machine):
    """The machine of a shield, or the machine itself."""
    return shield_or_machine.machine if isinstance(shield_or_machine, Shield) else \
        shield_or_machine
