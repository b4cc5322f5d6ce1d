"""The columnar view of a run file: :func:`read_columns` gives the numpy columns of every
state in a file (for replay and statistics) from the per-episode column attachments, without
decoding a single step message.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, Optional, Sequence

import numpy as np

from ..b.columns import Columns
from ..b.values import Elem
from ..errors import InputError
from .blobs import BLOCK_ROWS, BlobDisagrees, blob_records, verified_block
from .codec import columns_from_arrays, decode_columns, parameter_arrays
from ..errors import DamagedEpisode
from .reader import read_pieces
from .records import forget, mapped

__all__ = ["read_columns", "read_blocks", "take_episodes", "blocks_of", "block_refs", "BlockRef",
           "BlockUnchecked", "join", "RunColumns", "episode_columns", "written_columns"]


@dataclass
class RunColumns:
    """Every state of a file as numpy columns, one row per state (step 0 included).

    ``episode[r]`` and ``step[r]`` say which state row ``r`` is; ``starts[i]`` is the first
    row of the i-th episode (``starts[-1]`` the number of rows). ``action[r]`` indexes
    ``action_names`` (-1 at step 0); ``states`` holds the B variables for
    :meth:`tracecheck.b.Machine.enabled_batch`; ``parameters[p][r]`` the value of parameter
    ``p`` of a continuous action ``action[r]`` (NaN where it has none).
    """

    path: str
    episode_ids: np.ndarray
    starts: np.ndarray
    episode: np.ndarray
    step: np.ndarray
    time: np.ndarray
    action: np.ndarray
    action_names: tuple[str, ...]
    reward: np.ndarray
    crashed: np.ndarray
    states: Columns
    warnings: list[str] = field(default_factory=list)
    values: Optional[np.ndarray] = None  # (rows, actions): the agent's values, NaN if none
    seeds: list[Optional[int]] = field(default_factory=list)  # per episode
    #: per episode, why it ended (its end record: crashed, time-limit, end-of-trace, …)
    reasons: list[str] = field(default_factory=list)
    #: continuous actions, per parameter name: the executed value in each row (NaN where the
    #: row has none: step 0, an action without that parameter); empty for discrete runs
    parameters: dict[str, np.ndarray] = field(default_factory=dict)
    #: … and what the agent proposed before the shield (NaN where none was recorded)
    proposals: dict[str, np.ndarray] = field(default_factory=dict)
    #: how far the shield moved each row's proposal (NaN where none); None if no row has one
    distance: Optional[np.ndarray] = None

    @property
    def n(self) -> int:
        return int(self.starts[-1])


def read_columns(path: str | Path, *, salvage: bool = False) -> RunColumns:
    """All states of a file as numpy columns (see :class:`RunColumns`): its blocks
    (:func:`read_blocks`) joined. A file with a damaged tail gives its complete episodes, with
    the loss described in ``warnings``.

    Args:
        path: a run file.
        salvage: leave out episodes whose parts disagree, with a warning.

    Returns:
        The :class:`RunColumns`.

    >>> len(read_columns("sample_traces/base_none.mcap").episode_ids)  # repo root
    24
    """
    return join(str(path), list(read_blocks(path, salvage=salvage)))


def blocks_of(path: str | Path) -> int:
    """How many blocks the file's run blobs give (0: it has none that fit, it is read whole)."""
    return len(block_refs(path))


@dataclass(frozen=True)
class BlockRef:
    """Block ``index`` of the ``count`` blocks of a file, whose run blob is the record at
    ``offset`` (``size`` bytes): what a Ray task reads, and checks it finds so."""

    index: int
    count: int
    offset: int
    size: int


class BlockUnchecked(InputError):
    """A block a task was sent does not check (damaged, or the file changed since)."""


def block_refs(path: str | Path) -> list[BlockRef]:
    """The blocks of the file's run blobs (none: it has none that fit, it is read whole):
    the units of work of the Ray executor (see :func:`read_blocks`)."""
    with mapped(Path(path)) as buf:
        index = blob_records(buf)
    runs = index.runs if index is not None else []
    return [BlockRef(k, len(runs), o, s) for k, (o, s) in enumerate(runs)]


