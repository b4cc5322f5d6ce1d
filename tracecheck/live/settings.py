"""An environment's settings (``--env-config key=value``): what each setting takes, read
from the environment's defaults or from Gymnasium's own signature, and a value typed as the
environment takes it (``is_slippery=False`` is the boolean, not the string)."""

from __future__ import annotations

import functools
import inspect
import re
from typing import Any, Optional

from ..errors import InputError

__all__ = ["parse_config", "setting_kinds", "typed_setting", "gymnasium_keys", "gymnasium_kinds"]


def _gymnasium_parameters(env_id: str):
    import gymnasium as gym

    try:
        entry = gym.spec(env_id).entry_point
        try:
            hash(entry)
        except TypeError:  # an entry point that cannot key the cache: looked at each time
            return _entry_parameters.__wrapped__(entry)
        return _entry_parameters(entry)
    except Exception:  # noqa: BLE001 - a package missing: make_env will say so
        return None


@functools.cache
def _entry_parameters(entry):
    """The keyword parameters of a registered entry point, read-only (None: it takes any);
    remembered per entry point (one that fails to load raises, and is tried again)."""
    from types import MappingProxyType

    from gymnasium.envs.registration import load_env_creator

    params = inspect.signature(load_env_creator(entry) if isinstance(entry, str)
                               else entry).parameters
    if any(p.kind == p.VAR_KEYWORD for p in params.values()):
        return None
    return MappingProxyType({k: p for k, p in params.items() if k != "render_mode"})


#: what ``gymnasium.make`` itself takes
_MAKE_KINDS = {"max_episode_steps": frozenset({"int", "None"}),
               "disable_env_checker": frozenset({"bool", "None"})}


def gymnasium_keys(env_id: str) -> Optional[frozenset[str]]:
    """The keyword arguments ``gymnasium.make(env_id, **config)`` takes: those of the
    registered environment class and of ``make`` itself (None where they cannot be known)."""
    params = _gymnasium_parameters(env_id)
    return None if params is None else frozenset(params) | frozenset(_MAKE_KINDS)


def gymnasium_kinds(env_id: str) -> dict[str, Optional[frozenset[str]]]:
    """What each keyword argument of ``gymnasium.make(env_id, **config)`` takes, from the
    environment class's annotations and defaults (:func:`setting_kinds`)."""
    params = _gymnasium_parameters(env_id) or {}
    return {**{k: setting_kinds(p.default, p.annotation) for k, p in params.items()},
            **_MAKE_KINDS}


_NO = object()
#: how messages say what a kind of setting takes
_KIND_TEXT = {"bool": "true or false", "int": "an integer", "float": "a number",
              "str": "a string", "None": "null", "list": "a list", "tuple": "a list",
              "dict": "an object ({…})"}


def setting_kinds(default: Any = _NO, annotation: Any = _NO) -> Optional[frozenset[str]]:
    """The kinds of value a setting takes: from its annotation where that is made of
    ``bool``, ``int``, ``float``, ``str``, ``None``, ``list[…]``, ``tuple[…]``, ``dict[…]``
    joined by ``|``; else from its default's type (a number: an integer or a real); None
    (anything) where neither says.

    >>> sorted(setting_kinds(True)), sorted(setting_kinds(1, "str | None"))
    (['bool'], ['None', 'str'])
    """

    if annotation not in (_NO, inspect.Parameter.empty, None):
        text = annotation if isinstance(annotation, str) else \
            getattr(annotation, "__name__", None) if isinstance(annotation, type) else \
            str(annotation)
        names = {re.split(r"[\[\s]", part.strip())[0] for part in str(text).split("|")}
        if names <= set(_KIND_TEXT):
            return frozenset(names)
    if isinstance(default, bool):
        return frozenset({"bool"})
    if isinstance(default, (int, float)):
        return frozenset({"int", "float"})
    if isinstance(default, str):
        return frozenset({"str"})
    if isinstance(default, (list, tuple)):
        return frozenset({"list", "tuple"})
    if isinstance(default, dict):
        return frozenset({"dict"})
    return None


def typed_setting(env: str, key: str, value: Any, kinds: Optional[frozenset[str]]) -> Any:
    """``value`` as the setting ``key`` of ``env`` takes it (``kinds``, see
    :func:`setting_kinds`); an :class:`InputError` naming the key, the value and what it
    takes where it does not fit."""
    if kinds is None:
        return value
    if isinstance(value, bool):
        ok = "bool" in kinds
    elif isinstance(value, int):
        ok = bool(kinds & {"int", "float"})
        value = value if "int" in kinds or not ok else float(value)
    elif isinstance(value, float):
        ok = "float" in kinds
    elif isinstance(value, str):
        ok = "str" in kinds
    elif value is None:
        ok = "None" in kinds
    elif isinstance(value, (list, tuple)):
        ok = bool(kinds & {"list", "tuple"})
        value = tuple(value) if "list" not in kinds else list(value)
    else:
        ok = isinstance(value, dict) and "dict" in kinds
    if not ok:
        shown = kinds - {"int"} if "float" in kinds else kinds  # a number: either
        takes = " or ".join(dict.fromkeys(_KIND_TEXT[k] for k in sorted(shown)))
        raise InputError(f"the setting {key}={value!r} does not fit the environment {env}: "
                         f"{key} takes {takes}",
                         hint=f"e.g. {key}=true on the command line, {key}=True from "
                              "Python" if kinds == {"bool"} else None)
    return value


def parse_config(items: list[str]) -> dict[str, Any]:
    """``key=value`` settings: values read as JSON where they parse (true, 3, 0.5, "s"),
    Python's ``True`` and ``False`` as booleans, else as strings (the adapter's
    :meth:`~EnvAdapter.check_config` then checks each against what its setting takes)."""
    import orjson

    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise InputError(f"--env-config takes key=value, not {item!r}")
        if value in ("True", "False"):
            out[key] = value == "True"
            continue
        try:
            out[key] = orjson.loads(value)  # no NaN, nesting bounded
        except orjson.JSONDecodeError:
            out[key] = value
    return out
