"""The state vocabulary runs are read in: :class:`Vocabulary`, the variables and actions an
episode may use (a machine's, or an environment's: its adapter's
:meth:`~tracecheck.live.adapter.EnvAdapter.vocabulary`)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Vocabulary"]


@dataclass(frozen=True)
class Vocabulary:
    """The variables and actions an episode may use, the machine's name, and the name of its
    set of elements that ProB's traces list (``""``: none).

    >>> Vocabulary(("x",), ("Left", "Right"), "Corridor").actions
    ('Left', 'Right')
    """

    variables: tuple[str, ...]
    actions: tuple[str, ...]
    name: str
    set_name: str = ""
