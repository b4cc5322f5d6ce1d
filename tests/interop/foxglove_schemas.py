"""Foxglove's published JSON schemas of the messages tracecheck writes, to validate them against
(tests/interop/test_foxglove.py, tests/render/test_scene.py)."""

from __future__ import annotations

# Written from Foxglove's published JSON schemas (foxglove-sdk, schemas/jsonschema): every
# field tracecheck writes with its type, and no other field (a misspelt key fails).
_TIME = {"type": "object", "additionalProperties": False, "required": ["sec", "nsec"],
         "properties": {"sec": {"type": "integer", "minimum": 0},
                        "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}}}


def _closed(*keys):
    return {"type": "object", "additionalProperties": False, "required": list(keys),
            "properties": {k: {"type": "number"} for k in keys}}


PUBLISHED = {
    "foxglove.SceneUpdate": {
        "type": "object", "additionalProperties": False, "required": ["deletions", "entities"],
        "properties": {
            "deletions": {"type": "array", "items": {
                "type": "object", "additionalProperties": False,
                "required": ["timestamp", "type", "id"],
                "properties": {"timestamp": _TIME, "type": {"enum": [0, 1]},
                               "id": {"type": "string"}}}},
            "entities": {"type": "array", "items": {
                "type": "object", "additionalProperties": False,
                "required": ["timestamp", "frame_id", "id", "lifetime", "frame_locked",
                             "metadata", "arrows", "cubes", "spheres", "cylinders", "lines",
                             "triangles", "texts", "models"],
                "properties": {
                    "timestamp": _TIME, "frame_id": {"type": "string"},
                    "id": {"type": "string"}, "lifetime": _TIME,
                    "frame_locked": {"type": "boolean"},
                    "metadata": {"type": "array", "items": {
                        "type": "object", "additionalProperties": False,
                        "required": ["key", "value"],
                        "properties": {"key": {"type": "string"}, "value": {"type": "string"}}}},
                    "cubes": {"type": "array", "items": {
                        "type": "object", "additionalProperties": False,
                        "required": ["pose", "size", "color"],
                        "properties": {
                            "pose": {"type": "object", "additionalProperties": False,
                                     "required": ["position", "orientation"],
                                     "properties": {"position": _closed("x", "y", "z"),
                                                    "orientation": _closed("x", "y", "z", "w")}},
                            "size": _closed("x", "y", "z"),
                            "color": _closed("r", "g", "b", "a")}}},
                    **{k: {"type": "array"} for k in ("arrows", "spheres", "cylinders",
                                                      "lines", "triangles", "texts",
                                                      "models")}}}}}},
    "foxglove.Log": {
        "type": "object", "additionalProperties": False,
        "required": ["timestamp", "level", "message", "name", "file", "line"],
        "properties": {"timestamp": _TIME, "level": {"enum": [0, 1, 2, 3, 4, 5]},
                       "message": {"type": "string"}, "name": {"type": "string"},
                       "file": {"type": "string"}, "line": {"type": "integer", "minimum": 0}}},
    "tracecheck.Scalar": {"type": "object", "additionalProperties": False,
                          "required": ["value"], "properties": {"value": {"type": "number"}}},
}


_CLASSES: dict = {}


def decode(schema, data: bytes) -> dict:
    """A message of an MCAP channel as Foxglove's JSON form: JSON as it is; protobuf decoded
    with the ``FileDescriptorSet`` the file registered for it (every field, defaults too;
    times as ``{"sec", "nsec"}``, enums as numbers)."""
    import json

    if schema.encoding == "jsonschema":
        return json.loads(data)
    assert schema.encoding == "protobuf", schema.encoding
    key = (schema.name, bytes(schema.data))
    if key not in _CLASSES:
        from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

        files = descriptor_pb2.FileDescriptorSet.FromString(key[1])
        pool = descriptor_pool.DescriptorPool()
        for file in files.file:
            pool.Add(file)
        _CLASSES[key] = message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name))
    return _as_json(_CLASSES[key].FromString(data))


_TIMES = ("google.protobuf.Timestamp", "google.protobuf.Duration")


def _as_json(message) -> dict:
    out = {}
    for field in message.DESCRIPTOR.fields:
        value = getattr(message, field.name)
        kind = field.message_type
        if kind is not None and kind.full_name in _TIMES:
            convert = lambda v: {"sec": v.seconds, "nsec": v.nanos}  # noqa: E731
        elif kind is not None:
            convert = _as_json
        else:
            convert = lambda v: v  # noqa: E731
        repeated = field.is_repeated if hasattr(field, "is_repeated") else field.label == 3
        out[field.name] = [convert(v) for v in value] if repeated else convert(value)
    return out


def channels_and_messages(path) -> dict:
    """topic -> (schema name, schema encoding, [decoded messages in Foxglove's JSON form]) of
    an MCAP file, each channel's message encoding the one its schema's encoding implies."""
    from mcap.reader import make_reader

    found: dict = {}
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            entry = found.setdefault(channel.topic, (schema.name, schema.encoding, []))
            assert channel.message_encoding == (
                "protobuf" if schema.encoding == "protobuf" else "json"), channel.topic
            entry[2].append(decode(schema, message.data))
    return found
