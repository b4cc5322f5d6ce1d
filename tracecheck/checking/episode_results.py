"""What replay found in each episode: :class:`EpisodeReplay`, and a report's episodes kept
compactly (:class:`EpisodeRows`)."""

from __future__ import annotations

import dataclasses
from array import array
from dataclasses import dataclass
from typing import Iterable, Iterator, Optional, Sequence

__all__ = ["EpisodeReplay", "EpisodeRows"]


@dataclass(frozen=True, slots=True)  # slots: a campaign holds 10^5 of them
class EpisodeReplay:
    """What replay found in one episode (steps are numbered from the initial state 0)."""

    file: str
    episode: int
    steps: int
    first_infeasible: Optional[int]
    action: Optional[str]
    enabled: Optional[list[str]]
    alternative: Optional[str]
    infeasible_steps: int
    crashed: bool
    crash_step: Optional[int]
    crash_after_infeasible: bool
    deadlock_states: list[int]
    postcondition_violations: list[int]
    invariant_violations: list[int]
    #: a continuous action at the first infeasible step: its recorded parameter values, the
    #: values the shield allowed there (``a ∈ [-4.0, 0.3)``), how far outside they lay
    #: (Euclidean, in the parameters' units; None: see ``margin_note``) …
    parameters: Optional[dict[str, float]] = None
    allowed: Optional[str] = None
    margin: Optional[float] = None
    #: … why there is no margin (nothing allowed, the allowed set not boxes, a guard not
    #: linear in the parameters)
    margin_note: Optional[str] = None
    #: the largest margin over the episode's infeasible continuous actions
    max_margin: Optional[float] = None

    @property
    def matters(self) -> bool:
        return (self.crashed or self.first_infeasible is not None or bool(self.deadlock_states)
                or bool(self.postcondition_violations) or bool(self.invariant_violations))


class EpisodeRows(Sequence[EpisodeReplay]):
    """A report's episodes, in order, as a list of :class:`EpisodeReplay` behaves: kept
    compactly. An episode in which nothing happened is the one record of such an episode of
    its length (8 bytes to refer to) and its id (8 bytes), made whole only when read: a
    campaign of 10^5 episodes, most of them quiet, held 20 MB of records otherwise."""

    __slots__ = ("_items", "_ids")

    def __init__(self, items: Iterable[EpisodeReplay] = ()) -> None:
        self._items: list[EpisodeReplay] = []
        self._ids = array("q")
        self.extend(items)

    def append(self, e: EpisodeReplay) -> None:
        self._items.append(e)
        self._ids.append(e.episode)

    def append_as(self, like: EpisodeReplay, episode: int) -> None:
        """Episode ``episode``: ``like`` but for its id."""
        self._items.append(like)
        self._ids.append(episode)

    def extend(self, es: Iterable[EpisodeReplay]) -> None:
        if isinstance(es, EpisodeRows):
            self._items += es._items
            self._ids += es._ids
        else:
            for e in es:
                self.append(e)

    def __iadd__(self, es: Iterable[EpisodeReplay]) -> "EpisodeRows":
        self.extend(es)
        return self

    def __len__(self) -> int:
        return len(self._items)

    def _at(self, k: int) -> EpisodeReplay:
        e, ep = self._items[k], self._ids[k]
        return e if e.episode == ep else dataclasses.replace(e, episode=ep)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self._at(i) for i in range(*k.indices(len(self)))]
        return self._at(k)

    def __setitem__(self, k: int, e: EpisodeReplay) -> None:
        self._items[k] = e
        self._ids[k] = e.episode

    def __iter__(self) -> Iterator[EpisodeReplay]:
        replace = dataclasses.replace
        for e, ep in zip(self._items, self._ids):
            yield e if e.episode == ep else replace(e, episode=ep)

    def records(self) -> Iterator[EpisodeReplay]:
        """The records as kept, for what does not depend on an episode's id (a quiet one
        may carry another's)."""
        return iter(self._items)

    def __eq__(self, other) -> bool:
        if isinstance(other, (EpisodeRows, list)):
            return len(self) == len(other) and all(a == b for a, b in zip(self, other))
        return NotImplemented

    def __repr__(self) -> str:
        return f"EpisodeRows({list(self)!r})"
