"""Foxglove's own channels: in new recordings, added by `export foxglove`, each message valid
against the schema of its name, and the run read by tracecheck as before."""

from __future__ import annotations

import json

import jsonschema
import pytest

from tests.helpers import ROOT, run, untimed
from tests.interop.foxglove_schemas import PUBLISHED, channels_and_messages, decode
from tracecheck.episodes.model import StepRecord
from tracecheck.interop.foxglove import SCHEMAS, TOPICS, FoxgloveChannels, step_messages

PAPER = ROOT / "sample_traces" / "base_paper.mcap"

#: Foxglove's own schemas are written in protobuf, with the descriptors foxglove-sdk ships
ENCODINGS = {"foxglove.SceneUpdate": "protobuf", "foxglove.Log": "protobuf",
             "tracecheck.Scalar": "jsonschema"}


def check_all(found, absent=()):
    """Every channel has messages (but those in ``absent``), each valid."""
    for topic, name in TOPICS.items():
        if topic in absent:
            assert topic not in found, topic
            continue
        schema_name, encoding, messages = found[topic]
        assert (schema_name, encoding) == (name, ENCODINGS[name]), topic
        published = jsonschema.Draft202012Validator(PUBLISHED[name])
        registered = jsonschema.Draft202012Validator(SCHEMAS[name])  # the one in the file
        for m in messages:
            published.validate(m)
            registered.validate(m)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    path = tmp_path_factory.mktemp("fox") / "paper-fox.mcap"
    with pytest.raises(SystemExit) as info:
        from tracecheck.cli import main
        main(["export", "foxglove", str(PAPER), "-o", str(path)])
    assert info.value.code in (0, None)
    return path


def test_export_adds_every_channel_and_each_message_is_valid(exported):
    found = channels_and_messages(exported)
    check_all(found)
    steps = len(found["/tracecheck/step"][2])
    assert len(found["/foxglove/scene"][2]) == steps == len(found["/plot/speed"][2])
    scene = found["/foxglove/scene"][2][5]
    ids = [e["id"] for e in scene["entities"]]
    assert "EgoVehicle" in ids and "shield zones" in ids  # recorded under paper: its zones
    ego = next(e for e in scene["entities"] if e["id"] == "EgoVehicle")
    assert ego["cubes"][0]["pose"]["position"]["x"] == 0.0
    assert ego["cubes"][0]["color"]["b"] > 0.8  # blue
    logs = [m["message"] for m in found["/foxglove/log"][2]]
    assert any("the shield replaced" in m for m in logs)
    assert sum(m.endswith(": crash") for m in logs) == 2  # the run's two crashes, once each


def test_export_keeps_what_tracecheck_reads(capsys, exported):
    reports = []
    for path in (PAPER, exported):
        code, out, _ = run(capsys, "replay", str(path), "--shield", "paper", "--json")
        assert code == 0
        data = untimed(json.loads(out))
        data.pop("files")
        for e in data["per_episode"]:
            e.pop("file")
        reports.append(data)
    assert reports[0] == reports[1]
    code, _, err = run(capsys, "export", "foxglove", str(PAPER), "-o", str(exported))
    assert code == 2 and "exists; give another name, or --force" in err
    code, _, err = run(capsys, "export", "foxglove", str(PAPER), "-o", str(PAPER))
    assert code == 2 and "is the input" in err


def test_a_new_recording_carries_the_channels(tmp_path):
    from tracecheck.live.record import RecordSettings, record

    path = tmp_path / "run.mcap"
    record(RecordSettings(agent=str(ROOT / "models" / "agents" / "base.zip"), shield="paper",
                          episodes=1, seed=3, duration=6, env="highway"), path,
           channels=FoxgloveChannels)
    found = channels_and_messages(path)
    check_all(found)
    allowed = [m["value"] for m in found["/plot/allowed_actions"][2]]
    assert allowed and all(1 <= v <= 5 for v in allowed)


