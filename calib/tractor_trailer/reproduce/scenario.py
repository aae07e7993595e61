"""The patent's simulation scenario (KR 10-1481896, paragraphs [0127]–[0132], Figs. 7–13).

L1 = 1.25 m, L2 = 2.48 m; curvature commands H: κ = M sin(0.1 t), C: κ = M tanh(0.1 t),
L: κ = M (0.1 t / π − 1), M ∈ {0.2, 0.1} 1/m; ideal data from the steady-state relation.

Time grid: 630 samples evenly spaced over [0, 63] s for H and C, and over [0, 20π] s
(≈ 62.8 s, one full sweep of L from −M to +M) for L. This grid was found by comparing
candidates against the ideal-data figures (8, 10, 11), not stated in the patent: with it
every OLS/TLS condition number, singular value and slope of those figures agrees to the
printed precision but two; the 631-sample grid t = 0, 0.1, …, 63 s of METHODS.md matches H
and C to about 0.1 % but misses L by 0.5–1 % (L's printed intercepts of ~1e-12 also say
that its samples are symmetric about κ = 0, which only the [0, 20π] sweep gives).

Noise ("amplitude 0.03", [0130]): zero-mean Gaussian with σ = 0.03/√3 ≈ 0.0173 added to both
κ (1/m) and Ψ (rad), i.e. the standard deviation of a uniform ±0.03; with σ = 0.03 the noisy
slopes of Fig. 12 are not reproduced (METHODS.md).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from calib.results import json_safe
from calib.tractor_trailer.models.hitch_kinematics import steady_state_psi

__all__ = [
    "COMMANDS",
    "PATENT_SCENARIO",
    "PatentScenario",
]

FloatArray = NDArray[np.float64]

COMMANDS: tuple[str, ...] = ("H", "C", "L")


@dataclass(frozen=True)
class PatentScenario:
    """The patent's simulation set-up (see module docstring).

    Attributes:
        L1, L2: true link lengths (m).
        amplitudes: curvature amplitudes M (1/m).
        n_samples: samples per run.
        duration_s: run length per command (s).
        rate: ω of the commands (rad/s).
        noise_sigma: standard deviation of the Gaussian noise on κ (1/m) and Ψ (rad).
    """

    L1: float = 1.25
    L2: float = 2.48
    amplitudes: tuple[float, ...] = (0.2, 0.1)
    n_samples: int = 630
    duration_s: tuple[tuple[str, float], ...] = (("H", 63.0), ("C", 63.0), ("L", 20 * math.pi))
    rate: float = 0.1
    noise_sigma: float = 0.03 / math.sqrt(3.0)

    def time(self, command: str) -> FloatArray:
        """Sample times (s) of a run of ``command`` ("H", "C" or "L")."""
        return np.linspace(0.0, dict(self.duration_s)[command], self.n_samples)

    def kappa(self, command: str, M: float) -> FloatArray:
        """Ideal curvature (1/m) of ``command`` with amplitude ``M`` (1/m)."""
        wt = self.rate * self.time(command)
        if command == "H":
            return M * np.sin(wt)
        if command == "C":
            return M * np.tanh(wt)
        if command == "L":
            return M * (wt / math.pi - 1.0)
        raise ValueError(f"unknown command {command!r}; expected one of {COMMANDS}")

    def ideal(
        self, command: str, M: float, L1: float | None = None, L2: float | None = None
    ) -> tuple[FloatArray, FloatArray]:
        """(κ 1/m, Ψ rad) on the steady state, for the scenario's or the given link lengths."""
        k = self.kappa(command, M)
        return k, steady_state_psi(k, self.L1 if L1 is None else L1, self.L2 if L2 is None else L2)

    def noisy(
        self,
        command: str,
        M: float,
        *,
        repeats: int,
        rng: np.random.Generator,
        L1: float | None = None,
        L2: float | None = None,
    ) -> Iterator[tuple[FloatArray, FloatArray]]:
        """``repeats`` noisy copies of the ideal data, fresh noise each."""
        k, p = self.ideal(command, M, L1, L2)
        for _ in range(repeats):
            yield (
                k + rng.normal(0.0, self.noise_sigma, k.size),
                p + rng.normal(0.0, self.noise_sigma, p.size),
            )

    def to_dict(self) -> dict[str, object]:
        """JSON-safe description."""
        return json_safe(
            {
                "L1_m": self.L1,
                "L2_m": self.L2,
                "amplitudes_per_m": list(self.amplitudes),
                "n_samples": self.n_samples,
                "duration_s": dict(self.duration_s),
                "time_grid": "linspace(0, duration, n_samples)",
                "commands": {
                    "H": "M sin(0.1 t)",
                    "C": "M tanh(0.1 t)",
                    "L": "M (0.1 t / pi - 1)",
                },
                "noise": "Gaussian on kappa and psi",
                "noise_sigma": self.noise_sigma,
            }
        )


PATENT_SCENARIO = PatentScenario()
