"""Foxglove's own messages in protobuf, the encoding Foxglove publishes its schemas in.

The ``foxglove.SceneUpdate`` and ``foxglove.Log`` messages of
:mod:`tracecheck.interop.foxglove` (made in Foxglove's JSON form) are built as
foxglove-sdk's message classes and encoded by it, and their channels registered with the
``FileDescriptorSet`` foxglove-sdk ships: smaller than JSON, and readable by tools that decode
Foxglove's protobuf schemas but not its JSON ones (Rerun). Without foxglove-sdk, the JSON
form is written (:func:`protobuf_schemas` says which).
"""

from __future__ import annotations

import warnings
from typing import Any, Callable, Optional

from ..identity import ByIdentity

__all__ = ["protobuf_schemas", "encoder", "scene_encoder", "SceneBytes"]


def _messages():
    """foxglove-sdk's message classes, or None where it is not installed."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            import foxglove.messages as m
    except ImportError:
        return None
    return m


def protobuf_schemas() -> dict[str, bytes]:
    """The schema name -> serialized ``FileDescriptorSet`` of each Foxglove message written
    in protobuf (empty without foxglove-sdk: JSON is written)."""
    m = _messages()
    if m is None:
        return {}
    return {schema.name: bytes(schema.data) for schema in
            (m.SceneUpdate.get_schema(), m.Log.get_schema())}


def encoder() -> Optional[Callable[[str, dict], bytes]]:
    """``encode(schema name, message in Foxglove's JSON form) -> protobuf bytes`` for the
    schemas of :func:`protobuf_schemas` (None without foxglove-sdk)."""
    m = _messages()
    if m is None:
        return None
    build = _Builder(m)
    make = {"foxglove.SceneUpdate": build.scene_update, "foxglove.Log": build.log}
    return lambda name, data: make[name](data).encode()


def _by_value(kind) -> dict[int, Any]:
    """An SDK enum's members by their numbers (the JSON form has the numbers)."""
    return {getattr(kind, n).value: getattr(kind, n) for n in dir(kind)
            if not n.startswith("_") and n not in ("name", "value")}


class _Builder:
    """The SDK's message objects from the JSON form, field by field (a field the SDK does not
    know is an error in the SDK's constructor, not dropped)."""

    def __init__(self, m) -> None:
        self.m = m
        self.line_types = _by_value(m.LinePrimitiveLineType)
        self.levels = _by_value(m.LogLevel)
        self.deletions = _by_value(m.SceneEntityDeletionType)
        #: the SDK's primitives of primitives drawn again and again (a grid world's tiles)
        self._made: ByIdentity[Any] = ByIdentity(4096)

    def _once(self, make: Callable[[dict], Any], d: dict):
        made = self._made.get(d)
        return made if made is not None else self._made.put(d, make(d))

    def time(self, d: dict):
        return self.m.Timestamp(d["sec"], d["nsec"])

    def duration(self, d: dict):
        return self.m.Duration(d["sec"], d["nsec"])

    def pose(self, d: dict):
        m = self.m
        return m.Pose(position=m.Vector3(**d["position"]),
                      orientation=m.Quaternion(**d["orientation"]))

    def color(self, d: dict):
        return self.m.Color(**d)

    def cube(self, d: dict):
        return self.m.CubePrimitive(pose=self.pose(d["pose"]), size=self.m.Vector3(**d["size"]),
                                    color=self.color(d["color"]))

    def sphere(self, d: dict):
        return self.m.SpherePrimitive(pose=self.pose(d["pose"]),
                                      size=self.m.Vector3(**d["size"]),
                                      color=self.color(d["color"]))

    def line(self, d: dict):
        m = self.m
        return m.LinePrimitive(type=self.line_types[d["type"]], pose=self.pose(d["pose"]),
                               thickness=d["thickness"], scale_invariant=d["scale_invariant"],
                               points=[m.Point3(**p) for p in d["points"]],
                               color=self.color(d["color"]),
                               colors=[self.color(c) for c in d["colors"]],
                               indices=list(d["indices"]))

    def text(self, d: dict):
        return self.m.TextPrimitive(pose=self.pose(d["pose"]), billboard=d["billboard"],
                                    font_size=d["font_size"],
                                    scale_invariant=d["scale_invariant"],
                                    color=self.color(d["color"]), text=d["text"])

    def entity(self, d: dict, timed: bool = True):
        """An entity; not ``timed``: one without its time stamp (``d`` has none)."""
        m = self.m
        unknown = [k for k in ("arrows", "cylinders", "triangles", "models") if d.get(k)]
        if unknown:
            raise ValueError(f"tracecheck draws no {unknown[0]}")
        return m.SceneEntity(
            timestamp=self.time(d["timestamp"]) if timed else None,
            frame_id=d["frame_id"], id=d["id"],
            lifetime=self.duration(d["lifetime"]), frame_locked=d["frame_locked"],
            metadata=[m.KeyValuePair(**kv) for kv in d["metadata"]],
            cubes=[self._once(self.cube, c) for c in d["cubes"]],
            spheres=[self._once(self.sphere, s) for s in d["spheres"]],
            lines=[self._once(self.line, x) for x in d["lines"]],
            texts=[self._once(self.text, t) for t in d["texts"]])

    def scene_update(self, d: dict):
        m = self.m
        return m.SceneUpdate(
            deletions=[m.SceneEntityDeletion(timestamp=self.time(x["timestamp"]),
                                             type=self.deletions[x["type"]], id=x["id"])
                       for x in d["deletions"]],
            entities=[self.entity(e) for e in d["entities"]])

    def log(self, d: dict):
        return self.m.Log(timestamp=self.time(d["timestamp"]), level=self.levels[d["level"]],
                          message=d["message"], name=d["name"], file=d["file"], line=d["line"])


def scene_encoder() -> Optional["SceneBytes"]:
    """A :class:`SceneBytes` (None without foxglove-sdk)."""
    m = _messages()
    return None if m is None else SceneBytes(_Builder(m))


class SceneBytes:
    """A scene's ``foxglove.SceneUpdate`` in protobuf, each group's entity encoded once for
    the very same shapes.

    A grid world's 64 tiles are the same objects in every state of a run; building and
    encoding them again at every step was most of the cost of recording one (the encoding
    is deterministic, fields in the order of their numbers). The bytes are those of
    :func:`encoder` for :func:`~tracecheck.interop.foxglove.scene_entities`, exactly: an
    entity's time stamp is its field 1, so its bytes are those of the time stamp followed by
    those of the rest, and a message's repeated field is the concatenation of its items,
    each framed by its tag and length.
    """

    #: entities remembered: those met once (forgotten when this many are), and those met
    #: again (the tiles drawn at every step; forgotten when this many are)
    SIZE = 64

    def __init__(self, builder: "_Builder") -> None:
        self._build = builder
        self._new: dict[tuple, tuple[list, bytes]] = {}
        self._kept: dict[tuple, tuple[list, bytes]] = {}

    def __call__(self, groups: dict[str, list], entity: Callable[[str, list, Optional[dict]], dict],
                 ns: int) -> bytes:
        """The scene of ``groups`` (group -> its shapes, in order) at ``ns``; ``entity(group,
        shapes, None)`` makes a group's entity, without its time stamp, in the JSON form."""
        return self.stamped(self.bodies(groups, entity), ns)

    def bodies(self, groups: dict[str, list],
               entity: Callable[[str, list, Optional[dict]], dict]) -> tuple[bytes, ...]:
        """Each group's entity without its time stamp, encoded (see :meth:`__call__`): what
        :meth:`stamped` makes a scene of at any time (the same scene drawn again — a grid
        world's agent back on a cell — needs only that)."""
        out = []
        for group, shapes in groups.items():
            # the shapes are held with their bytes: while remembered, no other object has
            # one of their ids
            key = (group, *map(id, shapes))
            found = self._kept.get(key)
            if found is None:
                found = self._new.pop(key, None)
                if found is not None:
                    if len(self._kept) >= self.SIZE:
                        self._kept.clear()
                    self._kept[key] = found
                else:
                    found = (shapes, self._build.entity(entity(group, shapes, None),
                                                        timed=False).encode())
                    if len(self._new) >= self.SIZE:
                        self._new.clear()
                    self._new[key] = found
            out.append(found[1])
        return tuple(out)

    def stamped(self, bodies: tuple[bytes, ...], ns: int) -> bytes:
        """The scene of the entities ``bodies`` (:meth:`bodies`) at ``ns``.

        Its time stamp is framed here as the SDK frames it (a test compares them): a
        ``Timestamp`` is its seconds (field 1) and nanoseconds (field 2) as varints, each
        left out where 0; the scene's deletion of everything before (field 1 of the
        ``SceneUpdate``) is that stamp (its field 1) and the type ALL (field 2: 1); each
        entity (field 2) its stamp (field 1) then its body."""
        sec, nsec = divmod(ns, 1_000_000_000)
        if not 0 <= sec < 1 << 32:
            raise ValueError(f"a time stamp of {sec} s is beyond Foxglove's (u32 seconds)")
        time = (b"\x08" + _varint(sec) if sec else b"") + \
            (b"\x10" + _varint(nsec) if nsec else b"")
        stamp = b"\x0a" + _varint(len(time)) + time
        deletion = stamp + b"\x10\x01"
        out = [b"\x0a", _varint(len(deletion)), deletion]
        for body in bodies:
            size = len(stamp) + len(body)
            out += (b"\x12", _varint(size), stamp, body)  # SceneUpdate.entities: field 2
        return b"".join(out)


def _varint(n: int) -> bytes:
    """``n`` (not negative: a ValueError) as a protobuf varint."""
    if 0 <= n < 0x80:
        return _SMALL[n]
    if n < 0x4000:
        return bytes(((n & 0x7F) | 0x80, n >> 7))
    out = bytearray()
    while n > 0x7F:
        out.append((n & 0x7F) | 0x80)
        n >>= 7
    out.append(n)
    return bytes(out)


_SMALL = tuple(bytes((i,)) for i in range(0x80))  # the varints of one byte
