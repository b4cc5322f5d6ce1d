"""Foxglove-native channels: what Foxglove and Lichtblick draw without a plug-in.

Every step of an episode becomes, next to tracecheck's own messages:

* ``/foxglove/scene`` (``foxglove.SceneUpdate``): the step's scene as its environment draws it
  (its adapter's ``scene`` hook, the one the HTML viewer draws) in the frame ``road``, one
  entity per group of shapes: boxes as cubes, circles as spheres, lines as line strips, text
  as billboards, y flipped to Foxglove's left-handed-up convention; none for a run whose
  environment draws nothing or is not installed here;
* ``/foxglove/log`` (``foxglove.Log``): one entry per shield intervention (the agent's choice
  replaced), deadlock (nothing allowed) and crash;
* ``/plot/reward``, ``/plot/allowed_actions`` (``tracecheck.Scalar``, ``{"value": x}``): lines
  in a Plot panel; ``allowed_actions`` the number of actions the live shield allowed; and one
  ``/plot/NAME`` per number the environment plots (its adapter's ``plotted`` and ``plots``);
* for continuous actions (a run whose header declares ``action_parameters``), also
  ``tracecheck.Scalar`` channels per parameter P: ``/plot/P/proposal`` (the agent's value),
  ``/plot/P/executed`` (the value taken), ``/plot/P/allowed_low`` and ``/plot/P/allowed_high``
  (the ends of the first interval the live shield allowed; none for an unbounded end or where
  nothing was allowed), and ``/plot/projection_distance``; the log then has an entry where
  the shield moved a proposal.

A value a state does not have gives no message on that channel.
The messages are derived from the step: tracecheck itself never reads them back.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from itertools import groupby
from operator import attrgetter
from typing import Any, Callable, Iterator, Optional

from ..identity import ByIdentity
from ..live.scene import Box, Circle, Line, Scene

__all__ = ["FoxgloveChannels", "FoxgloveMessage", "step_messages", "scene_entities",
           "scene_groups", "scene_entity", "SCHEMAS",
           "TOPICS", "SCALARS", "CONTINUOUS_SCALARS", "continuous_topics", "plot_topics"]

SCENE, LOG, SCALAR = "foxglove.SceneUpdate", "foxglove.Log", "tracecheck.Scalar"
SCALARS = ("reward", "allowed_actions")
#: topic -> schema name
TOPICS = {"/foxglove/scene": SCENE, "/foxglove/log": LOG,
          **{f"/plot/{name}": SCALAR for name in SCALARS}}
#: per parameter of a continuous action: ``/plot/P/NAME``
CONTINUOUS_SCALARS = ("proposal", "executed", "allowed_low", "allowed_high")
DISTANCE_TOPIC = "/plot/projection_distance"


def plot_topics(adapter) -> dict[str, str]:
    """The channels of the numbers an environment plots (topic -> schema name; none without
    its adapter)."""
    return {f"/plot/{name}": SCALAR for name in getattr(adapter, "plotted", ())}


def continuous_topics(header) -> dict[str, str]:
    """The channels of a run's continuous actions (topic -> schema name; none for a run
    whose header declares no ``action_parameters``)."""
    declared = getattr(header, "action_parameters", None) or {}
    names = list(dict.fromkeys(p for params in declared.values() for p in params))
    if not names:
        return {}
    return {**{f"/plot/{p}/{kind}": SCALAR for p in names for kind in CONTINUOUS_SCALARS},
            DISTANCE_TOPIC: SCALAR}

_TIME = {"type": "object", "properties": {"sec": {"type": "integer", "minimum": 0},
                                          "nsec": {"type": "integer", "minimum": 0,
                                                   "maximum": 999_999_999}},
         "required": ["sec", "nsec"]}


def _numbers(*keys: str) -> dict:
    return {"type": "object", "required": list(keys),
            "properties": {k: {"type": "number"} for k in keys}}


_ENTITY_LISTS = ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts",
                 "models")
_DRAWN = ("cubes", "spheres", "lines", "texts")  # what a scene's shapes become
_POSE = {"type": "object", "required": ["position", "orientation"],
         "properties": {"position": _numbers("x", "y", "z"),
                        "orientation": _numbers("x", "y", "z", "w")}}
_COLOR = _numbers("r", "g", "b", "a")
#: The JSON schemas registered with the channels: the fields, types and required keys of
#: Foxglove's published schemas (foxglove-sdk, schemas/jsonschema) for what tracecheck writes.
SCHEMAS: dict[str, dict] = {
    SCENE: {
        "title": SCENE, "type": "object", "required": ["deletions", "entities"],
        "properties": {
            "deletions": {"type": "array", "items": {
                "type": "object", "required": ["timestamp", "type", "id"],
                "properties": {"timestamp": _TIME, "type": {"enum": [0, 1]},
                               "id": {"type": "string"}}}},
            "entities": {"type": "array", "items": {
                "type": "object",
                "required": ["timestamp", "frame_id", "id", "lifetime", "frame_locked",
                             "metadata", *_ENTITY_LISTS],
                "properties": {
                    "timestamp": _TIME, "frame_id": {"type": "string"},
                    "id": {"type": "string"}, "lifetime": _TIME,
                    "frame_locked": {"type": "boolean"},
                    "metadata": {"type": "array", "items": {
                        "type": "object", "required": ["key", "value"],
                        "properties": {"key": {"type": "string"},
                                       "value": {"type": "string"}}}},
                    "cubes": {"type": "array", "items": {
                        "type": "object", "required": ["pose", "size", "color"],
                        "properties": {"pose": _POSE, "size": _numbers("x", "y", "z"),
                                       "color": _COLOR}}},
                    "spheres": {"type": "array", "items": {
                        "type": "object", "required": ["pose", "size", "color"],
                        "properties": {"pose": _POSE, "size": _numbers("x", "y", "z"),
                                       "color": _COLOR}}},
                    "lines": {"type": "array", "items": {
                        "type": "object",
                        "required": ["type", "pose", "thickness", "scale_invariant", "points",
                                     "color", "colors", "indices"],
                        "properties": {"type": {"enum": [0, 1, 2]}, "pose": _POSE,
                                       "thickness": {"type": "number"},
                                       "scale_invariant": {"type": "boolean"},
                                       "points": {"type": "array",
                                                  "items": _numbers("x", "y", "z")},
                                       "color": _COLOR,
                                       "colors": {"type": "array", "items": _COLOR},
                                       "indices": {"type": "array",
                                                   "items": {"type": "integer"}}}}},
                    "texts": {"type": "array", "items": {
                        "type": "object",
                        "required": ["pose", "billboard", "font_size", "scale_invariant",
                                     "color", "text"],
                        "properties": {"pose": _POSE, "billboard": {"type": "boolean"},
                                       "font_size": {"type": "number"},
                                       "scale_invariant": {"type": "boolean"},
                                       "color": _COLOR, "text": {"type": "string"}}}},
                    **{k: {"type": "array", "maxItems": 0} for k in _ENTITY_LISTS
                       if k not in _DRAWN}}}}}},
    LOG: {
        "title": LOG, "type": "object",
        "required": ["timestamp", "level", "message", "name", "file", "line"],
        "properties": {"timestamp": _TIME, "level": {"enum": [0, 1, 2, 3, 4, 5]},
                       "message": {"type": "string"}, "name": {"type": "string"},
                       "file": {"type": "string"}, "line": {"type": "integer", "minimum": 0}}},
    SCALAR: {"title": SCALAR, "type": "object", "required": ["value"],
             "properties": {"value": {"type": "number"}}},
}

WARNING, ERROR = 3, 4  # foxglove.LogLevel
_FLAT = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}  # no rotation


@dataclass(frozen=True)
class FoxgloveMessage:
    """One message: its topic (its schema is ``TOPICS[topic]``) and its JSON data."""

    topic: str
    data: dict[str, Any]


def _stamp(ns: int) -> dict:
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _pose(x: float, y: float, z: float) -> dict:
    # the scene's y points down the page; Foxglove's (left-handed up) the other way
    return {"position": {"x": float(x), "y": -float(y), "z": float(z)},
            "orientation": dict(_FLAT)}


def _rgba(color) -> dict:
    return dict(zip("rgba", map(float, color)))


#: the primitives of shapes drawn again and again (a grid world's tiles); nobody changes them
_PRIMITIVES: ByIdentity[tuple[str, dict]] = ByIdentity(4096)


def _primitive(shape) -> tuple[str, dict]:
    """(the entity's list, the primitive) of one scene shape."""
    drawn = _PRIMITIVES.get(shape)
    return drawn if drawn is not None else _PRIMITIVES.put(shape, _draw(shape))


def _draw(shape) -> tuple[str, dict]:
    if isinstance(shape, Box):
        color = shape.fill if shape.fill is not None else (shape.stroke or (0.5, 0.5, 0.5, 1))
        if shape.fill is None:
            color = color[:3] + (0.25,)
        return "cubes", {"pose": _pose(shape.x, shape.y, shape.depth / 2),
                         "size": {"x": float(shape.width), "y": float(shape.height),
                                  "z": float(shape.depth)},
                         "color": _rgba(color)}
    if isinstance(shape, Circle):
        d = 2.0 * shape.radius
        return "spheres", {"pose": _pose(shape.x, shape.y, shape.radius),
                           "size": {"x": d, "y": d, "z": d},
                           "color": _rgba(shape.fill or shape.stroke or (0.5, 0.5, 0.5, 1))}
    if isinstance(shape, Line):
        return "lines", {"type": 0, "pose": _pose(0, 0, 0.05), "thickness": float(shape.width),
                         "scale_invariant": False,
                         "points": [{"x": float(x), "y": -float(y), "z": 0.0}
                                    for x, y in shape.points],
                         "color": _rgba(shape.color), "colors": [], "indices": []}
    return "texts", {"pose": _pose(shape.x, shape.y, 0.2), "billboard": True,
                     "font_size": float(shape.size), "scale_invariant": False,
                     "color": _rgba(shape.color), "text": shape.text}


def scene_entities(scene: Scene, ns: int) -> list[dict]:
    """A scene as Foxglove entities in the frame ``road``: one per group of shapes (each
    vehicle, ``shield zones``, a grid world's ``map`` and ``agent``), in the scene's order."""
    return [scene_entity(group, shapes, _stamp(ns))
            for group, shapes in scene_groups(scene).items()]


def scene_groups(scene: Scene) -> dict[str, list]:
    """A scene's shapes by group (an entity each), the groups in the order they first
    appear, each group's shapes in the scene's order."""
    groups: dict[str, list] = {}
    for group, run in groupby(scene.shapes, _GROUP):  # runs of one group (a map's tiles)
        found = groups.get(group)
        if found is None:
            groups[group] = list(run)
        else:
            found.extend(run)
    return groups


_GROUP = attrgetter("group")


def scene_entity(group: str, shapes: list, stamp: Optional[dict]) -> dict:
    """The entity of one group's shapes, time-stamped with ``stamp`` (``{"sec", "nsec"}``;
    None: without a time stamp, which the protobuf writer adds per message)."""
    entity: dict[str, Any] = {} if stamp is None else {"timestamp": stamp}
    entity.update({"frame_id": "road", "id": group, "lifetime": {"sec": 0, "nsec": 0},
                   "frame_locked": False, "metadata": [], **{k: [] for k in _ENTITY_LISTS}})
    labels = []
    for shape in shapes:
        kind, primitive = _primitive(shape)
        entity[kind].append(primitive)
        if getattr(shape, "label", ""):
            labels.append(shape.label)
    if len(labels) == 1:  # one labelled shape (a vehicle): its label says what it is
        entity["metadata"] = [{"key": "label", "value": labels[0]}]
    return entity


def step_messages(step, *, episode: int, stamp_ns: int, previous_crashed: bool = False,
                  draw: Optional[Callable[[Any], Optional[Scene]]] = None,
                  plots: Optional[Callable[[dict], dict[str, float]]] = None
                  ) -> Iterator[FoxgloveMessage]:
    """The Foxglove messages of one step (a ``StepRecord``) at ``stamp_ns``.

    Args:
        step: the step.
        episode: its episode's number (in the log's entries).
        stamp_ns: the messages' time stamp.
        previous_crashed: whether the step before had crashed (a crash is logged once).
        draw: the step's scene (:func:`tracecheck.render.scene.scene_drawer`; None: no
            scene).
        plots: the numbers the environment plots of a state (its adapter's ``plots``).

    Yields:
        One :class:`FoxgloveMessage` per channel with something to say.
    """
    scene = draw(step) if draw is not None else None
    entities = scene_entities(scene, stamp_ns) if scene is not None else []
    if entities:
        yield FoxgloveMessage("/foxglove/scene", {
            "deletions": [{"timestamp": _stamp(stamp_ns), "type": 1, "id": ""}],
            "entities": entities})
    where = f"episode {episode}, step {step.step}"
    events = []
    if step.preferred_action is not None and step.action is not None \
            and step.preferred_action != step.action:
        events.append((WARNING, f"{where}: the shield replaced {step.preferred_action} by "
                                f"{step.action}"))
    moved = _moved(step)
    if moved:
        events.append((WARNING, f"{where}: the shield moved the proposal {moved}"))
    if step.deadlock:
        events.append((ERROR, f"{where}: deadlock, the shield allowed no action; the "
                              "fallback was taken"))
    if step.crashed and not previous_crashed:
        events.append((ERROR, f"{where}: crash"))
    for level, message in events:
        yield FoxgloveMessage("/foxglove/log", {
            "timestamp": _stamp(stamp_ns), "level": level, "message": message,
            "name": "tracecheck", "file": f"episode {episode}", "line": step.step})
    values = {"reward": step.reward,
              "allowed_actions": (len(step.allowed_actions)
                                  if step.allowed_actions is not None else None),
              **(plots(step.state) if plots is not None else {})}
    for name, value in values.items():
        if value is not None and math.isfinite(value):
            yield FoxgloveMessage(f"/plot/{name}", {"value": float(value)})
    for topic, value in _continuous_scalars(step):
        if value is not None and math.isfinite(value):
            yield FoxgloveMessage(topic, {"value": float(value)})


def _moved(step) -> str:
    """How the shield moved a continuous proposal at ``step`` (``a = 2 to 1``), else ''."""
    executed = getattr(step, "parameters", None) or {}
    proposed = getattr(step, "proposal", None) or {}
    changed = [f"{p} = {proposed[p]:g} to {v:g}" for p, v in executed.items()
               if p in proposed and proposed[p] != v]
    return ", ".join(changed)


def _continuous_scalars(step) -> Iterator[tuple[str, Optional[float]]]:
    """(topic, value) of a continuous step's scalars (none for a discrete step, or a step
    that is not a ``StepRecord`` and has no such fields)."""
    if getattr(step, "parameters", None) is None:
        return
    intervals = step.allowed_intervals or {}
    for name, value in step.parameters.items():
        first = intervals[name][0] if intervals.get(name) else (None, None)
        yield f"/plot/{name}/proposal", (step.proposal or {}).get(name)
        yield f"/plot/{name}/executed", value
        yield f"/plot/{name}/allowed_low", first[0]
        yield f"/plot/{name}/allowed_high", first[1]
    yield DISTANCE_TOPIC, step.projection_distance


class FoxgloveChannels:
    """Foxglove's channels as the writer's plug-in
    (:class:`~tracecheck.episodes.writer.StepChannels`) for the run of ``header``: the scene
    and the plotted numbers of the run's environment, drawn by ``adapter`` (the one that
    ran the episodes: see :meth:`drawn_by`), else by its installed adapter, if any."""

    @classmethod
    def drawn_by(cls, adapter) -> Callable[[Any], "FoxgloveChannels"]:
        """The channels of a run whose episodes ``adapter`` runs (a factory of a header, as
        the writer takes it): its scene and plots even where the adapter is not installed,
        as the header's name alone would not find it. ``adapter``: the ``--env`` given (an
        installed name or ``package.module:Class``, loaded where the channels are made: it
        crosses to workers started by spawn, where an adapter object may not pickle), or
        the adapter itself."""
        if isinstance(adapter, str):
            return functools.partial(cls, env=adapter)
        return functools.partial(cls, adapter=adapter)

    def __init__(self, header, adapter=None, env: Optional[str] = None) -> None:
        import orjson

        from ..render.scene import scene_adapter, scene_drawer
        from .foxglove_protobuf import encoder, protobuf_schemas, scene_encoder

        self._dumps = orjson.dumps
        # Foxglove's own messages in protobuf with its published descriptors (JSON without
        # foxglove-sdk), tracecheck's scalars in JSON with their JSON schema
        self._encode = encoder()
        self._scene = scene_encoder() if self._encode is not None else None
        #: each scene's entities encoded, by the very same scene (a grid world's agent on a
        #: cell it was on before is the same scene: see grid_scene)
        self._bodies: ByIdentity[tuple[bytes, ...]] = ByIdentity(512)
        published = protobuf_schemas() if self._encode is not None else {}
        self.schemas = {name: published.get(name) or orjson.dumps(schema)
                        for name, schema in SCHEMAS.items()}
        self.schema_encodings = {name: "protobuf" for name in published}
        if adapter is None and env is not None:  # the --env given: the command line's
            from ..live.adapter import load_adapter

            adapter = load_adapter(env)
        if adapter is None:  # the installed one the run names, looked up once
            adapter = scene_adapter(header.environment, tuple(header.variables or ()))
        self.topics = {**TOPICS, **plot_topics(adapter), **continuous_topics(header)}
        self._draw = scene_drawer(adapter=adapter, shield=header.shield_name)
        self._plots = adapter.plots if adapter is not None else None

    def messages(self, step, *, episode: int, stamp_ns: int,
                 previous_crashed: bool) -> Iterator[tuple[str, bytes]]:
        draw = self._draw
        if self._scene is not None and draw is not None:  # the scene in protobuf, each
            scene = draw(step)                            # entity encoded once
            if scene is not None and scene.shapes:
                bodies = self._bodies.get(scene)
                if bodies is None:
                    bodies = self._bodies.put(scene, self._scene.bodies(scene_groups(scene),
                                                                        scene_entity))
                yield "/foxglove/scene", self._scene.stamped(bodies, stamp_ns)
            draw = None
        for m in step_messages(step, episode=episode, stamp_ns=stamp_ns,
                               previous_crashed=previous_crashed, draw=draw,
                               plots=self._plots):
            name = self.topics.get(m.topic)
            if name is None:  # a step's parameters its run header does not declare
                continue
            if name in self.schema_encodings:
                yield m.topic, self._encode(name, m.data)
            else:
                yield m.topic, self._dumps(m.data)
