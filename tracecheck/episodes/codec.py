"""Encodings: B states as JSON for step messages, and episodes as binary numpy columns.

The columns blob (one MCAP attachment per episode, media type
``application/x-tracecheck-columns``) is ``b"TCC3"``, a little-endian uint64 size, then
compressed with zstd (MCAP never compresses attachments itself) a uint32 header length, a
JSON header naming each array (dtype, shape, offset) and the raw array bytes, and last a
CRC-32 of all of it. Reading it is one decompression and a few ``numpy.frombuffer`` calls, so a
1000-episode file loads in a fraction of a second. ``TCC2`` (the same, uncompressed) and
``TCC1`` (without the CRC) blobs of older files are still read.
"""

from __future__ import annotations

import math
import struct
import zlib
from typing import Any, Mapping, NamedTuple, Optional, Sequence

import numpy as np
import orjson

from ..b.notation import from_json, parse_literal
from ..b.values import Elem, FuncValue, format_value
from ..b.columns import Columns
from ..errors import InputError, TracecheckError
from ..identity import ByIdentity
from .frames import unzstd, zstd
from .model import END_REASONS

__all__ = ["encode_state", "decode_state", "encode_columns", "decode_columns",
           "unpack_columns", "arrays_of", "Packed", "encode_run_columns", "parameter_arrays",
           "COLUMNS_MEDIA_TYPE", "RUN_COLUMNS_MEDIA_TYPE"]

COLUMNS_MEDIA_TYPE = "application/x-tracecheck-columns"
#: every episode of a file in one blob, written when the file is closed
RUN_COLUMNS_MEDIA_TYPE = "application/x-tracecheck-run-columns"
_MAGIC = b"TCC3"  # zstd-compressed arrays
_PLAIN_MAGIC = b"TCC2"  # files before compression: still read
_OLD_MAGIC = b"TCC1"  # … and before checksums
#: arrays may decompress to at most this many times their compressed size (plus 1 MiB)
_MAX_RATIO = 1000
_ZSTD_LEVEL = 3


def encode_value(value: Any) -> Any:
    """A B value as JSON (see :mod:`tracecheck.episodes.schema`)."""
    if isinstance(value, bool) or isinstance(value, int):
        return value
    if isinstance(value, float):
        if math.isnan(value) or math.isinf(value):
            raise InputError(f"the value {value} cannot be stored: B has no NaN or infinity")
        return value
    if isinstance(value, Elem):
        return str(value)
    if isinstance(value, FuncValue) and all(isinstance(k, Elem) for k in value.map):
        return {str(k): encode_value(v) for k, v in value.map.items()}
    if isinstance(value, frozenset) and all(isinstance(v, Elem) for v in value):
        return sorted(str(v) for v in value)
    return _literal(value)


_RECENT: ByIdentity[str] = ByIdentity(64)


def _literal(value: Any) -> str:
    """``format_value``, remembered for the same set: a grid world's map is one object
    in every step of an episode, and writing it out is the costly part of a step."""
    text = _RECENT.get(value)
    if text is not None:
        return text
    text = format_value(value)
    return _RECENT.put(value, text) if isinstance(value, frozenset) else text


def encode_state(state: Mapping[str, Any]) -> dict[str, Any]:
    out = {}
    for name, value in state.items():
        try:
            out[name] = encode_value(value)
        except TracecheckError as exc:
            raise InputError(f"variable {name}: {exc.message}", hint=exc.hint) from None
    return out


def decode_state(data: Mapping[str, Any], *, where: str = "") -> dict[str, Any]:
    """The B values of a state stored by :func:`encode_state`."""
    out = {}
    for name, value in data.items():
        if isinstance(value, dict) and all(type(v) is int or type(v) is float and
                                           math.isfinite(v) for v in value.values()):
            out[name] = FuncValue({Elem(k): v for k, v in value.items()})
        elif isinstance(value, list) and all(isinstance(v, str) and v.isidentifier()
                                             for v in value):
            out[name] = frozenset(Elem(v) for v in value)
        elif type(value) is str and len(value) >= _LONG:
            read = _READ.get(value)
            if read is None:  # not read before (or not readable: said each time)
                read = from_json(value, where=f"{where}variable {name}")
                if len(_READ) >= 64:
                    _READ.clear()
                _READ[value] = read
            out[name] = read
        else:
            out[name] = from_json(value, where=f"{where}variable {name}")
    return out


#: long literals read, by their text: a grid world's map is the same text at every step
#: (reading its 64 cells again was nearly all of reading such a file's episodes), and the
#: same text is the same value — one object, immutable
_READ: dict[str, Any] = {}
_LONG = 64


