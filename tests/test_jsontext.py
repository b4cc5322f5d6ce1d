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
