"""ProB's LibraryRegex.def (tracecheck.b.regex): ECMAScript patterns with ProB's documented
answers (the examples of ExternalFunctions.ipynb of hhu-stups/prob2_jupyter_kernel), and
a refusal wherever Python's re and ECMAScript could read a pattern differently."""

from __future__ import annotations

import pytest

from tests.helpers import run


@pytest.mark.parametrize("formula,value", [
    ('REGEX_MATCH("abc","[a-z]+")', "TRUE"),
    ('REGEX_MATCH("abc1","[a-z]+")', "FALSE"),
    ('REGEX_MATCH("123.45","[^a-zA-Z]+")', "TRUE"),
    ('REGEX_MATCH("1e9","[^a-zA-Z]+")', "FALSE"),
    ('IS_REGEX("ab[0-9]")', "TRUE"),
    ('IS_REGEX("ab[0-9")', "FALSE"),
    ('REGEX_REPLACE("a01b23c4d56","[0-9]+","NUM")', '"aNUMbNUMcNUMdNUM"'),
    ('REGEX_REPLACE("a01b23c4d56","[^0-9]+","X")', '"X01X23X4X56"'),
    ('REGEX_REPLACE("1abd00abc2","([a-z]+).*?([a-z]+)","<<$2$1>>")', '"1<<abcabd>>2"'),
    ('REGEX_REPLACE("ab12cd34","[0-9]+","($0)")', '"ab(12)cd(34)"'),
    ('REGEX_SEARCH_STR("abcdef000234daf","[1-9][0-9]*")', '"234"'),
    ('REGEX_SEARCH_STR("abcdef000234daf","[[:alpha:]]+")', '"abcdef"'),
    ('REGEX_SEARCH_STR("abcdef000234daf","[[:alpha:]]+$")', '"daf"'),
    ('REGEX_SEARCH_STR("0123","[[:alpha:]]+")', '""'),
    ('REGEX_SEARCH("abcdef000234daf",7,"[[:alpha:]]+")',
     'rec(length:3,position:13,string:"daf",submatches:∅)'),
    ('REGEX_SEARCH("abcdef000234daf",1,"([1-9])([0-9]*)")',
     'rec(length:3,position:10,string:"234",submatches:{(1↦"2"),(2↦"34")})'),
    ('REGEX_SEARCH("0123",1,"[[:alpha:]]+")',
     'rec(length:-1,position:-1,string:"",submatches:∅)'),
    ('REGEX_SEARCH_ALL("abcdef000234daf567","([1-9])([0-9]*)")', '{(1↦"234"),(2↦"567")}'),
    ('REGEX_SEARCH_ALL("0123","[[:alpha:]]+")', "∅"),
    ('REGEX_SEARCH_ALL("abc-äéà-123","[[:alpha:]]")',
     '{(1↦"a"),(2↦"b"),(3↦"c"),(4↦"ä"),(5↦"é"),(6↦"à")}'),
    ('REGEX_SEARCH("abc-äéà-123",1,"[äüéèà]+")',
     'rec(length:3,position:5,string:"äéà",submatches:∅)'),
    ('REGEX_REPLACE("abc-äéà-123","[äüéèà]+"," ça ")', '"abc- ça -123"'),
    ('REGEX_MATCH("äbc","...")', "TRUE"),
    ('REGEX_MATCH("äbc","abc")', "FALSE"),
    ('REGEX_MATCH("äbc","[[:alpha:]]{3}")', "TRUE"),
    ('REGEX_SEARCH_ALL("The quick fox.","\\w+")', '{(1↦"The"),(2↦"quick"),(3↦"fox")}'),
    ('REGEX_SEARCH_ALL("10234","\\d{1,3}")', '{(1↦"102"),(2↦"34")}'),
    ('REGEX_SEARCH("abc-defg-hi:jkl",1,"[[:alpha:]]+(?=:)")\'string', '"hi"'),
    ('REGEX_SEARCH("abc-defg-hi:jkl",1,"[[:alpha:]]+(?![-a-z])")\'string', '"hi"'),
    ('REGEX_SEARCH("abc-dede-hi:jkl",1,"([[:alpha:]]+)\\1")\'string', '"dede"'),
    # ECMAScript's $ is the end of the string, never before a final newline (Python's $)
    ('REGEX_MATCH("ab\\n","ab$")', "FALSE"),
    # . is not a line terminator
    ('REGEX_MATCH("a\\rb","a.b")', "FALSE"),
    ('REGEX_MATCH("-5", "[-[:digit:]]+")', "TRUE"),  # a '-' first in a class is itself
    ('IS_REGEX("*a")', "FALSE"),  # nothing to repeat
    ('REGEX_MATCH("a b", "a\\sb")', "TRUE"),
], ids=lambda v: v if len(v) < 40 else v[:40])
def test_prob_s_documented_answers(capsys, formula, value):
    assert run(capsys, "eval", "--timeout", "2", formula) == (0, value + "\n", "")


