"""The plot of ``tracecheck tune --plot FILE``: on the left, steps blocked and crashes with no
blocked step before them for every value of the tuned number (piecewise constant, as found);
on the right, the Pareto front of the two — the machine's own value marked on both, the knee
on the front."""

from __future__ import annotations

from pathlib import Path

from .stats_text import plain_plot_text

__all__ = ["tune_plot", "PLOT_SUFFIXES"]

PLOT_SUFFIXES = (".png", ".svg")
_SIZE, _DPI = (1100, 450), 100


@plain_plot_text()
def tune_plot(result, out: Path) -> Path:
    """Draw ``result`` (a :class:`~tracecheck.search.tuning.TuneResult`) to ``out`` (checked
    by the output rule beforehand; written whole or not at all)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..outputs import atomic_file

    fig = _figure(result)
    try:
        with atomic_file(Path(out)) as stream:
            fig.savefig(stream, format=Path(out).suffix.lower().lstrip("."), dpi=_DPI)
    finally:
        plt.close(fig)
    return Path(out)


def _figure(result):
    import matplotlib.pyplot as plt

    r = result
    label = r.target.label
    own = float(r.target.value)
    fig, (left, right) = plt.subplots(1, 2, figsize=(_SIZE[0] / _DPI, _SIZE[1] / _DPI),
                                      dpi=_DPI)
    try:
        steps = left
        missed = left.twinx()
        for p in r.pieces:
            f = p.figures
            lo, hi = float(p.low), float(p.high)
            if p.whole:  # an INTEGER's values: a dot at each whole number
                xs = range(int(lo), int(hi) + 1)
                steps.plot(xs, [f.steps_blocked] * len(xs), ".-", color="C0", markersize=5)
                missed.plot(xs, [r.crashes - f.crashes_after_blocked] * len(xs), ".-",
                            color="C3", markersize=5)
            elif lo == hi:
                steps.plot([lo], [f.steps_blocked], ".", color="C0", markersize=3)
                missed.plot([lo], [r.crashes - f.crashes_after_blocked], ".", color="C3",
                            markersize=3)
            else:
                steps.hlines(f.steps_blocked, lo, hi, color="C0", linewidth=1.6)
                missed.hlines(r.crashes - f.crashes_after_blocked, lo, hi, color="C3",
                              linewidth=1.6)
        steps.axvline(own, color="black", linestyle="--", linewidth=1.0)
        steps.text(own, steps.get_ylim()[1], f" machine's {own:g}", va="top", fontsize=8)
        steps.set_xlabel(f"{label}" + (" (grid)" if r.method == "grid" else " (exact)"))
        steps.set_ylabel("steps blocked", color="C0")
        missed.set_ylabel("crashes with no blocked step before", color="C3")
        steps.set_title(f"{r.shield['name']}: {r.episodes} episodes", fontsize=10)
        steps.grid(alpha=0.3)
        every = {(p.figures.steps_blocked, r.crashes - p.figures.crashes_after_blocked)
                 for p in r.pieces}
        right.plot([x for x, _ in every], [y for _, y in every], ".", color="0.7",
                   markersize=4, label="every value")
        xs = [f.figures.steps_blocked for f in r.front]
        ys = [f.crashes_missed for f in r.front]
        right.step(xs, ys, where="post", color="C2", linewidth=1.2)
        right.plot(xs, ys, "o", color="C2", markersize=4, label="Pareto front")
        cur = r.current
        right.plot([cur.steps_blocked], [r.crashes - cur.crashes_after_blocked], "s",
                   color="black", markersize=7, label=f"machine's {label} = {own:g}")
        if r.knee is not None:
            k = r.knee
            right.plot([k.figures.steps_blocked], [k.crashes_missed], "*", color="C1",
                       markersize=12, label=f"knee ({label} = {k.value:g})")
        right.set_xlabel("steps blocked (interventions)")
        right.set_ylabel("crashes with no blocked step before")
        right.set_title("trade-off", fontsize=10)
        right.grid(alpha=0.3)
        right.legend(fontsize=8, frameon=False)
        fig.tight_layout()
    except BaseException:
        plt.close(fig)
        raise
    return fig