# ------------------------------------------------------------------ columns


def encode_columns(episode: int, times: Sequence[float], actions: Sequence[Optional[str]],
                   rewards: Sequence[float], crashed: Sequence[bool], cols: Columns,
                   action_names: Sequence[str],
                   values: Optional[Sequence[Optional[Mapping[str, float]]]] = None,
                   seed: Optional[int] = None, checksums: Optional[dict] = None, *,
                   parameters: Optional[Sequence[Optional[Mapping[str, float]]]] = None,
                   proposals: Optional[Sequence[Optional[Mapping[str, float]]]] = None,
                   distances: Optional[Sequence[Optional[float]]] = None,
                   reason: Optional[str] = None) -> bytes:
    """One episode's steps as a binary columns blob (``values``: the agent's action values
    per step, when recorded; ``checksums``: CRC-32s of the episode's messages and the run
    header, so that readers find a changed byte anywhere in the episode; ``parameters``,
    ``proposals``, ``distances``: a continuous action's values, the agent's proposal and
    how far the shield moved it, per step — see :func:`parameter_arrays`; ``reason``: why
    it ended, as its end record says, so that a run blob's is checked against it)."""
    index = {a: i for i, a in enumerate(action_names)}
    arrays: dict[str, np.ndarray] = {
        "time": np.asarray(times, dtype=np.float64),
        "action": np.asarray([index[a] if a is not None else -1 for a in actions],
                             dtype=np.int16),
        "reward": np.asarray(rewards, dtype=np.float64),
        "crashed": np.asarray(crashed, dtype=bool),
    }
    if values is not None and any(v for v in values):
        table = np.full((len(times), len(action_names)), np.nan)
        for row, vals in enumerate(values):
            for name, q in (vals or {}).items():
                if name in index:
                    table[row, index[name]] = q
        arrays["values"] = table
    arrays.update(parameter_arrays(len(times), parameters, proposals, distances))
    kinds, literals = _state_arrays(cols, arrays)
    header: dict[str, Any] = {"episode": episode, "seed": seed, **(checksums or {}),
                              **({"reason": reason} if reason is not None else {}),
                              "elements": [str(e) for e in cols.elements],
                              "actions": list(action_names), "kinds": kinds,
                              "literals": literals}
    return _pack(header, arrays)


def parameter_arrays(n: int, parameters=None, proposals=None, distances=None
                     ) -> dict[str, np.ndarray]:
    """The columns of continuous actions over ``n`` rows: ``par:P`` (the executed value of
    parameter P per row), ``prop:P`` (the agent's proposal) and ``dist`` (how far the shield
    moved it), float64 with NaN where a row has none (step 0, an action without parameters).
    Only those some row has: a run of discrete actions has none of them."""
    arrays: dict[str, np.ndarray] = {}
    for prefix, rows in (("par", parameters), ("prop", proposals)):
        rows = rows or [None] * n
        for name in sorted({p for row in rows for p in (row or {})}):
            arrays[f"{prefix}:{name}"] = np.array(
                [float(row[name]) if row and name in row else np.nan for row in rows],
                dtype=np.float64)
    if distances is not None and any(d is not None for d in distances):
        arrays["dist"] = np.array([np.nan if d is None else float(d) for d in distances],
                                  dtype=np.float64)
    return arrays


def _state_arrays(cols: Columns, arrays: dict[str, np.ndarray]
                  ) -> tuple[dict[str, str], dict[str, list[str]]]:
    """Add the state variables of ``cols`` to ``arrays``; their kinds and literal tables."""
    kinds: dict[str, str] = {}
    for name, arr in cols.numbers.items():
        arrays[f"num:{name}"] = arr
        kinds[name] = "num"
    for name, arr in cols.booleans.items():
        arrays[f"bool:{name}"] = arr
        kinds[name] = "bool"
    for name, (vals, defined) in cols.functions.items():
        arrays[f"fun:{name}"] = vals
        arrays[f"def:{name}"] = defined
        kinds[name] = "func"
    for name, mask in cols.masks.items():
        arrays[f"set:{name}"] = mask
        kinds[name] = "set"
    literals: dict[str, list[str]] = {}
    for name, values in cols.others.items():
        arrays[f"lit:{name}"], literals[name] = _dictionary(values)
        kinds[name] = "lit"
    return kinds, literals


