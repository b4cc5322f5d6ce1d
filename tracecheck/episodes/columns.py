"""The columnar view of a run file: :func:`read_columns` gives the numpy columns of every
state in a file (for replay and statistics) from the per-episode column attachments, without
decoding a single step message.
"""

from __future__ import annotations

import warnings
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

from ..b.columns import Columns
from ..b.values import Elem
from ..errors import InputError
from .model import END_REASONS
from .codec import (RUN_COLUMNS_MEDIA_TYPE, columns_from_arrays, decode_columns,
                    parameter_arrays)
from ..errors import DamagedEpisode
from .reader import check_columns, read_pieces
from .records import find_attachment, mapped

__all__ = ["read_columns", "RunColumns", "episode_columns"]


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
    """All states of a file as numpy columns (see :class:`RunColumns`).

    Decodes only the per-episode column attachments (each checked against its episode's
    header, end record and last step message, see :mod:`tracecheck.episodes.reader`); a file
    with a damaged tail gives its complete episodes, with the loss described in ``warnings``.
    """
    path = Path(path)
    whole = _from_run_columns(path)
    if whole is not None:
        return whole
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DamagedEpisode)
        decoded, reasons = [], []
        for piece in read_pieces(path, decode=False, salvage=salvage):
            decoded.append((piece.head.episode, *piece.columns))
            reasons.append(piece.end.reason)
    notes = [str(w.message) for w in caught if issubclass(w.category, DamagedEpisode)]
    actions: list[str] = []
    elements: list[str] = []
    for _, header, _ in decoded:
        actions += [a for a in header["actions"] if a not in actions]
        elements += [e for e in header["elements"] if e not in elements]
    parts = []
    values = []
    literals: dict = {}
    for ep, header, arrays in decoded:
        order = [actions.index(a) for a in header["actions"]]
        remap = np.array(order + [-1], dtype=np.int16)
        cols = columns_from_arrays(header, arrays, literals,
                                   where=f"{path}, episode {ep}: ")
        parts.append((ep, arrays, remap[arrays["action"]], _widen(cols, elements)))
        table = np.full((len(arrays["time"]), len(actions)), np.nan)
        if "values" in arrays:
            table[:, order] = arrays["values"]
        values.append(table)
    result = _concatenate(str(path), parts, tuple(actions), tuple(Elem(e) for e in elements),
                          notes)
    if any("values" in arrays for _, _, arrays in decoded):
        result.values = np.concatenate(values)
    pieces = [arrays for _, _, arrays in decoded]
    result.parameters = _joined(pieces, "par:")
    result.proposals = _joined(pieces, "prop:")
    result.distance = _joined(pieces, "dist").get("")
    result.seeds = [header.get("seed") for _, header, _ in decoded]
    result.reasons = reasons
    return result


def _joined(pieces: list[dict], prefix: str) -> dict[str, np.ndarray]:
    """The columns named ``prefix + NAME`` of the episodes' arrays, one after the other, by
    NAME; NaN in the rows of an episode without one (episodes of a file may differ in which
    parameters their actions have)."""
    def column(arrays: dict, name: str) -> np.ndarray:
        found = arrays.get(prefix + name)
        return np.full(len(arrays["time"]), np.nan) if found is None else found

    names = sorted({k[len(prefix):] for arrays in pieces for k in arrays if k.startswith(prefix)})
    return {name: np.concatenate([column(arrays, name) for arrays in pieces]) for name in names}


def _from_run_columns(path: Path) -> Optional[RunColumns]:
    """The whole file from the blob its writer left when it closed the file — only if every
    byte before the blob is unchanged: the blob's own CRC, the CRC-32 of each episode's
    records (header to columns attachment, one after the other up to the blob) and of
    everything before the first episode. Otherwise None: the reader walks the file episode by
    episode, finding and naming whatever changed, so both ways give the same answer."""
    with mapped(path) as buf:
        view = memoryview(buf)
        try:
            found = _verified_blob(buf, view)
        finally:
            view.release()
    if found is None:
        return None
    header, arrays = found
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
    states.label = lambda i: f"{path}, episode {int(episode[i])}, step {int(step[i])}"
    return RunColumns(
        path=str(path), episode_ids=ids, starts=starts, episode=episode, step=step,
        time=body["time"], action=body["action"], action_names=tuple(header["actions"]),
        reward=body["reward"], crashed=body["crashed"].astype(bool), states=states,
        values=body.get("values"), parameters=_joined([body], "par:"),
        proposals=_joined([body], "prop:"), distance=body.get("dist"),
        seeds=[int(x) if ok else None for x, ok in zip(arrays["run:seeds"].tolist(),
                                                       arrays["run:seeded"].tolist())],
        reasons=[header["reasons"][int(k)] for k in arrays["run:reasons"]])


