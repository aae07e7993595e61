"""Simulated planar 2-link arm, 50 seeds: coverage of the 95 % intervals of every base
parameter (momentum WLS, Newey-West), and momentum vs acceleration regressor parameter error
when velocities are noisy. Run: python bench/manipulator_coverage.py [seeds]"""

from __future__ import annotations

import sys
import time

import numpy as np

from calib.manipulator.identify import identify_arm
from calib.manipulator.planar import Planar2Link, Planar2Params
from calib.manipulator.simulate import Friction, Sensors, simulate_planar


def main(seeds: int = 50) -> None:
    t0 = time.time()
    p, fr = Planar2Params(payload=0.1), Friction()
    model = Planar2Link(p)
    hits, names = None, None
    err = {"momentum-WLS": [], "acceleration-WLS": []}
    for s in range(seeds):
        run = simulate_planar(p, fr, duration_s=20.0, sensors=Sensors(torque_noise=0.05), seed=s)
        res = identify_arm(model, run.t_s, run.q, run.tau)
        truth = res.design.to_base(np.r_[p.theta(), fr.coulomb, fr.viscous])
        names = res.design.names
        ci = np.array([e.ci95 for e in res.recommended.parameters.values()])
        h = (ci[:, 0] <= truth) & (truth <= ci[:, 1])
        hits = h.astype(int) if hits is None else hits + h
        # noisy velocity: the logged velocity with extra noise is used instead of d/dt q
        noisy = simulate_planar(
            p, fr, duration_s=20.0, sensors=Sensors(velocity_noise=0.5, torque_noise=0.05), seed=s
        )
        r2 = identify_arm(model, noisy.t_s, noisy.q, noisy.tau, qd=noisy.qd)
        for m in r2.methods[:2]:
            v = np.array([e.value for e in m.parameters.values()])
            err[m.method].append(np.abs(v - truth) / np.abs(truth))
        if s % 10 == 9:
            print(f"  {s + 1} seeds, {time.time() - t0:.0f} s", flush=True)
    if hits is None or names is None:
        raise SystemExit("no seeds run")
    print(f"\nCoverage of the 95 % interval over {seeds} seeds (binomial 1-sigma in brackets):")
    for name, k in zip(names, hits, strict=True):
        f = k / seeds
        print(f"  {name:24s} {100 * f:5.1f} %  (± {100 * np.sqrt(f * (1 - f) / seeds):.1f})")
    print("\nNoisy velocity (0.5 rad/s std), median relative parameter error over seeds:")
    for m, e in err.items():
        e = np.array(e)
        print(
            f"  {m:18s} median {100 * np.median(e):.2f} %  worst parameter median "
            f"{100 * np.median(e, axis=0).max():.2f} %"
        )
    print(f"took {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 50)
