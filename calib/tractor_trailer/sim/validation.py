"""Checks of simulator parameters: the one place that decides which values make physical sense.

Every check raises :class:`SimParameterError`, which names the parameter (as the keyword the
caller passed: ``rate_hz``, ``L2``, ``v_mps``, ...), the value and what was expected, so a front
end (the ``logcal`` CLI) can translate the name into its own option and print one message.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from calib.errors import CalibError

__all__ = [
    "PSI_LIMIT_RAD",
    "SimParameterError",
    "check_finite",
    "check_non_negative",
    "check_positive",
    "check_steady_turn",
    "require",
    "show",
]

PSI_LIMIT_RAD = math.pi / 4
"""The patent's range of the joint angle, |psi| < 0.785 rad (METHODS.md)."""


class SimParameterError(CalibError, ValueError):
    """A simulator parameter that makes no physical sense.

    Also a :class:`ValueError`, so callers that caught the bare ``ValueError`` the simulator
    raised before keep working.

    Attributes:
        parameter: the parameter's name as the caller passed it (``rate_hz``, ``L2``, ...).
        value: the rejected value (a number, or the string of a bad choice).
        expected: what was expected, e.g. ``"a finite number > 0 (Hz)"``.
        related: the other parameters of a joint condition (e.g. ``{"L1": 1.25}`` when ``L2``
            is rejected for the pair), by name.
    """

    def __init__(
        self,
        parameter: str,
        value: float | str,
        expected: str,
        related: Mapping[str, float] | None = None,
    ) -> None:
        self.parameter = parameter
        self.value = value
        self.expected = expected
        self.related: dict[str, float] = dict(related or {})
        given = ", ".join(f"{k} = {show(v)}" for k, v in self.related.items())
        with_ = f" (with {given})" if given else ""
        super().__init__(f"{parameter} = {show(value)}{with_}: expected {expected}")


def show(value: float | str) -> str:
    """``value`` as the messages print it: numbers with ``:g``, strings quoted."""
    return f"{value:g}" if isinstance(value, float | int) else repr(value)


def require(
    ok: bool,
    parameter: str,
    value: float | str,
    expected: str,
    related: Mapping[str, float] | None = None,
) -> None:
    """Raise :class:`SimParameterError` ``(parameter, value, expected, related)`` unless ``ok``."""
    if not ok:
        raise SimParameterError(parameter, value, expected, related)


def _unit(unit: str) -> str:
    return f" ({unit})" if unit else ""


def check_finite(parameter: str, value: float, unit: str = "") -> float:
    """``value`` if it is a finite number (not NaN or +/-inf)."""
    require(math.isfinite(value), parameter, value, f"a finite number{_unit(unit)}")
    return value


def check_positive(parameter: str, value: float, unit: str = "") -> float:
    """``value`` if it is finite and > 0."""
    require(
        math.isfinite(value) and value > 0, parameter, value, f"a finite number > 0{_unit(unit)}"
    )
    return value


def check_non_negative(parameter: str, value: float, unit: str = "") -> float:
    """``value`` if it is finite and >= 0."""
    require(
        math.isfinite(value) and value >= 0, parameter, value, f"a finite number >= 0{_unit(unit)}"
    )
    return value


def check_steady_turn(L1: float, L2: float, kappa_peak: float) -> None:
    """Check that the trailer has a steady turn at the largest curvature ``kappa_peak`` (1/m):
    kappa^2 (L2^2 - L1^2) < 1. ``L1`` and ``L2`` (m) must already be finite, ``L2 > 0``; with
    ``|L1| >= L2`` every curvature has one. The error names ``L2`` (with ``L1`` as related).
    """
    k = abs(kappa_peak)
    if k == 0:
        return
    require(
        k * k * (L2 * L2 - L1 * L1) < 1.0,
        "L2",
        L2,
        f"L2^2 - L1^2 < {1.0 / (k * k):.4g} m^2, so that the trailer has a steady turn at the "
        f"largest commanded curvature {k:.3g} 1/m",
        {"L1": L1},
    )
