"""One entry point for the three robots' kind-bearing logs: ``generate_log`` draws nothing but
from ``seed`` and attaches the effect size of the kind (``robotlog.effect_size``) to the truth.

``truth["effect_size"]``: {channel: RMS(with - without) / noise std}; ``truth["max_effect_size"]``
the largest (0 for a clean log, computed the same way against a regenerated clean twin).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .arm import arm_log
from .diffdrive import diff_drive_log
from .kinds import KINDS
from .robotlog import RobotLog, effect_size
from .tractor_kinds import tractor_log

__all__ = ["GENERATORS", "generate_log"]

GENERATORS: dict[str, Callable[..., RobotLog]] = {
    "tractor_trailer": tractor_log,
    "diff_drive": diff_drive_log,
    "arm": arm_log,
}


def generate_log(
    robot: str, seed: int, kind: str | None = None, magnitude: float = 0.0, **kw: Any
) -> RobotLog:
    """A log of ``robot`` with ``kind`` at ``magnitude`` (None: clean), effect size attached."""
    if kind is not None and KINDS[kind].robot != robot:
        raise ValueError(f"kind {kind!r} is a {KINDS[kind].robot} kind, not {robot}")
    gen = GENERATORS[robot]
    log = gen(seed, kind, magnitude, **kw)
    clean = gen(seed, None, 0.0, **kw)
    es = effect_size(log, clean)
    log.truth["effect_size"] = es
    log.truth["max_effect_size"] = max(es.values(), default=0.0)
    if kind is not None:
        d = KINDS[kind]
        log.truth["kind_param"] = {d.param: magnitude}
    return log
