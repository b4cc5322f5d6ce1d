"""What a user asks ``prove`` to show: obligations from options and from an obligations file.

An obligations file is TOML (docs/prove.md)::

    deadlock_free = true
    well_defined = true
    assume = ["Crash = FALSE"]

    [[implies]]
    operation = "FASTER"
    predicate = "VehiclesVx(EgoVehicle) < 40.0"

Each mistake in a file names the file and the key; its predicates are type-checked by
:func:`~tracecheck.checking.proving.prove`, which names them by their entry, counted from 1
(``obs.toml: implies[2].predicate``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError
from ..inputs import read_text

__all__ = ["Given", "Obligations", "read_obligations", "implication", "operation_spec", "KEYS"]

#: the keys of an obligations file
KEYS = ("deadlock_free", "well_defined", "assume", "implies")


@dataclass(frozen=True)
class Given:
    """A formula a user gave, and where it came from, for messages: an option
    (``--assume``) or a file and entry (``obs.toml: implies[2].predicate``). ``params``:
    the names an implication gives its operation's REAL parameters (``PUSH(u) => …``)."""

    text: str
    where: str
    params: tuple[str, ...] = ()


@dataclass(frozen=True)
class Obligations:
    """What to prove of a machine: deadlock freedom, implications ``(operation, claim)``,
    well-defined guards — over the states that satisfy its invariant and ``assume``."""

    deadlock_free: bool = False
    implies: tuple[tuple[str, Given], ...] = ()
    well_defined: bool = False
    assume: tuple[Given, ...] = ()

    def also(self, other: Obligations) -> Obligations:
        """These obligations and ``other``'s (its formulas after these)."""
        return Obligations(self.deadlock_free or other.deadlock_free,
                           self.implies + other.implies,
                           self.well_defined or other.well_defined,
                           self.assume + other.assume)

    @property
    def empty(self) -> bool:
        """Nothing to prove (assumptions alone are no obligation)."""
        return not (self.deadlock_free or self.implies or self.well_defined)


_OPERATION = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_.]*)\s*(?:\(\s*([A-Za-z_]\w*(?:\s*,\s*"
                        r"[A-Za-z_]\w*)*)\s*\))?\s*")


def operation_spec(text: str, where: str) -> tuple[str, tuple[str, ...]]:
    """``OP`` or ``OP(u, v)`` as (operation, names of its parameters).

    >>> operation_spec("PUSH(u)", "--implies")
    ('PUSH', ('u',))
    """
    m = _OPERATION.fullmatch(text)
    if m is None:
        raise InputError(f"{where}: {text.strip()!r} is no operation: give OP, or OP(u) to "
                         "name the REAL parameters of an operation")
    names = tuple(n.strip() for n in m.group(2).split(",")) if m.group(2) else ()
    return m.group(1), names


def implication(text: str, where: str = "--implies") -> tuple[str, Given]:
    """``'OP => PREDICATE'`` as (operation, predicate); ``'OP(u) => PREDICATE'`` names the
    operation's REAL parameters: the predicate must hold for every value it allows.

    >>> implication("Inc => x < 3")
    ('Inc', Given(text='x < 3', where='--implies', params=()))
    >>> implication("PUSH(u) => v + u <= 2.0")[1].params
    ('u',)
    """
    op, sep, pred = text.partition("=>")
    if not sep or not op.strip() or not pred.strip():
        raise InputError(f"{where} takes 'OP => PREDICATE' (or 'OP(u) => PREDICATE' for "
                         f"every allowed value u), not {text!r}")
    name, params = operation_spec(op, where)
    return name, Given(pred.strip(), where, params)


def read_obligations(path: str | Path, machine) -> Obligations:
    """The obligations of a TOML file, checked: each mistake names the file and key, an
    implication's operation must be one of ``machine``'s (its predicates are type-checked
    by ``prove``, with the same names)."""
    import tomllib

    text = read_text(path, "obligations file")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"not valid TOML: {exc}", file=str(path)) from None
    unknown = set(data) - set(KEYS)
    if unknown:
        raise InputError(f"{path}: unknown key {sorted(unknown)[0]!r}; the keys are "
                         f"{', '.join(KEYS)}")
    flags = {key: data.get(key, False) for key in ("deadlock_free", "well_defined")}
    for key, value in flags.items():
        if not isinstance(value, bool):
            raise InputError(f"{path}: {key} must be true or false")
    assume = data.get("assume", [])
    if not isinstance(assume, list) or not all(isinstance(a, str) for a in assume):
        raise InputError(f"{path}: assume must be a list of predicates (strings)")
    return Obligations(
        deadlock_free=flags["deadlock_free"], well_defined=flags["well_defined"],
        assume=tuple(Given(a, f"{path}: assume[{i + 1}]") for i, a in enumerate(assume)),
        implies=_implications(path, data.get("implies", []), machine))


def _implications(path, items, machine) -> tuple[tuple[str, Given], ...]:
    """The ``[[implies]]`` tables of an obligations file."""
    if not isinstance(items, list):
        raise InputError(f"{path}: implies must be [[implies]] tables")
    out = []
    for i, item in enumerate(items):
        if not (isinstance(item, dict) and isinstance(item.get("operation"), str)
                and isinstance(item.get("predicate"), str)):
            raise InputError(f"{path}: implies[{i + 1}] needs operation = \"OP\" and "
                             "predicate = \"…\"")
        op, params = operation_spec(item["operation"], f"{path}: implies[{i + 1}].operation")
        if op not in machine.operations:
            raise InputError(f"{path}: implies[{i + 1}].operation: unknown operation "
                             f"{op!r}; the operations of {machine.name} are "
                             f"{', '.join(machine.operations)}")
        out.append((op, Given(item["predicate"], f"{path}: implies[{i + 1}].predicate",
                              params)))
    return tuple(out)
