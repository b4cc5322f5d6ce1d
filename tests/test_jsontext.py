"""Strict JSON: no NaN or Infinity, ever; what was not finite is said beside it."""

from __future__ import annotations

import json

import pytest

from tracecheck.jsontext import finite, json_text, script_json


def _strict(text: str):
    def refuse(name):
        raise AssertionError(f"{name} is not JSON")

    return json.loads(text, parse_constant=refuse)


def test_non_finite_numbers_become_null_with_a_note():
    data = {"a": float("inf"), "b": [1.0, float("-inf"), float("nan")], "c": {"d": float("nan")},
            "e": 2.5, "f": "inf", "g": None}
    assert _strict(json_text(data)) == {
        "a": None, "a_note": "+inf", "b": [1.0, None, None], "b_note": "[1] -inf; [2] nan",
        "c": {"d": None, "d_note": "nan"}, "e": 2.5, "f": "inf", "g": None}
    assert finite([float("inf"), {"x": float("inf")}]) == [None, {"x": None, "x_note": "+inf"}]


def test_a_note_given_where_the_value_was_known_is_kept():
    data = {"robustness": float("inf"), "robustness_note": "+inf: no sample to judge"}
    assert _strict(json_text(data)) == {"robustness": None,
                                        "robustness_note": "+inf: no sample to judge"}


def test_without_the_conversion_json_would_not_be_strict():
    with pytest.raises(ValueError):
        json.dumps({"a": float("inf")}, allow_nan=False)
    assert "Infinity" in json.dumps({"a": float("inf")})  # what print_json used to write


@pytest.mark.parametrize("text", ["</script>", "<!--<script>", "a\u2028b\u2029", "&lt;", ">"])
def test_script_json_cannot_end_or_comment_out_a_script(text):
    out = script_json({"s": text, "n": float("nan")})
    assert not set(out) & set("<>&\u2028\u2029")
    assert _strict(out) == {"s": text, "n": None, "n_note": "nan"}


def test_orjson_and_json_write_the_same_data():
    """orjson writes reports (fast); json only what orjson cannot: integers beyond 64 bits,
    keys that are not strings. The data read back is the same either way."""
    from dataclasses import dataclass

    from tracecheck.jsontext import json_text, plain

    @dataclass(frozen=True)
    class Row:
        name: str
        value: float
        items: tuple

    data = {"rows": plain([Row("a", 1e-7, (1, 2)), Row("é<", float("inf"), ())]),
            "big": 10 ** 30, "nested": {"x": [None, True, 2.5]}}
    text = json_text(data, indent=2)
    assert json.loads(text) == {"rows": [{"name": "a", "value": 1e-07, "items": [1, 2]},
                                         {"name": "é<", "value": None, "value_note": "+inf",
                                          "items": []}],
                                "big": 10 ** 30, "nested": {"x": [None, True, 2.5]}}
    small = {k: v for k, v in data.items() if k != "big"}  # orjson's path
    assert json.loads(json_text(small, indent=2)) == {
        k: v for k, v in json.loads(text).items() if k != "big"}
    assert json_text({"a": [1, 2]}, separators=(",", ":")) == '{"a":[1,2]}'
    assert json_text({1: 2}, indent=2) == '{\n  "1": 2\n}'


# ------------------------------------------------------------------ written a part at a time

from hypothesis import given, settings, strategies as st  # noqa: E402

from tracecheck.jsontext import Rows, write_json  # noqa: E402

_SCALARS = st.one_of(st.none(), st.booleans(), st.integers(-2**70, 2**70), st.floats(),
                     st.text(max_size=5))
_VALUES = st.recursive(_SCALARS, lambda inner: st.one_of(
    st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=3), inner, max_size=3)),
    max_leaves=8)


def _written(data: dict) -> str:
    import io

    out = io.StringIO()
    write_json(data, out)
    return out.getvalue()


@settings(max_examples=300, deadline=None)
@given(st.dictionaries(st.text(max_size=4), st.one_of(_VALUES, st.lists(
    st.dictionaries(st.text(max_size=3), _VALUES, max_size=3), max_size=4)
    .map(lambda items: ("rows", items))), max_size=5))
def test_a_report_written_a_part_at_a_time_is_the_same_text(data):
    """``write_json`` with some values as :class:`Rows` writes exactly the text
    ``json_text(…, indent=2)`` gives for the same data with lists (of objects, as a report's
    rows are): non-finite numbers, notes
    already there, integers beyond 64 bits, empty lists and objects alike."""
    whole = {k: v[1] if isinstance(v, tuple) else v for k, v in data.items()}
    parts = {k: Rows(v[1]) if isinstance(v, tuple) else v for k, v in data.items()}
    text, expected = _written(parts), json_text(whole, indent=2)
    # the same values, keys in the same order (an integer beyond 64 bits has json, not
    # orjson, write its part: 1e-09 where orjson writes 1e-9)
    assert json.loads(text, object_pairs_hook=list) == json.loads(expected,
                                                                  object_pairs_hook=list)
    if "e-0" not in expected and "e+" not in expected:
        assert text == expected


def test_rows_are_made_and_written_a_part_at_a_time(monkeypatch):
    """A list of 1200 items is made 500 at a time, never all at once; each item by ``make``."""
    import tracecheck.jsontext as jsontext

    made, largest = [], []
    original = jsontext.json_text

    def counting(value, **kw):
        if isinstance(value, list):
            largest.append(len(value))
        return original(value, **kw)

    monkeypatch.setattr(jsontext, "json_text", counting)
    text = _written({"episodes": Rows(range(1200), lambda i: made.append(i) or {"i": i,
                                                                                "x": 1 / 3}),
                     "n": float("nan")})
    assert len(made) == 1200 and max(largest) == 500
    assert json.loads(text) == {"episodes": [{"i": i, "x": 1 / 3} for i in range(1200)],
                                "n": None, "n_note": "nan"}
