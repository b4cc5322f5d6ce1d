"""The small pictures of an episode in the report: the environment's scene of one state,
or where the environment draws none, its numeric variables over time with the step
marked."""

from __future__ import annotations

import html
from typing import Optional

from .scene import scene_svg
from .viewer import numeric_series

__all__ = ["picture", "sparklines"]


def _e(text) -> str:
    return html.escape(str(text), quote=True)


def picture(draw, ep, k: int, width: int = 300) -> str:
    """Episode ``ep`` at step ``k`` (the last where it has fewer): ``draw(step)``'s scene
    (:func:`~tracecheck.render.scene.scene_drawer`), else its variables' lines marked at k."""
    k = min(k, len(ep.steps) - 1)
    scene = draw(ep.steps[k])
    return scene_svg(scene, width, view=scene.focus) if scene is not None \
        else sparklines(ep, k)


def sparklines(ep, mark: Optional[int], width: int = 260, row: int = 26) -> str:
    """Up to four numeric variables of an episode as small lines, the marked step as a red
    rule."""
    series = [(line["label"], line["values"]) for entry in numeric_series(
        [s.state for s in ep.steps]) for line in entry["lines"]][:4]
    if not series:
        return ""
    n = len(ep.steps)
    label_w = 90
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" '
             f'height="{row * len(series)}" role="img">']
    x = lambda k: label_w + (width - label_w - 4) * (k / (n - 1) if n > 1 else 0.5)  # noqa: E731
    if mark is not None:
        parts.append(f'<line x1="{x(mark):.1f}" x2="{x(mark):.1f}" y1="0" '
                     f'y2="{row * len(series)}" stroke="#e53935"/>')
    for i, (label, values) in enumerate(series):
        given = [v for v in values if v is not None]
        lo, hi = (min(given), max(given)) if given else (0.0, 1.0)
        hi = hi if hi > lo else lo + 1.0
        top = i * row
        points = " ".join(f"{x(k):.1f},{top + 3 + (row - 8) * (1 - (v - lo) / (hi - lo)):.1f}"
                          for k, v in enumerate(values) if v is not None)
        parts.append(f'<text x="0" y="{top + row / 2 + 4:.0f}" font-size="10" fill="#444">'
                     f'{_e(label[:16])}<title>{_e(label)}</title></text>'
                     f'<polyline points="{points}" fill="none" stroke="#1f77b4" '
                     f'stroke-width="1.2"/>')
    parts.append("</svg>")
    return "".join(parts)
