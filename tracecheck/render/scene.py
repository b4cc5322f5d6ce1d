"""How a state is drawn: the drawer that asks the run's environment for its scene (its
adapter's ``scene`` hook), and a scene as the viewer's JSON or a static SVG. The shapes
themselves (:class:`~tracecheck.live.scene.Scene`, ``Box``, ``Circle``, ``Line``, ``Text``)
are the adapters' contract and live in :mod:`tracecheck.live.scene`; each environment draws
its own (a run whose environment is not installed here is drawn without a picture).
"""

from __future__ import annotations

from typing import Callable, Optional

import inspect

from ..errors import InputError
from ..live.scene import Box, Circle, Color, Line, Scene, Shape

__all__ = ["scene_drawer", "scene_adapter", "scene_svg", "css", "shape_json"]


def css(color: Optional[Color]) -> str:
    """A colour as CSS (``none`` for None)."""
    if color is None:
        return "none"
    r, g, b, a = color
    return f"rgba({round(r * 255)},{round(g * 255)},{round(b * 255)},{a:g})"


def shape_json(shape: Shape) -> dict:
    """A shape as the HTML viewer reads it (colours as CSS)."""
    if isinstance(shape, Box):
        return {"kind": "box", "x": shape.x, "y": shape.y, "w": shape.width,
                "h": shape.height, "fill": css(shape.fill), "stroke": css(shape.stroke),
                "sw": shape.stroke_width, "dashed": shape.dashed, "label": shape.label}
    if isinstance(shape, Circle):
        return {"kind": "circle", "x": shape.x, "y": shape.y, "r": shape.radius,
                "fill": css(shape.fill), "stroke": css(shape.stroke),
                "sw": shape.stroke_width, "label": shape.label}
    if isinstance(shape, Line):
        return {"kind": "line", "points": [list(p) for p in shape.points],
                "stroke": css(shape.color), "sw": shape.width, "dashed": shape.dashed,
                "arrow": shape.arrow, "label": shape.label}
    return {"kind": "text", "x": shape.x, "y": shape.y, "text": shape.text,
            "size": shape.size, "fill": css(shape.color)}


def scene_drawer(environment: Optional[str] = None, adapter=None, *,
                 shield: Optional[str] = None,
                 variables: tuple[str, ...] = ()) -> Callable[..., Optional[Scene]]:
    """A function from a step (a ``StepRecord``) to its scene: the ``scene`` hook of
    ``adapter``, or of the installed adapter named ``environment`` (only ever looked up among
    the installed entry points); no picture (None) where there is neither.

    Args:
        environment: the run's environment, as its header names it.
        adapter: the adapter itself, where the caller has it loaded.
        shield: the name of the shield the run is drawn with (passed on to a hook that
            takes it: a scene may show what that shield's guards test).
        variables: the run's state variables (a run that names no environment is drawn by
            the installed one that claims them).
    """
    hook = _hook(adapter if adapter is not None else scene_adapter(environment, variables))

    def draw(step) -> Optional[Scene]:
        if hook is None:
            return None
        scene = hook(step, shield)
        if scene is not None and not isinstance(scene, Scene):
            raise InputError(f"the adapter's scene() returned {type(scene).__name__}, "
                             "not a tracecheck.live.scene.Scene (or None)")
        return scene
    return draw


def no_scene_caption(environment: Optional[str], adapter=None,
                     variables: tuple[str, ...] = ()) -> str:
    """What the viewer says where a run is drawn without a picture — truthfully: its
    environment is not installed here, or its adapter draws none.

    Args:
        environment: the run's environment, as its header names it.
        adapter: the adapter given (``--env``), if any.
        variables: the run's state variables.
    """
    charts = "the charts show every numeric variable over the episode."
    found = adapter if adapter is not None else scene_adapter(environment, variables)
    if found is None:
        why = (f"The run's environment {environment} is not installed here" if environment
               else "The run names no environment and no installed one claims its states")
        return (f"{why}, so no picture is drawn (give its adapter with --env "
                f"package.module:Class to draw its scene); {charts}")
    if _hook(found) is None:
        return (f"The environment {found.name} draws no picture (its adapter has no scene() "
                f"hook: see docs/environments.md, \"Drawing your environment\"); {charts}")
    return f"The environment {found.name} draws no picture of these states; {charts}"