def read_blocks(path: str | Path, *, salvage: bool = False, block: Optional[BlockRef] = None,
                regions: Optional[list[tuple[int, int]]] = None) -> Iterator[RunColumns]:
    """The states of a file as numpy columns, one block of episodes at a time (each a
    :class:`RunColumns` of its own, rows and episodes counted from 0 in it), so that memory is
    set by the block, not the file: from the file's run blobs where every byte they stand for
    is unchanged (:mod:`tracecheck.episodes.blobs`), else by walking the file episode by
    episode — each episode checked against its header, end record and last step message (see
    :mod:`tracecheck.episodes.reader`) — in blocks of about :data:`BLOCK_ROWS` states.

    ``block``: only that block of :func:`block_refs` (:class:`BlockUnchecked` if the file's
    blobs are no longer those or the block does not check);
    ``regions``: only the episodes in these byte ranges, walked (what :func:`written_columns`
    gives for them as they were written). At least one block comes, empty where the file
    holds no complete episode.
    """
    path = Path(path)
    done = 0  # episodes given from blobs
    notes: list[str] = []  # why a blob that checks was not used
    with mapped(path) as buf:
        index = None if regions else _index(path, buf, block is not None)
        runs = index.runs if index is not None else []
        forget(buf)  # the summary's pages too
        view = memoryview(buf)
        try:
            same = block is None or (len(runs) == block.count
                                     and runs[block.index] == (block.offset, block.size))
            wanted = range(len(runs)) if block is None else [block.index] if same else []
            for k in wanted:
                cols = _from_blob(path, buf, view, index, k, notes)
                forget(buf)  # the pages of the block just read leave this process
                if cols is None:
                    break
                yield cols
                done += len(cols.episode_ids)
            else:
                if wanted:
                    return  # every block from its blob
        finally:
            view.release()
    if block is not None:
        raise BlockUnchecked(f"{path}: block {block.index} of its episodes does not check "
                             "(damaged, or the file changed while it was read)")
    yield from _walked(path, salvage, done, regions, notes)


#: the blob index of the last file read a block at a time, by the file's identity: a worker
#: given block after block of one file reads its summary once (a block whose bytes are not
#: those the index says does not check, and its file is read again whole)
_INDEX: dict[tuple, object] = {}


def _index(path: Path, buf, one_block: bool):
    if not one_block:
        return blob_records(buf)
    st = path.stat()
    key = (str(path.resolve()), st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)
    if key not in _INDEX:
        _INDEX.clear()
        _INDEX[key] = blob_records(buf)
    return _INDEX[key]


def _from_blob(path: Path, buf, view, index, k: int, notes: list[str]
               ) -> Optional[RunColumns]:
    """Block ``k`` of the file from its run blob, or None where the blob does not check —
    or checks but holds otherwise than its episodes' own columns (then ``notes`` says so:
    the blob was edited, or written otherwise than this tracecheck writes blobs)."""
    try:
        found = verified_block(buf, view, index, k)
    except BlobDisagrees as exc:
        notes.append(f"{path}: the run blob of block {k} holds otherwise than its episodes' "
                     f"own columns ({exc}); they were read one by one instead, as render and "
                     "export read them — the blob was edited after the file was written, or "
                     "written otherwise than this tracecheck writes blobs")
        return None
    return None if found is None else _block_columns(path, *found)


def _walked(path: Path, salvage: bool, skip: int, regions=None,
            notes: Optional[list[str]] = None) -> Iterator[RunColumns]:
    """The file's episodes walked record by record (the first ``skip`` left out: they came
    from blobs), in blocks of about :data:`BLOCK_ROWS` states; ``notes``: warnings the first
    block carries."""
    pieces = read_pieces(path, decode=False, salvage=salvage, regions=regions)
    group: list = []
    rows = 0
    given = False
    notes = list(notes or [])
    while True:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", DamagedEpisode)
            piece = next(pieces, None)
        notes += [str(w.message) for w in caught if issubclass(w.category, DamagedEpisode)]
        if piece is not None:
            if skip:
                skip -= 1
                continue
            group.append((piece.head.episode, piece.end.reason, piece.columns))
            rows += len(piece.columns[1]["time"])
        if group and (piece is None or rows >= BLOCK_ROWS) or piece is None and not given:
            yield _pieces_columns(path, group, notes)
            group, rows, notes, given = [], 0, [], True
        if piece is None:
            return