def _verified_blob(buf, view) -> Optional[tuple[dict, dict]]:
    """The run blob's header and arrays where it fits together and every byte it stands for
    is as written (see :func:`_from_run_columns`)."""
    found = find_attachment(buf, RUN_COLUMNS_MEDIA_TYPE)
    if found is None:
        return None
    offset, blob = found
    try:
        header, arrays = decode_columns(blob)
        spans, crcs = arrays["run:spans"], arrays["run:span_crcs"]
        starts, ids = arrays["run:starts"], arrays["run:episodes"]
        e = len(ids)
        if not (header.get("run") is True and e and spans.shape == (e, 2)
                and crcs.shape == arrays["run:seeds"].shape == arrays["run:seeded"].shape == (e,)
                and _reasons_fit(header, arrays, e)
                and starts.shape == (e + 1,) and starts[0] == 0
                and np.all(np.diff(starts) > 0) and len(np.unique(ids)) == e):
            return None
        # the episodes' records follow each other from the first to the blob's record
        if not (0 < spans[0, 0] and np.all(spans[:, 0] < spans[:, 1])
                and np.array_equal(spans[1:, 0], spans[:-1, 1]) and spans[-1, 1] == offset):
            return None
        if zlib.crc32(view[:int(spans[0, 0])]) != header.get("head_crc") or any(
                zlib.crc32(view[a:b]) != crc for (a, b), crc in zip(spans.tolist(),
                                                                    crcs.tolist())):
            return None
        body = {k: v for k, v in arrays.items() if not k.startswith("run:")}
        check_columns({**header, "episode": 0}, body, first_action=False)
        n = int(starts[-1])
        first = np.zeros(n, dtype=bool)
        first[starts[:-1]] = True
        if len(body["time"]) != n or not np.array_equal(body["action"] == -1, first):
            return None  # one row per state, no action exactly at each step 0
    except (InputError, KeyError, TypeError, ValueError):
        return None
    return header, arrays


def _reasons_fit(header: dict, arrays: dict, episodes: int) -> bool:
    """The blob names each episode's end reason (files written before it did: walked)."""
    names, codes = header.get("reasons"), arrays.get("run:reasons")
    return (isinstance(names, list) and all(n in END_REASONS for n in names)
            and codes is not None and codes.shape == (episodes,) and codes.dtype.kind == "i"
            and bool(np.all((codes >= 0) & (codes < len(names)))))


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


def _continuous(steps) -> dict:
    """The continuous-action fields of :class:`RunColumns` for steps in memory."""
    arrays = parameter_arrays(len(steps), [s.parameters for s in steps],
                              [s.proposal for s in steps],
                              [s.projection_distance for s in steps])
    return {"parameters": _joined([arrays], "par:"), "proposals": _joined([arrays], "prop:"),
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
        v, d = np.zeros((cols.n, k)), np.zeros((cols.n, k), dtype=bool)
        v[:, where], d[:, where] = vals, defined
        out.functions[name] = (v, d)
    for name, mask in cols.masks.items():
        m = np.zeros((cols.n, k), dtype=bool)
        m[:, where] = mask
        out.masks[name] = m
    return out


def _concatenate(path: str, parts, actions, elements, notes) -> RunColumns:
    lengths = [len(arrays["time"]) for _, arrays, _, _ in parts]
    starts = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    n = int(starts[-1])
    ids = np.array([ep for ep, _, _, _ in parts], dtype=np.int64)

    def cat(key):
        return (np.concatenate([arrays[key] for _, arrays, _, _ in parts]) if parts
                else np.zeros(0))

    states = Columns(n=n, elements=elements)
    if parts:
        first = parts[0][3]
        for name in first.numbers:
            states.numbers[name] = np.concatenate([c.numbers[name] for *_, c in parts])
        for name in first.booleans:
            states.booleans[name] = np.concatenate([c.booleans[name] for *_, c in parts])
        for name in first.functions:
            states.functions[name] = (
                np.concatenate([c.functions[name][0] for *_, c in parts]),
                np.concatenate([c.functions[name][1] for *_, c in parts]))
        for name in first.masks:
            states.masks[name] = np.concatenate([c.masks[name] for *_, c in parts])
        for name in first.others:
            states.others[name] = [v for *_, c in parts for v in c.others[name]]
    episode = np.repeat(ids, lengths)
    step = np.concatenate([np.arange(m) for m in lengths]) if parts else np.zeros(0, np.int64)
    states.label = lambda i: f"{path}, episode {int(episode[i])}, step {int(step[i])}"
    return RunColumns(
        path=path, episode_ids=ids, starts=starts,
        episode=episode, step=step,
        time=cat("time"), action=np.concatenate([a for _, _, a, _ in parts]) if parts
        else np.zeros(0, dtype=np.int16), action_names=actions, reward=cat("reward"),
        crashed=cat("crashed").astype(bool), states=states, warnings=notes)
