"""Shields: B machines with one operation per agent action, whose guards say what is safe.

A shield is asked for by the name of one an installed environment brings (its adapter's
``shields``; ``tracecheck envs`` lists them), by ``none`` (every action allowed, made for the
actions of the run or agent), or by the path of any ``.mch`` file. Its identity is its name plus
the sha256 of its text, so a report always says exactly which shield it used.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from .. import registry
from ..b.machine import Machine, load_machine, load_machine_text
from ..errors import InputError, JoinedText, TracecheckError, closest

__all__ = ["Shield", "ShieldMachine", "load_shield", "for_actions", "builtin_shields",
           "shield_names", "SHIELD_DIR", "check_vocabulary", "typing_machine", "data_dir"]

def data_dir() -> Path:
    """Where the built-in shields and bundled agents are: ``models/`` of a source checkout, or
    the installed package data ``tracecheck.models`` (a wheel)."""
    source = Path(__file__).resolve().parents[2] / "models"
    if (source / "shields").is_dir():
        return source
    from importlib import resources

    return Path(str(resources.files("tracecheck.models")))


#: where tracecheck's own environments keep their shields' files
SHIELD_DIR = data_dir() / "shields"


def builtin_shields() -> dict[str, Path]:
    """The shields the installed environments bring, by name (their adapters' ``shields``).

    Returns:
        ``{name: path of the .mch file}``, sorted by name.
    """
    found = registry.bundled("shields")
    return {name: Path(found[name][1]) for name in sorted(found)}


def shield_names() -> list[str]:
    """Every name ``--shield`` takes besides a path: ``none`` and the environments' shields."""
    return ["none", *(n for n in builtin_shields() if n != "none")]


@dataclass(frozen=True)
class Shield:
    name: str
    sha256: str
    path: str
    machine: Machine

    @property
    def identity(self) -> dict:
        return {"name": self.name, "sha256": self.sha256, "path": self.path}

    def __reduce__(self):
        """Pickled as its machine's text, rebuilt where it is unpickled: a Ray task gets the
        shield itself — ``none`` made from a run's actions too — never a name or path to
        load again (which on a worker may mean another shield, or none at all)."""
        text = self.machine.source
        if isinstance(text, JoinedText):  # joined from the machines it sees or includes:
            text = text.parts[0][2]  # its own text (they are read again, the sha256 checked)
        return (_rebuilt, (self.name, self.sha256, self.path, text, self.machine.file))


def load_shield(spec: str | Path, *, actions: Optional[tuple[str, ...]] = None,
                parameters: Optional[dict[str, tuple[str, ...]]] = None) -> Shield:
    """The shield ``spec`` names.

    Args:
        spec: the name of a shield an installed environment brings (:func:`shield_names`),
            ``none``, or the path of a ``.mch`` file.
        actions: the live agent's actions: the shield must have one operation for each
            (replay and diff check instead that each action a recording uses has one);
            ``none`` is built for them.
        parameters: for ``none`` and continuous actions, the REAL parameters of each action
            (:attr:`~tracecheck.live.adapter.EnvAdapter.parameters`).

    Returns:
        The :class:`Shield`: its name, the sha256 of its text, its path and its machine (a
        :class:`ShieldMachine`).

    >>> load_shield("none", actions=("Left", "Right")).machine.operations.keys()
    dict_keys(['Left', 'Right'])
    """
    text = str(spec)
    builtin = builtin_shields() if Path(text).suffix != ".mch" else {}
    twice = registry.clashes("shields").get(text) if text in builtin else None
    if twice:
        raise InputError(f"the shield name {text!r} is declared by the environments "
                         f"{', '.join(twice)}, each for its own machine",
                         hint="give the path of the .mch file you mean")
    if text == "none" and actions is not None and (
            parameters or "none" not in builtin
            or set(load_machine(builtin["none"]).operations) != set(actions)):
        return _none_for(actions, parameters or {})
    if text in builtin:
        path, name = builtin[text], text
        if not path.exists():
            raise InputError(f"the shield {text} of an installed environment is not at "
                             f"{path}; reinstall the environment's package")
    else:
        path = Path(text)
        if path.suffix != ".mch" and not path.exists():
            raise InputError(f"unknown shield {text!r}: give one of "
                             f"{', '.join(shield_names())} or the path of a .mch file")
        name = path.stem
    machine = load_machine(path, kind=ShieldMachine)
    shield = Shield(name=name, sha256=machine.sha256, path=str(path), machine=machine)
    return for_actions(shield, actions) if actions is not None else shield


#: the solver's time per state for an allowed set whose guard is not linear in its
#: parameters, where recorded states are decided (replay, diff, guards --state)
OFFLINE_SOLVER_S = 2.0


class ShieldMachine(Machine):
    """A shield's machine: where a guard is not linear in its REAL parameters, its allowed
    set in a recorded state is the solver's (:mod:`.solved_set`, within
    :data:`OFFLINE_SOLVER_S`) — where a plain :class:`~tracecheck.b.machine.Machine`
    (:func:`~tracecheck.b.machine.load_machine`) refuses. Everything else is the same.
    """

    def beyond_linear(self, op: str, env: dict):
        from .solved_set import solved_set

        return solved_set(self, op, env=env, timeout_s=OFFLINE_SOLVER_S)

    def settle_constants(self, names: list[str]) -> None:
        from .constants_setup import settle

        settle(self, names)


def load_solving(path: str | Path) -> ShieldMachine:
    """The machine in ``path`` as a shield's (:class:`ShieldMachine`)."""
    return load_machine(path, kind=ShieldMachine)


def for_actions(shield: Shield, actions: tuple[str, ...]) -> Shield:
    """``shield`` itself, once it has one operation for each of the live agent's
    ``actions`` (a shield loaded here or sent to a worker)."""
    missing = [a for a in actions if a not in shield.machine.operations]
    if missing:
        spare = [op for op in shield.machine.operations if op not in actions]
        near = [(a, b) for a, b in ((a, closest(a, spare)) for a in missing) if b]
        pos = shield.machine.operations[near[0][1]].pos if near else None  # the misspelt one
        raise InputError(f"a shield needs one operation per action ({', '.join(actions)}); "
                         f"{shield.machine.name} lacks {', '.join(missing)}"
                         + (f" and has {', '.join(spare)}, which no action is" if spare else ""),
                         file=str(shield.path), source=shield.machine.source if pos else None,
                         line=pos.line if pos else None, column=pos.column if pos else None,
                         hint="; ".join(f"is the operation {b} the action {a} misspelt?"
                                        for a, b in near) + " An action and its operation "
                         "have one name." if near else
                         "the bundled shield none is another environment's; load_shield(\"none\", "
                         "actions=adapter.actions, parameters=adapter.parameters) allows "
                         "every action of yours" if shield.name == "none" else
                         "name each of the environment's actions (the adapter's `actions`) "
                         "as the shield's operation for it")
    return shield


def _rebuilt(name: str, sha256: str, path: str, text: str, file: Optional[str]) -> Shield:
    """A pickled :class:`Shield` again, from its text (the sha256 checked: the same shield)."""
    machine = load_machine_text(text, file=file, kind=ShieldMachine)
    if machine.sha256 != sha256:
        raise InputError(f"the shield {name} sent to a worker arrived changed (sha256 "
                         f"{machine.sha256[:12]}, not {sha256[:12]})")
    return Shield(name=name, sha256=sha256, path=path, machine=machine)


def _none_for(actions: tuple[str, ...], parameters: dict[str, tuple[str, ...]]) -> Shield:
    """``none`` for any environment: one operation per action, each always enabled (with
    its REAL parameters, any value allowed)."""
    def op(a: str) -> str:
        params = parameters.get(a)
        if not params:
            return f"{a} = skip"
        typed = " & ".join(f"{p} : REAL" for p in params)
        return f"{a}({', '.join(params)}) = PRE {typed} THEN skip END"
    ops = ";\n  ".join(op(a) for a in actions)
    text = (f"/* everything allowed: built from the actions */\nMACHINE none\nOPERATIONS\n"
            f"  {ops}\nEND\n")
    machine = load_machine_text(text, file="none", kind=ShieldMachine)
    return Shield(name="none", sha256=machine.sha256, path="none", machine=machine)


def typing_machine(adapter) -> Optional["Machine"]:
    """The machine whose types make ``adapter``'s states B values when the shield gives
    none (``none``): the environment's own shield (:attr:`~tracecheck.live.adapter.EnvAdapter.default_shield`),
    or None — then only what needs no type is converted.

    Args:
        adapter: an environment adapter.

    Returns:
        The machine of its default shield, or None when it has none that loads.

    >>> typing_machine(type("NoShield", (), {"default_shield": None})()) is None
    True
    """
    name = getattr(adapter, "default_shield", None)
    if not name:
        return None
    try:
        return load_shield(name).machine
    except TracecheckError:
        return None


def _read_at(node, name: str):
    """Where ``node`` first reads the variable ``name`` (its position; None if unknown)."""
    from ..b import ast

    todo = [node] if node is not None else []
    while todo:
        here = todo.pop()
        if isinstance(here, ast.Name) and here.id == name and here.pos is not None:
            return here.pos
        todo.extend(reversed(ast.children(here)))
    return None


def check_vocabulary(shield: Shield, adapter, env) -> None:
    """Before any episode: the environment's states fit the shield's machine. Each variable
    the adapter gives must be declared (and of the declared type, tried on a real first
    state), and each variable a guard reads must be one the adapter gives."""
    machine = shield.machine
    if not machine.variables:
        return
    given = set(adapter.variables)
    extra = [v for v in adapter.variables if v not in machine.variables]
    if extra:
        own = adapter.default_shield and adapter.default_shield != shield.name and \
            Path(str(adapter.default_shield)).stem != Path(str(shield.path)).stem
        raise InputError(f"the environment {adapter.name} gives the variable {extra[0]}, which "
                         f"the shield {shield.name} does not declare (its variables are "
                         f"{', '.join(machine.variables)})",
                         hint=(f"use a shield written for {adapter.name}, e.g. "
                               f"{adapter.default_shield}") if own else
                         "name the variables alike in the adapter's `variables` (and the keys "
                         "its state() returns) and in the shield's VARIABLES")
    from ..b import ast

    readers = [(f"the guard of {name}", read, machine.operations[name].guard)
               for name, read in machine.guard_variables().items()]
    if machine.invariant_node is not None:  # replay checks each state against it
        readers.append(("the INVARIANT", ast.free_names(machine.invariant_node),
                        machine.invariant_node))
    for what, read, node in readers:
        missing = sorted((read & set(machine.variables)) - given)
        if missing:
            pos = _read_at(node, missing[0])
            raise InputError(f"{what} in {shield.name} reads {missing[0]}, which the "
                             f"environment {adapter.name} never gives (it gives "
                             f"{', '.join(adapter.variables)}): replay could not judge a "
                             "recording's states by it", file=str(shield.path),
                             line=pos.line if pos else None,
                             column=pos.column if pos else None,
                             source=machine.source if pos else None,
                             hint=f"give {missing[0]} in the adapter's variables and its "
                                  "state(), or leave it out of the shield")
    obs, info = adapter.reset(env, 0)  # the hook: an exception in it is said as the adapter's
    state = adapter.observer(env).state(obs, dict(info, crashed=False), 0.0, True)
    where = f"state() of the adapter {adapter.name} (the first state)"
    unset = [v for v in adapter.variables if v not in state]
    if unset:  # the recording would lack it, and replay refuse it only then
        raise InputError(f"{where} gives no value for {unset[0]}, "
                         f"a variable the adapter declares ({', '.join(adapter.variables)})",
                         hint="state() returns a value for each of the adapter's variables")
    state = machine.native(state, where=where)
    machine.check_state(state, where=where, python=True)
    broken, _ = machine.invariant_check(state)
    if broken:  # sets of another size (a 9x7 map under a 7x7 shield): replay would report
        #         an invariant violation at every state
        raise InputError(f"the first state of {adapter.name} breaks the invariant of the "
                         f"shield {shield.name}: {broken[0]}"
                         + (f" (and {len(broken) - 1} more conjunct(s))" if broken[1:] else ""),
                         hint="the shield's sets or constants do not describe this "
                              "environment (a map of another size?); `tracecheck guards` "
                              "shows the state against the shield")
