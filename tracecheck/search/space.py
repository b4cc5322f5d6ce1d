"""What a search varies (``tracecheck falsify --param NAME=LO..HI``): the episode seed, the
environment's settings, and what the episode starts from where the adapter declares it
(``reset_parameters``: the values reach its ``reset`` hook), each a range of numbers or a
list of choices.

A point of the space is reached from a point of the unit cube (one coordinate per
dimension, in the order the user gave them), which is what the optimisers search
(:mod:`.optimizers`): a number range scales the coordinate (an integer one rounds it), a
list of choices cuts [0, 1] into equal parts. Every range is checked against what the
environment takes before any episode runs (:func:`check_space`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Optional, Sequence

from ..errors import InputError

__all__ = ["Dimension", "Space", "parse_param", "check_space", "SEED", "MAX_SEED"]

#: the dimension that is the episode's seed (not an environment setting)
SEED = "seed"
#: the largest seed Gymnasium takes and a run file stores
MAX_SEED = 2 ** 63 - 1
_NUMBER = r"[+-]?(?:\d+\.?\d*(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?)"
_RANGE = re.compile(rf"^\s*({_NUMBER})\s*\.\.\s*({_NUMBER})\s*$")


@dataclass(frozen=True)
class Dimension:
    """One thing the search varies: ``name`` (``seed`` or a setting); ``low``/``high`` for
    a range (``integer``: whole numbers only), or ``choices``."""

    name: str
    low: Optional[float] = None
    high: Optional[float] = None
    integer: bool = False
    choices: Optional[tuple] = None
    #: the ``--param`` text it was read from (messages quote it)
    text: str = field(default="", compare=False)
    #: one of the adapter's ``reset_parameters`` (given to ``reset``), not a setting
    reset: bool = False

    def value(self, u: float) -> Any:
        """The value at the unit coordinate ``u`` (clipped to [0, 1])."""
        u = min(1.0, max(0.0, float(u)))
        if self.choices is not None:
            return self.choices[min(int(u * len(self.choices)), len(self.choices) - 1)]
        assert self.low is not None and self.high is not None
        if self.integer:
            lo, hi = int(self.low), int(self.high)
            return min(hi, lo + int(math.floor(u * (hi - lo + 1))))
        return self.low + u * (self.high - self.low)

    def shown(self) -> str:
        if self.choices is not None:
            return f"{self.name}={{{','.join(map(str, self.choices))}}}"
        lo, hi = (int(self.low), int(self.high)) if self.integer else (self.low, self.high)
        return f"{self.name}={lo}..{hi}"


@dataclass(frozen=True)
class Space:
    """The dimensions of a search, in the order given."""

    dimensions: tuple[Dimension, ...]

    def point(self, unit: Sequence[float]) -> dict[str, Any]:
        """The parameters at a point of the unit cube."""
        return {d.name: d.value(u) for d, u in zip(self.dimensions, unit)}

    @property
    def settings(self) -> tuple[Dimension, ...]:
        """The dimensions that are environment settings (not the seed, nor what ``reset``
        takes)."""
        return tuple(d for d in self.dimensions if d.name != SEED and not d.reset)

    @property
    def resets(self) -> tuple[Dimension, ...]:
        """The dimensions the adapter's ``reset`` takes (its ``reset_parameters``)."""
        return tuple(d for d in self.dimensions if d.reset)

    def describe(self) -> dict[str, list]:
        """Each dimension as a run header stores it: [low, high] or the choices."""
        return {d.name: list(d.choices) if d.choices is not None else
                [int(d.low), int(d.high)] if d.integer else [d.low, d.high]
                for d in self.dimensions}


def parse_param(text: str, kinds: Optional[frozenset[str]] = None,
                default: Any = None) -> Dimension:
    """``NAME=LO..HI`` or ``NAME={a,b,c}`` (``--param``); ``kinds``: what the setting takes
    (:func:`tracecheck.live.settings.setting_kinds`; None: anything), ``default`` its value
    in the environment's configuration — a range of a setting whose default is a whole
    number (``lanes_count``), or that takes integers only, is one of integers."""
    name, eq, rest = text.partition("=")
    name = name.strip()
    if not eq or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
        raise InputError(f"--param {text!r}: write NAME=LO..HI (a range) or NAME={{a,b}} "
                         "(choices)", hint="e.g. --param vehicles_density=0.5..2.0 or "
                                           "--param seed=0..999")
    rest = rest.strip()
    if rest.startswith("{") and rest.endswith("}"):
        items = tuple(_choice(x.strip()) for x in rest[1:-1].split(",") if x.strip())
        if not items:
            raise InputError(f"--param {text!r}: no choices between the braces")
        if len(set(map(repr, items))) != len(items):
            raise InputError(f"--param {text!r}: a choice is listed twice")
        return Dimension(name, choices=items, text=text)
    m = _RANGE.match(rest)
    if m is None or "..." in rest:
        raise InputError(f"--param {text!r}: {rest!r} is no range LO..HI of numbers nor a "
                         "list {a,b}", hint="e.g. --param vehicles_density=0.5..2.0")
    lo, hi = float(m.group(1)), float(m.group(2))
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
        raise InputError(f"--param {text!r}: the range must go from a lower to a higher "
                         "finite number")
    integer = name == SEED or type(default) is int or (
        kinds is not None and "int" in kinds and "float" not in kinds)
    if integer and (lo != int(lo) or hi != int(hi)):
        raise InputError(f"--param {text!r}: {name} takes whole numbers; give whole ends")
    if name == SEED and (lo < 0 or hi > MAX_SEED):
        raise InputError(f"--param {text!r}: a seed is 0 … 2^63 - 1")
    if kinds is not None and not ({"int", "float"} & kinds):
        raise InputError(f"--param {text!r}: {name} does not take numbers "
                         f"(it takes {', '.join(sorted(kinds))}); give its choices: "
                         f"{name}={{a,b}}")
    return Dimension(name, lo, hi, integer=integer, text=text)