def written_columns(path: str | Path, blobs: Sequence[bytes]) -> RunColumns:
    """The columns of episodes from their columns attachments as a writer made them, in
    order: what walking them in the file gives (:func:`read_blocks` with ``regions``), once
    the file holds them — the writer builds a block's run blob so, from what it wrote."""
    decoded = [decode_columns(blob, where=f"{path}: ") for blob in blobs]
    return _pieces_columns(Path(path), [(h["episode"], h.get("reason"), (h, a))
                                        for h, a in decoded], [])


def _pieces_columns(path: Path, pieces: list, notes: list[str]) -> RunColumns:
    """The columns of walked episodes (each (episode, how it ended, its decoded columns);
    each episode's own actions and elements joined)."""
    parts = []
    literals: dict = {}  # parsed once for the block's episodes
    for ep, reason, (header, arrays) in pieces:
        states = columns_from_arrays(header, arrays, literals, where=f"{path}, episode {ep}: ")
        n = len(arrays["time"])
        parts.append(RunColumns(
            path=str(path), episode_ids=np.array([ep], dtype=np.int64),
            starts=np.array([0, n], dtype=np.int64), episode=np.full(n, ep, dtype=np.int64),
            step=np.arange(n), time=arrays["time"], action=arrays["action"],
            action_names=tuple(header["actions"]), reward=arrays["reward"],
            crashed=arrays["crashed"].astype(bool), states=states, values=arrays.get("values"),
            seeds=[header.get("seed")], reasons=[reason],
            parameters=_prefixed(arrays, "par:"), proposals=_prefixed(arrays, "prop:"),
            distance=arrays.get("dist")))
    joined = join(str(path), parts)
    joined.warnings = list(notes)
    return joined


def _block_columns(path: Path, header: dict, arrays: dict) -> Optional[RunColumns]:
    """The columns of one verified run blob (None: its states do not fit together)."""
    starts, ids = arrays["run:starts"], arrays["run:episodes"]
    body = {k: v for k, v in arrays.items() if not k.startswith("run:")}
    try:
        states = columns_from_arrays(header, body, where=f"{path}: ")
    except (InputError, KeyError, TypeError, ValueError):
        return None
    n = int(starts[-1])
    lengths = np.diff(starts)
    episode = np.repeat(ids, lengths)
    step = np.arange(n) - np.repeat(starts[:-1], lengths)
    states.label = _labels(str(path), episode, step)
    return RunColumns(
        path=str(path), episode_ids=ids, starts=starts, episode=episode, step=step,
        time=body["time"], action=body["action"], action_names=tuple(header["actions"]),
        reward=body["reward"], crashed=body["crashed"].astype(bool), states=states,
        values=body.get("values"), parameters=_prefixed(body, "par:"),
        proposals=_prefixed(body, "prop:"), distance=body.get("dist"),
        seeds=[int(x) if ok else None for x, ok in zip(arrays["run:seeds"].tolist(),
                                                       arrays["run:seeded"].tolist())],
        reasons=[header["reasons"][int(k)] for k in arrays["run:reasons"]])


def _labels(path: str, episode: np.ndarray, step: np.ndarray):
    return lambda i: f"{path}, episode {int(episode[i])}, step {int(step[i])}"


def _prefixed(arrays: dict, prefix: str) -> dict[str, np.ndarray]:
    """The columns named ``prefix + NAME``, by NAME in order."""
    return {k[len(prefix):]: arrays[k] for k in sorted(arrays) if k.startswith(prefix)}


def episode_columns(episodes, action_names) -> RunColumns:
    """The columns of episodes in memory (``simulate`` checks each new one as a run of its
    own), as :func:`read_columns` gives them for a file."""
    episodes = list(episodes)
    steps = [s for ep in episodes for s in ep.steps]
    lengths = [len(ep.steps) for ep in episodes]
    starts = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    ids = np.array([ep.id for ep in episodes], dtype=np.int64)
    index = {a: i for i, a in enumerate(action_names)}
    values = np.full((len(steps), len(action_names)), np.nan)
    for row, s in enumerate(steps):
        for name, q in (s.action_values or {}).items():
            if name in index:
                values[row, index[name]] = q
    episode = np.repeat(ids, lengths)
    return RunColumns(
        path="<memory>", episode_ids=ids, starts=starts, episode=episode,
        step=np.array([s.step for s in steps], dtype=np.int64),
        time=np.array([s.time for s in steps], dtype=float),
        action=np.array([index[s.action] if s.action is not None else -1 for s in steps],
                        dtype=np.int16),
        action_names=tuple(action_names),
        reward=np.array([s.reward for s in steps], dtype=float),
        crashed=np.array([s.crashed for s in steps], dtype=bool),
        states=Columns.from_states([s.state for s in steps]),
        values=values if np.any(~np.isnan(values)) else None,
        seeds=[ep.seed for ep in episodes], reasons=[ep.end.reason for ep in episodes],
        **_continuous(steps))


