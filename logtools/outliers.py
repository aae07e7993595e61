"""Single-sample outliers in a logical signal, found with robust statistics and excluded.

Why hand-written: the test is specific to drive logs (a sample that jumps away and straight back,
with commands that legitimately step), and a library outlier detector (z-scores, isolation
forests) either needs a noise model or flags command steps.

A sample ``i`` is an outlier when

* both its rates of change, into it ``d_i = (x_i - x_{i-1}) / (t_i - t_{i-1})`` and out of it
  ``d_{i+1}``, exceed ``K`` robust standard deviations of all rates of change of the signal
  (``1.4826 * MAD`` of ``d`` about its median; with a floor of ``1.4826 * MAD`` of the values over
  the median period, so that piecewise-constant commands, whose ``d`` is mostly 0, still need a
  jump beyond their own spread), in opposite directions, and the signal returns:
  ``|x_{i+1} - x_{i-1}|`` is below a quarter of the smaller jump. A step of a command has one large
  rate of change, not two, and is kept.
* or its distance from the median exceeds :data:`GROSS_FACTOR` times (the 1-99 % range of the
  values + ``|median|`` + 1): a 1e308 or 1e7 anywhere, also as the first or last sample.

``K`` = :data:`SPIKE_K` (10). For Gaussian noise a false alarm needs two adjacent 10-sigma rates of
change; a speed sample of 100 m/s among 1,200 at 1-2 m/s is far beyond. The outliers are dropped
before alignment and reported (one :class:`Problem` per signal, with their times), so an
estimate never moves silently because of them.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import polars as pl

from logtools.problems import Problem, ProblemKind

__all__ = ["GROSS_FACTOR", "SPIKE_K", "drop_outliers", "outlier_mask"]

SPIKE_K = 10.0
"""Robust standard deviations of the rate of change both jumps of a spike exceed."""
GROSS_FACTOR = 1e3
"""A value this many times the signal's range (+ |median| + 1) from the median is an outlier."""
_MAD_TO_STD = 1.4826
_SHOWN = 5


def _mad(a: np.ndarray) -> float:
    return float(np.median(np.abs(a - np.median(a)))) if a.size else 0.0


def outlier_mask(t_ns: np.ndarray, x: np.ndarray) -> np.ndarray:
    """True for the samples of ``x`` (at increasing, distinct times ``t_ns``) that are outliers
    by the rules of the module docstring; all False for fewer than 5 finite samples."""
    x = np.asarray(x, dtype=float)
    t = np.asarray(t_ns, dtype=np.int64)
    bad = np.zeros(x.size, dtype=bool)
    finite = np.isfinite(x)
    if np.count_nonzero(finite) < 5:
        return bad
    with np.errstate(over="ignore", invalid="ignore"):
        lo, med, hi = (float(q) for q in np.percentile(x[finite], [1.0, 50.0, 99.0]))
        gross = GROSS_FACTOR * (hi - lo + abs(med) + 1.0)
        bad |= finite & (np.abs(x - med) > gross)
        keep = ~bad & finite
        tk, xk = t[keep], x[keep]
        if xk.size < 5:
            return bad
        dt = np.diff(tk).astype(float) * 1e-9
        d = np.diff(xk) / dt
        dt_med = float(np.median(dt))
        scale = _MAD_TO_STD * max(_mad(d), _mad(xk) / dt_med)
        thr = SPIKE_K * scale + 1e-12 * (abs(med) + 1.0) / dt_med
        d_in, d_out = d[:-1], d[1:]
        jump_in, jump_out = np.abs(np.diff(xk)[:-1]), np.abs(np.diff(xk)[1:])
        returns = np.abs(xk[2:] - xk[:-2]) < 0.25 * np.minimum(jump_in, jump_out)
        spike = (np.abs(d_in) > thr) & (np.abs(d_out) > thr) & (np.sign(d_in) != np.sign(d_out))
        spike &= returns
    idx = np.flatnonzero(keep)[1:-1][spike]
    bad[idx] = True
    return bad


def drop_outliers(
    path: str, signals: Mapping[str, pl.DataFrame], origin_ns: int
) -> tuple[dict[str, pl.DataFrame], list[Problem]]:
    """Each signal (``t_ns``, ``value``) without its outliers, and one ``OUTLIER`` problem per
    signal that had some (times in the sentence relative to ``origin_ns``)."""
    out: dict[str, pl.DataFrame] = {}
    problems: list[Problem] = []
    for name, frame in signals.items():
        if "value" not in frame.columns or frame.height < 5:
            out[name] = frame
            continue
        t = frame["t_ns"].to_numpy()
        x = frame["value"].cast(pl.Float64).to_numpy()
        bad = outlier_mask(t, x)
        k = int(np.count_nonzero(bad))
        if not k:
            out[name] = frame
            continue
        out[name] = frame.filter(pl.Series(~bad))
        tb, xb = t[bad], x[bad]
        shown = ", ".join(
            f"{(int(ti) - origin_ns) * 1e-9:.3f} s ({xi:.4g})"
            for ti, xi in zip(tb[:_SHOWN], xb[:_SHOWN], strict=True)
        )
        more = f" and {k - _SHOWN} more" if k > _SHOWN else ""
        problems.append(
            Problem(
                ProblemKind.OUTLIER,
                name,
                int(tb[0]),
                int(tb[-1]),
                count=k,
                message=f"{path}: signal {name!r}: {k} of {frame.height} samples jump away from "
                f"their neighbours and back (robust rate-of-change test) and were excluded: at "
                f"{shown}{more} (times relative to the first sample)",
            )
        )
    return out, problems
