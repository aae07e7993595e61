"""Coverage of the recommended link-length estimator's 95 % intervals on simulated logs.

Five L1/L2 splits of about the patent's L1 + L2 = 3.73 m (including L1 = L2 and L1 > L2) x N
noise seeds (default 50). Each log: the patent's H, C, L curvature commands (M = 0.2 1/m,
63 s each) at 1 m/s, actuator lag 0.1 s (curvature is continuous, as on a real robot), the
simulator's default sensor noise (``--scenario noisy|both``: 5x the yaw-rate noise and the
patent's psi noise 0.0173 rad). Measured kappa = omega / v and psi go to
``calibrate_link_lengths``; the study prints how often each 95 % interval holds the truth, next
to the naive white-residual (Fisher) interval and the Newey-West-only interval of the same
transient fit. Last, on steady-state-only low-curvature logs without speed (EIV), how often
the verdict says the split is not determined and the sum's interval holds the truth.

Run: python bench/coverage_study.py [--seeds 50] [--jobs 2] [--scenario default|noisy|both]
"""

from __future__ import annotations

import argparse
import time
from multiprocessing import Pool

import numpy as np

from calib.tractor_trailer.estimators import TransientFit, calibrate_link_lengths
from calib.tractor_trailer.results import CommandType
from calib.tractor_trailer.sim.commands import CommandSequence, CommandSpec
from calib.tractor_trailer.sim.tractor_trailer import (
    Effects,
    NoiseSpec,
    SimulatedRun,
    TractorTrailerSim,
    simulate_tractor_trailer,
)

SPLITS = [(0.5, 3.2), (1.25, 2.48), (1.865, 1.865), (2.4, 1.3), (3.0, 0.7)]
DEFAULT_NOISE = {"v": 0.01, "omega": 0.002, "psi": 0.005}
NOISY = {"v": 0.01, "omega": 0.01, "psi": 0.0173}
Z95 = 1.959963984540054


def commands() -> CommandSequence:
    kinds = (CommandType.HARMONIC, CommandType.CURVE, CommandType.LINEAR)
    return CommandSequence([CommandSpec(k, 63.0, 0.2, 0.1) for k in kinds])


def measured(run: SimulatedRun) -> tuple[np.ndarray, ...]:
    od, hi = run.frames["odom"], run.frames["hitch"]
    t = (od["t_ns"].to_numpy() - od["t_ns"][0]) * 1e-9
    v = od["v"].to_numpy()
    k = od["omega"].to_numpy() / np.where(np.abs(v) > 0.05, v, np.nan)
    return t, k, v, hi["psi"].to_numpy()


def inside(lo: float, hi: float, x: float) -> bool:
    return lo <= x <= hi


def one_run(job: tuple[float, float, int, dict[str, float]]) -> dict[str, float]:
    """Recommended estimate and the transient fit's interval variants for one log."""
    L1, L2, seed, noise = job
    cfg = TractorTrailerSim(
        L1=L1,
        L2=L2,
        commands=commands(),
        noise=NoiseSpec(std=noise),
        effects=Effects(actuator_lag_s=0.1),
    )
    t, k, v, p = measured(simulate_tractor_trailer(cfg, seed))
    res, _ = calibrate_link_lengths(t, k, p, v)
    out = {
        "transient": float(res.method == TransientFit.name),
        "identifiable": float(res.identifiable),
        "L1": float(inside(*res.parameters["L1"].ci95, L1)),
        "L2": float(inside(*res.parameters["L2"].ci95, L2)),
        "sum": float(inside(*res.derived["sum_L1_L2"].ci95, L1 + L2)),
        "err_L1": res.parameters["L1"].value - L1,
        "se_L1": res.parameters["L1"].std,
    }
    fit = TransientFit().fit(t, k, v, p)
    x = np.array([fit.L1_, fit.L2_])
    for name, cov in (("iid", fit.cov_iid_), ("hac", fit.cov_hac_)):
        sd = np.sqrt(np.diag(cov)[:2])
        ssum = float(np.sqrt(cov[0, 0] + cov[1, 1] + 2 * cov[0, 1]))
        out[f"{name}_L1"] = float(abs(x[0] - L1) <= Z95 * sd[0])
        out[f"{name}_L2"] = float(abs(x[1] - L2) <= Z95 * sd[1])
        out[f"{name}_sum"] = float(abs(x.sum() - L1 - L2) <= Z95 * ssum)
    return out


