"""The grammar: one case per construct, in ASCII and Unicode, and located syntax errors."""

from __future__ import annotations

import pytest

from tracecheck.b import ast as A
from tracecheck.b.parser import parse_formula, parse_machine_source, parse_substitution
from tracecheck.errors import BSyntaxError

x, y, S, f = A.Name("x"), A.Name("y"), A.Name("S"), A.Name("f")
one, two = A.IntLit(1), A.IntLit(2)

FORMULAS = [
    ("x & y", A.And(x, y)),
    ("x ∧ y", A.And(x, y)),
    ("x or y", A.Or(x, y)),
    ("x ∨ y", A.Or(x, y)),
    ("x => y", A.Implies(x, y)),
    ("x ⇒ y", A.Implies(x, y)),
    ("x <=> y", A.Equiv(x, y)),
    ("x ⇔ y", A.Equiv(x, y)),
    ("not(x)", A.Not(x)),
    ("¬x", A.Not(x)),
    ("x = 1", A.Rel("=", x, one)),
    ("x /= 1", A.Rel("/=", x, one)),
    ("x ≠ 1", A.Rel("/=", x, one)),
    ("x < 1", A.Rel("<", x, one)),
    ("x <= 1", A.Rel("<=", x, one)),
    ("x ≤ 1", A.Rel("<=", x, one)),
    ("x > 1", A.Rel(">", x, one)),
    ("x >= 1", A.Rel(">=", x, one)),
    ("x ≥ 1", A.Rel(">=", x, one)),
    ("x : S", A.Rel(":", x, S)),
    ("x ∈ S", A.Rel(":", x, S)),
    ("x /: S", A.Rel("/:", x, S)),
    ("x ∉ S", A.Rel("/:", x, S)),
    ("x <: S", A.Rel("<:", x, S)),
    ("x ⊆ S", A.Rel("<:", x, S)),
    ("x <<: S", A.Rel("<<:", x, S)),
    ("x ⊂ S", A.Rel("<<:", x, S)),
    ("x /<: S", A.Rel("/<:", x, S)),
    ("x /<<: S", A.Rel("/<<:", x, S)),
    ("!x.(x : S => x > 1)", A.Quant("!", ("x",), A.Implies(A.Rel(":", x, S), A.Rel(">", x, one)))),
    ("∀x·(x ∈ S ⇒ x > 1)", A.Quant("!", ("x",), A.Implies(A.Rel(":", x, S), A.Rel(">", x, one)))),
    ("#x.(x : S)", A.Quant("#", ("x",), A.Rel(":", x, S))),
    ("∃x·(x ∈ S)", A.Quant("#", ("x",), A.Rel(":", x, S))),
    ("#(x,y).(x : S & y : S)", A.Quant("#", ("x", "y"), A.And(A.Rel(":", x, S), A.Rel(":", y, S)))),
    ("bool(x = 1)", A.Call("bool", (A.Rel("=", x, one),))),
    ("TRUE", A.BoolLit(True)),
    ("FALSE", A.BoolLit(False)),
    ("1.5", A.RealLit(1.5)),
    ('"text"', A.StrLit("text")),
    ("x + 1", A.BinOp("+", x, one)),
    ("x - 1", A.BinOp("-", x, one)),
    ("x * 1", A.BinOp("*", x, one)),
    ("x / 1", A.BinOp("/", x, one)),
    ("x mod 2", A.BinOp("mod", x, two)),
    ("x ** 2", A.BinOp("**", x, two)),
    ("-x", A.Neg(x)),
    ("min(S)", A.Call("min", (S,))),
    ("max(S)", A.Call("max", (S,))),
    ("card(S)", A.Call("card", (S,))),
    ("dom(f)", A.Call("dom", (f,))),
    ("ran(f)", A.Call("ran", (f,))),
    ("f(x)", A.Apply(f, (x,))),
    ("f(x, y)", A.Apply(f, (x, y))),
    ("f[S]", A.Image(f, S)),
    ("f~", A.Inverse(f)),
    ("{}", A.SetExt(())),
    ("∅", A.SetExt(())),
    ("{1, 2}", A.SetExt((one, two))),
    ("1..2", A.BinOp("..", one, two)),
    ("{x | x : S}", A.Comprehension(("x",), A.Rel(":", x, S))),
    ("{x, y | x : S & y = x}", A.Comprehension(("x", "y"), A.And(A.Rel(":", x, S), A.Rel("=", y, x)))),
    ("{x·x : S | x + 1}", A.Comprehension(("x",), A.Rel(":", x, S), A.BinOp("+", x, one))),
    ("{x•x : S | x + 1}", A.Comprehension(("x",), A.Rel(":", x, S), A.BinOp("+", x, one))),
    ("{x.x : S | x + 1}", A.Comprehension(("x",), A.Rel(":", x, S), A.BinOp("+", x, one))),
    ("S \\/ S", A.BinOp("\\/", S, S)),
    ("S ∪ S", A.BinOp("\\/", S, S)),
    ("S /\\ S", A.BinOp("/\\", S, S)),
    ("S ∩ S", A.BinOp("/\\", S, S)),
    ("S \\ S", A.BinOp("\\", S, S)),
    ("S ∖ S", A.BinOp("\\", S, S)),
    ("S * S", A.BinOp("*", S, S)),
    ("S × S", A.BinOp("*", S, S)),
    ("POW(S)", A.Call("POW", (S,))),
    ("ℙ(S)", A.Call("POW", (S,))),
    ("BOOL", A.Name("BOOL")),
    ("INTEGER", A.Name("INTEGER")),
    ("ℤ", A.Name("INTEGER")),
    ("NATURAL", A.Name("NATURAL")),
    ("ℕ", A.Name("NATURAL")),
    ("REAL", A.Name("REAL")),
    ("ℝ", A.Name("REAL")),
    ("S --> S", A.BinOp("-->", S, S)),
    ("S → S", A.BinOp("-->", S, S)),
    ("S +-> S", A.BinOp("+->", S, S)),
    ("S ⇸ S", A.BinOp("+->", S, S)),
    ("x |-> y", A.Pair(x, y)),
    ("x ↦ y", A.Pair(x, y)),
    ("(x, y)", A.Pair(x, y)),
    ("%x.(x : S | x)", A.Lambda(("x",), A.Rel(":", x, S), x)),
    ("λx·(x ∈ S | x)", A.Lambda(("x",), A.Rel(":", x, S), x)),
    ("IF x THEN 1 ELSE 2 END", A.IfExpr(((x, one),), two)),
    ("IF x THEN 1 ELSIF y THEN 2 ELSE x END", A.IfExpr(((x, one), (y, two)), x)),
    ("LET x BE x = 1 IN x END", A.Let(("x",), A.Rel("=", x, one), x)),
    ("SIGMA(x).(x : S | x)", A.QuantExpr("SIGMA", ("x",), A.Rel(":", x, S), x)),
    ("∑(x)·(x ∈ S | x)", A.QuantExpr("SIGMA", ("x",), A.Rel(":", x, S), x)),
    ("PI(x).(x : S | x)", A.QuantExpr("PI", ("x",), A.Rel(":", x, S), x)),
    ("floor(x)", A.Call("floor", (x,))),
    ("ceiling(x)", A.Call("ceiling", (x,))),
    ("real(x)", A.Call("real", (x,))),
    ("RSQRT(x)", A.Call("RSQRT", (x,))),
    ("RABS(x)", A.Call("RABS", (x,))),
    ("x' > x$0", A.Rel(">", A.Name("x'"), A.Name("x$0"))),
]


