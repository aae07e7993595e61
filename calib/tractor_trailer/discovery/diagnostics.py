"""Residual diagnostics: where and under which conditions the model fails.

Per time window and per segment, binned by speed, |curvature|, |curvature rate per distance|
and command type; Ljung-Box whiteness; cross-correlation of residuals with each input at lags;
mismatch regions (windows whose RMS stands clearly above the sensor noise, merged).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from calib.adequacy.whiteness import ljung_box
from calib.results import json_safe
from calib.tractor_trailer.discovery.data import DiscoveryData
from calib.tractor_trailer.results import Segment

__all__ = [
    "MismatchRegion",
    "binned_stats",
    "command_types",
    "cross_correlations",
    "find_regions",
    "ljung_box",
]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

UNITS = {"omega": "rad/s", "psi": "rad"}


def cross_correlations(
    r: FloatArray, inputs: Mapping[str, FloatArray], dt_s: float, max_lag_s: float = 2.0
) -> dict[str, dict[str, float]]:
    """Peak normalised cross-correlation of ``r`` with each input over lags of +/- max_lag_s.

    A positive ``lag_s`` means the residual follows the input later in time.
    """
    out: dict[str, dict[str, float]] = {}
    x0 = r - r.mean()
    sr = float(np.std(x0))
    nl = max(1, round(max_lag_s / dt_s))
    for name, u in inputs.items():
        u0 = u - u.mean()
        su = float(np.std(u0))
        if sr <= 0 or su <= 0:
            out[name] = {"corr": 0.0, "lag_s": 0.0, "corr_at_0": 0.0}
            continue
        best, best_lag, at0 = 0.0, 0, 0.0
        for k in range(-nl, nl + 1):
            if k >= 0:
                c = float(np.mean(x0[k:] * u0[: u0.size - k])) / (sr * su)
            else:
                c = float(np.mean(x0[:k] * u0[-k:])) / (sr * su)
            if k == 0:
                at0 = c
            if abs(c) > abs(best):
                best, best_lag = c, k
        out[name] = {"corr": best, "lag_s": best_lag * dt_s, "corr_at_0": at0}
    return out


def command_types(t_s: FloatArray, segments: Sequence[Segment] | None) -> list[str]:
    """Command type of each time (s from the start), "none" outside every segment."""
    labels = np.full(t_s.size, "none", dtype=object)
    for seg in segments or ():
        labels[(t_s >= seg.start_s) & (t_s < seg.end_s)] = str(seg.command_type)
    return labels.tolist()


def _stats(r: FloatArray) -> dict[str, float]:
    return {"n": int(r.size), "rms": float(np.sqrt(np.mean(r**2))), "mean": float(np.mean(r))}


def binned_stats(
    residuals: Mapping[str, FloatArray],
    by: FloatArray | Sequence[str],
    n_bins: int = 4,
    mask: BoolArray | None = None,
) -> list[dict[str, Any]]:
    """Residual RMS and mean per output in bins of ``by`` (quantile bins, or labels)."""
    first = next(iter(residuals.values()))
    mk = np.ones(first.size, dtype=bool) if mask is None else mask
    rows: list[dict[str, Any]] = []
    if isinstance(by, np.ndarray) and by.dtype.kind == "f":
        vals = by[mk]
        edges = np.unique(np.quantile(vals, np.linspace(0, 1, n_bins + 1)))
        if edges.size < 2:
            edges = np.array([vals.min(), vals.max() + 1e-12])
        idx = np.clip(np.searchsorted(edges, by, side="right") - 1, 0, edges.size - 2)
        for b in range(edges.size - 1):
            sel = mk & (idx == b)
            if sel.any():
                row: dict[str, Any] = {"bin": [float(edges[b]), float(edges[b + 1])]}
                row.update({c: _stats(r[sel]) for c, r in residuals.items()})
                rows.append(row)
        return rows
    labels = np.asarray(list(by))
    for lab in sorted(set(labels[mk].tolist())):
        sel = mk & (labels == lab)
        row = {"bin": lab}
        row.update({c: _stats(r[sel]) for c, r in residuals.items()})
        rows.append(row)
    return rows


@dataclass(frozen=True)
class MismatchRegion:
    """A stretch where the model misses one output by clearly more than the sensor noise.

    Times in s from the first sample; ``rms``/``mean`` of recorded - modelled in the output's
    unit; ``noise_ratio`` = rms / noise level on the fitting grid; ``share`` the fraction of the
    output's squared residual inside the region; ``conditions`` mean speed (m/s), mean
    |kappa_cmd| (1/m), mean |dkappa_cmd/ds| (1/m^2) and the command types present.
    """

    channel: str
    start_s: float
    end_s: float
    rms: float
    mean: float
    noise_ratio: float
    share: float
    conditions: Mapping[str, Any] = field(default_factory=dict)

    def report(self) -> str:
        c = self.conditions
        return (
            f"{self.channel} {self.start_s:.1f}-{self.end_s:.1f} s: rms {self.rms:.3g} "
            f"{UNITS.get(self.channel, '')} ({self.noise_ratio:.1f}x noise, mean "
            f"{self.mean:+.3g}), {100 * self.share:.0f} % of its misfit; v {c.get('speed', 0):.2f}"
            f" m/s, |kappa| {c.get('abs_kappa', 0):.3f} 1/m, |dkappa/ds| "
            f"{c.get('abs_dkappa_ds', 0):.3g} 1/m^2, {', '.join(c.get('command_types', []))}"
        )

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "channel": self.channel,
                "start_s": self.start_s,
                "end_s": self.end_s,
                "rms": self.rms,
                "mean": self.mean,
                "noise_ratio": self.noise_ratio,
                "share": self.share,
                "conditions": dict(self.conditions),
            }
        )


def find_regions(
    data: DiscoveryData,
    residuals: Mapping[str, FloatArray],
    inputs: Mapping[str, FloatArray],
    types: Sequence[str],
    window_s: float = 5.0,
    threshold: float = 3.0,
    max_regions: int = 20,
) -> list[MismatchRegion]:
    """Windows of ``window_s`` whose residual RMS exceeds ``threshold`` x the noise, merged.

    Only rows in ``data.valid`` count. Sorted by share of misfit, largest first.
    """
    t = data.tc_s
    dt = float(np.median(np.diff(t)))
    w = max(2, round(window_s / dt))
    regions: list[MismatchRegion] = []
    types_arr = np.asarray(list(types))
    for c, r in residuals.items():
        rv = np.where(data.valid, r, 0.0)
        total = float(np.sum(rv**2))
        nw = r.size // w
        flags = []
        for i in range(nw):
            sl = slice(i * w, (i + 1) * w)
            ok = data.valid[sl]
            rms = float(np.sqrt(np.mean(r[sl][ok] ** 2))) if ok.sum() >= w // 2 else 0.0
            flags.append(rms > threshold * data.sigma_d[c])
        i = 0
        while i < nw:
            if not flags[i]:
                i += 1
                continue
            j = i
            while j + 1 < nw and flags[j + 1]:
                j += 1
            sel = np.zeros(r.size, dtype=bool)
            sel[i * w : (j + 1) * w] = True
            sel &= data.valid
            rr = r[sel]
            rms = float(np.sqrt(np.mean(rr**2)))
            regions.append(
                MismatchRegion(
                    channel=c,
                    start_s=float(t[i * w]),
                    end_s=float(t[min((j + 1) * w, r.size) - 1]),
                    rms=rms,
                    mean=float(np.mean(rr)),
                    noise_ratio=rms / data.sigma_d[c],
                    share=float(np.sum(rr**2)) / total if total > 0 else 0.0,
                    conditions={
                        "speed": float(np.mean(np.abs(inputs["v"][sel]))),
                        "abs_kappa": float(np.mean(np.abs(inputs["kappa_cmd"][sel]))),
                        "abs_dkappa_ds": float(np.mean(np.abs(inputs["dkappa_cmd/ds"][sel]))),
                        "command_types": sorted(set(types_arr[sel].tolist())),
                    },
                )
            )
            i = j + 1
    regions.sort(key=lambda g: -g.share)
    return regions[:max_regions]