def test_grid_worlds_are_tiles_with_the_agent(tmp_path):
    from tracecheck.live.record import RecordSettings, record

    path = tmp_path / "lake.mcap"
    record(RecordSettings(env="frozenlake", agent=str(ROOT / "models" / "agents" /
                                                      "frozenlake.npy"),
                          shield="frozenlake", episodes=1, seed=0, duration=10), path,
           channels=FoxgloveChannels)
    found = channels_and_messages(path)
    check_all(found, absent={"/plot/speed", "/plot/nearest_gap"})  # no vehicles to measure
    scene = found["/foxglove/scene"][2][0]
    tiles = next(e for e in scene["entities"] if e["id"] == "map")["cubes"]
    assert len(tiles) == 64  # the 8 x 8 lake


def test_log_entries_name_episode_step_and_what_happened():
    state = {"x": 1, "y": 2}
    step = StepRecord(step=4, time=4.0, action="SLOWER", state=state, reward=0.5, crashed=True,
                      preferred_action="FASTER", allowed_actions=("SLOWER",), deadlock=True)
    messages = list(step_messages(step, episode=7, stamp_ns=3_500_000_000))
    logs = [m.data for m in messages if m.topic == "/foxglove/log"]
    assert [(m["level"], m["message"]) for m in logs] == [
        (3, "episode 7, step 4: the shield replaced FASTER by SLOWER"),
        (4, "episode 7, step 4: deadlock, the shield allowed no action; the fallback was taken"),
        (4, "episode 7, step 4: crash")]
    assert logs[0]["timestamp"] == {"sec": 3, "nsec": 500_000_000}
    again = list(step_messages(step, episode=7, stamp_ns=0, previous_crashed=True))
    assert sum(m.data.get("message", "").endswith("crash") for m in again) == 0
    scalars = {m.topic: m.data["value"] for m in messages if m.topic.startswith("/plot/")}
    assert scalars == {"/plot/reward": 0.5, "/plot/allowed_actions": 1.0}


def _as_protobuf_json(data, key=None):
    """Foxglove's JSON encoding as protobuf's JSON mapping: times and durations are
    ``{"sec", "nsec"}`` objects in the one and RFC 3339 / "1.5s" strings in the other."""
    import datetime

    if isinstance(data, dict) and set(data) == {"sec", "nsec"}:
        if key == "lifetime":
            return f"{data['sec'] + data['nsec'] / 1e9:.9f}s"
        stamp = datetime.datetime.fromtimestamp(data["sec"], datetime.timezone.utc)
        return stamp.strftime("%Y-%m-%dT%H:%M:%S") + f".{data['nsec']:09d}Z"
    if isinstance(data, dict):
        return {k: _as_protobuf_json(v, k) for k, v in data.items()}
    if isinstance(data, list):
        return [_as_protobuf_json(v) for v in data]
    return data


def test_every_message_parses_as_foxglove_s_own_schema(exported):
    """Against the schemas Foxglove publishes in its SDK (protobuf descriptors of
    foxglove.SceneUpdate and foxglove.Log): every field name and type must be theirs."""
    import warnings

    pytest.importorskip("foxglove")
    from google.protobuf import descriptor_pb2, descriptor_pool, json_format, message_factory

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        import foxglove.messages as published

    found = channels_and_messages(exported)
    for topic, name in (("/foxglove/scene", "SceneUpdate"), ("/foxglove/log", "Log")):
        schema = getattr(published, name).get_schema()
        files = descriptor_pb2.FileDescriptorSet.FromString(bytes(schema.data))
        pool = descriptor_pool.DescriptorPool()
        for file in files.file:
            pool.Add(file)
        message = message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name))
        assert found[topic][0] == schema.name
        for data in found[topic][2]:
            parsed = json_format.ParseDict(_as_protobuf_json(data), message())
            assert parsed.ByteSize() > 0
        with pytest.raises(json_format.ParseError):  # the check can fail: a misspelt field
            json_format.ParseDict({**_as_protobuf_json(data), "mesage": "x"}, message())