@pytest.mark.parametrize("text,expected", FORMULAS, ids=[t for t, _ in FORMULAS])
def test_formula(text, expected):
    assert parse_formula(text) == expected


PRECEDENCE = [
    ("x & y or x", A.Or(A.And(x, y), x)),  # & and or share a level, left to right
    ("x => y => x", A.Implies(A.Implies(x, y), x)),  # => is left-associative in B
    ("x & y => x", A.Implies(A.And(x, y), x)),
    ("x = 1 & y = 2", A.And(A.Rel("=", x, one), A.Rel("=", y, two))),
    ("1 + 2 * x", A.BinOp("+", one, A.BinOp("*", two, x))),
    ("1 - 2 - x", A.BinOp("-", A.BinOp("-", one, two), x)),
    ("2 ** 1 ** 2", A.BinOp("**", two, A.BinOp("**", one, two))),
    ("-x ** 2", A.BinOp("**", A.Neg(x), two)),  # ProB: unary minus (210) binds tighter than ** (200)
    ("x |-> 1 + 2", A.Pair(x, A.BinOp("+", one, two))),
    ("S \\/ S --> S", A.BinOp("-->", A.BinOp("\\/", S, S), S)),
    ("1..x + 1", A.BinOp("..", one, A.BinOp("+", x, one))),
    ("not(x) & y", A.And(A.Not(x), y)),
    ("(1, 2, x)", A.Pair(A.Pair(one, two), x)),
]


@pytest.mark.parametrize("text,expected", PRECEDENCE, ids=[t for t, _ in PRECEDENCE])
def test_precedence(text, expected):
    assert parse_formula(text) == expected


