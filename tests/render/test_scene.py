"""The scene model: checked when built, drawn by the viewer and sent to Foxglove alike."""

from __future__ import annotations

import jsonschema
import pytest

from tests.interop.foxglove_schemas import PUBLISHED
from tracecheck.errors import InputError
from tracecheck.interop.foxglove import SCHEMAS, scene_entities, step_messages
from tracecheck.live.scene import Box, Circle, Line, Scene, Text
from tracecheck.render.scene import scene_svg


@pytest.mark.parametrize("make,message", [
    (lambda: Box(0, float("nan"), 1, 1), "Box has y nan: give a finite number"),
    (lambda: Circle(0, 0, 1, fill=(1, 0, 0)), "Circle has fill (1, 0, 0): give (r, g, b, a)"),
    (lambda: Line(((0, 0),)), "Line has points ((0, 0),): give a tuple of at least two"),
    (lambda: Scene((Box(0, 0, 1, 1),), (0, 0, 0, 1)), "its width and height must be above 0"),
    (lambda: Scene(["box"], (0, 0, 1, 1)), "shapes must be a tuple of Box, Circle"),
], ids=["nan", "colour", "line", "view", "shapes"])
def test_a_bad_scene_is_refused_naming_the_shape(make, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        make()


SCENE = Scene((Box(1, 2, 4, 2, fill=(0.2, 0.4, 0.9, 1.0), label="ego", group="ego"),
               Circle(5, 1, 0.5, group="ball"), Line(((0, 0), (3, 4)), arrow=True),
               Text(2, -1, "gap <3> & m")), (0, -2, 10, 6), caption="c")


def test_every_shape_becomes_a_valid_foxglove_primitive():
    from types import SimpleNamespace

    entities = {e["id"]: e for e in scene_entities(SCENE, 1_500_000_000)}
    assert entities["ego"]["cubes"][0]["pose"]["position"] == {"x": 1.0, "y": -2.0, "z": 0.05}
    assert entities["ego"]["metadata"] == [{"key": "label", "value": "ego"}]
    assert len(entities["ball"]["spheres"]) == 1
    assert entities["scene"]["lines"][0]["points"][1] == {"x": 3.0, "y": -4.0, "z": 0.0}
    assert entities["scene"]["texts"][0]["text"] == "gap <3> & m"
    step = SimpleNamespace(state={}, crashed=False, preferred_action=None, action=None,
                           deadlock=None, step=0, reward=0.0, allowed_actions=None)
    [message] = [m for m in step_messages(step, episode=0, stamp_ns=0, draw=lambda s: SCENE)
                 if m.topic == "/foxglove/scene"]
    for schema in (PUBLISHED["foxglove.SceneUpdate"], SCHEMAS["foxglove.SceneUpdate"]):
        jsonschema.Draft202012Validator(schema).validate(message.data)


def test_the_report_s_svg_escapes_text():
    svg = scene_svg(SCENE)
    assert "gap &lt;3&gt; &amp; m" in svg and "<title>ego</title>" in svg


def test_a_thumbnail_keeps_its_text_readable():
    """A 90 m wide road drawn 300 px wide: a 1.5 m text would be 5 px high (the acc report's
    "gap 25.3 m"); it is drawn 10 px high (3 m in the view's units), larger text as it is."""
    road = Scene((Text(40, -2, "gap 25.3 m", 1.5), Text(40, 2, "big", 6.0)), (-10, -5, 90, 8))
    svg = scene_svg(road, 300)
    assert 'width="300" height="27"' in svg
    assert 'font-size="3"' in svg and 'font-size="6"' in svg


def test_a_grid_map_is_drawn_once_and_each_map_as_itself():
    """A grid world's map is one object in every state of a run: its tiles (and their
    Foxglove primitives) are built once for it — and a different map, even one equal in
    size, gets its own tiles, never the last one's."""
    from tracecheck.b.values import Elem, FuncValue
    from tracecheck.live.envs.grid_scene import grid_scene

    holes = frozenset({"HOLE"})

    def lake(holes):
        return FuncValue({(x, y): Elem("HOLE" if (x, y) in holes else "ICE")
                          for x in range(4) for y in range(4)})

    one, other = lake({(1, 1)}), lake({(2, 3)})
    first = grid_scene({"x": 0, "y": 0, "field": one}, danger=holes)
    again = grid_scene({"x": 1, "y": 0, "field": one}, danger=holes)
    assert all(a is b for a, b in zip(first.shapes[:16], again.shapes[:16]))
    assert first.shapes[-1].x == 0.5 and again.shapes[-1].x == 1.5  # the agent moved
    dark = {(s.x - 0.5, s.y - 0.5) for s in grid_scene({"x": 0, "y": 0, "field": other}, danger=holes).shapes
            if s.group == "map" and s.fill[0] < 0.5}
    assert dark == {(2, 3)}
    cubes = [e for e in scene_entities(first, 0) if e["id"] == "map"][0]["cubes"]
    assert cubes == [e for e in scene_entities(again, 1) if e["id"] == "map"][0]["cubes"]
    assert sum(c["color"]["r"] < 0.5 for c in cubes) == 1


def test_a_grid_worlds_scene_is_drawn_once_per_map_goal_and_agent():
    """Issue 46: the agent back on a cell of the same map is the same scene (what is
    remembered for it, its Foxglove entities encoded, holds at every step); another cell, a
    fall, another goal, another map or other kinds drawn dark are another scene."""
    from tracecheck.b.values import Elem, FuncValue
    from tracecheck.live.envs.grid_scene import grid_scene

    def lake():
        return FuncValue({(x, y): Elem("HOLE" if (x, y) == (1, 1) else "ICE")
                          for x in range(3) for y in range(3)})

    one, holes = lake(), frozenset({"HOLE"})

    def draw(x=0, y=0, field_=one, crashed=False, danger=holes, **goal):
        return grid_scene({"x": x, "y": y, "field": field_, **goal}, crashed, danger)

    first = draw()
    assert draw() is first and draw(goal_x=2, goal_y=2) is draw(goal_x=2, goal_y=2)
    others = [draw(1, 0), draw(crashed=True), draw(goal_x=2, goal_y=2), draw(field_=lake()),
              draw(danger=frozenset())]
    assert all(o is not first for o in others)
    assert len({id(o) for o in others}) == len(others)
    assert draw(crashed=True).shapes[-1].fill != first.shapes[-1].fill
    assert [s.fill for s in draw(danger=frozenset()).shapes[:9]] != [
        s.fill for s in first.shapes[:9]]


def test_a_grid_worlds_agent_is_drawn_once_per_place_and_labelled_as_its_numbers():
    """Issue 46: the goal and the agent are the same shapes wherever they stand again (what
    is remembered for a shape holds at every step), each place by its numbers' type and text:
    0.0 and -0.0 are labelled as they are, an int and a float apart."""
    from tracecheck.b.values import Elem, FuncValue
    from tracecheck.live.envs.grid_scene import grid_scene

    lake = FuncValue({(x, y): Elem("ICE") for x in range(2) for y in range(2)})

    def agent(x, y, crashed=False):
        scene = grid_scene({"x": x, "y": y, "goal_x": 1, "goal_y": 1, "field": lake}, crashed)
        return scene.shapes[-1], scene.shapes[-2]

    (a, goal), (b, again) = agent(1, 0), agent(1, 0)
    assert a is b and goal is again and a.label == "agent at (1, 0)"
    assert agent(1, 0, True)[0] is not a and agent(1, 0, True)[0].fill != a.fill
    assert agent(0.0, 0)[0].label == "agent at (0.0, 0)"
    assert agent(-0.0, 0)[0].label == "agent at (-0.0, 0)"
    assert agent(1.0, 0)[0] is not a


def test_one_map_drawn_with_other_kinds_to_avoid_is_drawn_again():
    """The tiles remembered for a map are those of the kinds it was drawn dark for: the same
    map drawn with another set of kinds to avoid gets its own tiles."""
    from tracecheck.b.values import Elem, FuncValue
    from tracecheck.live.envs.grid_scene import grid_scene

    lake = FuncValue({(0, 0): Elem("HOLE"), (1, 0): Elem("ICE")})

    def dark(danger):
        scene = grid_scene({"x": 0, "y": 0, "field": lake}, danger=frozenset(danger))
        return [s.label for s in scene.shapes if s.group == "map" and s.fill[0] < 0.5]

    assert dark({"HOLE"}) == ["(0, 0): HOLE"]
    assert dark({"ICE"}) == ["(1, 0): ICE"]
    assert dark({"HOLE"}) == ["(0, 0): HOLE"]