def _pack(header: dict[str, Any], arrays: dict[str, np.ndarray]) -> bytes:
    """The blob: magic, the size of what follows it once decompressed, then compressed with
    zstd: header length, JSON header (with each array's dtype, shape and offset) and the
    arrays' bytes; last a CRC-32 of all of it."""

    header["arrays"] = []
    blobs, offset = [], 0
    for name, arr in arrays.items():
        arr = np.ascontiguousarray(arr)
        data = arr.tobytes()
        header["arrays"].append({"name": name, "dtype": arr.dtype.str, "shape": list(arr.shape),
                                 "offset": offset})
        blobs.append(data)
        offset += len(data)
    head = orjson.dumps(header)
    inner = b"".join([struct.pack("<I", len(head)), head, *blobs])
    body = (_MAGIC + struct.pack("<Q", len(inner))
            + zstd(inner, _ZSTD_LEVEL))
    return body + struct.pack("<I", zlib.crc32(body))  # a flipped bit is found, not trusted


def encode_run_columns(run, spans: np.ndarray, span_crcs: np.ndarray, head_crc: int,
                       head_end: int) -> bytes:
    """A block of episodes of a file in one columns blob (``run``: their
    :class:`~tracecheck.episodes.columns.RunColumns`, read back through the checked reader
    when the block is closed), with the byte span of each episode's records and their CRC-32s
    and the CRC-32 of the file's first ``head_end`` bytes (before any episode): a reader that
    finds them unchanged reads the block in a few array operations (see
    :mod:`tracecheck.episodes.blobs`)."""
    arrays: dict[str, np.ndarray] = {
        "time": np.asarray(run.time, dtype=np.float64),
        "action": np.asarray(run.action, dtype=np.int16),
        "reward": np.asarray(run.reward, dtype=np.float64),
        "crashed": np.asarray(run.crashed, dtype=bool),
    }
    if run.values is not None:
        arrays["values"] = np.asarray(run.values, dtype=np.float64)
    for name, arr in run.parameters.items():
        arrays[f"par:{name}"] = np.asarray(arr, dtype=np.float64)
    for name, arr in run.proposals.items():
        arrays[f"prop:{name}"] = np.asarray(arr, dtype=np.float64)
    if run.distance is not None:
        arrays["dist"] = np.asarray(run.distance, dtype=np.float64)
    kinds, literals = _state_arrays(run.states, arrays)
    arrays["run:episodes"] = np.asarray(run.episode_ids, dtype=np.int64)
    arrays["run:starts"] = np.asarray(run.starts, dtype=np.int64)
    arrays["run:seeds"] = np.asarray([-1 if s is None else s for s in run.seeds],
                                     dtype=np.int64)
    arrays["run:seeded"] = np.asarray([s is not None for s in run.seeds], dtype=bool)
    arrays["run:reasons"] = np.asarray([END_REASONS.index(r) for r in run.reasons],
                                       dtype=np.int16)
    arrays["run:spans"] = np.asarray(spans, dtype=np.int64).reshape(-1, 2)
    arrays["run:span_crcs"] = np.asarray(span_crcs, dtype=np.uint32)
    header: dict[str, Any] = {"episode": -1, "run": True, "head_crc": head_crc,
                              "head_end": head_end,
                              "reasons": list(END_REASONS),
                              "elements": [str(e) for e in run.states.elements],
                              "actions": list(run.action_names), "kinds": kinds,
                              "literals": literals}
    return _pack(header, arrays)


def _dictionary(values: Sequence[Any]) -> tuple[np.ndarray, list[str]]:
    """Any B values as an index per row into their distinct literals (a value that stays the
    same over an episode, like a grid world's map, is written once)."""
    index: dict[Any, int] = {}
    literals: list[str] = []
    rows = np.empty(len(values), dtype=np.uint32)
    for row, value in enumerate(values):
        k = index.get(value)
        if k is None:
            k = index[value] = len(literals)
            literals.append(_literal(value))
        rows[row] = k
    return rows, literals


_SAFE_DTYPES = {d: np.dtype(d) for d in ("<f8", "<i8", "<i2", "|b1", "<u4")}


class Packed(NamedTuple):
    """A columns blob opened (:func:`unpack_columns`): its JSON header, and the bytes that
    hold its arrays — ``data[base:end]``, each at its spec's offset from ``base``."""

    header: dict
    data: bytes
    base: int
    end: int


def decode_columns(blob: bytes, *, where: str = "") -> tuple[dict, dict[str, np.ndarray]]:
    """The header and arrays of a columns blob."""
    packed = unpack_columns(blob, where=where)
    return packed.header, arrays_of(packed, where=where)


