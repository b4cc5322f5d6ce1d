"""The run blobs a writer leaves in a file: each holds the columns of one *block* of episodes
(a new block every :data:`BLOCK_ROWS` states or so, and one at the end), with the byte span
of each of its episodes' records and their CRC-32s, and the CRC-32 of everything before the
first episode.

A block is taken from its blob only where every byte it stands for is as written: its
episodes' records follow each other from the end of the previous blob (for the first block:
from the file's head) up to its own blob, each with its checksum, each ending with the
columns the file's summary lists there — and where each episode's own columns hold exactly
the blob's rows for it (:mod:`tracecheck.episodes.agreement`: the checksums alone are the
blob's word). Files from before blocks have one blob for the whole file: one block. A reader
that finds a blob that does not fit walks the file episode by episode instead, which finds
and names whatever changed.
"""

from __future__ import annotations

import zlib
from typing import NamedTuple, Optional

import numpy as np

from ..errors import InputError
from .agreement import block_agrees
from .codec import COLUMNS_MEDIA_TYPE, RUN_COLUMNS_MEDIA_TYPE, arrays_of, unpack_columns
from .model import END_REASONS
from .column_checks import check_columns
from .records import DATA_END, attachment_at, indexed_attachments

__all__ = ["BLOCK_ROWS", "BlobIndex", "BlobDisagrees", "blob_records", "verified_block"]

#: a writer closes a block once its episodes hold this many states: a reader's memory is
#: set by the block, not by the file (about 20 MB of numpy columns for 10⁴ episodes of five vehicles)
BLOCK_ROWS = 1 << 15


class BlobIndex(NamedTuple):
    """The run blobs of a file and its episodes' columns, as its summary lists them."""

    #: (offset, size) of each run blob's record, in order
    runs: list[tuple[int, int]]
    #: (offset, size) of each episode's columns attachment record, in order
    episodes: np.ndarray


def blob_records(buf) -> Optional[BlobIndex]:
    """The run blobs and episodes' columns the file's summary lists; None where it lists no
    blob, another attachment (an episode's columns) comes after the last one (the writer
    stopped writing blobs), or the data section does not end right after it: the file is
    then walked."""
    index = indexed_attachments(buf, RUN_COLUMNS_MEDIA_TYPE, also=COLUMNS_MEDIA_TYPE)
    if index is None:
        return None
    runs, other, episodes = index
    # the data section ends right after the last blob: no record (an episode) follows it
    if not runs or other > runs[-1][0] or sum(runs[-1]) >= len(buf) \
            or buf[sum(runs[-1])] != DATA_END:
        return None
    episodes = np.frombuffer(episodes, dtype=np.int64).reshape(-1, 2)
    return BlobIndex(runs, episodes[np.argsort(episodes[:, 0], kind="stable")])


def _listed(index: BlobIndex, k: int) -> np.ndarray:
    """(offset, size) of the episodes' columns the summary lists between run blob ``k`` and
    the one before it (for the first: from the file's start)."""
    runs, offsets = index.runs, index.episodes[:, 0]
    lo = sum(runs[k - 1]) if k else 0
    return index.episodes[np.searchsorted(offsets, lo):np.searchsorted(offsets, runs[k][0])]


class BlobDisagrees(Exception):
    """A run blob that checks (its checksums, its episodes where the summary lists them)
    holds other than its episodes' own columns: the message says where."""


def verified_block(buf, view, index: BlobIndex, k: int) -> Optional[tuple[dict, dict]]:
    """The header and arrays of block ``k`` of ``index`` (:func:`blob_records`) where it
    fits together, every byte it stands for is as written, and its episodes are the ones the
    summary lists before its blob; else None. Raises :class:`BlobDisagrees` where all that
    holds but its episodes' own columns hold otherwise than it."""
    blob = attachment_at(buf, *index.runs[k], RUN_COLUMNS_MEDIA_TYPE)
    if blob is None:
        return None
    try:
        packed = unpack_columns(blob)
        header, arrays = packed.header, arrays_of(packed)
        listed = _listed(index, k)
        if not (_shaped(header, arrays) and _in_place(index, k, arrays["run:spans"], listed)
                and _as_written(view, header, arrays, k) and _rows_fit(header, arrays)):
            return None
    except (InputError, KeyError, TypeError, ValueError):
        return None
    why = block_agrees(buf, packed, arrays, listed)
    if why is not None:  # checks, but is not what its episodes' own columns hold
        raise BlobDisagrees(why)
    return header, arrays


def _shaped(header: dict, arrays: dict) -> bool:
    """The blob's arrays of episodes: one row each (of distinct ids, of at least one
    state), as many as it says."""
    spans, starts, ids = arrays["run:spans"], arrays["run:starts"], arrays["run:episodes"]
    e = len(ids)
    return bool(header.get("run") is True and e and spans.shape == (e, 2)
                and arrays["run:span_crcs"].shape == arrays["run:seeds"].shape
                == arrays["run:seeded"].shape == (e,)
                and _reasons_fit(header, arrays, e)
                and starts.shape == (e + 1,) and starts[0] == 0
                and np.all(np.diff(starts) > 0) and len(np.unique(ids)) == e)


def _in_place(index: BlobIndex, k: int, spans: np.ndarray, listed: np.ndarray) -> bool:
    """The block's episodes' records follow each other from the previous blob (or the
    file's head) to its own blob's record, and end with the columns the summary lists
    there (``listed``), one each."""
    runs = index.runs
    first = int(spans[0, 0])
    return bool(0 < first and np.all(spans[:, 0] < spans[:, 1])
                and np.array_equal(spans[1:, 0], spans[:-1, 1]) and spans[-1, 1] == runs[k][0]
                and (k == 0 or first == sum(runs[k - 1]))
                and np.array_equal(listed[:, 0] + listed[:, 1], spans[:, 1]))


def _as_written(view, header: dict, arrays: dict, k: int) -> bool:
    """The head (schemas, channels, run header: the first block starts right after it, a
    later one names where it ends) and each of the block's episodes as their checksums
    say."""
    spans = arrays["run:spans"]
    first = int(spans[0, 0])
    head_end = header.get("head_end", first if k == 0 else None)
    if (type(head_end) is not int or not 0 < head_end <= first
            or (k == 0 and head_end != first)
            or zlib.crc32(view[:head_end]) != header.get("head_crc")):
        return False
    return all(zlib.crc32(view[a:b]) == crc for (a, b), crc in zip(
        spans.tolist(), arrays["run:span_crcs"].tolist()))


def _rows_fit(header: dict, arrays: dict) -> bool:
    """The blob's columns as a reader relies on them (an InputError if not), one row per
    state, no action exactly at each step 0."""
    starts = arrays["run:starts"]
    body = {k: v for k, v in arrays.items() if not k.startswith("run:")}
    check_columns({**header, "episode": 0}, body, first_action=False)
    n = int(starts[-1])
    starting = np.zeros(n, dtype=bool)
    starting[starts[:-1]] = True
    return len(body["time"]) == n and np.array_equal(body["action"] == -1, starting)


def _reasons_fit(header: dict, arrays: dict, episodes: int) -> bool:
    """The blob names each episode's end reason (files written before it did: walked)."""
    names, codes = header.get("reasons"), arrays.get("run:reasons")
    return (isinstance(names, list) and all(n in END_REASONS for n in names)
            and codes is not None and codes.shape == (episodes,) and codes.dtype.kind == "i"
            and bool(np.all((codes >= 0) & (codes < len(names)))))
