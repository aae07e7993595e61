"""Read the concealed-effect sample logs with the mcap library (JSON encoding) into an aligned
frame, independently of logtools' readers: every topic interpolated onto /cmd/curvature."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import polars as pl
from mcap.reader import make_reader

ROOT = Path(__file__).resolve().parents[2]
LOG_DIR = ROOT / "sample_logs"
TRUTH_PATH = ROOT / "tests" / "fixtures" / "concealed_truth.json"

# The tractor-trailer effects the discovery must name (the independent list the tests check).
ISSUE_CATALOGUE = frozenset(
    {
        "hitch_transient",
        "sensor_offset",
        "sensor_scale",
        "actuator_delay",
        "actuator_lag",
        "understeer",
        "clock_offset",
    }
)

_FIELDS = {
    "/cmd/curvature": {"curvature": "kappa_cmd"},
    "/odom": {"v": "v", "omega": "omega"},
    "/hitch/angle": {"angle": "psi"},
}


def load_truth() -> dict[str, dict]:
    return json.loads(TRUTH_PATH.read_text())


def read_aligned(path: Path) -> pl.DataFrame:
    """Aligned frame (t_ns, kappa_cmd, v, omega, psi) of a JSON MCAP drive log."""
    series: dict[str, tuple[list[int], dict[str, list[float]]]] = {
        t: ([], {c: [] for c in f.values()}) for t, f in _FIELDS.items()
    }
    with path.open("rb") as fh:
        for _, channel, message in make_reader(fh).iter_messages(topics=list(_FIELDS)):
            stamps, cols = series[channel.topic]
            msg = json.loads(message.data)
            stamps.append(message.log_time)
            for field, col in _FIELDS[channel.topic].items():
                cols[col].append(float(msg[field]))
    t_ref = np.asarray(series["/cmd/curvature"][0], dtype=np.int64)
    out: dict[str, np.ndarray] = {"t_ns": t_ref}
    keep = np.ones(t_ref.size, dtype=bool)
    for stamps, cols in series.values():
        ts = np.asarray(stamps, dtype=np.int64)
        keep &= (t_ref >= ts[0]) & (t_ref <= ts[-1])
        for col, vals in cols.items():
            out[col] = np.interp(t_ref.astype(float), ts.astype(float), np.asarray(vals))
    return pl.DataFrame({k: v[keep] for k, v in out.items()})
