"""Effects added the plug-in way, over many seeds: the effects the plug-in tests define (a
differential drive's right encoder that over-counts by 5 % while turning backwards; an arm's
torque ripple 0.2 sin(8 q1) N*m on joint 1), each in its own hook, never in the package.

Per seed: a clean simulated log and the same log carrying the effect (transformed as the tests
do). Counts how often discovery names the effect first on the log that carries it, and how
often the engine accepts it on the clean log (the arm: the effect tried alone, since a clean
arm log is explained before any round). Held-out sums (diff drive, noise units) and RMS (arm,
N*m) before and after, as medians.

    python bench/effect_plugin_study.py [--n 20] [--robot both|diff_drive|arm]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from diff_drive import test_effect_plugin as dd  # type: ignore[import-not-found]
from manipulator import test_effect_plugin as arm  # type: ignore[import-not-found]

from calib.diff_drive.effects import discover_effects
from calib.diff_drive.odometry_lsq import fit_lsq
from calib.discovery import select_effects
from calib.manipulator import discovery as arm_discovery
from calib.manipulator.simulate import Friction, Sensors, simulate_planar


def diff_drive(n: int) -> None:
    named = false = 0
    ratios = []
    for seed in range(1, n + 1):
        clean = dd._clean(seed)
        run = dd._with_backward_gain(clean, dd.GAIN)
        fit = fit_lsq([run], n_boot=20)
        d = discover_effects(
            [run], dd.NOM, calibrated=fit.params, marker=fit.offset, extra=(dd.BACKWARD_GAIN,)
        )
        named += bool(d.named and d.named[0] == dd.BACKWARD_GAIN.id)
        if d.selection is not None:
            ratios.append(d.selection.final.heldout_sse / d.selection.base.heldout_sse)
        fc = fit_lsq([clean], n_boot=20)
        dc = discover_effects(
            [clean], dd.NOM, calibrated=fc.params, marker=fc.offset, extra=(dd.BACKWARD_GAIN,)
        )
        false += dd.BACKWARD_GAIN.id in dc.named
        print(f"diff drive seed {seed:3d}: named {d.named}, clean log named {dc.named}", flush=True)
    print(
        f"diff drive: named first on {named}/{n} logs with the effect; accepted on "
        f"{false}/{n} clean logs; held-out sum after/before, median "
        f"{float(np.median(ratios)):.2f}"
    )


def manipulator(n: int) -> None:
    named = false = 0
    ratios = []
    arm_discovery.register_effect(arm.RIPPLE)
    try:
        for seed in range(1, n + 1):
            clean = simulate_planar(
                arm.ARM, Friction(), duration_s=20.0, sensors=Sensors(), seed=seed
            )
            d = arm_discovery.run_discovery(arm._fitter(arm._with_ripple(clean)))
            keys = [f.key for f in d.named]
            named += bool(keys and keys[0] == arm.KEY)
            if d.named:
                ratios.append(d.named[0].rms_after / d.named[0].rms_before)
            sel = select_effects(arm._fitter(clean), (arm.RIPPLE,), max_effects=1)
            accepted = sel is not None and sel.tried[0].accepted
            false += accepted
            print(
                f"arm seed {seed:3d}: named {keys}, accepted alone on the clean log: {accepted}",
                flush=True,
            )
    finally:
        arm_discovery.unregister_effect(arm.RIPPLE)
    print(
        f"arm: named first on {named}/{n} logs with the effect; accepted on {false}/{n} "
        f"clean logs; held-out RMS after/before, median {float(np.median(ratios)):.2f}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20, help="seeds per robot")
    ap.add_argument("--robot", choices=("both", "diff_drive", "arm"), default="both")
    args = ap.parse_args()
    if args.robot in ("both", "diff_drive"):
        diff_drive(args.n)
    if args.robot in ("both", "arm"):
        manipulator(args.n)


if __name__ == "__main__":
    main()