@pytest.mark.parametrize("formula,why", [
    ('REGEX_SEARCH("abc-defg-hi:jkl",1,"[[:alpha:]]+(?<=:)")', "lookbehind"),
    ('REGEX_SEARCH_ALL("äb","\\w+")', "\\w on a string with characters beyond ASCII"),
    ('REGEX_REPLACE("abc","x*","-")', "matches the empty string"),
    ('REGEX_MATCH("ab","(?P<x>a)b")', "the group '(?P'"),
    ('REGEX_REPLACE("ab","a","$x")', "$ followed by 'x'"),
    ('REGEX_MATCH("a{","a{")', "a '{' that is not a quantifier"),
    ('REGEX_SEARCH("ab",2,"^b")', "^ or \\b in a search that does not start"),
    # found by review: each read differently by Python's re and by ECMAScript
    ('REGEX_MATCH("A", "[[:digit:]-a]")', "a range with a class of characters at one end"),
    ('REGEX_MATCH("5", "[0-[:digit:]]")', "a range with a class of characters at one end"),
    ('REGEX_MATCH("x", "[\\d-z]")', "a range with a class of characters at one end"),
    ('REGEX_MATCH("b", "(a)?\\1b")', "\\1 refers to a group that may take part in no match"),
    ('REGEX_MATCH("b", "(?:(a)|b)\\1")', "\\1 refers to a group"),
    ('REGEX_MATCH("ab", "(?!(a))\\1ab")', "\\1 refers to a group"),
    ('REGEX_MATCH("aa", "a*+a")', "a quantifier right after a quantifier"),
    ('IS_REGEX("a++")', "a quantifier right after a quantifier"),
    ('REGEX_MATCH("a","a{4294967295}")', "a repetition count or nesting too large"),
    ('REGEX_MATCH("aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa!", "(a|aa)*b")',
     "its matching can take exponential time"),
    # catastrophic backtracking without a repeated group (they ran past any timeout)
    ('REGEX_MATCH("' + "a" * 40 + '", "' + "a?" * 40 + "a" * 40 + '")',
     "a pattern with 40 repetitions of variable width (a search's start counts as one), on "
     "a string of 40 characters, can take about 41^40 steps"),
    ('REGEX_MATCH("' + "abc" * 13 + '", "' + ".*" * 8 + 'x")',
     "a pattern with 8 repetitions of variable width"),
    ('REGEX_SEARCH("ab",1,"(?:(a)|b)c")', "submatches of a group that may take part in no"),
    ('REGEX_REPLACE("ab","(a)?b","$1")', "$1 names a group that may take part in no match"),
], ids=["lookbehind", "unicode-w", "empty-match", "python-group", "dollar", "brace", "anchor",
        "class-range", "range-class", "d-range", "optional-ref", "branch-ref", "lookahead-ref",
        "possessive", "possessive-is", "huge-count", "exponential", "optional-40",
        "dot-star-8", "branch-submatch",
        "optional-replace"])