def steady_run(seed: int) -> dict[str, float]:
    """Steady-state-only, low-curvature log without speed: the EIV verdict."""
    L1, L2 = 1.25, 2.48
    cfg = TractorTrailerSim(
        L1=L1,
        L2=L2,
        commands=CommandSequence([CommandSpec(CommandType.HARMONIC, 63.0, 0.1)]),
        hitch_model="steady",
        noise=NoiseSpec(std={"v": 0.01, "omega": 0.0173, "psi": 0.0173}),
    )
    t, k, _, p = measured(simulate_tractor_trailer(cfg, seed))
    res, _ = calibrate_link_lengths(t, k, p, None)
    return {
        "split_not_determined": float(
            not res.parameters["L1"].identifiable and not res.parameters["L2"].identifiable
        ),
        "sum_determined": float(res.derived["sum_L1_L2"].identifiable),
        "sum_covered": float(inside(*res.derived["sum_L1_L2"].ci95, L1 + L2)),
        "L1_covered": float(inside(*res.parameters["L1"].ci95, L1)),
    }


def study(pool: Pool, noise: dict[str, float], seeds: int, label: str) -> bool:
    print(f"\n== {label}: noise std {noise}, {len(SPLITS)} splits x {seeds} seeds ==")
    print(
        f"{'L1':>6} {'L2':>6} | {'trans':>5} {'ident':>5} | recommended 95 % coverage "
        f"L1 / L2 / sum | naive Fisher L1 / L2 / sum | HAC-only L1 / L2 / sum | "
        f"bias L1, emp sd / mean se"
    )
    ok = True
    for L1, L2 in SPLITS:
        rows = pool.map(one_run, [(L1, L2, s, noise) for s in range(seeds)])
        m = {k: float(np.mean([r[k] for r in rows])) for k in rows[0]}
        err = np.array([r["err_L1"] for r in rows])
        se = np.mean([r["se_L1"] for r in rows])
        print(
            f"{L1:6.3f} {L2:6.3f} | {m['transient']:5.2f} {m['identifiable']:5.2f} | "
            f"{m['L1']:.2f} / {m['L2']:.2f} / {m['sum']:.2f}"
            f"{'':>10}| {m['iid_L1']:.2f} / {m['iid_L2']:.2f} / {m['iid_sum']:.2f}"
            f"{'':>9}| {m['hac_L1']:.2f} / {m['hac_L2']:.2f} / {m['hac_sum']:.2f}"
            f"{'':>5}| {err.mean():+.5f}, {err.std():.5f} / {se:.5f}"
        )
        ok &= min(m["L1"], m["L2"], m["sum"]) >= 0.90
    return ok


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument(
        "--scenario",
        choices=["default", "noisy", "both"],
        default="default",
        help="sensor noise: the simulator's default, high input noise, or both",
    )
    args = ap.parse_args()
    t0 = time.perf_counter()
    with Pool(args.jobs) as pool:
        ok = True
        if args.scenario in ("default", "both"):
            ok &= study(pool, DEFAULT_NOISE, args.seeds, "default sensor noise")
        if args.scenario in ("noisy", "both"):
            ok &= study(pool, NOISY, args.seeds, "noisy inputs (5x yaw-rate noise, psi 0.0173)")
        rows = pool.map(steady_run, range(args.seeds))
    m = {k: float(np.mean([r[k] for r in rows])) for k in rows[0]}
    print(
        f"\n== steady-state-only log, M = 0.1 1/m, noise 0.0173, no speed (EIV), "
        f"{args.seeds} seeds =="
    )
    print(
        f"verdict 'split not determined': {m['split_not_determined']:.2f}; sum determined: "
        f"{m['sum_determined']:.2f}; sum interval covers truth: {m['sum_covered']:.2f}; "
        f"L1 interval covers truth: {m['L1_covered']:.2f}"
    )
    print(f"\nall recommended coverages >= 0.90: {ok}   ({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