def scene_adapter(environment: Optional[str], variables: tuple[str, ...] = ()):
    """The installed adapter of a run (:func:`tracecheck.live.adapter.run_adapter`), None
    where its environment is not installed here (it is then drawn without a picture)."""
    from ..live.adapter import run_adapter

    return run_adapter(environment, variables)


def _hook(adapter) -> Optional[Callable]:
    """``adapter.scene`` as a function of (step, shield), None where it draws nothing."""
    from ..live.adapter import EnvAdapter

    method = getattr(type(adapter), "scene", None) if adapter is not None else None
    if method is None or method is EnvAdapter.scene:
        return None
    scene = adapter.scene
    try:
        takes_shield = "shield" in inspect.signature(scene).parameters
    except (TypeError, ValueError):
        takes_shield = False
    if takes_shield:
        return lambda step, shield: scene(step, shield=shield)
    return lambda step, shield: scene(step)


#: the smallest text a static picture shows, in pixels: a scene's text is sized in the
#: environment's units, and a thumbnail of a wide view would make it a few pixels high
MIN_TEXT_PX = 10.0


def scene_svg(scene: Scene, width: int = 360, max_height: int = 180,
              view: Optional[tuple[float, float, float, float]] = None) -> str:
    """A scene as a static inline SVG (the report's pictures; ``view`` instead of the
    scene's own), its texts at least :data:`MIN_TEXT_PX` high; every text escaped."""
    from html import escape

    x0, y0, w, h = view or scene.view
    width = min(width, round(max_height * w / h))
    height = max(10, round(width * h / w))
    least = MIN_TEXT_PX * w / width  # in the view's units
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="{x0:g} {y0:g} {w:g} {h:g}" '
             f'width="{width}" height="{height}" role="img">']
    if scene.background is not None:
        parts.append(f'<rect x="{x0:g}" y="{y0:g}" width="{w:g}" height="{h:g}" '
                     f'fill="{css(scene.background)}"/>')
    for s in scene.shapes:
        title = f"<title>{escape(s.label)}</title>" if getattr(s, "label", "") else ""
        if isinstance(s, Box):
            dash = f' stroke-dasharray="{s.stroke_width * 4:g}"' if s.dashed else ""
            parts.append(f'<rect x="{s.x - s.width / 2:g}" y="{s.y - s.height / 2:g}" '
                         f'width="{s.width:g}" height="{s.height:g}" fill="{css(s.fill)}" '
                         f'stroke="{css(s.stroke)}" stroke-width="{s.stroke_width:g}"{dash}>'
                         f'{title}</rect>')
        elif isinstance(s, Circle):
            parts.append(f'<circle cx="{s.x:g}" cy="{s.y:g}" r="{s.radius:g}" '
                         f'fill="{css(s.fill)}" stroke="{css(s.stroke)}" '
                         f'stroke-width="{s.stroke_width:g}">{title}</circle>')
        elif isinstance(s, Line):
            points = " ".join(f"{x:g},{y:g}" for x, y in s.points)
            dash = f' stroke-dasharray="{s.width * 4:g}"' if s.dashed else ""
            parts.append(f'<polyline points="{points}" fill="none" stroke="{css(s.color)}" '
                         f'stroke-width="{s.width:g}"{dash}>{title}</polyline>')
        else:
            parts.append(f'<text x="{s.x:g}" y="{s.y:g}" font-size="{max(s.size, least):g}" '
                         f'fill="{css(s.color)}" text-anchor="middle" '
                         f'dominant-baseline="middle">{escape(s.text)}</text>')
    parts.append("</svg>")
    return "".join(parts)
