"""Property files, mutated at random: wrong types, missing and unknown keys, odd strings and
names, huge numbers, bad formulas, broken TOML. Through the `stats` command, every file gives
the intact answer (the entries the mutation did not touch keep their statistics, and the JSON
is strict) or exit 2 with `error:` naming the file — never another exception, never a hang.
(Like tests/episodes/test_fuzz.py for run files.)"""

from __future__ import annotations

import json
import math

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from tests.helpers import run, strict_json

#: a valid file using every kind of entry: aggregates, an estimate, tests, LTL and STL
INTACT = {
    "metrics": {
        "n": {"aggregate": "steps", "description": "Episode length"},
        "avg": {"expression": "Reward", "aggregate": "average",
                "estimate": {"value": 1.0, "epsilon": 0.5}},
        "low": {"expression": "VehiclesX(EgoVehicle)", "aggregate": "min"},
        "margin": {"expression": "G({VehiclesX(EgoVehicle) >= 90.0})", "aggregate": "stl"},
    },
    "properties": {
        "never_crash": {"predicate": "Crash = FALSE", "test": {"p": 0.9, "alpha": 0.05}},
        "far": {"predicate": "VehiclesX(EgoVehicle) > 120.0", "kind": "eventually"},
        "ltl": {"predicate": "G({Crash = FALSE})", "kind": "ltl"},
        "stl": {"predicate": "F[0,2]({VehiclesX(EgoVehicle) > 120.0})", "kind": "stl"},
    },
}

FORMULAS = ["", " ", "Crash = ", "Crash", "Reward + 1", "1 / 0 = 1", "Reward > 1", "{Crash}",
            "G({Crash = FALSE}", "G[0,99999999999999999999] true",
            "G[0,100000000]({VehiclesX(EgoVehicle) > 0.0})", "F[5,2] true", "X({Reward > 0.0})",
            "G(" * 250 + "true" + ")" * 250, "[FASTER]", "e(NOPE)", "Speed > 1.0",
            "VehiclesX(Nobody) > 1.0", "card(INTEGER) > 1", "2 ** 100000 > 1",
            "Reward = 1.0e308 * 10.0", "#v.(v : PresentVehicles & VehiclesX(v) > 0.0)"]
WORDS = ["steps", "average", "sum", "sum_between_steps", "min", "max", "return", "stl", "ltl",
         "invariant", "eventually", "final", "left", "right", "two", "median"]
KEYS = ["expression", "aggregate", "estimate", "description", "predicate", "kind", "test",
        "value", "epsilon", "p", "alpha", "tail", "agregate", "metrics", "properties"]

text = st.text(st.characters(exclude_categories=("Cs",)), max_size=12)
scalars = st.one_of(
    st.booleans(), st.integers(-10, 10), st.integers(),
    st.sampled_from([2 ** 63, -2 ** 63 - 1, 10 ** 30, 10 ** 400]),
    st.floats(allow_nan=True, allow_infinity=True), text, st.sampled_from(FORMULAS + WORDS))
values = st.one_of(scalars, st.lists(scalars, max_size=3),
                   st.dictionaries(st.one_of(st.sampled_from(KEYS), text), scalars, max_size=3))
names = st.one_of(st.sampled_from(["n", "avg", "low", "far", "x", "", "a\x00b", "\x1b[2J",
                                   "a/../b", "$\\frac{1}$", "<script>", "=1+1"]), text)


