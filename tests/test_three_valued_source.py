"""The three-valued rule, checked over the source (docs/safety.md, "Cannot tell is not
FALSE"): no exception handler in the engine, the checking layer or live execution answers
with a boolean — a limit hit, an unknown finiteness, a cast, an operation that is missing
are refusals, never FALSE or TRUE. The few handlers where a boolean is the right answer are
listed here, each with why."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "tracecheck"
LAYERS = ("b", "checking", "live")

#: (file, function, exception caught): why the boolean is right there
ALLOWED = {
    ("b/linear.py", "_linear_conjunct", "UnsupportedError"):
        "not an evaluation: whether a conjunct can join a guard's own range; one the "
        "linear form refuses is left out, so the range holds more values, never fewer "
        "(both its users ask what no action could be: unbounded, or outside the space)",
    ("b/parser.py", "grammar_cache", "OSError"):
        "not an evaluation: no private cache folder means no grammar cache (False)",
    ("b/regex.py", "_is_regex", "BadPattern"):
        "the question is whether the text is a valid pattern: a bad pattern is a real no "
        "(a pattern too large for Python's re raises Unsupported, which is not caught)",
    ("b/spaces.py", "contains", "KeyError"):
        "prj1/prj2: apply raises KeyError only for a pair outside S*T, which is not a member "
        "(a product that cannot decide membership raises EvaluationError, not caught)",
    ("b/typecheck.py", "unify_quiet", "TypeClash"):
        "type unification: a clash is a definite no",
    ("checking/candidates.py", "passes", "TracecheckError"):
        "a pruning check: True keeps the candidate, so the full evaluation at the leaf "
        "decides (and refuses there); it never decides the answer",
    ("checking/solved_set.py", "check", "WellDefinednessError"):
        "a float point is executed only where the guard is TRUE; where it has no value the "
        "point is not confirmed and another is sought (the live shield fails closed)",
    ("checking/solving.py", "holds", "WellDefinednessError"):
        "a solution must be a point where the predicate is defined and true; an undefined "
        "point is no solution (and is noted: a FALSE with such a point is an error)",
    ("checking/solving.py", "_small_set", "TracecheckError"):
        "a heuristic, not an answer: False only means 'do not enumerate it' (the solver or "
        "the evaluator's refusal decides)",
    ("live/external.py", "_kill_if", "(OSError, AttributeError)"):
        "not an evaluation: whether a process was killed (it is gone, or not ours)",
    ("live/external.py", "_kill_if", "(OSError, ProcessLookupError)"):
        "not an evaluation: whether a process was killed (it is gone, or not ours)",
    ("live/continuous.py", "_enabled", "TracecheckError"):
        "the live shield must act: it fails closed (not enabled) and records why in "
        "self.problem, which info['shield']['problem'] and the recording keep",
}


def _handlers_returning_booleans(package: Path = PACKAGE) -> list[tuple[str, str, str, int]]:
    """(file, enclosing function, caught exception, line) of every except handler in the
    layers whose body returns True or False."""
    found = []
    for layer in LAYERS:
        for path in sorted((package / layer).rglob("*.py")):
            tree = ast.parse(path.read_text(), str(path))
            for func in ast.walk(tree):
                if not isinstance(func, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    continue
                for node in ast.walk(func):
                    if not isinstance(node, ast.ExceptHandler):
                        continue
                    for sub in ast.walk(ast.Module(body=node.body, type_ignores=[])):
                        if isinstance(sub, ast.Return) and isinstance(sub.value, ast.Constant) \
                                and isinstance(sub.value.value, bool):
                            caught = ast.unparse(node.type) if node.type else "everything"
                            found.append((path.relative_to(package).as_posix(), func.name,
                                          caught, node.lineno))
                            break
    # a handler inside a nested function is met once per enclosing function: keep the
    # innermost (the one whose name the allow-list gives)
    innermost: dict[tuple[str, int], tuple[str, str, str, int]] = {}
    for entry in found:
        innermost[(entry[0], entry[3])] = entry
    return sorted(innermost.values())


def test_no_handler_turns_a_refusal_into_a_boolean():
    found = _handlers_returning_booleans()
    unexplained = [f"{f}:{line} in {fn}(): except {exc} returns a boolean"
                   for f, fn, exc, line in found if (f, fn, exc) not in ALLOWED]
    assert not unexplained, (
        "these handlers answer TRUE/FALSE where the code could not tell; raise (a refusal "
        "with its reason and place) or, where a boolean is right, add the handler to "
        "ALLOWED with why:\n" + "\n".join(unexplained))


def test_every_allowed_handler_still_exists():
    here = {(f, fn, exc) for f, fn, exc, _ in _handlers_returning_booleans()}
    stale = sorted(set(ALLOWED) - here)
    assert not stale, f"no longer in the source, remove from ALLOWED: {stale}"


@pytest.mark.parametrize("source", [
    # the INITIALISATION check of issue 40: a size limit answered "cannot give this state"
    "def _possible(m):\n    try:\n        return m.ok()\n    except EvaluationError:\n"
    "        return False\n",
    "def f():\n    try:\n        pass\n    except (SetLimitError, KeyError) as exc:\n"
    "        if exc:\n            return True\n",
])
def test_the_check_finds_such_a_handler(source, tmp_path):
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "bad.py").write_text(source)
    (entry,) = _handlers_returning_booleans(tmp_path)
    assert entry[0] == "b/bad.py" and (entry[0], entry[1], entry[2]) not in ALLOWED
