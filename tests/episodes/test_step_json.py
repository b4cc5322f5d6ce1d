"""A step message's bytes: the plain path (orjson) writes what the schema (pydantic) writes,
and refuses what it refuses."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from tracecheck.episodes import schema
from tracecheck.episodes.step_json import _plain, step_json


def _pydantic(msg: dict) -> bytes:
    return schema.StepMessage.model_validate(msg).model_dump_json(exclude_none=True).encode()


finite = st.floats(allow_nan=False, allow_infinity=False)
text = st.text(st.characters(blacklist_categories=("Cs",)), max_size=12)
leaf = st.one_of(st.booleans(), st.integers(-2**70, 2**70), finite, text)
value = st.recursive(leaf, lambda inner: st.one_of(
    st.lists(inner, max_size=3), st.dictionaries(text, inner, max_size=3)), max_leaves=8)


@st.composite
def messages(draw):
    msg = {"episode": draw(st.integers(-5, 2**40)), "step": draw(st.integers(0, 10**6)),
           "time": draw(finite)}
    if draw(st.booleans()):
        msg["action"] = draw(text)
    msg["state"] = draw(st.dictionaries(text, value, max_size=4))
    msg["reward"], msg["crashed"] = draw(finite), draw(st.booleans())
    number = st.one_of(finite, st.integers(-2**60, 2**60), st.booleans())
    rows = st.lists(st.one_of(st.lists(number, max_size=3), st.tuples(number, number)),
                    max_size=3)
    optional = {"observation": st.one_of(rows, rows.map(tuple)),
                "action_values": st.dictionaries(text, finite, max_size=3),
                "preferred_action": text,
                "allowed_actions": st.one_of(st.lists(text, max_size=3),
                                             st.lists(text, max_size=3).map(tuple)),
                "shield_time_us": finite, "deadlock": st.booleans()}
    for key, strategy in optional.items():  # in the schema's order
        if draw(st.booleans()):
            msg[key] = draw(strategy)
    return msg


@settings(max_examples=400, deadline=None)
@given(messages())
def test_plain_messages_are_written_as_the_schema_writes_them(msg):
    try:
        expected = _pydantic(msg)
    except ValidationError as exc:  # a bool in an observation, a float beyond 2^53 …
        with pytest.raises(ValidationError) as err:
            step_json(msg)
        assert err.value.errors() == exc.errors()
        return
    assert step_json(msg) == expected


def test_a_recorded_step_takes_the_plain_path():
    msg = {"episode": 3, "step": 1, "time": 1.0, "action": "Move_Right",
           "state": {"x": 0, "y": 1, "field": "{(0|->0|->ICE)}"}, "reward": 0.0,
           "crashed": False, "observation": ((12,),),
           "action_values": {"Move_Up": 0.5, "Move_Right": 0.25},
           "preferred_action": "Move_Up", "allowed_actions": ("Move_Down", "Move_Right"),
           "shield_time_us": 12.5}
    assert _plain(msg) is not None
    assert step_json(msg) == _pydantic(msg)
    assert b'"observation":[[12.0]]' in step_json(msg)


@pytest.mark.parametrize("change", [
    {"time": 1},  # an integer where a float is asked: the schema makes it 1.0
    {"reward": 2},
    {"action": None},  # written as null by orjson, left out by the schema
    {"state": {"x": 2**70}},  # beyond orjson's 64 bits
    {"parameters": {"a": 0.5}, "proposal": {"a": 1.0}, "projection_distance": 0.5,
     "allowed_intervals": {"a": [(None, 0.5)]}},  # a continuous step's fields
    {"observation": [[2 ** 60, 2.0]]},  # an integer no float holds exactly
])
def test_other_messages_go_through_the_schema(change):
    msg = {"episode": 0, "step": 2, "time": 2.0, "action": "LEFT", "state": {"x": 1},
           "reward": 1.5, "crashed": False, **change}
    assert _plain(msg) is None or "state" in change
    assert step_json(msg) == _pydantic(msg)


@pytest.mark.parametrize("change, where", [
    ({"step": -1}, "step"),
    ({"reward": math.nan}, "reward"),
    ({"time": math.inf}, "time"),
    ({"crashed": "maybe"}, "crashed"),
    ({"shield_time_us": math.nan}, "shield_time_us"),
    ({"allowed_actions": ["LEFT", 3]}, "allowed_actions"),
    ({"unknown": 1}, "unknown"),
])
def test_what_the_schema_refuses_is_refused(change, where):
    msg = {"episode": 0, "step": 2, "time": 2.0, "action": "LEFT", "state": {"x": 1},
           "reward": 1.5, "crashed": False, **change}
    with pytest.raises(ValidationError) as err:
        step_json(msg)
    assert err.value.errors()[0]["loc"][0] == where


def test_keys_in_another_order_are_written_in_the_schema_s():
    msg = {"step": 2, "episode": 0, "time": 2.0, "state": {"x": 1}, "action": "LEFT",
           "reward": 1.5, "crashed": False, "allowed_actions": ["LEFT"],
           "observation": [[1.0]]}
    assert _plain(msg) is None
    assert step_json(msg) == _pydantic(msg)
    assert step_json(msg).startswith(b'{"episode":0,"step":2,"time":2.0,"action":"LEFT"')

