"""An aligned frame built from a simulated run, for tests and studies without logtools.

Test and bench helper (moved out of ``calib.tractor_trailer.discovery``: the library has no use for
it);
imported as ``sim_frame`` with ``tests/`` on the path (pytest's ``pythonpath``; bench scripts
insert it).
"""

from __future__ import annotations

import numpy as np
import polars as pl

from calib.tractor_trailer.sim.tractor_trailer import SimulatedRun

__all__ = ["aligned_frame_from_run"]


def aligned_frame_from_run(run: SimulatedRun, reference: str = "cmd") -> pl.DataFrame:
    """Every sensor group's signals linearly interpolated onto the ``reference`` group's stamps.

    Returns ``t_ns``, kappa_cmd, v_cmd, v, omega, x, y, yaw, psi and ``kappa`` = omega / v
    (NaN where |v| < 0.05 m/s); rows outside another group's time span are dropped.
    """
    ref = run.frames[reference]
    t = ref.get_column("t_ns").to_numpy()
    cols: dict[str, np.ndarray] = {"t_ns": t}
    keep = np.ones(t.size, dtype=bool)
    for frame in run.frames.values():
        tg = frame.get_column("t_ns").to_numpy()
        keep &= (t >= tg[0]) & (t <= tg[-1])
        for name in frame.columns:
            if name != "t_ns":
                cols[name] = np.interp(t.astype(float), tg.astype(float), frame[name].to_numpy())
    v, om = cols["v"], cols["omega"]
    with np.errstate(divide="ignore", invalid="ignore"):
        cols["kappa"] = np.where(np.abs(v) > 0.05, om / v, np.nan)
    return pl.DataFrame({k: c[keep] for k, c in cols.items()})
