"""The scene an adapter draws a state with: boxes, circles, lines and text in a
:class:`Scene`, checked when they are made. The viewer (:mod:`tracecheck.render.scene`,
:mod:`tracecheck.render.viewer`) draws them as SVG and the Foxglove writer
(:mod:`tracecheck.interop.foxglove`) converts them to a ``foxglove.SceneUpdate``.

Coordinates are the environment's own units (metres on a road, cells in a grid world),
x to the right and y *down*, as on a page; Foxglove's y points the other way and its writer
flips it. Colours are RGBA in 0..1. Every shape has a ``group`` (the Foxglove entity it joins,
e.g. one per vehicle) and an optional ``label`` (the viewer's hover text).

An adapter draws its own environment by implementing ``scene(step)`` (docs/environments.md,
"Drawing your environment")::

    def scene(self, step):
        gap = step.state["Gap"]
        return Scene(shapes=(Box(x=0, y=0, width=4, height=2, fill=BLUE, label="ego"),
                             Box(x=gap, y=0, width=4, height=2, fill=GREY, label="lead")),
                     view=(-10, -5, gap + 20, 10), caption="ego (blue) and lead car")
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional, Union

from ..errors import InputError

__all__ = ["Scene", "Box", "Circle", "Line", "Text", "Shape", "Color", "WHITE", "BLACK", "GREY",
           "BLUE", "GREEN", "RED", "YELLOW"]

Color = tuple[float, float, float, float]
WHITE, BLACK, GREY = (1.0, 1.0, 1.0, 1.0), (0.1, 0.1, 0.1, 1.0), (0.55, 0.55, 0.55, 1.0)
BLUE, GREEN, RED, YELLOW = ((0.29, 0.48, 0.82, 1.0), (0.24, 0.69, 0.26, 1.0),
                            (0.83, 0.2, 0.2, 1.0), (1.0, 0.84, 0.31, 1.0))


def _number(owner: str, name: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"a scene's {owner} has {name} {value!r}: give a finite number")


def _color(owner: str, name: str, value) -> None:
    if value is None:
        return
    if (not isinstance(value, tuple) or len(value) != 4
            or not all(isinstance(c, (int, float)) and 0 <= c <= 1 for c in value)):
        raise InputError(f"a scene's {owner} has {name} {value!r}: give (r, g, b, a), each "
                         "from 0 to 1")


def _check(shape, numbers: tuple[str, ...], colors: tuple[str, ...]) -> None:
    owner = type(shape).__name__
    for name in numbers:
        _number(owner, name, getattr(shape, name))
    for name in colors:
        _color(owner, name, getattr(shape, name))


@dataclass(frozen=True, slots=True)
class Box:
    """A rectangle centred on (x, y); ``depth`` is its height in Foxglove's 3D view."""

    x: float
    y: float
    width: float
    height: float
    fill: Optional[Color] = GREY
    stroke: Optional[Color] = None
    stroke_width: float = 0.1
    dashed: bool = False
    label: str = ""
    group: str = "scene"
    depth: float = 0.1

    def __post_init__(self):
        _check(self, ("x", "y", "width", "height", "stroke_width", "depth"), ("fill", "stroke"))


@dataclass(frozen=True, slots=True)
class Circle:
    """A disc centred on (x, y) (a sphere in Foxglove)."""

    x: float
    y: float
    radius: float
    fill: Optional[Color] = GREY
    stroke: Optional[Color] = None
    stroke_width: float = 0.05
    label: str = ""
    group: str = "scene"

    def __post_init__(self):
        _check(self, ("x", "y", "radius", "stroke_width"), ("fill", "stroke"))


@dataclass(frozen=True, slots=True)
class Line:
    """A polyline through ``points``; ``arrow`` puts a head on its last point."""

    points: tuple[tuple[float, float], ...]
    color: Color = BLACK
    width: float = 0.1
    dashed: bool = False
    arrow: bool = False
    label: str = ""
    group: str = "scene"

    def __post_init__(self):
        if not isinstance(self.points, tuple) or len(self.points) < 2:
            raise InputError(f"a scene's Line has points {self.points!r}: give a tuple of at "
                             "least two (x, y) pairs")
        for p in self.points:
            if not isinstance(p, tuple) or len(p) != 2:
                raise InputError(f"a scene's Line has the point {p!r}: give an (x, y) pair")
            _number("Line", "a point coordinate", p[0])
            _number("Line", "a point coordinate", p[1])
        _check(self, ("width",), ("color",))


@dataclass(frozen=True, slots=True)
class Text:
    """``text`` centred on (x, y), ``size`` high."""

    x: float
    y: float
    text: str
    size: float = 1.0
    color: Color = BLACK
    group: str = "scene"

    def __post_init__(self):
        _check(self, ("x", "y", "size"), ("color",))
        if not isinstance(self.text, str):
            raise InputError(f"a scene's Text has text {self.text!r}: give a string")


Shape = Union[Box, Circle, Line, Text]
_SHAPES = frozenset((Box, Circle, Line, Text))


@dataclass(frozen=True, slots=True)
class Scene:
    """What one state shows: ``shapes`` drawn in order (later ones on top) inside ``view``
    (x, y, width, height: the region to show), a ``caption`` saying how to read it."""

    shapes: tuple[Shape, ...]
    view: tuple[float, float, float, float]
    background: Optional[Color] = None
    caption: str = ""
    #: pixels per unit of the view on the viewer's page (a 7×7 grid at 40: 280 px), never
    #: more than fits the page; None: as large as fits (the page's width, 60 % of the
    #: window's height)
    scale: Optional[float] = field(default=None)
    #: the region a small picture (the report's thumbnails) shows, (x, y, width, height);
    #: None: the whole view
    focus: Optional[tuple[float, float, float, float]] = None

    def __post_init__(self):
        if not isinstance(self.shapes, tuple) or (
                not _SHAPES.issuperset(map(type, self.shapes))  # at C speed, then subclasses
                and not all(isinstance(s, (Box, Circle, Line, Text)) for s in self.shapes)):
            raise InputError("a Scene's shapes must be a tuple of Box, Circle, Line and Text")
        if not isinstance(self.view, tuple) or len(self.view) != 4:
            raise InputError(f"a Scene has view {self.view!r}: give (x, y, width, height)")
        for v in self.view:
            _number("view", "a bound", v)
        if self.view[2] <= 0 or self.view[3] <= 0:
            raise InputError(f"a Scene has view {self.view!r}: its width and height must be "
                             "above 0")
        if self.focus is not None:
            if not isinstance(self.focus, tuple) or len(self.focus) != 4 or any(
                    isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)
                    for v in self.focus) or self.focus[2] <= 0 or self.focus[3] <= 0:
                raise InputError(f"a Scene has focus {self.focus!r}: give (x, y, width, "
                                 "height) with a width and height above 0, or None")
        if self.scale is not None and (isinstance(self.scale, bool) or not isinstance(
                self.scale, (int, float)) or not math.isfinite(self.scale) or self.scale <= 0):
            raise InputError(f"a Scene has scale {self.scale!r}: give the pixels per unit of "
                             "its view (a number above 0), or None to fit the page")
        _color("Scene", "background", self.background)
