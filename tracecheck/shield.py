"""Shields: B machines with one operation per agent action, whose guards say what is safe.

A shield is asked for by a built-in name (``none``, ``paper``, ``strict``: the machines in
``models/shields/``) or by the path of any ``.mch`` file. Its identity is its name plus the
sha256 of its text, so a report always says exactly which shield it used.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from .b.machine import Machine, load_machine
from .episodes.model import HIGHWAY_ACTIONS
from .errors import InputError

__all__ = ["Shield", "load_shield", "BUILTIN_SHIELDS", "SHIELD_DIR"]

SHIELD_DIR = Path(__file__).resolve().parents[1] / "models" / "shields"
BUILTIN_SHIELDS = ("none", "paper", "strict")


@dataclass(frozen=True)
class Shield:
    name: str
    sha256: str
    path: str
    machine: Machine

    @property
    def identity(self) -> dict:
        return {"name": self.name, "sha256": self.sha256, "path": self.path}


def load_shield(spec: str | Path, *, actions: Optional[tuple[str, ...]] = None) -> Shield:
    """The shield ``spec`` names: a built-in name or a path to a ``.mch`` file.

    With ``actions`` (the live agent's actions) it must have one operation for each; replay
    and diff check instead that each action a recording uses has an operation.
    """
    text = str(spec)
    if text in BUILTIN_SHIELDS:
        path, name = SHIELD_DIR / f"{text}.mch", text
        if not path.exists():
            raise InputError(f"the built-in shield {text} is not installed at {path}; "
                             "install tracecheck from its source folder (pip install -e .)")
    else:
        path = Path(text)
        if path.suffix != ".mch" and not path.exists():
            raise InputError(f"unknown shield {text!r}: give one of "
                             f"{', '.join(BUILTIN_SHIELDS)} or the path of a .mch file")
        name = path.stem
    machine = load_machine(path)
    missing = [a for a in actions or () if a not in machine.operations]
    if missing:
        raise InputError(f"{path}: a shield needs one operation per action "
                         f"({', '.join(actions)}); {machine.name} lacks {', '.join(missing)}")
    return Shield(name=name, sha256=machine.sha256, path=str(path), machine=machine)
