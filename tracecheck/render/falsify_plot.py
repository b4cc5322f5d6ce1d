"""The objective over a search (``tracecheck falsify --plot FILE``): per optimiser, the lowest
value found so far after each evaluation — each search thin, the median over the searches
bold — with 0, below which an episode violates the property, marked."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

from .stats_text import plain_plot_text

__all__ = ["objective_plot", "objective_svg", "PLOT_SUFFIXES"]

#: the formats the plot is written in, by the file's suffix
PLOT_SUFFIXES = (".png", ".svg")
_SIZE, _DPI = (800, 450), 100


@plain_plot_text()
def objective_plot(values: Sequence[tuple[str, int, int, float]], out: Path, *,
                   title: str) -> Path:
    """Draw ``values`` — (optimizer, search, evaluation, objective) — to ``out`` (checked by
    the output rule beforehand; written whole or not at all)."""
    import matplotlib.pyplot as plt

    from ..outputs import atomic_file

    fig = _figure(values, title)
    try:
        fmt = Path(out).suffix.lower().lstrip(".")
        with atomic_file(Path(out)) as stream:
            fig.savefig(stream, format=fmt, dpi=_DPI)
    finally:
        plt.close(fig)
    return Path(out)


@plain_plot_text()
def objective_svg(values: Sequence[tuple[str, int, int, float]], *, title: str) -> str:
    """The plot of :func:`objective_plot` as an inline SVG text (the report's)."""
    import io

    import matplotlib.pyplot as plt

    fig = _figure(values, title)
    try:
        buf = io.StringIO()
        fig.savefig(buf, format="svg")
    finally:
        plt.close(fig)
    text = buf.getvalue()
    return text[text.index("<svg"):]


def _figure(values: Sequence[tuple[str, int, int, float]], title: str):
    """The figure: per optimiser each search's lowest value so far, and their median."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    runs: dict = {}
    for optimizer, search, evaluation, value in values:
        runs.setdefault(optimizer, {}).setdefault(search, []).append((evaluation, value))
    fig, ax = plt.subplots(figsize=(_SIZE[0] / _DPI, _SIZE[1] / _DPI), dpi=_DPI)
    try:
        colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
        for k, (optimizer, searches) in enumerate(runs.items()):
            colour = colours[k % len(colours)]
            curves = []
            for points in searches.values():
                best = np.minimum.accumulate([v for _, v in sorted(points)])
                curves.append(best)
                ax.plot(np.arange(1, len(best) + 1), best, color=colour, alpha=0.25,
                        linewidth=0.8, drawstyle="steps-post")
            n = min(len(c) for c in curves)
            median = np.median(np.vstack([c[:n] for c in curves]), axis=0)
            ax.plot(np.arange(1, n + 1), median, color=colour, linewidth=2.2,
                    drawstyle="steps-post",
                    label=f"{optimizer} (median of {len(curves)} search(es))")
        ax.axhline(0.0, color="black", linewidth=1.0, linestyle="--")
        ax.text(1, 0.0, " violation below", va="top", fontsize=8)
        ax.set_xlabel("evaluations (episodes)")
        ax.set_ylabel("lowest objective so far")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
        if runs:
            ax.legend(loc="upper right", fontsize=8, frameon=False)
        fig.tight_layout()
    except BaseException:
        plt.close(fig)
        raise
    return fig
