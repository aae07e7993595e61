"""The tractor-trailer's own options (``logcal analyze``/``view`` flags, settings keys)."""

from __future__ import annotations

from dataclasses import dataclass

from calib.tractor_trailer.results import Baseline
from logtools.robot_options import RobotOptions, option

__all__ = ["TractorTrailerOptions"]


@dataclass(frozen=True)
class TractorTrailerOptions(RobotOptions):
    """Options of a tractor-trailer analysis (None: not given, the analysis' default).

    Attributes:
        discovery_span_s: seconds of a long log discovery looks at, in windows spread over it
            (default 600; 0: all of it).
        method_for_psi: a method (e.g. ``OLS1(EM1)``) whose steady-state joint angle the views
            also draw.
        baseline: the model discovery compares against (None: ``Baseline.TRANSIENT``, the
            off-axle trailer kinematics, which diagnoses best in
            bench/discovery_confusion_study.py; ``Baseline.STEADY``: the patent's steady state).
    """

    discovery_span_s: float | None = option(
        flag="--discovery-span",
        metavar="SECONDS",
        at_least=0.0,
        help="Seconds of a long tractor-trailer log discovery looks at, in windows spread "
        "over it (default 600; 0: all of it, slower).",
    )
    method_for_psi: str | None = option(
        flag="--method",
        metavar="NAME",
        view=True,
        help="In the rerun views, also draw psi predicted by this method (e.g. OLS1(EM1)).",
    )
    baseline: Baseline | None = option(  # noqa: RUF009  (option() is a dataclasses.field)
        flag="--baseline",
        view=True,
        batch=True,
        help="Discovery baseline of the tractor-trailer: transient (default) or steady "
        "(the patent's view).",
    )
