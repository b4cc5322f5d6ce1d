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
