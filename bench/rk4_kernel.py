"""Speed of the joint-angle RK4 loop (calib.tractor_trailer.models.hitch_rk4): compiled, numpy,
Python, solve_ivp.

Integrates the hitch dynamics d psi/dt = v (kappa (1 + L1/L2 cos psi) - sin(psi)/L2) over a
60 s drive at 100 Hz (6000 steps), in the same run:

- ``rk4_hitch``: the compiled loop (one trajectory on libm's sin/cos; 64 parameter sets stepped
  together on the vectorised sin/cos of calib/tractor_trailer/_sincos.h, per set);
- ``rk4_hitch(..., reference=True)``: the numpy reference of the same arithmetic, 64 sets side
  by side, per set (the fallback when the extension is not built);
- the same RK4 as a Python loop over floats with the right-hand side written out (what the
  project ran before the compiled loop);
- ``scipy.integrate.solve_ivp`` (RK45 forced to the same step: first_step = max_step = dt,
  loose tolerances so it never shrinks the step), inputs interpolated linearly.

Prints the median of 5 repeats of each and every time's ratio to the compiled loop's, and
how far compiled and reference are apart (bit for bit for one set; a few units in the last
place for the sets, whose sin/cos is not libm's). Run: ``python bench/rk4_kernel.py`` (~15 s).
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable

import numpy as np
from scipy.integrate import solve_ivp

from calib.tractor_trailer.models.hitch_rk4 import compiled_available, rk4_hitch

L1, L2 = 1.25, 2.48
RATE_HZ, DURATION_S, M_SETS, REPEATS = 100.0, 60.0, 64, 5


def _median_time(fn: Callable[[], object]) -> float:
    times = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _python_loop(v: list[float], k: list[float], dt: float) -> list[float]:
    """RK4 in Python floats with the right-hand side written out."""
    r, il2 = L1 / L2, 1.0 / L2
    cos, sin = math.cos, math.sin
    n = (len(v) + 1) // 2
    out, p, hh = [0.0] * n, 0.0, dt / 2.0
    for i in range(n - 1):
        j = 2 * i
        a1 = v[j] * (k[j] * (1.0 + r * cos(p)) - sin(p) * il2)
        q = p + hh * a1
        a2 = v[j + 1] * (k[j + 1] * (1.0 + r * cos(q)) - sin(q) * il2)
        q = p + hh * a2
        a3 = v[j + 1] * (k[j + 1] * (1.0 + r * cos(q)) - sin(q) * il2)
        q = p + dt * a3
        a4 = v[j + 2] * (k[j + 2] * (1.0 + r * cos(q)) - sin(q) * il2)
        p = p + dt * (a1 + 2.0 * (a2 + a3) + a4) / 6.0
        out[i + 1] = p
    return out


def main() -> None:
    if not compiled_available():
        raise SystemExit("the compiled loop is not built: run pip install -e . first")
    dt = 1.0 / RATE_HZ
    n = round(DURATION_S * RATE_HZ) + 1
    th = np.arange(2 * n - 1) * (dt / 2.0)  # half-step grid
    v = 1.0 + 0.3 * np.sin(0.5 * th)
    k = 0.3 * np.sin(0.2 * th)
    V = np.stack([v[0:-2:2], v[1::2], v[2::2]], axis=1)
    U = V * np.stack([k[0:-2:2], k[1::2], k[2::2]], axis=1)
    h = np.full(n - 1, dt)
    r, il2 = L1 / L2, 1.0 / L2
    L1s = np.linspace(0.5, 2.0, M_SETS)
    L2s = np.linspace(1.5, 3.0, M_SETS)

    def one() -> np.ndarray:
        return rk4_hitch(h, U, V, 1.0, r, il2, 0.0)

    def sets(reference: bool) -> np.ndarray:
        return rk4_hitch(h, U, V, 1.0, L1s / L2s, 1.0 / L2s, 0.0, reference=reference)

    def ivp() -> np.ndarray:
        tg = th[::2]

        def f(t: float, y: np.ndarray) -> np.ndarray:
            vv = np.interp(t, th, v)
            kk = np.interp(t, th, k)
            return vv * (kk * (1.0 + r * np.cos(y)) - np.sin(y) * il2)

        sol = solve_ivp(
            f,
            (0.0, tg[-1]),
            [0.0],
            method="RK45",
            t_eval=tg,
            first_step=dt,
            max_step=dt,
            rtol=1e-3,
            atol=1e-3,
        )
        return sol.y[0]

    print(f"hitch ODE, {n - 1} steps of {dt} s; median of {REPEATS} repeats", flush=True)
    same = np.array_equal(one(), rk4_hitch(h, U, V, 1.0, r, il2, 0.0, reference=True))
    gap = float(np.max(np.abs(sets(False) - sets(True))))
    print(
        f"compiled == numpy reference, bit for bit, one set: {same}; "
        f"{M_SETS} sets: max |difference| {gap:.1e} rad"
    )
    psi = one()[:, 0, 0]
    rows = [
        ("compiled, one trajectory", _median_time(one)),
        (f"compiled, {M_SETS} sets, per set", _median_time(lambda: sets(False)) / M_SETS),
        (f"numpy reference, {M_SETS} sets, per set", _median_time(lambda: sets(True)) / M_SETS),
        (
            "Python float loop, one trajectory",
            _median_time(lambda: _python_loop(v.tolist(), k.tolist(), dt)),
        ),
        ("solve_ivp RK45 at the same step", _median_time(ivp)),
    ]
    base = rows[0][1]
    for name, t in rows:
        print(f"{name:42s} {t * 1e3:9.3f} ms   {t / base:8.1f}x the compiled loop")
    ref = ivp()
    print(
        f"max |psi_rk4 - psi_ivp| = {np.max(np.abs(psi - ref)):.2e} rad "
        "(solve_ivp interpolates the inputs; RK4 takes them at the nodes)"
    )


if __name__ == "__main__":
    main()
