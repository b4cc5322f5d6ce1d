"""The environments installed here: one entry point each, and what each one brings.

An environment is registered by one line in the entry-point group ``tracecheck.environments``
(``corridor = "my_envs.corridor:Corridor"``); the class it names (a
:class:`~tracecheck.live.adapter.EnvAdapter`) carries everything tracecheck knows of the
environment. This module is where every other layer asks for what environments bring —
shields by name (``--shield NAME``), property sets by name (``--properties NAME``),
the environment whose vocabulary a run's states are in — so that no module outside the
adapters names an environment, and a new one is seen everywhere at once.

It reads the classes' declarations only (``shields``, ``property_sets``) and never makes an
adapter; the live layer (:mod:`tracecheck.live.adapter`) makes and checks them.

>>> all(":" in ep.value for ep in entry_points().values())
True
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any, Optional

__all__ = ["ENTRY_POINT_GROUP", "Registered", "entry_points", "registered", "bundled",
           "clashes", "names"]

ENTRY_POINT_GROUP = "tracecheck.environments"

#: what a plug-in's import may raise that is reported as its problem (a broken plug-in
#: must not stop the others): any exception, and SystemExit — not KeyboardInterrupt
_USERS = (Exception, SystemExit)


@dataclass(frozen=True)
class Registered:
    """One entry point: its name, its ``module:Class`` target, the class it loads (None when
    it cannot be loaded) and why not."""

    name: str
    target: str
    cls: Optional[type]
    problem: Optional[str]


@functools.lru_cache(maxsize=1)
def entry_points() -> dict[str, metadata.EntryPoint]:
    """The registered environments by name: the installed distributions' entry points, and
    those of the source checkout this package runs from when it is not installed (its
    ``pyproject.toml``: ``PYTHONPATH=checkout`` runs that checkout's environments).

    Returns:
        The entry points of the group, by name (scanned once per process).
    """
    found = {ep.name: ep for ep in metadata.entry_points(group=ENTRY_POINT_GROUP)}
    for name, target in _source_tree().items():
        found.setdefault(name, metadata.EntryPoint(name, target, ENTRY_POINT_GROUP))
    return found


def _source_tree() -> dict[str, str]:
    """The group's lines in the ``pyproject.toml`` of the checkout this package is in (none
    for an installed wheel)."""
    import tomllib

    pyproject = Path(__file__).resolve().parents[1] / "pyproject.toml"
    try:
        data = tomllib.loads(pyproject.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    project = data.get("project", {})
    if project.get("name") != "tracecheck":
        return {}
    group = project.get("entry-points", {}).get(ENTRY_POINT_GROUP, {})
    return {str(k): str(v) for k, v in group.items()}


def registered() -> tuple[Registered, ...]:
    """Every registered environment, its class loaded where it can be, sorted by name.

    Returns:
        One :class:`Registered` per entry point (a class that cannot be imported has
        ``cls=None`` and the reason in ``problem``). An imported module is not imported
        again: after the first call this costs microseconds.
    """
    out = []
    for name, ep in sorted(entry_points().items()):
        try:
            cls, problem = ep.load(), None
        except _USERS as exc:  # noqa: BLE001 - a broken plug-in must not stop the list
            cls, problem = None, f"{type(exc).__name__}: {exc}"
        out.append(Registered(name, ep.value, cls, problem))
    return tuple(out)


def names() -> list[str]:
    """The registered environments' names, sorted (no class is loaded)."""
    return sorted(entry_points())


def bundled(attribute: str) -> dict[str, tuple[str, Any]]:
    """What the registered environments bring under one of their mappings (``shields``,
    ``property_sets``): each entry's name, with the environment that declares it and its
    value. Two environments may declare one name with the same value (an environment and
    its variant); the first, by environment name, is kept where the values differ.

    Args:
        attribute: the class attribute, a mapping from names to values.

    Returns:
        ``{name: (environment, value)}``.
    """
    out: dict[str, tuple[str, Any]] = {}
    for name, mapping in _declared(attribute):
        for key, value in mapping.items():
            out.setdefault(key, (name, value))
    return out


def clashes(attribute: str) -> dict[str, list[str]]:
    """The names that more than one registered environment declares under ``attribute``
    with different values (a name that means two things is refused where it is asked for).

    Returns:
        ``{name: [the environments that declare it]}``.
    """
    seen: dict[str, dict[str, Any]] = {}
    for name, mapping in _declared(attribute):
        for key, value in mapping.items():
            seen.setdefault(key, {})[name] = value
    return {key: sorted(by) for key, by in seen.items()
            if len({str(v) for v in by.values()}) > 1}


def _declared(attribute: str):
    """(environment, its mapping under ``attribute``) for each registered environment whose
    declaration is a mapping of names to strings or paths; one that is not (or that raises
    when read) is left out here — ``tracecheck envs`` says what is wrong with it."""
    for entry in registered():
        if entry.cls is None:
            continue
        try:
            mapping = getattr(entry.cls, attribute, None)
        except _USERS:  # noqa: BLE001 - a plug-in's property: its problem, shown by envs
            continue
        if not isinstance(mapping, Mapping) or not all(
                isinstance(k, str) and k and isinstance(v, (str, Path))
                for k, v in mapping.items()):
            continue
        yield entry.name, dict(mapping)
