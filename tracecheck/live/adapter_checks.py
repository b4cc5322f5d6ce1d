"""The checks of an adapter's declarations when it is loaded, and how an exception from a
user's adapter is reported (:mod:`tracecheck.live.adapter` applies them)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Mapping

from ..errors import InputError, printable

__all__ = ["USERS", "raised", "check_attributes", "strings", "name_or_path", "ATTRIBUTES"]

#: what the user's code may raise that is reported as its error: any exception, and
#: SystemExit (``sys.exit()`` in a hook must not end tracecheck silently with its code) —
#: not KeyboardInterrupt, which stays an interrupt
USERS = (Exception, SystemExit)


def raised(where: str, exc: BaseException, hook: str, *, env: bool = False) -> InputError:
    """The error that reports ``exc``, raised by the adapter ``where`` in ``hook`` (``env``:
    by the environment it makes, in its own ``reset`` or ``step``)."""
    whose = f"the environment of the adapter {where}" if env else f"the adapter {where}"
    return InputError(f"{whose} raised {type(exc).__name__} {hook}: {exc}",
                      hint="tracecheck --debug … shows its traceback")


def strings(value) -> bool:
    return isinstance(value, (tuple, list)) and all(isinstance(v, str) for v in value)


def name_or_path(value) -> bool:
    return value is None or (isinstance(value, (str, os.PathLike)) and str(value) != "")


#: (attribute, what it must be, the check) for every attribute an adapter declares
ATTRIBUTES = (
    ("env_id", "a string (the Gymnasium id)", lambda v: isinstance(v, str)),
    ("variables", "a tuple of B variable names (strings), each once",
     lambda v: strings(v) and len(set(v)) == len(v) and all(v)),
    ("model_name", "a string (the B machine's name)", lambda v: isinstance(v, str)),
    ("horizon", "a whole number of agent steps, at least 1",
     lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 1),
    ("seconds_per_step", "a finite number of seconds above 0",
     lambda v: isinstance(v, (int, float)) and not isinstance(v, bool) and 0 < v < float("inf")),
    ("assumptions", 'a tuple of B predicates (strings), e.g. ("x : 0..7",) — one string alone '
                    "needs the comma", strings),
    ("properties", "None or a property set's name or the path of a property file",
     name_or_path),
    ("default_shield", "None or a shield's name or the path of a machine", name_or_path),
    ("requires", "a tuple of package names (strings)", strings),
    ("parameters", 'a dict from an operation name to the tuple of its REAL parameters, one per '
                   'component of the action vector, e.g. {"ACCELERATE": ("a",)}',
     lambda v: isinstance(v, dict) and all(
         isinstance(k, str) and k and isinstance(p, tuple) and p and strings(p) and all(p)
         and len(set(p)) == len(p) for k, p in v.items())),
    ("fallback_action", "None or a tuple of numbers (the action vector taken when the shield "
                        "allows nothing)",
     lambda v: v is None or (isinstance(v, tuple) and all(
         isinstance(x, (int, float)) and not isinstance(x, bool) for x in v))),
    ("profiles", "a dict of named configurations (name -> dict of settings)",
     lambda v: isinstance(v, dict) and all(isinstance(k, str) and isinstance(c, dict)
                                           for k, c in v.items())),
    ("description", "a string (one line for people)", lambda v: isinstance(v, str)),
    ("shields", "a dict from a shield's name to the path of its .mch file",
     lambda v: isinstance(v, Mapping) and all(isinstance(k, str) and k and isinstance(
         f, (str, Path)) for k, f in v.items())),
    ("property_sets", "a dict from a property set's name to its TOML text or the Path of "
                      "its file",
     lambda v: isinstance(v, Mapping) and all(isinstance(k, str) and k and isinstance(
         f, (str, Path)) for k, f in v.items())),
    ("observation_shape", "None or a tuple of whole numbers (the observations' shape)",
     lambda v: v is None or (isinstance(v, tuple) and all(
         isinstance(x, int) and not isinstance(x, bool) for x in v))),
    ("plotted", "a tuple of names (strings) of the numbers plots() gives", strings),
    ("reset_parameters", "a dict from a name (not seed) to one line saying what it sets at "
                         "the start of an episode",
     lambda v: isinstance(v, Mapping) and all(
         isinstance(k, str) and k.isidentifier() and k != "seed" and isinstance(d, str)
         for k, d in v.items())),
    ("set_name", "a string (the set of elements ProB's traces list, or empty)",
     lambda v: isinstance(v, str)),
)


def check_attributes(adapter, where: str) -> None:
    """Every attribute the adapter declares has the type tracecheck reads it as (checked
    when it is loaded, not where it is first used: ``horizon = "abc"`` would fail in
    the middle of a recording, ``assumptions = "pos > 1"`` be read letter by letter); reading
    one that raises is reported like a hook's error."""
    def read(attr: str):
        try:
            return getattr(adapter, attr)
        except USERS as exc:  # noqa: BLE001 - a property of the user's
            raise raised(where, exc, f"when its attribute {attr} was read") from exc

    def refuse(attr: str, value, expected: str) -> InputError:
        return InputError(f"the adapter {where} has {attr} = {printable(repr(value))[:80]}; "
                          f"it must be {expected}")

    name, actions = read("name"), read("actions")
    if not name or not actions:
        raise InputError(f"the adapter {where} needs a name and actions")
    if not isinstance(name, str):
        raise refuse("name", name, "a string (what --env and run files call it)")
    if not strings(actions) or not all(actions):
        raise InputError(f"the adapter {where} has actions {printable(repr(actions))[:80]}; "
                         "give a tuple of operation names, one per action index")
    actions = tuple(actions)
    twice = next((a for i, a in enumerate(actions) if a in actions[:i]), None)
    if twice is not None:
        raise InputError(f"the adapter {where} names the action {twice!r} twice in its "
                         f"actions {actions!r}: each action index needs its own name (the B "
                         "operation it stands for)")
    for attr, expected, ok in ATTRIBUTES:
        value = read(attr)
        if not ok(value):
            raise refuse(attr, value, expected)
    fallback = read("fallback")
    if fallback is not None and fallback not in actions:
        raise refuse("fallback", fallback, f"None or one of its actions ({', '.join(actions)})")
    parameters = read("parameters")
    stray = [op for op in parameters or {} if op not in actions]
    if stray:
        raise refuse("parameters", parameters,
                     f"keyed by its actions ({', '.join(actions)}): {stray[0]} is not one "
                     "(a Box action space is one operation whose parameters take the "
                     "components; a hybrid space gives some or all of its actions parameters)")