def _choice(text: str) -> Any:
    """A choice as the environment's setting would take it: a number, a boolean, a
    string."""
    if re.fullmatch(_NUMBER, text):
        value = float(text)
        return int(value) if value == int(value) and "." not in text and "e" not in \
            text.lower() else value
    if text in ("True", "False", "true", "false"):
        return text.lower() == "true"
    return text.strip("'\"")


def check_space(texts: Sequence[str], adapter, base: Optional[dict] = None,
                check: Optional[Callable[[Any], None]] = None) -> Space:
    """The search space of ``--param`` texts for the environment ``adapter`` (its run
    configuration ``base``): each setting one the environment takes; both ends of each
    range, and each choice, taken by the environment (its configuration checked and the
    environment made and reset with them, and ``check(env)`` — the agent and the shield
    fit it) — before any episode."""
    if not texts:
        raise InputError("give what the search varies: --param NAME=LO..HI (seed, or a "
                         "setting of the environment)", hint="e.g. --param seed=0..9999")
    kinds = adapter.config_kinds()
    resets = dict(adapter.reset_parameters)
    try:
        defaults = adapter.config(base or None)
    except InputError:
        defaults = {}
    dims = []
    for text in texts:
        name = text.partition("=")[0].strip()
        if name in resets:  # a reset parameter: whole ends (0..4) are a range of integers
            dim = replace(parse_param(text, None, 0 if _whole_ends(text) else None),
                          reset=True)
        else:
            _known(adapter, name, resets)
            dim = parse_param(text, None if name == SEED else kinds.get(name),
                              defaults.get(name))
        if any(d.name == dim.name for d in dims):
            raise InputError(f"--param {dim.name} is given twice")
        dims.append(dim)
    space = Space(tuple(dims))
    for dim in space.settings + space.resets:
        ends = dim.choices if dim.choices is not None else (dim.value(0.0), dim.value(1.0))
        for value in ends:
            _try_setting(adapter, base or {}, dim, value, check)
    return space


def _whole_ends(text: str) -> bool:
    """Whether both ends of the range ``text`` are written as whole numbers (no point, no
    exponent), as a choice ``1`` is the integer and ``1.0`` the real."""
    m = _RANGE.match(text.partition("=")[2])
    return m is not None and not any(c in m.group(1) + m.group(2) for c in ".eE")


def _known(adapter, name: str, resets: dict) -> None:
    """``name`` is the seed or a setting the environment takes (where it says which it
    takes), else an InputError listing what can be searched."""
    keys = adapter.config_keys()
    if name == SEED or keys is None or name in keys:
        return
    raise InputError(f"--param {name}: the environment {adapter.name} has no setting nor "
                     f"reset parameter {name!r}; a search varies {SEED}, its settings "
                     f"{', '.join(sorted(keys)) or '(none)'} and its reset parameters "
                     f"{', '.join(sorted(resets)) or '(none)'}",
                     hint=None if not resets else "the reset parameters: " + "; ".join(
                         f"{k}: {v}" for k, v in sorted(resets.items())))


def _try_setting(adapter, base: dict, dim: Dimension, value: Any, check) -> None:
    """The environment made and reset with ``dim`` at ``value``, and ``check`` given it (an
    InputError naming the option where it cannot be)."""
    try:
        config = adapter.config({**(base or {}), dim.name: value} if not dim.reset
                                else base or None)
        env = adapter.make_env(config)
        try:
            adapter.reset(env, 0, {dim.name: value} if dim.reset else None)
            if check is not None:
                check(env)
        finally:
            env.close()
    except InputError as exc:
        raise InputError(f"--param {dim.text or dim.shown()}: at {dim.name}={value!r}: "
                         f"{exc.message}", hint=exc.hint) from None
    except Exception as exc:  # noqa: BLE001 - whatever the environment raises for a value
        raise InputError(f"--param {dim.text or dim.shown()}: the environment {adapter.name} "
                         f"does not take {dim.name}={value!r}: {type(exc).__name__}: {exc}",
                         hint="give a range the environment takes") from None