def unpack_columns(blob: bytes, *, where: str = "") -> Packed:
    """A columns blob with its checksum checked and its arrays decompressed, not yet read
    (:func:`arrays_of` reads and checks them)."""
    try:
        end = len(blob)
        if blob[:4] in (_MAGIC, _PLAIN_MAGIC):
            end -= 4
            (crc,) = struct.unpack_from("<I", blob, end)
            if zlib.crc32(memoryview(blob)[:end]) != crc:  # no copy of the data
                raise ValueError("its checksum does not match its contents")
        elif blob[:4] != _OLD_MAGIC:
            raise ValueError("not a tracecheck columns attachment")
        at = 4
        if blob[:4] == _MAGIC:
            blob, at = _unpacked(blob, end), 0
            end = len(blob)
        (size,) = struct.unpack_from("<I", blob, at)
        header = orjson.loads(blob[at + 4:at + 4 + size])
        if not isinstance(header, dict):
            raise ValueError("its header is not a table")
        return Packed(header, blob, at + 4 + size, end)
    except (ValueError, struct.error, orjson.JSONDecodeError) as exc:
        raise InputError(f"{where}damaged columns attachment: {exc}") from None


def arrays_of(packed: Packed, *, where: str = "") -> dict[str, np.ndarray]:
    """The arrays of an opened columns blob, by name: each of a dtype tracecheck writes, of
    at most two dimensions, inside the blob (views of its bytes, not copies)."""
    header, blob, base, end = packed
    try:
        arrays = {}
        for spec in header["arrays"]:
            dtype, shape, offset = _SAFE_DTYPES.get(spec["dtype"]), spec["shape"], spec["offset"]
            if dtype is None:
                raise ValueError(f"the array {spec['name']} has dtype {spec['dtype']!r}, not "
                                 "one tracecheck writes")
            if not (isinstance(shape, list) and len(shape) <= 2 and type(offset) is int
                    and all(type(k) is int and k >= 0 for k in shape)):
                raise ValueError(f"the array {spec['name']} has a bad shape or offset")
            count = math.prod(shape)
            if offset < 0 or base + spec["offset"] + count * dtype.itemsize > end:
                raise ValueError(f"the array {spec['name']} runs past the attachment's end")
            arrays[spec["name"]] = np.frombuffer(
                blob, dtype=dtype, count=count, offset=base + spec["offset"]
            ).reshape(spec["shape"])
        return arrays
    except (ValueError, KeyError, TypeError) as exc:
        raise InputError(f"{where}damaged columns attachment: {exc}") from None


def _unpacked(blob: bytes, end: int) -> bytes:
    """What a compressed blob holds between its size and its CRC, decompressed: exactly as
    many bytes as it declares, not too many for its compressed size, and only where its zstd
    frame declares the same (see :mod:`tracecheck.episodes.frames`)."""
    (size,) = struct.unpack_from("<Q", blob, 4)
    limit = _MAX_RATIO * (end - 12) + (1 << 20)
    if size > limit:
        raise ValueError(f"it would decompress to {size} bytes from {end - 12} (more than "
                         f"tracecheck's limit of {limit} bytes for it)")
    return unzstd(bytes(blob[12:end]), size, "it")


def columns_from_arrays(header: dict, arrays: dict[str, np.ndarray],
                        literals: Optional[dict[str, Any]] = None, where: str = "") -> Columns:
    """The B-engine :class:`Columns` of one decoded blob (``literals``: values already read,
    by their text, shared between the episodes of a file)."""
    literals = {} if literals is None else literals
    n = len(arrays["time"])
    cols = Columns(n=n, elements=tuple(Elem(e) for e in header["elements"]))
    for name, kind in header["kinds"].items():
        if kind == "num":
            cols.numbers[name] = arrays[f"num:{name}"]
        elif kind == "bool":
            cols.booleans[name] = arrays[f"bool:{name}"]
        elif kind == "func":
            cols.functions[name] = (arrays[f"fun:{name}"], arrays[f"def:{name}"])
        elif kind == "set":
            cols.masks[name] = arrays[f"set:{name}"]
        elif kind == "lit":
            texts = header["literals"][name]
            distinct = [literals[t] if t in literals else literals.setdefault(
                t, parse_literal(t, where=f"{where}variable {name}")) for t in texts]
            rows = arrays[f"lit:{name}"]
            if rows.size and int(rows.max()) >= len(distinct):
                raise InputError(f"{where}damaged columns attachment: variable {name} refers "
                                 f"to literal {int(rows.max())} of {len(distinct)}")
            cols.others[name] = [distinct[k] for k in rows.tolist()]
    return cols
