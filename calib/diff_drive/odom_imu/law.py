"""The gain law discovery ends with, re-estimated and re-reported: the effects' parameters with
their (Newey-West) intervals, the law in one formula, the gain it implies over the log (its range
over the windows that turn and its turn-weighted mean, with a delta-method interval), and the
adequacy of the model with it (the gyro's yaw-change residual against its noise floor, held out
on two folds), so that the verdict before -> after is the same test on both models.

The turn-weighted mean gain is the ratio of the odometry's total turn to the gyro's
(sum |odometry yaw change| / sum |odometry yaw change| / G over the windows that turn): the one
number a constant-gain calibration would give if the law held.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.stats import t as student_t

from calib.adequacy import Adequacy, ResidualChannel, assess, not_assessed
from calib.diff_drive.odom_imu.fitter import GainFitter, GainPayload
from calib.diff_drive.odom_imu.gain import block_boot
from calib.diff_drive.odom_imu.windows import WINDOW_S
from calib.discovery import EffectKind, ModelFit
from calib.results import Estimate, json_safe
from calib.stats import Z95

__all__ = ["GainLaw", "gain_law", "law_formula"]

Array = NDArray[np.float64]

_SYMBOL = {"rate": "|omega|", "speed": "|v|", "speed*rate": "|v| |omega|"}


def law_formula(fit: ModelFit) -> str:
    """The gain of ``fit``'s effects in one formula, G = G0 (1 + ...) / (1 - ...), described
    terms noted."""
    const = 0.0
    grow: list[str] = []
    slip: list[str] = []
    described = False
    for e in fit.effects:
        form = getattr(e.model, "form", "")
        if form == "described" or str(e.kind) == str(EffectKind.DESCRIBED):
            described = True
            continue
        pars = fit.effect_parameters.get(e.key, {})
        for p, part in zip(e.params, getattr(e.model, "covers", ()), strict=False):
            val = pars[p.name].value if p.name in pars else math.nan
            if part == "1":
                const += val
            else:
                # a growth adds + val x; a slip loses val x of the turn: written 1 - val x
                sign = ("-" if val < 0 else "+") if form == "growth" else ("+" if val < 0 else "-")
                (grow if form == "growth" else slip).append(
                    f"{sign} {abs(val):.3g} {_SYMBOL.get(part, part)}"
                )
    text = f"G = {1 + const:.4g}"
    if grow:
        text += f" (1 {' '.join(grow)})"
    if slip:
        text += f" / (1 {' '.join(slip)})"
    return text + (" + the described yaw-rate terms" if described else "")


@dataclass(frozen=True)
class GainLaw:
    """The final model's gain (module docstring): ``formula``; ``mean_gain`` over the turning
    windows; ``lowest``/``highest`` gain over them; ``at_slow_turn`` G0 when the model fits a
    constant; ``adequacy`` of the model; ``residual_rms`` (rad) of the gyro's yaw change."""

    fit: ModelFit
    formula: str
    mean_gain: Estimate
    lowest: float
    highest: float
    at_slow_turn: Estimate | None
    adequacy: Adequacy
    residual_rms: float

    @property
    def explains(self) -> bool:
        return self.adequacy.explains

    def lines(self) -> list[str]:
        m = self.mean_gain
        mean = (
            f", turn-weighted mean {m.value:.4g} [95 %: {m.ci95[0]:.4g}, {m.ci95[1]:.4g}]"
            if m.identifiable
            else " (the model with it does not explain the log: no single gain is determined)"
        )
        span = (
            f"{self.lowest:.4g} to {self.highest:.4g}"
            if math.isfinite(self.highest)
            else f"{self.lowest:.4g} upward (the law has the robot not turning on some of them)"
        )
        out = [f"gain law: {self.formula}; over the windows that turn G runs {span}{mean}"]
        if self.at_slow_turn is not None and self.at_slow_turn.identifiable:
            out.append("slow-turn gain " + self.at_slow_turn.report())
        return out

    def to_dict(self) -> dict[str, object]:
        return json_safe(
            {
                "model": self.fit.label,
                "formula": self.formula,
                "mean_gain": self.mean_gain.to_dict(),
                "lowest": self.lowest,
                "highest": self.highest,
                "at_slow_turn": None if self.at_slow_turn is None else self.at_slow_turn.to_dict(),
                "residual_rms_rad": self.residual_rms,
                "verdict": self.adequacy.verdict,
            }
        )


def _slopes(fitter: GainFitter, fit: ModelFit, values: Mapping[str, float]) -> Array:
    rows = fitter.use
    out: Array = np.broadcast_to(
        np.asarray(fitter.slope(values, rows, fit.effects), float), rows.shape
    )
    return out


def _mean_gain(fitter: GainFitter, fit: ModelFit, values: Mapping[str, float]) -> float:
    turn = np.abs(fitter.w.odo[fitter.use])
    seen = float(np.sum(turn * _slopes(fitter, fit, values)))
    return float(np.sum(turn)) / seen if seen > 0 else math.inf