def take_episodes(cols: RunColumns, ranges: Sequence[tuple[int, int]]) -> RunColumns:
    """Episode ``i`` of ``cols`` cut to its states ``ranges[i]`` (a slice ``lo:hi`` of them,
    as Python slices a list), for the first ``len(ranges)`` episodes: the columns
    :func:`episode_columns` gives for the episodes so cut, taken by row."""
    lengths = np.diff(cols.starts)[:len(ranges)]
    parts, kept = [], []
    for (lo, hi), start, n in zip(ranges, cols.starts.tolist(), lengths.tolist()):
        lo, hi = slice(lo, hi).indices(n)[:2]
        parts.append(np.arange(start + lo, start + max(hi, lo), dtype=np.int64))
        kept.append(max(hi - lo, 0))
    rows = np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)
    k = len(ranges)

    def by_row(named: dict) -> dict:
        return {name: v[rows] for name, v in named.items()}

    values = None if cols.values is None else cols.values[rows]

    return RunColumns(
        path=cols.path, episode_ids=cols.episode_ids[:k],
        starts=np.concatenate([[0], np.cumsum(kept)]).astype(np.int64),
        episode=cols.episode[rows], step=cols.step[rows], time=cols.time[rows],
        action=cols.action[rows], action_names=cols.action_names, reward=cols.reward[rows],
        crashed=cols.crashed[rows], states=cols.states.take(rows),
        values=values if values is not None and np.any(~np.isnan(values)) else None,
        seeds=cols.seeds[:k], reasons=cols.reasons[:k], parameters=by_row(cols.parameters),
        proposals=by_row(cols.proposals),
        distance=None if cols.distance is None else cols.distance[rows])


def _continuous(steps) -> dict:
    """The continuous-action fields of :class:`RunColumns` for steps in memory."""
    arrays = parameter_arrays(len(steps), [s.parameters for s in steps],
                              [s.proposal for s in steps],
                              [s.projection_distance for s in steps])
    return {"parameters": _prefixed(arrays, "par:"), "proposals": _prefixed(arrays, "prop:"),
            "distance": arrays.get("dist")}


def _widen(cols: Columns, elements: list[str]) -> Columns:
    """``cols`` with its element axis in the order of ``elements`` (missing: undefined)."""
    if [str(e) for e in cols.elements] == elements:
        return cols
    where = [elements.index(str(e)) for e in cols.elements]
    k = len(elements)
    out = Columns(n=cols.n, elements=tuple(Elem(e) for e in elements),
                  numbers=cols.numbers, booleans=cols.booleans, others=cols.others)
    for name, (vals, defined) in cols.functions.items():
        v, d = np.zeros((cols.n, k), dtype=vals.dtype), np.zeros((cols.n, k), dtype=bool)
        v[:, where], d[:, where] = vals, defined
        out.functions[name] = (v, d)
    for name, mask in cols.masks.items():
        m = np.zeros((cols.n, k), dtype=bool)
        m[:, where] = mask
        out.masks[name] = m
    return out


