"""Tuning of the command segmentation (the defaults are the documented method)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["SegmentationSettings"]


@dataclass(frozen=True)
class SegmentationSettings:
    """Tuning of ``segment_command`` (the defaults are the documented method).

    Args:
        max_rate_hz: rate (Hz) of the decimated grid the search runs on.
        merge_rate_hz: rate (Hz) of the grid on which merge decisions fit templates.
        jump_sigmas: a jump exceeds this many noise standard deviations of a difference.
        jump_frac: ... and this fraction of the command's scale.
        min_piece_s: shortest piece (s) binary segmentation makes.
        refine_window_s: half-width (s) of the boundary refinement window.
        sigma_floor_frac: floor of the noise level, as a fraction of the scale.
        dissolve_max_s: longest segment (s) that may be handed to its neighbours.
    """

    max_rate_hz: float = 10.0
    merge_rate_hz: float = 2.0
    jump_sigmas: float = 8.0
    jump_frac: float = 0.02
    min_piece_s: float = 1.0
    refine_window_s: float = 8.0
    sigma_floor_frac: float = 1e-3
    dissolve_max_s: float = 30.0
