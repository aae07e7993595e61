"""Coverage of pooled intervals (calib.pooling): k pieces with correlated 2-D estimates, with and
without between-piece heterogeneity, over many seeds.

Each replicate draws k pieces: piece i's covariance Σ_i = D_i R_i D_i (standard deviations
uniform in [0.5, 2], correlation uniform in [0.5, 0.9]), its own true value θ + u_i with
u_i ~ N(0, τ² Ψ) (Ψ: unit variances, correlation 0.3; τ = 0: no heterogeneity) and its
estimate θ_i ~ N(θ + u_i, Σ_i). The pooled estimate is judged against θ (what a pooled
calibration claims to give): per parameter, whether θ_j lies in value ± 1.96 std; jointly,
whether (value - θ)ᵀ Σ⁻¹ (value - θ) <= χ²₂(0.95).

Methods: ``fixed`` GLS (random="never"), ``auto`` (random effects where the generalised Q test
rejects at 5 %), ``always`` (random effects always, logcal's default: an estimated between-piece
covariance of 0 leaves the fixed effect), and ``per_parameter``
(each parameter pooled on its own, DerSimonian-Laird where heterogeneous; no joint region, as
logcal pooled before covariances were used).

Usage: python bench/pooling_coverage.py [--reps 3000] [--seed 0]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from calib.pooling import pool_gls, pool_univariate

Z = 1.959963984540054
CHI2_95 = float(stats.chi2.ppf(0.95, 2))
PSI = np.array([[1.0, 0.3], [0.3, 1.0]])
METHODS = ("fixed", "auto", "always")


def _pieces(rng: np.random.Generator, k: int, tau: float) -> tuple[np.ndarray, np.ndarray]:
    sd = rng.uniform(0.5, 2.0, size=(k, 2))
    rho = rng.uniform(0.5, 0.9, size=k)
    covs = np.empty((k, 2, 2))
    covs[:, 0, 0] = sd[:, 0] ** 2
    covs[:, 1, 1] = sd[:, 1] ** 2
    covs[:, 0, 1] = covs[:, 1, 0] = rho * sd[:, 0] * sd[:, 1]
    u = rng.multivariate_normal(np.zeros(2), tau**2 * PSI, size=k) if tau > 0 else np.zeros((k, 2))
    vals = np.array([rng.multivariate_normal(u[i], covs[i]) for i in range(k)])
    return vals, covs


def _covered(value: np.ndarray, cov: np.ndarray) -> tuple[bool, bool, bool]:
    sd = np.sqrt(np.diag(cov))
    per = np.abs(value) <= Z * sd
    joint = float(value @ np.linalg.solve(cov, value)) <= CHI2_95
    return bool(per[0]), bool(per[1]), joint


def coverage(reps: int, *, k: int, tau: float, seed: int) -> dict[str, dict[str, float]]:
    """Share of ``reps`` replicates whose pooled interval covers the truth, per method:
    ``{"fixed": {"p0": .., "p1": .., "joint": ..}, ..., "per_parameter": {"p0", "p1"}}``."""
    rng = np.random.default_rng(seed)
    hits = {m: np.zeros(3) for m in METHODS}
    per_param = np.zeros(2)
    for _ in range(reps):
        vals, covs = _pieces(rng, k, tau)
        for m, random in zip(METHODS, ("never", "auto", "always"), strict=True):
            res = pool_gls(vals, covs, random=random)  # type: ignore[arg-type]
            hits[m] += _covered(res.value, res.cov)
        for j in range(2):
            uni = pool_univariate(vals[:, j], np.sqrt(covs[:, j, j]))
            per_param[j] += abs(uni.value[0]) <= Z * np.sqrt(uni.cov[0, 0])
    out = {
        m: dict(zip(("p0", "p1", "joint"), (h / reps).tolist(), strict=True))
        for m, h in hits.items()
    }
    out["per_parameter"] = {"p0": float(per_param[0] / reps), "p1": float(per_param[1] / reps)}
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=3000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    se = 100 * np.sqrt(0.95 * 0.05 / args.reps)
    print(
        f"95 % coverage over {args.reps} replicates each (binomial std {se:.2f} points at "
        "95 %); p0, p1 per parameter, joint: the 95 % ellipse"
    )
    print(f"{'k':>3} {'tau':>4}  {'method':<14} {'p0':>6} {'p1':>6} {'joint':>6}")
    n = 0
    for k in (3, 6, 12):
        for tau in (0.0, 0.5, 1.0):
            res = coverage(args.reps, k=k, tau=tau, seed=args.seed + n)
            n += 1
            for m, c in res.items():
                joint = f"{100 * c['joint']:6.1f}" if "joint" in c else f"{'-':>6}"
                print(
                    f"{k:>3} {tau:>4.1f}  {m:<14} {100 * c['p0']:6.1f} {100 * c['p1']:6.1f} {joint}"
                )
    print(f"({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
