"""Errors raised by calib."""

from __future__ import annotations

__all__ = ["CalibError", "InsufficientDataError", "SolverError"]


class CalibError(Exception):
    """Root of every error calib raises on purpose."""


class InsufficientDataError(CalibError):
    """Too few samples, or inputs that do not excite what is to be estimated."""


class SolverError(CalibError):
    """A numerical solve failed (singular system, no convergence)."""