def _delta_std(fitter: GainFitter, fit: ModelFit, pay: GainPayload) -> float:
    """Delta-method std of the turn-weighted mean gain (central differences)."""
    base = dict(pay.values)
    grad = np.zeros(len(pay.names))
    for i, n in enumerate(pay.names):
        h = 1e-6 * max(1.0, abs(base[n]))
        up, dn = dict(base), dict(base)
        up[n] += h
        dn[n] -= h
        grad[i] = (_mean_gain(fitter, fit, up) - _mean_gain(fitter, fit, dn)) / (2 * h)
    var = float(grad @ pay.cov @ grad)
    return math.sqrt(var) if var >= 0 and math.isfinite(var) else math.nan


BOOT_REPS = 100


def _boot(fitter: GainFitter, fit: ModelFit, seed: int) -> tuple[float, int]:
    """Moving-block bootstrap std of the turn-weighted mean gain (the law refitted on resampled
    windows, the mean taken on the log's windows) and the t's degrees of freedom (blocks - 1)."""
    use = fitter.use
    rng = np.random.default_rng(seed)
    reps = []
    for idx in block_boot(use.size, rng, BOOT_REPS):
        vals = fitter.values_on(fit.effects, use[idx])
        if vals is not None:
            reps.append(_mean_gain(fitter, fit, vals))
    arr = np.asarray(reps, float)
    arr = arr[np.isfinite(arr)]
    blk = max(1, round(use.size ** (1 / 3)))
    dof = max(1, int(np.ceil(use.size / blk)) - 1)
    return (float(np.std(arr, ddof=1)) if arr.size > 10 else math.nan), dof


def _adequacy(fitter: GainFitter, fit: ModelFit, model: str) -> tuple[Adequacy, float]:
    w = fitter.w
    pay: GainPayload = fit.payload
    every = np.arange(w.t.size, dtype=np.intp)
    resid = w.gyro - fitter.predicted(pay.values, every, fit.effects)
    held = fitter.heldout_residual(fit)
    chan = ResidualChannel(
        "gyro yaw change",
        "rad",
        w.t - w.t[0],
        resid,
        held,
        timescale_s=WINDOW_S,
        covariates={"|turn rate| (rad/s)": w.rate, "speed (m/s)": w.speed},
    )
    try:
        ad = assess([chan], model=model)
    except (ValueError, FloatingPointError):
        ad = not_assessed(model, "the residual could not be judged")
    return ad, float(np.sqrt(np.mean(resid**2)))


def gain_law(fitter: GainFitter, fit: ModelFit, seed: int = 0) -> GainLaw:
    """The law of ``fit`` (a fit of ``fitter``) re-reported (module docstring). The mean gain's
    interval is value ± t std, std the larger of the delta method's and a moving-block
    bootstrap's (the law refitted on resampled windows; t on blocks - 1 degrees of freedom):
    the delta method alone was too narrow on simulated logs."""
    pay: GainPayload = fit.payload
    formula = law_formula(fit)
    slopes = _slopes(fitter, fit, pay.values)
    lowest = 1.0 / float(np.max(slopes)) if float(np.max(slopes)) > 0 else math.inf
    highest = 1.0 / float(np.min(slopes)) if float(np.min(slopes)) > 0 else math.inf
    mean = _mean_gain(fitter, fit, pay.values)
    adequacy, rms = _adequacy(fitter, fit, f"yaw-rate gain law {formula} + gyro bias")
    std, q = _delta_std(fitter, fit, pay), Z95
    if adequacy.explains:  # the value is reported: its interval from resampling too
        boot, dof = _boot(fitter, fit, seed)
        if math.isfinite(boot):
            std, q = max(std, boot), float(student_t.ppf(0.975, dof))
    mean_e = Estimate(
        "yaw_rate_gain",
        mean,
        std,
        (mean - q * std, mean + q * std),
        math.isfinite(std) and math.isfinite(mean) and adequacy.explains,
        "1",
        f"turn-weighted mean over {fitter.use.size} windows that turn under {formula} "
        "(the larger of the delta method's and a moving-block bootstrap's std)",
    )
    slow = None
    for e in fit.effects:
        covers = getattr(e.model, "covers", ())
        if covers and covers[0] == "1":  # the effect's first parameter is G0 - 1
            p = fit.effect_parameters[e.key][e.params[0].name]
            slow = Estimate(
                "yaw_rate_gain_slow_turn",
                1 + p.value,
                p.std,
                (1 + p.ci95[0], 1 + p.ci95[1]),
                p.identifiable and adequacy.explains,
                "1",
                "G0: the gain as speed and turn rate go to zero",
            )
    return GainLaw(fit, formula, mean_e, lowest, highest, slow, adequacy, rms)