def test_what_could_be_read_differently_is_refused(capsys, formula, why):
    code, out, err = run(capsys, "eval", formula)
    assert code == 2 and out == "" and "not supported: " in err and why in err, err


def test_a_pattern_that_is_no_regular_expression_has_no_value(capsys):
    code, out, err = run(capsys, "eval", 'REGEX_MATCH("a","a(")')
    assert code == 2 and "not a regular expression: an unclosed '('" in err


def test_in_a_machine_as_prob_s_def_file_brings_them(capsys, tmp_path):
    model = tmp_path / "R.mch"
    model.write_text('MACHINE R\nDEFINITIONS "LibraryRegex.def"; "LibraryProB.def"\nEND\n')
    assert run(capsys, "eval", "-m", model, 'REGEX_MATCH("abc","[a-c]+")',
               '1+ASSERT_EXPR(bool(2>1),"err",3)', "FORCE({1,2})") == \
        (0, "TRUE\n4\n{1,2}\n", "")
    code, out, err = run(capsys, "eval", "-m", model, 'ASSERT_EXPR(bool(2<1),"too small",3)')
    assert code == 2 and "the assertion failed: too small" in err


def test_ecmascript_s_whitespace_is_not_python_s():
    """Python's \\s also takes U+001C..U+001F (found by review): ECMAScript's does not."""
    from tracecheck.b.regex import _match

    assert not _match("\x1c", "\\s") and _match(" ", "\\s") and _match("\x1f", "\\S")


def test_strings_read_in_prob_s_notation_keep_unknown_escapes():
    """ProB prints the two characters backslash and a as "\\a" (not an escape): read back,
    they are those two characters, as B's string literals read them."""
    from tracecheck.b.notation import parse_literal

    assert parse_literal('"\\a"') == "\\a" and parse_literal('"(\\d+)"') == "(\\d+)"
    assert parse_literal('"\\\\\\""') == '\\"' and parse_literal('"x\\ny"') == "x\ny"


def test_a_few_repetitions_on_ordinary_strings_still_match(capsys):
    code, out, _ = run(capsys, "eval", 'REGEX_MATCH("john@example.com", '
                                       '"^[a-z]+@[a-z]+\\.[a-z]+$")')
    assert (code, out.strip()) == (0, "TRUE")
    code, out, _ = run(capsys, "eval", 'REGEX_MATCH("' + "a" * 400 + '", "a{400}")')
    assert (code, out.strip()) == (0, "TRUE")  # a fixed count is no choice to backtrack


def test_a_fixed_count_is_no_repetition_to_backtrack(capsys):
    code, out, err = run(capsys, "eval", 'REGEX_MATCH("' + "1" * 1000 + '", '
                                         '"[0-9]{4}-[0-9]{2}-[0-9]{2}")')
    assert (code, out.strip()) == (0, "FALSE"), err


def test_a_search_counts_its_start_and_a_replacement_its_size(capsys):
    """`.*b` tried from each of 60 000 positions took 7 s (Python's re cannot be stopped);
    4000 replacements of a 60 000-character `$&` built 240 M characters."""
    code, _, err = run(capsys, "eval", 'REGEX_SEARCH_STR("' + "a" * 60000 + '", ".*b")')
    assert code == 2 and "a pattern with 2 repetitions of variable width (a search's start " \
        "counts as one), on a string of 60000 characters" in " ".join(err.split())
    code, out, _ = run(capsys, "eval", 'REGEX_SEARCH_STR("' + "a" * 500 + 'b", ".*b")')
    assert code == 0 and out.strip() == '"' + "a" * 500 + 'b"'
    big = "x" * 60000
    code, _, err = run(capsys, "eval", f'REGEX_REPLACE("{"a" * 4000}", "a", "{big}")')
    assert code == 2 and "REGEX_REPLACE would build a string of over 16,777,216 characters" \
        in " ".join(err.split())
