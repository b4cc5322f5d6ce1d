"""The error hierarchy: one base class, located messages with a caret and a hint."""

from __future__ import annotations

import pytest

from tracecheck import errors as E

CLASSES = [E.BSyntaxError, E.BTypeError, E.BScopeError, E.WellDefinednessError,
           E.EvaluationError, E.UnsupportedError, E.ModelError, E.InputError]


@pytest.mark.parametrize("cls", CLASSES, ids=[c.__name__ for c in CLASSES])
def test_every_error_is_located_and_exits_2(cls):
    err = cls("something is wrong", file="m.mch", line=2, column=3,
              source="first\nab cd\n", hint="do this instead")
    assert isinstance(err, E.TracecheckError) and err.exit_code == 2
    assert str(err) == ("m.mch:2:3: something is wrong\n"
                        "    ab cd\n"
                        "      ^\n"
                        "  hint: do this instead")


def test_location_without_line():
    assert str(E.InputError("bad", file="x.json")) == "x.json: bad"
    assert str(E.InputError("bad")) == "bad"
    assert str(E.BSyntaxError("bad", line=1, column=2)) == "<input>:1:2: bad"


def test_located_fills_in_only_what_is_missing():
    err = E.BSyntaxError("oops", line=1, column=1)
    err.located(file="a.mch", source="xyz")
    err.located(file="b.mch")
    assert err.file == "a.mch" and str(err).startswith("a.mch:1:1: oops\n    xyz\n    ^")


def test_caret_ignores_lines_out_of_range():
    assert E.caret_excerpt("one line", 5, 1) == ""
    assert E.caret_excerpt(None, 1, 1) == ""
