"""What a run file lists against what it holds, for a reader that walks it.

A walk reads the episodes that are in the data section, one after the other; by itself it
cannot see that some are missing — a block cut out of the middle of a file leaves a file
that walks cleanly, with fewer episodes. Two things the writer leaves say what should be
there, and a walk checks both against what it met:

- **the summary** (MCAP's index at the end of the file), which lists every attachment the
  writer wrote: each episode's columns (``episode-ID.columns``) and each block's run blob
  (``run-N.columns``). The tracecheck attachments it lists must be exactly the ones the data
  section holds, at the offsets it gives, and the summary must start where the data section
  ends. A file without a summary to read (a killed recording) has nothing to check here.
- **the run blobs' names**: the blob ``run-N.columns`` closes a block after the file's
  first N episodes, so exactly N episodes' columns must come before it.

A file that fails either was cut or edited after it was written: an error naming what the
summary lists and what the file holds (with ``--salvage``, a warning, and the episodes it
holds are read). Positions are compared, names only described: a summary another MCAP tool
rewrote lists its own file's offsets.
"""

from __future__ import annotations

import re
from array import array
from typing import Optional

from .codec import COLUMNS_MEDIA_TYPE, RUN_COLUMNS_MEDIA_TYPE
from .records import Attachment, attachment_name, summary_listing

__all__ = ["Holdings", "CUT_HINT"]

_RUN_NAME = re.compile(r"run-(\d{1,18})\.columns")
_EPISODE_NAME = re.compile(r"episode-(-?\d{1,19})\.columns")
_KINDS = {COLUMNS_MEDIA_TYPE: 0, RUN_COLUMNS_MEDIA_TYPE: 1}  # an episode's, a block's

#: what to do about a file whose summary or run blobs say episodes are missing
CUT_HINT = ("read a copy of the file as it was written; --salvage reads the episodes it holds, "
            "with a warning")


class Holdings:
    """The tracecheck attachments a walk met, in order (their offsets and kinds only: a
    campaign has 10^5 of them), and the first run blob whose name does not fit them."""

    def __init__(self) -> None:
        self.offsets = array("q")
        self.kinds = bytearray()
        self.unplaced: dict[int, str] = {}  # the names of those met inside a chunk
        self.episodes = 0
        self.misnamed: Optional[str] = None

    def met(self, record: Attachment) -> None:
        """Note an attachment the walk met (others than tracecheck's are not noted)."""
        kind = _KINDS.get(record.media_type)
        if kind is None:
            return
        if record.at < 0:
            self.unplaced[len(self.offsets)] = record.name
        self.offsets.append(record.at)
        self.kinds.append(kind)
        if kind == 0:
            self.episodes += 1
            return
        named = _RUN_NAME.fullmatch(record.name)
        if named and int(named[1]) != self.episodes and self.misnamed is None:
            n, held = int(named[1]), self.episodes
            self.misnamed = (
                f"the run blob {record.name} closes a block after the file's first {n} "
                f"episodes, but {held} come before it: "
                + (f"{n - held} episode(s) are missing before it" if n > held else
                   f"{held - n} episode(s) more than were written come before it"))

    def problem(self, buf, data_end: Optional[int]) -> Optional[str]:
        """What is wrong, in words, where the summary (read from ``data_end``, where the
        walk met the end of the data section; None: it did not) or a run blob's name
        disagrees with what the walk met; None where they agree."""
        found = self._summary_problem(buf, data_end) if data_end is not None else None
        why = found or self.misnamed
        return None if why is None else f"{why} — the file was cut or edited after it was written"

    def _summary_problem(self, buf, data_end: int) -> Optional[str]:
        summary = summary_listing(buf, data_end)
        if summary is None:
            return None
        start, listed = summary
        listed = [(o, n, _KINDS[m]) for o, n, m in listed if m in _KINDS]
        if not listed:
            return None  # a summary that indexes no attachments: nothing to compare
        if start == data_end and [o for o, _, _ in listed] == self.offsets.tolist() \
                and bytes(k for _, _, k in listed) == bytes(self.kinds):
            return None
        found = [(o, self.unplaced[i] if o < 0 else attachment_name(buf, o), k)
                 for i, (o, k) in enumerate(zip(self.offsets, self.kinds))]
        return _difference(listed, found, start, data_end)


def _difference(listed: list, found: list, start: int, data_end: int) -> str:
    """How the summary's attachments (``listed``) and the walk's (``found``), each
    (offset, name, kind), differ: the episodes one has and the other not, by id and block,
    else the first that lies elsewhere."""
    said, held = _episodes(listed), _episodes(found)
    head = (f"the file's summary lists {_count(said, listed)}, but its data section holds "
            f"{_count(held, found)}")
    missing = [(name, block) for name, block in said if name not in {n for n, _ in held}]
    extra = [name for name, _ in held if name not in {n for n, _ in said}]
    parts = []
    if missing:
        blocks = sorted({b for _, b in missing})
        parts.append(f"episode(s) {_ids([n for n, _ in missing])} "
                     f"(block{'s' if len(blocks) > 1 else ''} "
                     f"{', '.join(map(str, blocks))}) are missing")
    if extra:
        parts.append(f"episode(s) {_ids(extra)} are not in the summary")
    if not parts:
        moved = next(((a, b) for a, b in zip(listed, found) if a[0] != b[0]), None)
        parts.append(f"its summary puts {moved[0][1]} at byte {moved[0][0]}, the file holds it "
                     f"at byte {moved[1][0]}" if moved else
                     f"its footer puts the summary at byte {start}, the data section ends at "
                     f"byte {data_end}")
    return f"{head}: {'; '.join(parts)}"


def _episodes(entries: list) -> list[tuple[str, int]]:
    """(name, block) of each episode's columns among ``entries``, the block counted by the
    run blobs before it."""
    out, block = [], 0
    for _, name, kind in entries:
        if kind == 0:
            out.append((name, block))
        else:
            block += 1
    return out


def _count(episodes: list, entries: list) -> str:
    blobs = sum(kind for _, _, kind in entries)
    said = (f"{len(episodes)} episode(s) ({_ids([n for n, _ in episodes])})" if episodes
            else "no episode")
    return said + (f" in {blobs} block(s)" if blobs else "")


def _ids(names: list[str], most: int = 8) -> str:
    """Episode ids (from their columns' names) as ranges: ``0–7, 12–19``."""
    ids = []
    for name in names:
        m = _EPISODE_NAME.fullmatch(name)
        ids.append(int(m[1]) if m else name)
    ranges: list[list] = []
    for i in ids:
        if ranges and isinstance(i, int) and isinstance(ranges[-1][1], int) \
                and i == ranges[-1][1] + 1:
            ranges[-1][1] = i
        else:
            ranges.append([i, i])
    text = [f"{a}" if a == b else f"{a}–{b}" for a, b in ranges[:most]]
    return ", ".join(text) + (f", … ({len(ids)} in all)" if len(ranges) > most else "")
