"""PNG plots of the batch report: one parameter of one robot across its logs, in time order.

matplotlib (Agg, no display) draws what :class:`logtools.batch.fleet.ParameterSeries` carries:
each log's estimate with its 95 % interval, the pooled value and interval as a band, and the
flagged step change as a vertical line. Logs whose estimate is not determined are marked on
the axis, not drawn as numbers.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

from logtools.batch.fleet import ParameterSeries

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["log_labels", "series_figure", "series_png"]

#: Okabe-Ito colours (as ``viz.style.OKABE_ITO``; ``logtools`` does not import ``viz``).
_BLUE, _ORANGE, _VERMILLION = "#0072b2", "#e69f00", "#d55e00"
_MAX_LABELS = 24
"""More logs than this: every k-th log is named on the axis (the others keep a tick)."""


def log_labels(logs: list[str]) -> list[str]:
    """The x axis's label of each log: its file name without the suffix; with more than
    ``_MAX_LABELS`` logs, every k-th named and the others blank."""
    names = [Path(p).stem or str(p) for p in logs]
    step = max(1, math.ceil(len(names) / _MAX_LABELS))
    return [n if i % step == 0 else "" for i, n in enumerate(names)]


def series_png(series: ParameterSeries, path: Path) -> None:
    """Draw ``series`` to the PNG ``path`` (written as given: the caller renames atomically)."""
    import matplotlib.pyplot as plt

    fig = series_figure(series)
    try:
        fig.savefig(path, format="png")
    finally:
        plt.close(fig)


def series_figure(series: ParameterSeries) -> Figure:
    """The figure of ``series``: per log (named on the x axis, in time order) its estimate with
    its 95 % interval, the pooled band, the step change; the legend right of the axes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig: Figure = plt.figure(figsize=(9.0, 3.6), dpi=100)
    try:
        ax = fig.add_subplot(1, 1, 1)
        xs, ys, es, bad = [], [], [], []
        for i, (v, s, ok) in enumerate(
            zip(series.values, series.stds, series.identifiable, strict=True)
        ):
            if ok is not False and v is not None and s is not None and math.isfinite(s):
                xs.append(i)
                ys.append(v)
                es.append(1.96 * s)
            else:
                bad.append(i)
        ax.errorbar(xs, ys, yerr=es, fmt="o", ms=4, capsize=2, color=_BLUE, label="per log (95 %)")
        est = series.pooled.estimate
        if math.isfinite(est.value) and math.isfinite(est.std):
            lo, hi = est.ci95
            ax.axhspan(lo, hi, color=_ORANGE, alpha=0.3, label="pooled (95 %)")
            ax.axhline(est.value, color=_ORANGE, lw=1)
        d = series.drift
        if d.change_point and d.change_after is not None:
            k = series.logs.index(d.change_after)
            ax.axvline(k + 0.5, color=_VERMILLION, ls="--", lw=1.2, label="step change")
        if bad:
            ax.plot(
                bad,
                [ax.get_ylim()[0]] * len(bad),
                "x",
                color="grey",
                label="not determined",
                clip_on=False,
            )
        ax.set_xticks(range(len(series.logs)), log_labels(series.logs))
        ax.tick_params(axis="x", labelsize=7, labelrotation=30)
        for label in ax.get_xticklabels():
            label.set_horizontalalignment("right")
        ax.set_xlabel("log, in time order")
        unit = f" ({series.unit})" if series.unit else ""
        ax.set_ylabel(f"{series.parameter}{unit}", parse_math=False)
        ax.set_title(
            f"{series.robot_id} · {series.robot} · {series.parameter}",
            fontsize=10,
            parse_math=False,
        )
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
        ax.grid(alpha=0.3)
        fig.tight_layout()
    except Exception:
        plt.close(fig)
        raise
    return fig