def test_protobuf_messages_are_the_json_form_exactly():
    """Issue 28: Foxglove's scene and log go out in protobuf, with the descriptors foxglove-sdk
    publishes: decoded with them, every field of every message is the JSON form's (none
    lost, none changed), in fewer bytes."""
    from types import SimpleNamespace

    from tracecheck.episodes.reader import read_run
    from tracecheck.interop.foxglove_protobuf import encoder, protobuf_schemas

    schemas = protobuf_schemas()
    assert set(schemas) == {"foxglove.SceneUpdate", "foxglove.Log"}
    encode = encoder()
    run_ = read_run(PAPER)
    draw = FoxgloveChannels(run_.header)._draw
    seen, sizes = set(), [0, 0]
    for ep in run_.episodes[:3]:
        for k, step in enumerate(ep.steps):
            for m in step_messages(step, episode=ep.id, stamp_ns=k * 1_000_000_007 + 3,
                                   previous_crashed=k > 0 and ep.steps[k - 1].crashed,
                                   draw=draw):
                name = TOPICS[m.topic]
                if name not in schemas:
                    continue
                data = encode(name, m.data)
                schema = SimpleNamespace(name=name, encoding="protobuf", data=schemas[name])
                assert decode(schema, data) == m.data
                seen.add(name)
                kinds = {kind for e in m.data.get("entities", ()) for kind in
                         ("cubes", "lines", "texts") if e[kind]}
                seen |= kinds
                sizes[0] += len(data)
                sizes[1] += len(json.dumps(m.data, separators=(",", ":")))
    assert seen >= {"foxglove.SceneUpdate", "foxglove.Log", "cubes", "lines"}
    assert sizes[0] < 0.8 * sizes[1]
    with pytest.raises(KeyError):  # a field the JSON form lacks is an error, not a default
        encode("foxglove.Log", {"level": 3, "message": "x"})


def _grid_scenes():
    """A grid world's scenes as a recording draws them: one map object, the agent moving,
    falling once, and another map."""
    from tracecheck.b.values import Elem, FuncValue
    from tracecheck.live.envs.grid_scene import grid_scene

    def lake(holes):
        return FuncValue({(x, y): Elem("HOLE" if (x, y) in holes else "ICE")
                          for x in range(4) for y in range(4)})

    one, other = lake({(1, 1)}), lake({(2, 3)})
    path = [(0, 0), (1, 0), (1, 1), (0, 0), (1, 0), (2, 0), (2, 1), (3, 3)]
    for field_ in (one, other, one):
        for x, y in path:
            yield grid_scene({"x": x, "y": y, "goal_x": 3, "goal_y": 3, "field": field_},
                             crashed=(x, y) == (1, 1), danger=frozenset({"HOLE"}))


@pytest.mark.parametrize("size", [64, 1])
def test_a_scene_is_the_same_bytes_with_each_entity_encoded_once(size, monkeypatch):
    """Issue 46: each entity of the very same shapes (a grid world's 64 tiles, at every step)
    is encoded once and its bytes reused with the step's time stamp: the scene's bytes are
    exactly those of the whole scene encoded by foxglove-sdk, for the paper's highway scenes
    and a grid world's, step after step — and so when what was remembered is forgotten
    (``size`` 1)."""
    from tracecheck.episodes.reader import read_run
    from tracecheck.interop.foxglove import scene_entities, scene_entity, scene_groups
    from tracecheck.interop.foxglove_protobuf import SceneBytes, encoder, scene_encoder

    monkeypatch.setattr(SceneBytes, "SIZE", size)
    encode, scenes = encoder(), scene_encoder()
    run_ = read_run(PAPER)
    draw = FoxgloveChannels(run_.header)._draw
    drawn = [draw(step) for ep in run_.episodes[:3] for step in ep.steps]
    made = []

    def entity(group, shapes, stamp):
        made.append(group)
        return scene_entity(group, shapes, stamp)

    grid = list(_grid_scenes())
    for k, scene in enumerate(drawn + grid):
        ns = k * 1_000_000_007 + 3
        whole = encode("foxglove.SceneUpdate", {
            "deletions": [{"timestamp": {"sec": ns // 1_000_000_000,
                                         "nsec": ns % 1_000_000_000}, "type": 1, "id": ""}],
            "entities": scene_entities(scene, ns)})
        assert scenes(scene_groups(scene), entity, ns) == whole, k
    built = made[-3 * len(grid):]  # the grid world's: map, goal, agent in each scene
    if size == 64:  # two maps, one goal, an agent per place and fall: each built once
        assert built.count("map") == 2 and built.count("goal") == 1
        assert built.count("agent") == len({(s.shapes[-1].x, s.shapes[-1].y, s.shapes[-1].fill)
                                            for s in grid})
    else:
        assert len(made) > len(drawn) + len(grid) * 2


