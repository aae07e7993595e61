"""Benchmark: the patent's 36 methods x 10 repeats on a 1-hour, 100 Hz log (360k samples).

Not a test. Prints wall-clock times and ratios against baselines measured in the same run:
one plain ``numpy.linalg.lstsq`` on the EM1 design (the cheapest honest "one fit"), and a naive
evaluation of the 36 methods that builds every design from the raw arrays and fits it with the
estimators' array ``fit`` (no shared QR factors, no PM-fit reuse).

Data: κ cycles through the patent's H, C and L commands (63 s each, M = 0.2), Ψ on the steady
state (L1 = 1.25 m, L2 = 2.48 m), Gaussian noise σ = 0.0173 on both.

Run: ``python bench/bench_methods.py [--samples N] [--repeats R]``.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable

import numpy as np

from calib.lsq import OLS1, OLS2, TLS
from calib.tractor_trailer.methods import METHOD_NAMES, evaluate_methods, method_spec
from calib.tractor_trailer.models.hitch_kinematics import steady_state_psi
from calib.tractor_trailer.patent_models import em_design, lengths_from_beta, pm_design
from calib.tractor_trailer.repeats import methods_over_repeats, methods_table

SOLVERS = {"OLS1": OLS1, "OLS2": OLS2, "TLS": TLS}
SIGMA = 0.03 / math.sqrt(3.0)


def make_log(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Ideal (κ, Ψ) of H, C, L commands in turn, 63 s each, sampled at 100 Hz."""
    t = np.arange(n) / 100.0
    local = np.mod(t, 63.0)
    kind = np.floor_divide(t, 63.0).astype(int) % 3
    w = 0.1 * local
    k = np.where(kind == 0, np.sin(w), np.where(kind == 1, np.tanh(w), w / np.pi - 1.0)) * 0.2
    return k, steady_state_psi(k, 1.25, 2.48)


def noisy(k: np.ndarray, p: np.ndarray, rng: np.random.Generator):
    return k + rng.normal(0, SIGMA, k.size), p + rng.normal(0, SIGMA, p.size)


def naive_all_methods(k: np.ndarray, p: np.ndarray) -> dict[str, tuple[float, float]]:
    """Every method from scratch on explicit designs (the reference implementation)."""
    out = {}
    for name in METHOD_NAMES:
        spec = method_spec(name)
        kk, pp = k, p
        if spec.pm is not None:
            fit = SOLVERS[spec.pm_solver]().fit(*pm_design(spec.pm, k, p))
            a = fit.beta_[0]
            b = fit.beta_[1] if str(spec.pm) == "PM2" else 0.0
            if spec.em is None and spec.em_solver is None:
                out[name] = (a, b)
                continue
            kk = np.concatenate([k, (p - b) / a])
            pp = np.concatenate([a * k + b, p])
        em = spec.em or "EM1"
        fit = SOLVERS[spec.em_solver]().fit(*em_design(em, kk, pp))
        out[name] = lengths_from_beta(em, fit.beta_)
        if spec.em is None:  # TLS(EM1,2,3): the other two condition numbers
            for other in ("EM2", "EM3"):
                TLS().fit(*em_design(other, kk, pp))
    return out


def best_of(fn: Callable[[], object], runs: int) -> float:
    """Smallest wall-clock time (s) of ``runs`` calls."""
    best = math.inf
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=360_000)
    ap.add_argument("--repeats", type=int, default=10)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    k0, p0 = make_log(args.samples, rng)
    datasets = [noisy(k0, p0, rng) for _ in range(args.repeats)]
    k, p = datasets[0]
    A, y = em_design("EM1", k, p)

    t_lstsq = best_of(lambda: np.linalg.lstsq(A, y, rcond=None), 5)
    t_one = best_of(lambda: evaluate_methods(k, p), 3)
    t_naive = best_of(lambda: naive_all_methods(k, p), 1)
    t_rep = best_of(lambda: methods_over_repeats(datasets), 1)
    t_boot = best_of(
        lambda: methods_table(k, p, repeats=args.repeats, rng=np.random.default_rng(1)), 1
    )
    # agreement of the fast path with the naive reference (same data)
    fast, ref = evaluate_methods(k, p), naive_all_methods(k, p)
    worst = max(
        abs(fast[n].L1 - ref[n][0]) / abs(ref[n][0])
        for n in METHOD_NAMES
        if method_spec(n).em_solver is not None
    )

    n, r = args.samples, args.repeats
    rows = [
        ("baseline: one np.linalg.lstsq, EM1 design", t_lstsq),
        ("36 methods, once (evaluate_methods)", t_one),
        ("36 methods, once, naive (no shared factors)", t_naive),
        (f"36 methods x {r} fresh-noise repeats", t_rep),
        (f"36 methods x {r} block-bootstrap repeats", t_boot),
    ]
    print(f"{n} samples ({n / 100 / 3600:.2f} h at 100 Hz), {r} repeats")
    print(f"{'what':48s} {'time (s)':>10s} {'x lstsq':>9s}")
    for label, t in rows:
        print(f"{label:48s} {t:10.4f} {t / t_lstsq:9.1f}")
    print(f"naive / fast, one evaluation: {t_naive / t_one:.1f}x")
    print(f"max relative L1 difference fast vs naive: {worst:.2e}")


if __name__ == "__main__":
    main()
