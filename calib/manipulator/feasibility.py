"""Physical feasibility of identified base parameters, by check and flag (not projection).

Base parameters mix several links' masses and inertias, so "positive masses, positive-definite
link inertias" cannot be checked on them one by one. What they do determine is checked instead:

* the mass matrix M(q) they give must be positive definite at every checked configuration of the
  log (its kinetic energy is positive; this is what positive masses and PD link inertias imply
  for the data), computed from the momentum columns with unit joint velocities;
* friction coefficients must not be negative beyond their 95 % interval. A negative friction
  coefficient whose interval excludes zero is not friction: the column is absorbing something
  the model lacks that correlates with velocity (e.g. a torque estimated from motor current that
  leaves out, or over-counts, what the rotor and gear dissipate; an unmodelled delay; the
  inertia of a weakly excited joint), so the value must not be read as friction and the other
  parameters are biased by the same cause. The problem text says so.

Projecting onto the feasible set (e.g. an LMI on the full parameters) would move an estimate away
from what the data say; we report a violation instead, and the verdict carries it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from calib.manipulator.design import FRICTION_TERMS, Design

__all__ = ["Feasibility", "check_feasibility"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Feasibility:
    """``feasible`` and why not (``problems``); ``min_eig_M`` the smallest eigenvalue of M(q)
    over the checked configurations (kg*m^2)."""

    feasible: bool
    min_eig_M: float
    problems: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, object]:
        m = self.min_eig_M if np.isfinite(self.min_eig_M) else None
        return {"feasible": self.feasible, "min_eig_M": m, "problems": list(self.problems)}


def check_feasibility(
    design: Design, theta: Array, std: Array, q: Array, max_configs: int = 40
) -> Feasibility:
    """Check ``theta`` (base parameters of ``design``) at up to ``max_configs`` rows of ``q``."""
    problems: list[str] = []
    th = np.nan_to_num(theta)
    idx = np.linspace(0, len(q) - 1, min(max_configs, len(q))).astype(int)
    qs = q[idx]
    n = q.shape[1]
    M = np.zeros((len(qs), n, n))
    for k in range(n):
        e = np.zeros_like(qs)
        e[:, k] = 1.0
        Xp, _, kp, _ = design.momentum(qs, e)
        M[:, :, k] = Xp @ th + kp
    M = 0.5 * (M + np.transpose(M, (0, 2, 1)))
    eig = float(np.linalg.eigvalsh(M).min())
    if eig <= 0:
        problems.append(f"M(q) not positive definite along the log (smallest eigenvalue {eig:.3g})")
    names = design.names
    for term in FRICTION_TERMS:
        for k in design.term_slice(term):
            if np.isfinite(std[k]) and th[k] + 1.96 * std[k] < 0:
                problems.append(
                    f"{names[k]} = {th[k]:.3g} ± {1.96 * std[k]:.2g} < 0: not friction, the "
                    "column absorbs an unmodelled velocity-correlated torque (e.g. the "
                    "current-to-torque estimate or a delay); do not read it as friction"
                )
    return Feasibility(not problems, eig, problems)