def join(path: str, blocks: list[RunColumns]) -> RunColumns:
    """Blocks of one file (or the episodes of one) as one :class:`RunColumns`: actions and
    elements in the order they first appear, a block's missing ones undefined or NaN."""
    if len(blocks) == 1:
        return blocks[0]
    actions = tuple(dict.fromkeys(a for b in blocks for a in b.action_names))
    elements = list(dict.fromkeys(str(e) for b in blocks for e in b.states.elements))
    lengths = [b.n for b in blocks]
    n = sum(lengths)
    widened = [_widen(b.states, elements) for b in blocks]
    _same_variables(path, blocks)
    states = Columns(n=n, elements=tuple(Elem(e) for e in elements))
    if blocks:
        first = widened[0]
        for name in first.numbers:
            states.numbers[name] = np.concatenate([c.numbers[name] for c in widened])
        for name in first.booleans:
            states.booleans[name] = np.concatenate([c.booleans[name] for c in widened])
        for name in first.functions:
            states.functions[name] = (
                np.concatenate([c.functions[name][0] for c in widened]),
                np.concatenate([c.functions[name][1] for c in widened]))
        for name in first.masks:
            states.masks[name] = np.concatenate([c.masks[name] for c in widened])
        for name in first.others:
            states.others[name] = [v for c in widened for v in c.others[name]]
    orders = [[actions.index(a) for a in b.action_names] for b in blocks]

    def cat(arrays, dtype=np.float64):
        return np.concatenate(arrays) if blocks else np.zeros(0, dtype=dtype)

    ids = cat([b.episode_ids for b in blocks], np.int64)
    episode_lengths = np.concatenate([np.diff(b.starts) for b in blocks]) if blocks else []
    starts = np.concatenate([[0], np.cumsum(episode_lengths)]).astype(np.int64)
    episode, step = cat([b.episode for b in blocks], np.int64), cat([b.step for b in blocks],
                                                                    np.int64)
    states.label = _labels(path, episode, step)
    out = RunColumns(
        path=path, episode_ids=ids, starts=starts, episode=episode, step=step,
        time=cat([b.time for b in blocks]),
        action=cat([np.array(o + [-1], dtype=np.int16)[b.action]
                    for o, b in zip(orders, blocks)], np.int16),
        action_names=actions, reward=cat([b.reward for b in blocks]),
        crashed=cat([b.crashed for b in blocks], bool), states=states,
        warnings=[w for b in blocks for w in b.warnings],
        seeds=[s for b in blocks for s in b.seeds],
        reasons=[r for b in blocks for r in b.reasons])
    if any(b.values is not None for b in blocks):
        values = np.full((n, len(actions)), np.nan)
        row = 0
        for o, b in zip(orders, blocks):
            if b.values is not None:
                values[row:row + b.n, o] = b.values
            row += b.n
        out.values = values
    out.parameters = _joined_by_name([(b.n, b.parameters) for b in blocks])
    out.proposals = _joined_by_name([(b.n, b.proposals) for b in blocks])
    if any(b.distance is not None for b in blocks):
        out.distance = _joined_by_name([(b.n, {"": b.distance} if b.distance is not None
                                         else {}) for b in blocks])[""]
    return out


#: what each kind of column holds, in words
_KIND_WORDS = {"numbers": "a number", "booleans": "a boolean",
               "functions": "a function of set elements", "masks": "a set of elements",
               "others": "a value of another kind"}


def _kinds(cols: Columns) -> dict[str, str]:
    return {name: kind for kind in _KIND_WORDS for name in getattr(cols, kind)}


def _same_variables(path: str, blocks: list[RunColumns]) -> None:
    """The blocks (or episodes) of a file have the same variables, each of one kind: else an
    error naming the variable and an episode where it differs (never one kind silently
    taken for all)."""
    first = _kinds(blocks[0].states) if blocks else {}
    for b in blocks[1:]:
        mine = _kinds(b.states)
        if mine == first:
            continue
        name = next(v for v in sorted(set(first) | set(mine)) if first.get(v) != mine.get(v))
        e0 = int(blocks[0].episode_ids[0]) if len(blocks[0].episode_ids) else "?"
        ep = int(b.episode_ids[0]) if len(b.episode_ids) else "?"
        if name in first and name in mine:
            what = (f"is {_KIND_WORDS[first[name]]} in episode {e0} and "
                    f"{_KIND_WORDS[mine[name]]} in episode {ep}")
        else:
            what = (f"is in episode {e0} but not in episode {ep}" if name in first
                    else f"is in episode {ep} but not in episode {e0}")
        raise InputError(f"{path}: the variable {name} {what}; the episodes of a file must "
                         "have the same variables, each of one kind")


def _joined_by_name(parts: list[tuple[int, dict[str, np.ndarray]]]) -> dict[str, np.ndarray]:
    """Columns by name of parts of ``n`` rows each, NaN where a part has none by that name."""
    names = sorted({name for _, cols in parts for name in cols})
    return {name: np.concatenate([cols.get(name, np.full(n, np.nan)) for n, cols in parts])
            for name in names}
