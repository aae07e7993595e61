"""PNG plots of the batch report: one parameter of one robot across its logs, in time order.

matplotlib (Agg, no display) draws what :class:`logtools.batch.fleet.ParameterSeries` carries:
each log's estimate with its 95 % interval, the pooled value and interval as a band, and the
flagged step change as a vertical line. Logs whose estimate is not determined are marked on
the axis, not drawn as numbers.
"""

from __future__ import annotations

import math
from pathlib import Path

from logtools.batch.fleet import ParameterSeries

__all__ = ["series_png"]


def series_png(series: ParameterSeries, path: Path) -> None:
    """Draw ``series`` to the PNG ``path`` (written as given: the caller renames atomically)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    fig: Figure = plt.figure(figsize=(7.5, 3.2), dpi=100)
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
        ax.errorbar(
            xs, ys, yerr=es, fmt="o", ms=4, capsize=2, color="tab:blue", label="per log (95 %)"
        )
        est = series.pooled.estimate
        if math.isfinite(est.value) and math.isfinite(est.std):
            lo, hi = est.ci95
            ax.axhspan(lo, hi, color="tab:orange", alpha=0.25, label="pooled (95 %)")
            ax.axhline(est.value, color="tab:orange", lw=1)
        d = series.drift
        if d.change_point and d.change_after is not None:
            k = series.logs.index(d.change_after)
            ax.axvline(k + 0.5, color="tab:red", ls="--", lw=1.2, label="step change")
        if bad:
            ax.plot(
                bad,
                [ax.get_ylim()[0]] * len(bad),
                "x",
                color="grey",
                label="not determined",
                clip_on=False,
            )
        from matplotlib.ticker import MaxNLocator

        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_xlabel("log, in time order (0 = first)")
        unit = f" ({series.unit})" if series.unit else ""
        ax.set_ylabel(f"{series.parameter}{unit}", parse_math=False)
        ax.set_title(
            f"{series.robot_id} · {series.robot} · {series.parameter}",
            fontsize=10,
            parse_math=False,
        )
        ax.legend(fontsize=7, loc="best")
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(path, format="png")
    finally:
        plt.close(fig)
