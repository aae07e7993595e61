"""Real recordings (../shared/realworld_drive/optiodom): calibrate on one session, dead-reckon
the runs of the other sessions (and its own), end-point error before (nominal) / after per
run; parameters of each session with their 95 % intervals; and, per run, the end-point error
the calibration's own uncertainty implies (median and 95th percentile over the LSQ bootstrap
replicates of the calibrating session): a run whose nominal error is already below that cannot
show a 5x improvement whatever the method.

    python bench/diff_drive_real.py [OPTIODOM_DIR]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from calib.diff_drive.data import DriveRun
from calib.diff_drive.dead_reckoning import dead_reckon
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.odometry_lsq import calibrate_lsq
from calib.diff_drive.umbmark import umbmark, umbmark_result
from logtools.readers.optiodom import read_optiodom, session_runs

ROOT = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("/work/shared/realworld_drive/optiodom")


def load(folder: Path) -> tuple[list[DriveRun], DiffDriveParams, float | None]:
    runs = []
    nominal = None
    side = None
    for f in session_runs(folder):
        log = read_optiodom(f)
        fr = log.topics["csv"]
        t = fr["t_ns"].to_numpy() * 1e-9
        runs.append(
            DriveRun(
                t,
                fr["wheel_right"].to_numpy(),
                fr["wheel_left"].to_numpy(),
                fr["x"].to_numpy(),
                fr["y"].to_numpy(),
                fr["yaw"].to_numpy(),
                name=f.stem,
            )
        )
        nom = log.metadata["logcal.nominal"]
        nominal = DiffDriveParams(
            float(nom["wheel_radius_right"]),
            float(nom["wheel_radius_left"]),
            float(nom["track_width"]),
        )
        side = float(nom["square_side"]) if "square_side" in nom else None
    assert nominal is not None
    return runs, nominal, side


def end_error(run: DriveRun, p: DiffDriveParams) -> float:
    dr = dead_reckon(run.t, run.wheel_right, run.wheel_left, p, (run.x[0], run.y[0], run.yaw[0]))
    return float(np.hypot(dr.x[-1] - run.x[-1], dr.y[-1] - run.y[-1]))


def main() -> None:
    sessions = {
        f"{k.name}/{s.name}": s
        for k in sorted(ROOT.iterdir())
        if k.is_dir()
        for s in sorted(k.iterdir())
        if s.is_dir()
    }
    data = {name: load(folder) for name, folder in sessions.items()}
    fits = {}
    boots = {}
    print("== parameters per session (LSQ, 95 % block-bootstrap intervals; UMBmark on squares)")
    for name, (runs, nominal, side) in data.items():
        res, fit = calibrate_lsq(runs, seed=0)
        fits[name] = res
        boots[name] = fit.boot[:100, :3]
        print(f"{name}: {len(runs)} runs, {fit.n_segments} segments")
        for e in res.parameters.values():
            print("   ", e.report())
        try:
            u = umbmark(runs, nominal, side)
            ur = umbmark_result(u, len(u.errors_cw), len(u.errors_ccw))
            fits[name + " UMBmark"] = ur
            print("    UMBmark:", ur.verdict)
        except Exception as err:
            print("    UMBmark: not applicable:", err)
    print("\n== end-point error (m) per run: nominal -> calibrated (factor)")
    summary = []
    for cal_name, res in fits.items():
        p = res.parameters
        params = DiffDriveParams(
            p["wheel_radius_right"].value, p["wheel_radius_left"].value, p["track_width"].value
        )
        print(f"calibrated on {cal_name}:")
        for name, (runs, nominal, _) in data.items():
            own = " (own session, in-sample)" if cal_name.split(" ")[0] == name else ""
            cells = []
            for r in runs:
                e0, e1 = end_error(r, nominal), end_error(r, params)
                cells.append(f"{e0:.3f}->{e1:.3f} ({e0 / e1:.1f}x)")
                if not own:
                    summary.append((cal_name, name, e0, e1))
            print(f"  {name}{own}: " + ", ".join(cells))
    print("\n== end-point error (m) implied by the LSQ parameter uncertainty: median / p95")
    for cal_name, boot in boots.items():
        print(f"calibrated on {cal_name}:")
        for name, (runs, _, _) in data.items():
            cells = []
            for r in runs:
                eb = np.array([end_error(r, DiffDriveParams(*row)) for row in boot])
                cells.append(f"{np.median(eb):.3f}/{np.percentile(eb, 95):.3f}")
            print(f"  {name}: " + ", ".join(cells))
    print("\n== out-of-session summary: median factor, runs with >= 5x")
    for cal_name in fits:
        rows = [(e0, e1) for c, _, e0, e1 in summary if c == cal_name]
        f = np.array([e0 / e1 for e0, e1 in rows])
        m0 = np.mean([e0 for e0, _ in rows])
        m1 = np.mean([e1 for _, e1 in rows])
        print(
            f"  {cal_name}: median {np.median(f):.1f}x, >=5x in {int(np.sum(f >= 5))}/{f.size} "
            f"runs, mean error {m0:.3f} -> {m1:.3f} m"
        )


if __name__ == "__main__":
    main()
