"""The learning curve of a training run: each finished episode's return over environment
steps, with the running mean of the last episodes (a PNG beside the model card)."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

from .stats_text import plain_plot_text

__all__ = ["learning_curve", "CURVE_SIZE"]

#: width and height of the PNG, in pixels (8 × 4.5 inches at 100 dpi)
CURVE_SIZE = (800, 450)
_DPI = 100


def running_mean(values: Sequence[float], window: int) -> list[float]:
    """The mean of each value and the ``window - 1`` before it (fewer at the start).

    >>> running_mean([1.0, 3.0, 5.0], 2)
    [1.0, 2.0, 4.0]
    """
    import numpy as np

    sums = np.cumsum(np.asarray(values, dtype=np.float64))
    out = []
    for i in range(len(values)):
        lo = i - window
        out.append(float((sums[i] - (sums[lo] if lo >= 0 else 0.0)) / (i - max(lo, -1))))
    return out


@plain_plot_text()
def learning_curve(end_steps: Sequence[int], returns: Sequence[float], out: Path, *,
                   window: int, steps: int, title: str) -> Path:
    """Draw the curve to ``out`` (checked by the output rule beforehand; written whole or not
    at all). With no finished episode the plot says so instead of showing an empty axis."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..outputs import atomic_file

    fig, ax = plt.subplots(figsize=(CURVE_SIZE[0] / _DPI, CURVE_SIZE[1] / _DPI), dpi=_DPI)
    try:
        if returns:
            ax.scatter(end_steps, returns, s=6, alpha=0.35, color="tab:blue",
                       label="episode return")
            ax.plot(end_steps, running_mean(returns, window), color="tab:red", linewidth=2,
                    label=f"mean of the last {window} episodes")
            ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncols=2,
                      frameon=False)
        else:
            ax.text(0.5, 0.5, f"no episode finished in {steps} steps", ha="center",
                    va="center", transform=ax.transAxes)
        ax.set_xlim(0, max(steps, 1))
        ax.set_xlabel("environment steps")
        ax.set_ylabel("return")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        with atomic_file(Path(out)) as stream:
            fig.savefig(stream, format="png", dpi=_DPI)
    finally:
        plt.close(fig)
    return Path(out)
