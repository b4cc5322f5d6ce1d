"""A step message as the bytes a run file keeps: the JSON of
:class:`~tracecheck.episodes.schema.StepMessage`, validated.

Recording writes one such message per step, and pydantic's validation and serialisation were
a tenth of recording a grid world. A step whose fields all have the plain types the schema
asks for (an ``int`` episode and step, finite ``float`` time and reward, a ``bool`` crash,
the common optional fields of a discrete step, an observation of numbers) needs no coercion
but an observation's integers made floats, so its checks are a few type tests here and its
bytes are orjson's — the same bytes as pydantic's, which a test
compares on generated messages. Anything else (an integer where a float is asked, the
fields of a continuous step, a value orjson cannot write) goes through the schema as before,
with its errors.
"""

from __future__ import annotations

import math
from typing import Any, Optional

import orjson

from . import schema

__all__ = ["step_json"]

_FLOAT = float
_INF = math.inf
_SEQUENCE = (list, tuple)
_EXACT = 2 ** 53  # the integers a float holds exactly
_BASE = frozenset({"episode", "step", "time", "action", "state", "reward", "crashed"})
#: the optional fields of a discrete live step checked here (:func:`_simple`), beside its
#: observation; any other optional field sends the message through the schema
_SIMPLE = frozenset({"action_values", "preferred_action", "allowed_actions", "shield_time_us",
                     "deadlock"})
#: each field's place in the schema (the order pydantic writes them in)
_RANK = {name: i for i, name in enumerate(schema.StepMessage.model_fields)}


def step_json(msg: dict[str, Any]) -> bytes:
    """The JSON of the step message ``msg``: its fields in the schema's order, None fields
    left out, validated by the schema (a ``msg`` whose keys are in another order is written
    by the schema).

    Raises:
        pydantic.ValidationError: where the schema refuses it.
        pydantic_core.PydanticSerializationError: where it cannot be written.
    """
    plain = _plain(msg)
    if plain is not None:
        try:
            return orjson.dumps(plain)
        except TypeError:  # an integer beyond 64 bits, a lone surrogate: the schema says
            pass
    return schema.StepMessage.model_validate(msg).model_dump_json(exclude_none=True).encode()


def _plain(msg: dict[str, Any]) -> Optional[dict[str, Any]]:
    """``msg`` as the schema makes it, where that is what orjson writes as the schema does
    (None: ask the schema)."""
    get = msg.get
    time, reward, step, state = get("time"), get("reward"), get("step"), get("state")
    if not (type(get("episode")) is int and type(step) is int and step >= 0
            and type(time) is _FLOAT and -_INF < time < _INF
            and type(reward) is _FLOAT and -_INF < reward < _INF
            and type(get("crashed")) is bool and type(state) is dict):
        return None
    for k in state:
        if type(k) is not str:
            return None
    out, rank = msg, -1
    for key, value in msg.items():
        was, rank = rank, _RANK.get(key, -2)
        if rank <= was:  # not in the schema's order (or not in it: refused there)
            return None
        if key in _BASE:
            if key == "action" and type(value) is not str:
                return None  # None: left out by the schema, written as null by orjson
        elif key == "observation":
            rows = _rows(value)
            if rows is None:
                return None
            out = dict(msg, observation=rows)
        elif key not in _SIMPLE or not _simple(key, value):
            return None
    return out


def _rows(observation: Any) -> Optional[list[list[float]]]:
    """An observation (rows of numbers) as the schema's lists of floats: a Python int
    exactly a float made one (the schema writes 3 as 3.0), anything else None."""
    if type(observation) not in _SEQUENCE:
        return None
    out = []
    for row in observation:
        if type(row) not in _SEQUENCE:
            return None
        made = []
        for v in row:
            t = type(v)
            if t is _FLOAT and math.isfinite(v):
                made.append(v)
            elif t is int and -_EXACT <= v <= _EXACT:
                made.append(float(v))
            else:
                return None
        out.append(made)
    return out


def _simple(key: str, value: Optional[Any]) -> bool:
    if key == "action_values":
        return type(value) is dict and all(
            type(k) is str and type(v) is _FLOAT and math.isfinite(v) for k, v in value.items())
    if key == "preferred_action":
        return type(value) is str
    if key == "allowed_actions":  # a tuple is written as a list, as the schema does
        return type(value) in _SEQUENCE and all(type(a) is str for a in value)
    if key == "shield_time_us":
        return type(value) is _FLOAT and math.isfinite(value)
    return type(value) is bool  # deadlock