SUBSTITUTIONS = [
    ("x := 1", A.Assign((x,), (one,))),
    ("x, y := 1, 2", A.Assign((x, y), (one, two))),
    ("f(x) := 1", A.Assign((A.Apply(f, (x,)),), (one,))),
    ("x :: S", A.BecomesIn(("x",), S)),
    ("x :∈ S", A.BecomesIn(("x",), S)),
    ("x : (x > x')", A.BecomesSuchThat(("x",), A.Rel(">", x, A.Name("x'")))),
    ("x :| (x > x$0)", A.BecomesSuchThat(("x",), A.Rel(">", x, A.Name("x$0")))),
    ("x := 1 || y := 2", A.Parallel((A.Assign((x,), (one,)), A.Assign((y,), (two,))))),
    ("x := 1 ; y := 2", A.Sequence((A.Assign((x,), (one,)), A.Assign((y,), (two,))))),
    ("skip", A.Skip()),
    ("BEGIN skip END", A.Skip()),
    ("PRE x THEN skip END", A.Pre(x, A.Skip())),
    ("SELECT x THEN skip WHEN y THEN skip ELSE skip END",
     A.Select(((x, A.Skip()), (y, A.Skip())), A.Skip())),
    ("ANY y WHERE y : S THEN x := y END", A.Any(("y",), A.Rel(":", y, S), A.Assign((x,), (y,)))),
    ("IF x THEN skip ELSIF y THEN skip ELSE skip END",
     A.IfSubst(((x, A.Skip()), (y, A.Skip())), A.Skip())),
    ("LET y BE y = 1 IN x := y END", A.LetSubst(("y",), A.Rel("=", y, one), A.Assign((x,), (y,)))),
    ("CHOICE x := 1 OR x := 2 END", A.Choice((A.Assign((x,), (one,)), A.Assign((x,), (two,))))),
]


@pytest.mark.parametrize("text,expected", SUBSTITUTIONS, ids=[t for t, _ in SUBSTITUTIONS])
def test_substitution(text, expected):
    assert parse_substitution(text) == expected


def test_positions_are_kept_but_not_compared():
    node = parse_formula("  x + 1")
    assert node == A.BinOp("+", x, one)
    assert (node.pos.line, node.pos.column) == (1, 3)
    assert node.left.pos.column == 3 and node.right.pos.column == 7


@pytest.mark.parametrize("text,line,col,fragment", [
    ("x + > 2", 1, 5, "unexpected '>'; expected a predicate or expression"),
    ("x + 2 &", 1, 8, "unexpected end of the formula"),
    ("x $ 2", 1, 3, "unexpected character '$'"),
    ("{x + 1 | x : S}", 1, 2, "must be names"),
    ("f(1\n  & )", 2, 5, "unexpected ')'"),
], ids=["operator", "end", "character", "comprehension-binder", "second-line"])
def test_syntax_errors_are_located(text, line, col, fragment):
    with pytest.raises(BSyntaxError) as info:
        parse_formula(text)
    err = info.value
    assert (err.line, err.column) == (line, col)
    assert fragment in err.message
    rendered = str(err)
    assert "^" in rendered and rendered.splitlines()[-1].index("^") == col + 3


def test_assignment_arity_is_checked():
    with pytest.raises(BSyntaxError, match=r"2 variable\(s\) on the left of ':=' but 1 value"):
        parse_substitution("x, y := 1")


MACHINE = """/* header comment */
MACHINE M
SETS Colour = {red, green}; Thing
CONSTANTS c /*@desc "a constant" */
PROPERTIES c = 3
DEFINITIONS
    double(a) == a * 2;
    VISB_JSON_FILE == "vis.json";
    ANIMATION_FUNCTION == {(1 |-> 2) |-> }  // tools only: may use syntax we do not read
VARIABLES v /*@desc "the value" */, w
INVARIANT v : INTEGER & w : Colour
ASSERTIONS v >= 0; w : Colour
INITIALISATION v := 0 || w := red
OPERATIONS
    inc = PRE v < 10 THEN v := double(v) + 1 END;
    out <-- get = BEGIN out := v END;
    set(n) = PRE n : 0..5 THEN v := n END
END
"""