def toml(value) -> str:
    """``value`` as TOML: the document is one line per key, tables inline."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") \
            if math.isinf(value) else repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # JSON's escapes are TOML's
    if isinstance(value, list):
        return "[" + ", ".join(toml(v) for v in value) + "]"
    return "{ " + ", ".join(f"{json.dumps(k, ensure_ascii=False)} = {toml(v)}"
                            for k, v in value.items()) + " }"


def document(data: dict) -> str:
    return "".join(f"{json.dumps(k, ensure_ascii=False)} = {toml(v)}\n" for k, v in data.items())


@st.composite
def mutations(draw):
    """(TOML text, the (section, name) entries the mutation touched; None: any of them)."""
    data = json.loads(json.dumps(INTACT))
    section = draw(st.sampled_from(["metrics", "properties"]))
    name = draw(st.sampled_from(sorted(data[section])))
    entry = data[section][name]
    kind = draw(st.sampled_from(["set", "set", "set", "describe", "describe", "delete", "add",
                                 "nested", "rename", "entry", "section", "top", "text"]))
    touched = {(section, name)}
    if kind == "describe":  # text that must reach every format as text
        entry["description"] = draw(st.one_of(names, text))
    elif kind == "set":
        entry[draw(st.sampled_from(sorted(entry)))] = draw(values)
    elif kind == "delete":
        del entry[draw(st.sampled_from(sorted(entry)))]
    elif kind == "add":
        entry[draw(st.one_of(st.sampled_from(KEYS), text))] = draw(values)
    elif kind == "nested":
        inner = entry.setdefault(draw(st.sampled_from(["estimate", "test"])), {})
        if isinstance(inner, dict):
            inner[draw(st.sampled_from(KEYS))] = draw(values)
    elif kind == "rename":
        new = draw(names)
        data[section][new] = data[section].pop(name)
        touched |= {(s, new) for s in ("metrics", "properties")}
    elif kind == "entry":
        data[section][name] = draw(values)
    elif kind == "section":
        data[section] = draw(values)
        touched = None
    elif kind == "top":
        data[draw(st.one_of(st.sampled_from(KEYS), text))] = draw(values)
        touched = None
    source = document(data)
    if kind == "text":  # broken TOML: cut, or a character put in
        at = draw(st.integers(0, len(source)))
        source = source[:at] + draw(st.sampled_from(["", "\x00", "\"", "[", "=", "\n", "{"]))
        touched = None
    return source, touched


def _entries(data: dict) -> dict:
    r = data["runs"][0]
    return {**{("metrics", k): v for k, v in r["metrics"].items()},
            **{("properties", k): v for k, v in r["properties"].items()}}


@settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
@given(case=mutations())
def test_mutated_property_files_give_the_intact_answer_or_exit_2(capsys, hand_run, tmp_path,
                                                                 reference, case):
    source, touched = case
    path = tmp_path / "props.toml"
    path.write_text(source, encoding="utf-8")
    code, out, err = run(capsys, "stats", str(hand_run), "-p", str(path), "--json")
    event(f"exit {code}" + ("" if touched is None else " (entries compared)"))
    if code == 2:
        assert err.startswith("error: ") and "Traceback" not in err, err
        assert str(path) in err or "nested too deeply" in err, err
        return
    assert code == 0, (code, err)
    got = _entries(strict_json(out))
    for key, value in reference.items():
        if touched is not None and key not in touched and key in got:
            assert got[key] == value, (key, source)
    if touched is not None:  # nothing else appeared, nothing untouched went missing
        assert {k for k in reference if k not in touched} <= set(got), source
    for fmt in ("csv", "md", "text"):
        code, _, err = run(capsys, "stats", str(hand_run), "-p", str(path), "--format", fmt)
        assert code == 0, err


@pytest.fixture(scope="module")
def reference(hand_run, tmp_path_factory):
    """The intact file's statistics, entry by entry, as `stats --json` prints them."""
    from tracecheck.jsontext import json_text
    from tracecheck.stats.estimates import statistics
    from tracecheck.stats.properties import load_properties

    path = tmp_path_factory.mktemp("fuzz") / "props.toml"
    path.write_text(document(INTACT), encoding="utf-8")
    return _entries(strict_json(json_text(statistics([hand_run], load_properties(path)))))


def test_the_intact_file_is_accepted_and_complete(reference):
    assert sorted(reference) == sorted(
        [(s, n) for s in ("metrics", "properties") for n in INTACT[s]])
    assert reference[("metrics", "margin")]["mean"] == 10.0


def test_a_formula_without_a_value_names_its_property_file(capsys, hand_run, tmp_path):
    """Found by the fuzz test above: an overflow named the run's state, not the property."""
    path = tmp_path / "props.toml"
    path.write_text('[properties.p]\npredicate = "Reward = 1.0e308 * 10.0"\n', encoding="utf-8")
    code, out, err = run(capsys, "stats", str(hand_run), "-p", str(path), "--json")
    assert code == 2 and out == ""
    assert err.startswith(f"error: {path}: property p:1:10: {hand_run}, episode 0, step 0: "
                          "the real result is out of range (overflow)"), err