@pytest.mark.parametrize("ns", [0, 3, 1_000_000_000, 1_000_000_000 * 17 + 5,
                                (2 ** 32 - 1) * 1_000_000_000 + 999_999_999])
def test_a_scene_s_time_stamp_is_framed_as_the_sdk_frames_it(ns):
    """The time stamp SceneBytes frames itself (no SDK object per step) is the SDK's: a
    seconds or nanoseconds field of 0 left out, both 0 an empty stamp; beyond Foxglove's
    u32 seconds an error, not a wrapped time."""
    from tracecheck.interop.foxglove import scene_entities, scene_entity, scene_groups
    from tracecheck.interop.foxglove_protobuf import encoder, scene_encoder

    encode, scenes = encoder(), scene_encoder()
    for scene in list(_grid_scenes())[:3]:
        whole = encode("foxglove.SceneUpdate", {
            "deletions": [{"timestamp": {"sec": ns // 1_000_000_000,
                                         "nsec": ns % 1_000_000_000}, "type": 1, "id": ""}],
            "entities": scene_entities(scene, ns)})
        assert scenes(scene_groups(scene), scene_entity, ns) == whole
    with pytest.raises(ValueError, match="beyond Foxglove's"):
        scenes.stamped((), 2 ** 32 * 1_000_000_000)


def test_the_writers_scene_is_the_scene_encoded_whole():
    """What a recording writes on ``/foxglove/scene`` (the channels' ``messages``) is the
    scene of ``step_messages`` encoded whole by foxglove-sdk, for every step, and the other
    channels' messages are as before."""
    from tracecheck.episodes.reader import read_run
    from tracecheck.interop.foxglove_protobuf import encoder

    encode = encoder()
    run_ = read_run(PAPER)
    channels = FoxgloveChannels(run_.header)
    for ep in run_.episodes[:2]:
        for k, step in enumerate(ep.steps):
            kw = dict(episode=ep.id, stamp_ns=k * 7_000_000_011,
                      previous_crashed=k > 0 and ep.steps[k - 1].crashed)
            got = list(channels.messages(step, **kw))
            expected = []
            for m in step_messages(step, draw=channels._draw, plots=channels._plots, **kw):
                name = TOPICS.get(m.topic) or channels.topics[m.topic]
                expected.append((m.topic, encode(name, m.data) if name in channels.schema_encodings
                                 else json.dumps(m.data, separators=(",", ":")).encode()))
            assert got == expected


def test_a_negative_varint_is_refused():
    from tracecheck.interop.foxglove_protobuf import _varint

    assert [_varint(n) for n in (0, 127, 128, 16383, 16384)] == [
        b"\x00", b"\x7f", b"\x80\x01", b"\xff\x7f", b"\x80\x80\x01"]
    with pytest.raises(ValueError):
        _varint(-1)


def test_channels_drawn_by_an_env_given_cross_to_spawned_workers():
    """`record --env package.module:Class` draws its scene with that adapter, which the run's
    header names but no later command imports; the factory made of the --env text pickles,
    as a worker started by spawn needs (an adapter object does not, as a rule)."""
    import pickle

    from tracecheck.episodes.writer import new_header

    header = new_header("recorded", environment="cruise", variables=["Gap", "Speed",
                                                                     "LeadSpeed"],
                        actions=["KEEP", "ACCEL", "BRAKE"])
    step = StepRecord(1, 1.0, "KEEP", {"Gap": 20.0, "Speed": 10.0, "LeadSpeed": 11.0}, 0.0,
                      False)
    factory = pickle.loads(pickle.dumps(FoxgloveChannels.drawn_by("tests.live.toy:Cruise")))
    drawn = dict(factory(header).messages(step, episode=0, stamp_ns=10**9,
                                          previous_crashed=False))
    assert drawn.get("/foxglove/scene")
    by_name = dict(FoxgloveChannels(header).messages(step, episode=0, stamp_ns=10**9,
                                                     previous_crashed=False))
    assert "/foxglove/scene" not in by_name  # "cruise" is installed nowhere
