"""Result types every robot shares (calib's estimators, the CLI reports and viz): an
:class:`Estimate`, a :class:`CalibrationResult` (named parameters, N x N covariance, derived
quantities), an :class:`AnalysisResult`, and the JSON helpers (:class:`JsonRecord`,
:func:`json_safe`, :func:`format_pm`). A robot's own result types live in its room (the
tractor-trailer's method rows and command segments: :mod:`calib.tractor_trailer.results`).

Every result is a frozen dataclass with ``to_dict()`` (JSON-safe: NaN -> None) and, where it is
shown to people, ``report()``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from enum import StrEnum
from typing import Any, ClassVar

__all__ = [
    "PM_MEANING",
    "AnalysisResult",
    "CalibrationResult",
    "Estimate",
    "JsonRecord",
    "Matrix",
    "StageStatus",
    "as_matrix",
    "correlations_of",
    "format_pm",
    "json_safe",
]

PM_MEANING = (
    "(± is one standard error; in method tables, the spread over bootstrap repeats. "
    "[95 %: lo, hi] is the 95 % interval.)"
)
"""What ± means wherever logcal prints it (report, rerun tables): said once, in the report."""


def format_pm(value: float | None, std: float | None, digits: int = 3, unit: str = "") -> str:
    """``value ± std unit`` with ``digits`` decimals: the one formatter of ± (see PM_MEANING);
    "-" for a missing or non-finite value, the value alone for a missing or zero std."""
    if value is None or not math.isfinite(value):
        return "-"
    tail = f" {unit}" if unit else ""
    if std is None or not math.isfinite(std) or std == 0:
        return f"{value:.{digits}f}{tail}"
    return f"{value:.{digits}f} ± {std:.{digits}f}{tail}"


def json_safe(value: Any) -> Any:
    """Recursively convert to JSON-safe builtins: NaN/inf -> None, tuples -> lists, enums -> str."""
    if isinstance(value, StrEnum):
        return str(value)
    if isinstance(value, float | int) and not isinstance(value, bool):
        f = float(value)
        if isinstance(value, int):
            return value
        return f if math.isfinite(f) else None
    if hasattr(value, "item") and callable(value.item) and getattr(value, "ndim", 1) == 0:
        return json_safe(value.item())
    if hasattr(value, "tolist"):
        return json_safe(value.tolist())
    if isinstance(value, Mapping):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    if hasattr(value, "to_dict"):
        return value.to_dict()
    return value


class JsonRecord:
    """The one ``to_dict`` of logcal's result dataclasses: every field by name, then the
    properties named in ``json_properties``, made JSON-safe by :func:`json_safe` (NaN and inf
    -> None, enums -> their value, arrays and tuples -> lists, nested records -> their dicts).
    Fields named in ``json_skip`` are left out. A class whose JSON differs from its fields
    overrides ``to_dict`` and says why."""

    json_properties: ClassVar[tuple[str, ...]] = ()
    json_skip: ClassVar[tuple[str, ...]] = ()

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            f.name: getattr(self, f.name)
            for f in fields(self)  # type: ignore[arg-type]  # mixed into dataclasses only
            if f.name not in self.json_skip
        }
        out.update({name: getattr(self, name) for name in self.json_properties})
        safe: dict[str, Any] = json_safe(out)
        return safe


def _plain(x: Any) -> Any:
    """``x`` as a Python float when it is a real number (numpy's too), else as it is."""
    return float(x) if isinstance(x, numbers.Real) else x


@dataclass(frozen=True)
class Estimate(JsonRecord):
    """One estimated quantity: value +/- standard error, 95 % interval, identifiability.

    ``identifiable`` is False when the data cannot determine the quantity; ``note`` says why.
    """

    name: str
    value: float
    std: float
    ci95: tuple[float, float]
    identifiable: bool = True
    unit: str = "m"
    note: str = ""

    def __post_init__(self) -> None:
        """Hold plain Python floats (a numpy scalar prints as ``np.float64(1.25)`` in a
        tuple or a repr, where a user expects ``1.25``)."""
        object.__setattr__(self, "value", _plain(self.value))
        object.__setattr__(self, "std", _plain(self.std))
        object.__setattr__(self, "ci95", tuple(_plain(x) for x in self.ci95))

    def report(self) -> str:
        lo, hi = self.ci95
        tag = "" if self.identifiable else "  (not determined by this log)"
        if not (math.isfinite(self.std) and math.isfinite(lo) and math.isfinite(hi)):
            why = f": {self.note}" if self.note else ""
            return f"{self.name}: not determined by this log{why}"
        unit = f" {self.unit}" if self.unit else ""
        return (
            f"{self.name} = {self.value:.4g} ± {self.std:.2g}{unit} [95 %: {lo:.4g}, {hi:.4g}]{tag}"
        )


Matrix = tuple[tuple[float, ...], ...]
"""A square matrix as a tuple of rows of floats (immutable, and JSON-safe through json_safe)."""


def as_matrix(m: Any) -> Matrix:
    """``m`` (a nested sequence or a 2-D array) as a :data:`Matrix` of floats.

    Raises:
        ValueError: ``m`` is not square.
    """
    rows = tuple(tuple(float(x) for x in row) for row in m)
    if any(len(r) != len(rows) for r in rows):
        raise ValueError(
            f"a covariance must be square; got rows of lengths {[len(r) for r in rows]}"
        )
    return rows


def correlations_of(cov: Matrix) -> Matrix:
    """The correlation matrix of covariance ``cov``: cov_ij / sqrt(cov_ii cov_jj), clipped to
    [-1, 1]. An entry whose variances are not finite and positive is NaN (a parameter the data
    do not determine has no correlation); the diagonal is exactly 1 where the variance is
    finite and positive."""
    sd = [
        math.sqrt(c[i]) if math.isfinite(c[i]) and c[i] > 0 else math.nan for i, c in enumerate(cov)
    ]
    out = []
    for i, row in enumerate(cov):
        r = []
        for j, c in enumerate(row):
            den = sd[i] * sd[j]
            if not (math.isfinite(den) and math.isfinite(c)):
                r.append(math.nan)
            else:
                r.append(1.0 if i == j else max(-1.0, min(1.0, c / den)))
        out.append(tuple(r))
    return tuple(out)


_RESULT_KEYS = frozenset(
    {
        "method",
        "verdict",
        "identifiable",
        "parameter_names",
        "derived_names",
        "covariance",
        "correlations",
        "converged",
        "aic",
        "bic",
        "details",
        "assumptions",
    }
)
"""The JSON keys of a CalibrationResult that are not a parameter or a derived quantity."""


@dataclass(frozen=True)
class CalibrationResult:
    """One method's (or the recommended) parameter set, with intervals and a verdict: the one
    result type of every robot.

    ``parameters`` maps each parameter's name to an ``Estimate``, in the order of ``covariance``
    (the tractor-trailer's "L1" and "L2"; a differential drive's wheel radii and track; an
    arm's base parameters). ``derived`` holds the robot's own quantities computed from the
    parameters, filled by that robot's code (the tractor-trailer's "sum_L1_L2", usually far
    better determined than the split); this type knows no robot. ``covariance`` is the N x N
    covariance of the fit the parameters come from, over ``parameters`` in their order (None
    when unknown); where a robot widens its intervals afterwards (a misfit, explanations the
    log cannot tell apart) the intervals may be wider than its diagonal says. ``verdict`` is a
    plain-language sentence for people. ``assumptions``: what the intervals take as given that
    the log does not check (e.g. "the joint angle's gain is 1"), each a short clause; pooling
    keeps those every piece shares.

    Raises:
        ValueError: a covariance that is not N x N over the parameters, or a parameter or
            derived name that clashes with another or with a key of the JSON document.
    """

    method: str
    parameters: Mapping[str, Estimate]
    verdict: str
    covariance: Matrix | None = None
    derived: Mapping[str, Estimate] = field(default_factory=dict)
    converged: bool = True
    aic: float = math.nan
    bic: float = math.nan
    details: Mapping[str, Any] = field(default_factory=dict)
    assumptions: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        clash = (set(self.parameters) & set(self.derived)) | (
            (set(self.parameters) | set(self.derived)) & _RESULT_KEYS
        )
        if clash:
            raise ValueError(
                f"CalibrationResult {self.method!r}: names {sorted(clash)} clash "
                "(a parameter, a derived quantity and the JSON keys must differ)"
            )
        if self.covariance is not None:
            cov = as_matrix(self.covariance)
            if len(cov) != len(self.parameters):
                raise ValueError(
                    f"CalibrationResult {self.method!r}: covariance is {len(cov)} x {len(cov)} "
                    f"but there are {len(self.parameters)} parameters"
                )
            object.__setattr__(self, "covariance", cov)

    @property
    def identifiable(self) -> bool:
        return all(e.identifiable for e in self.parameters.values())

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """The parameters' names in the order of ``covariance`` and ``correlations``."""
        return tuple(self.parameters)

    @property
    def correlations(self) -> Matrix | None:
        """The parameters' correlation matrix (:func:`correlations_of`); None without a
        covariance."""
        return None if self.covariance is None else correlations_of(self.covariance)

    def report(self) -> str:
        lines = [f"Recommended estimate ({self.method}):"]
        lines += ["  " + e.report() for e in self.parameters.values()]
        lines += ["  " + e.report() for e in self.derived.values()]
        lines.append("  " + self.verdict)
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Each parameter, then each derived quantity, at the top level under its key; the
        result's own keys after them (``parameter_names`` gives the covariance's order)."""
        d: dict[str, Any] = {name: est.to_dict() for name, est in self.parameters.items()}
        d.update({name: est.to_dict() for name, est in self.derived.items()})
        d["method"] = self.method
        d["verdict"] = self.verdict
        d["identifiable"] = self.identifiable
        d["parameter_names"] = list(self.parameters)
        d["derived_names"] = list(self.derived)
        d["covariance"] = self.covariance
        d["correlations"] = self.correlations
        d["converged"] = self.converged
        d["aic"] = self.aic
        d["bic"] = self.bic
        d["details"] = dict(self.details)
        d["assumptions"] = list(self.assumptions)
        return json_safe(d)


@dataclass(frozen=True)
class StageStatus(JsonRecord):
    """How one stage of an analysis ended: "ok", "skipped" (the log has too little for it) or
    "failed" (a numerical failure, caught at the stage's boundary); ``reason`` says why."""

    stage: str
    status: str
    reason: str = ""


@dataclass(frozen=True)
class AnalysisResult:
    """Everything ``logcal analyze`` found in one log; ``to_dict()`` is the ``--json`` document.

    ``discovery`` is the model-mismatch result (any object with ``to_dict()``), ``adequacy``
    the verdict on whether the model explains the log (``calib.adequacy.Adequacy``), ``truth`` the
    true parameters when the log carries them (simulated logs), ``source`` facts about the file.
    ``stages`` says how each stage ended. For several runs of one robot, ``estimate`` is the
    pooled one and ``runs`` holds each run's own analysis. ``sections`` holds a robot's own
    results (objects with ``to_dict()`` or JSON-safe values) under their JSON keys, e.g. a
    differential drive's ``dead_reckoning`` or an arm's ``excitation``. ``segments`` (stretches
    of the log) and ``methods`` (one row per method) are the robot's own records, objects with
    ``to_dict()`` (e.g. the tractor-trailer's ``Segment`` and ``MethodResult``; another robot's
    ``methods`` may hold one ``CalibrationResult`` per method). ``artifacts`` carries arrays and
    inputs for later steps (views, pooling) and is not part of the JSON.
    """

    robot: str
    segments: list[Any]
    methods: list[Any]
    estimate: CalibrationResult | None
    discovery: Any = None
    adequacy: Any = None
    """``calib.adequacy.Adequacy``: whether the model explains the log (None: not assessed)."""
    truth: Mapping[str, float] = field(default_factory=dict)
    source: Mapping[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    stages: list[StageStatus] = field(default_factory=list)
    runs: list[AnalysisResult] = field(default_factory=list)
    sections: Mapping[str, Any] = field(default_factory=dict)
    artifacts: Mapping[str, Any] = field(default_factory=dict, compare=False, repr=False)
    """What the analysis computed for later steps but not for the JSON: arrays the views draw,
    inputs a pooled fit reuses. Keys are the plugin's own."""

    def to_dict(self) -> dict[str, Any]:
        out = self._own_dict()
        if self.runs:
            out["runs"] = [r.to_dict() for r in self.runs]
        return out

    def _own_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "robot": self.robot,
                "stages": [s.to_dict() for s in self.stages],
                "source": dict(self.source),
                "segments": [s.to_dict() for s in self.segments],
                "methods": [m.to_dict() for m in self.methods],
                "estimate": None if self.estimate is None else self.estimate.to_dict(),
                "adequacy": (
                    {"verdict": "not assessed", "reason": "this analysis did not judge its model"}
                    if self.adequacy is None
                    else self.adequacy.to_dict()
                ),
                "discovery": None if self.discovery is None else self.discovery.to_dict(),
                "truth": dict(self.truth),
                "warnings": list(self.warnings),
                **dict(self.sections),
            }
        )
