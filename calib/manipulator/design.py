"""The identification model of an arm: rigid-body base parameters plus per-joint terms
(Coulomb and viscous friction, torque-sensor offset) and, against a nominal model, a payload.

Base parameters: the regressor's columns are evaluated at random states, and a QR decomposition
*without* pivoting keeps each column that is not a combination of the columns before it (|R_kk|
above 1e-8 of the largest); the others are regrouped into the kept ones,
``theta_base = theta_kept + beta theta_dropped`` with ``beta = R_kk^-1 R_kd`` (Gautier 1990).
Keeping the given order (link by link, friction last) names each base parameter after a physical
one. The Coulomb term is ``Fc tanh(qd / 0.01)`` (sign(qd) above 0.01 rad/s, smooth through zero)
in the simulator and the regressor alike; the DFKI source's ``cf atan(100 qd)`` has the same
velocity scale. ``coulomb_friction_smooth`` is the alternative ``Fcs tanh(qd / 0.1)``: friction
that builds up over 0.1 rad/s (pre-sliding, a lubricated gear), an alternative *to*
``coulomb_friction`` (discovery swaps one for the other and keeps the better held-out fit).

Rotor inertia: each joint's armature ``Ia`` (gear ratio squared times rotor inertia) sits on its own
diagonal of M. The gear coupling of a rotor carried by the previous link (the DFKI arm's
``- gr Ir`` in M12) adds ``c qd_i (a_i . omega_{i-1})`` to the kinetic energy; when the joint axes
are parallel that is a constant M_ij, which regroups into the link inertia and ``Ia`` (no new base
parameter; a test checks the published DFKI model, coupling included, is exactly representable).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np
from numpy.typing import NDArray

from calib.manipulator.model import ArmModel, ParameterInfo

__all__ = [
    "ALTERNATIVES",
    "COULOMB_SMOOTHING",
    "COULOMB_SMOOTH_SCALE",
    "FRICTION_TERMS",
    "Design",
    "Term",
    "coulomb",
    "make_design",
    "term_column",
    "term_name",
    "term_unit",
]

Array = NDArray[np.float64]

COULOMB_SMOOTHING = 0.01
"""Velocity (rad/s or m/s) below which Coulomb friction is smoothed (tanh)."""
COULOMB_SMOOTH_SCALE = 0.1
"""Velocity scale (rad/s or m/s) of the ``coulomb_friction_smooth`` alternative."""


class Term(StrEnum):
    """Per-joint terms beside the rigid body (also discovery's catalogue)."""

    COULOMB = "coulomb_friction"
    COULOMB_SMOOTH = "coulomb_friction_smooth"
    VISCOUS = "viscous_friction"
    OFFSET = "torque_offset"
    PAYLOAD = "payload_mass"


_PREFIX = {Term.COULOMB: "Fc", Term.COULOMB_SMOOTH: "Fcs", Term.VISCOUS: "Fv", Term.OFFSET: "tau0"}
_UNIT = {
    Term.COULOMB: "N*m",
    Term.COULOMB_SMOOTH: "N*m",
    Term.VISCOUS: "N*m*s/rad",
    Term.OFFSET: "N*m",
}
FRICTION_TERMS = (Term.COULOMB, Term.COULOMB_SMOOTH, Term.VISCOUS)
ALTERNATIVES = {Term.COULOMB: Term.COULOMB_SMOOTH, Term.COULOMB_SMOOTH: Term.COULOMB}
"""Terms that model the same effect: a model holds at most one of each pair."""


def coulomb(qd: Array, scale: float = COULOMB_SMOOTHING) -> Array:
    """Coulomb friction's shape: ``tanh(qd / scale)``."""
    return np.tanh(qd / scale)


def term_name(term: Term, joint: str) -> str:
    """The parameter name of ``term`` at ``joint`` (``Fc[Joint1]``); ``payload`` for the payload."""
    return "payload" if term is Term.PAYLOAD else f"{_PREFIX[term]}[{joint}]"


def term_unit(term: Term) -> str:
    """The unit of ``term``'s coefficient."""
    return "kg" if term is Term.PAYLOAD else _UNIT[term]


def term_column(term: Term, qd: Array) -> Array | float:
    """The per-joint column of a friction or offset term (its coefficient's multiplier)."""
    return _term_column(term, qd)


def _term_column(term: Term, qd: Array) -> Array | float:
    if term is Term.COULOMB:
        return coulomb(qd)
    if term is Term.COULOMB_SMOOTH:
        return coulomb(qd, COULOMB_SMOOTH_SCALE)
    return qd if term is Term.VISCOUS else 1.0


@dataclass(frozen=True)
class Design:
    """Columns of the identification model: ``full`` rigid + term columns, ``base`` the kept
    ones, ``beta`` the regrouping (theta_base = theta_full[base] + beta @ theta_full[dropped]).

    ``rigid`` False: the rigid body is fixed at ``fixed_rigid`` (a nominal model) and only the
    terms are fitted.
    """

    model: ArmModel
    terms: tuple[Term, ...]
    names_full: tuple[str, ...]
    units_full: tuple[str, ...]
    base: NDArray[Any]
    dropped: NDArray[Any]
    beta: Array
    rigid: bool = True
    fixed_rigid: Array | None = None
    n_rigid: int = 0
    notes: list[str] = field(default_factory=list)

    @property
    def n(self) -> int:
        return len(self.model.joint_names)

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the base parameters, regrouped ones written out."""
        out = []
        for k, i in enumerate(self.base):
            parts = [self.names_full[i]]
            for d, b in zip(self.dropped, self.beta[k], strict=True):
                if abs(b) > 1e-9:
                    sign = "+" if b > 0 else "-"
                    coef = "" if abs(abs(b) - 1) < 1e-9 else f"{abs(b):.4g}·"
                    parts.append(f" {sign} {coef}{self.names_full[d]}")
            out.append("".join(parts))
        return tuple(out)

    @property
    def units(self) -> tuple[str, ...]:
        return tuple(self.units_full[i] for i in self.base)

    def to_base(self, theta_full: Array) -> Array:
        """Base parameters of a full parameter vector."""
        th = np.asarray(theta_full, float)
        return th[self.base] + self.beta @ th[self.dropped]

    def term_slice(self, term: Term) -> list[int]:
        """Indices into the base vector of ``term``'s parameters."""
        start = self.n_rigid
        idx = []
        for t in self.terms:
            width = 1 if t is Term.PAYLOAD else self.n
            if t is term:
                idx = list(range(start, start + width))
            start += width
        return [k for k, i in enumerate(self.base) if i in idx]

    # ---------------------------------------------------------------- columns
    def _rigid_offset(self, Y_rigid: Array) -> Array:
        if self.rigid or self.fixed_rigid is None:
            return np.zeros(Y_rigid.shape[:2])
        return Y_rigid @ self.fixed_rigid

    def classic(self, q: Array, qd: Array, qdd: Array) -> tuple[Array, Array]:
        """(X (N, n, P), known (N, n)): ``tau = X theta_base + known``."""
        Y = self.model.regressor(q, qd, qdd)
        cols: list[Array] = [Y]
        for t in self.terms:
            if t is Term.PAYLOAD:
                cols.append((Y @ self.model.payload_increment())[:, :, None])
            else:
                x = _term_column(t, qd)
                cols.append(np.broadcast_to(x, qd.shape)[:, :, None] * np.eye(qd.shape[1]))
        full = np.concatenate(cols, axis=2)
        return self._select(full), self._rigid_offset(Y)

    def momentum(self, q: Array, qd: Array) -> tuple[Array, Array, Array, Array]:
        """(Xp, Xr, known_p, known_r): ``int tau = [Xp theta]_a^b + int Xr theta`` (+ knowns)."""
        Yp, Yr = self.model.momentum(q, qd), self.model.rest(q, qd)
        n = qd.shape[1]
        cp: list[Array] = [Yp]
        cr: list[Array] = [Yr]
        for t in self.terms:
            if t is Term.PAYLOAD:
                inc = self.model.payload_increment()
                cp.append((Yp @ inc)[:, :, None])
                cr.append((Yr @ inc)[:, :, None])
            else:
                x = _term_column(t, qd)
                cp.append(np.zeros((len(qd), n, n)))
                cr.append(np.broadcast_to(x, qd.shape)[:, :, None] * np.eye(n))
        Xp, Xr = self._select(np.concatenate(cp, axis=2)), self._select(np.concatenate(cr, axis=2))
        return Xp, Xr, self._rigid_offset(Yp), self._rigid_offset(Yr)

    def _select(self, full: Array) -> Array:
        if not self.rigid:
            full = full[:, :, self.n_rigid :]
            return full
        return full[:, :, self.base]


def make_design(
    model: ArmModel,
    terms: tuple[Term, ...] = (Term.COULOMB, Term.VISCOUS),
    *,
    rigid: bool = True,
    fixed_rigid: Array | None = None,
    seed: int = 0,
    samples: int = 200,
    q_range: tuple[Array, Array] | None = None,
) -> Design:
    """The design of ``model`` with ``terms``; base parameters from random states (see module).

    ``rigid`` False fixes the rigid body at ``fixed_rigid`` (then every term column is kept).
    """
    params: tuple[ParameterInfo, ...] = model.parameters
    n = len(model.joint_names)
    names = [p.name for p in params]
    units = [p.unit for p in params]
    for t in terms:
        if t is Term.PAYLOAD:
            names.append("payload")
            units.append("kg")
        else:
            names += [f"{_PREFIX[t]}[{j}]" for j in model.joint_names]
            units += [_UNIT[t]] * n
    n_rigid = len(params)
    if not rigid:
        idx = np.arange(n_rigid, len(names))
        return Design(
            model,
            terms,
            tuple(names),
            tuple(units),
            idx,
            np.zeros(0, int),
            np.zeros((len(idx), 0)),
            rigid=False,
            fixed_rigid=fixed_rigid,
            n_rigid=n_rigid,
        )
    rng = np.random.default_rng(seed)
    lo, hi = q_range if q_range is not None else (np.full(n, -np.pi), np.full(n, np.pi))
    lo = np.where(np.isfinite(lo), lo, -np.pi)
    hi = np.where(np.isfinite(hi), hi, np.pi)
    q = rng.uniform(lo, hi, size=(samples, n))
    qd, qdd = rng.normal(size=(samples, n)), rng.normal(size=(samples, n))
    probe = Design(
        model,
        terms,
        tuple(names),
        tuple(units),
        np.arange(len(names)),
        np.zeros(0, int),
        np.zeros((len(names), 0)),
        n_rigid=n_rigid,
    )
    W = probe.classic(q, qd, qdd)[0].reshape(samples * n, -1)
    scale = np.maximum(np.linalg.norm(W, axis=0), 1e-300)
    R = np.linalg.qr(W / scale, mode="r")
    diag = np.abs(np.diag(R))
    keep = diag > 1e-8 * max(diag.max(), 1e-300)
    base, dropped = np.flatnonzero(keep), np.flatnonzero(~keep)
    # regroup: W_d = W_b beta  (least squares on the probe, exact for structural dependence)
    if len(dropped):
        beta, *_ = np.linalg.lstsq(W[:, base], W[:, dropped], rcond=None)
        beta[np.abs(beta) < 1e-10] = 0.0
    else:
        beta = np.zeros((len(base), 0))
    return Design(
        model,
        terms,
        tuple(names),
        tuple(units),
        base,
        dropped,
        np.asarray(beta, dtype=np.float64),
        n_rigid=n_rigid,
    )