def test_machine_clauses():
    src = parse_machine_source(MACHINE, file="M.mch")
    assert src.name == "M"
    assert [(n, e) for n, e, _ in src.sets] == [("Colour", ("red", "green")), ("Thing", None)]
    assert [n for n, _ in src.constants] == ["c"]
    assert [n for n, _ in src.variables] == ["v", "w"]
    assert len(src.assertions) == 2
    assert set(src.definitions) == {"double", "VISB_JSON_FILE", "ANIMATION_FUNCTION"}
    assert src.definitions["double"].params == ("a",)
    assert src.definitions["VISB_JSON_FILE"].kind == "string"
    assert src.definitions["ANIMATION_FUNCTION"].kind == "unparsed"
    ops = {op.name: op for op in src.operations}
    assert ops["get"].outputs == ("out",) and ops["set"].params == ("n",)
    descs = [src.description_after(p) for _, p in src.constants + src.variables]
    assert descs == ["a constant", "the value", None]


@pytest.mark.parametrize("text,fragment", [
    ("", "the file is empty"),
    ("MACHINE M VARIABLES x INVARIANT x : BOOL", "does not end with END"),
    ("SYSTEM M END", "SYSTEM is not supported"),
    ("MACHINE M REFINES N END", "the clause REFINES is not supported"),
    ("MACHINE M VARIABLES x VARIABLES y END", "the clause VARIABLES appears twice"),
    ("MACHINE M DEFINITIONS d = 1 END", "needs '==' after its name"),
    ("MACHINE M DEFINITIONS d == 1; d == 2 END", "the definition d appears twice"),
    ("MACHINE M DEFINITIONS d == 1 + END", "unexpected end of the definition d"),
    ("MACHINE M OPERATIONS a = skip; a = skip END", "the operation a is defined twice"),
    ("MACHINE M INVARIANT END", "the INVARIANT clause is empty"),
    ("hello", "a machine starts with MACHINE"),
])
def test_machine_syntax_errors(text, fragment):
    with pytest.raises(BSyntaxError) as info:
        parse_machine_source(text, file="bad.mch")
    assert fragment in info.value.message
    assert info.value.file == "bad.mch"


def test_the_grammar_cache_is_private(tmp_path, monkeypatch):
    """Lark's cache files are pickles: kept only in a folder of this user's that no one else
    can write, never in the shared temporary folder."""
    import os

    from tracecheck.b.parser import grammar_cache

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv("TRACECHECK_NO_CACHE", raising=False)
    path = grammar_cache("parser")
    assert path and path.startswith(str(tmp_path / "tracecheck"))
    assert (tmp_path / "tracecheck").stat().st_mode & 0o777 == 0o700
    os.chmod(tmp_path / "tracecheck", 0o777)
    assert grammar_cache("parser") is False
    os.chmod(tmp_path / "tracecheck", 0o700)
    with open(path, "wb") as f:
        f.write(b"planted")
    os.chmod(path, 0o666)
    assert grammar_cache("parser") is False
    os.chmod(path, 0o600)
    assert grammar_cache("parser") == path
    monkeypatch.setenv("TRACECHECK_NO_CACHE", "1")
    assert grammar_cache("parser") is False


def test_a_formula_longer_than_the_limit_is_refused_before_it_is_lexed():
    """A 1.5 MB predicate from a script was parsed whole (800 MB) before the nesting limit
    refused it; now its length is checked first, in no time."""
    import time

    from tracecheck.b.parser import MAX_FORMULA_CHARS, parse_substitution

    text = "x = 1 & " * (MAX_FORMULA_CHARS // 8) + "x = 1"
    start = time.perf_counter()
    with pytest.raises(BSyntaxError, match=f"the formula is {len(text):,} characters long; "
                                           f"tracecheck reads formulas of up to "
                                           f"{MAX_FORMULA_CHARS:,} characters"):
        parse_formula(text, file="script")
    assert time.perf_counter() - start < 0.5
    with pytest.raises(BSyntaxError, match="the substitution is"):
        parse_substitution("x := 1 || " * (MAX_FORMULA_CHARS // 10) + "x := 1")
    assert parse_formula("x = 1 & " * 1000 + "x = 1")  # long, but within both limits


def test_the_us_spelling_initialization_is_the_initialisation():
    """Issue 42: `INITIALIZATION` was refused as an unsupported clause telling the user to
    put everything into one machine."""
    from tracecheck.b.machine import load_machine_text

    text = ("MACHINE M\nVARIABLES x\nINVARIANT x : 0..3\nINITIALIZATION x := 2\n"
            "OPERATIONS Up = SELECT x < 3 THEN x := x + 1 END\nEND")
    m = load_machine_text(text)
    assert m.initialisation == load_machine_text(
        text.replace("INITIALIZATION", "INITIALISATION")).initialisation
    with pytest.raises(BSyntaxError, match="the clause INITIALISATION appears twice"):
        load_machine_text(text.replace("OPERATIONS", "INITIALISATION x := 1\nOPERATIONS"))
