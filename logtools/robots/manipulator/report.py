"""The serial arm's part of the readable report: joints, excitation, held-out torque error,
feasibility, model notes and discovery."""

from __future__ import annotations

from rich.console import RenderableType
from rich.text import Text

from calib.results import AnalysisResult

__all__ = ["report_lines", "report_text"]


def report_lines(result: AnalysisResult) -> list[RenderableType]:
    """The arm's own part of the report: joints, excitation, held-out RMS, feasibility,
    discovery; plain lines as rich ``Text`` (parameter names hold brackets, not markup)."""
    return [Text(line) for line in report_text(result)]


def report_text(result: AnalysisResult) -> list[str]:
    """:func:`report_lines` as plain strings."""
    s = result.sections
    lines = [
        f"Arm: {len(s.get('joints', []))} joints ({', '.join(s.get('joints', []))}); "
        f"model: {s.get('model', {}).get('source', '?')}"
    ]
    exc = s.get("excitation")
    if exc:
        lines.append(
            f"Excitation: condition number {exc['condition_number']:.3g} (scaled momentum "
            f"regressor); {exc['n_determined']} of {exc['n_base_parameters']} base parameters "
            "determined"
        )
    hold = s.get("torque_rms_holdout")
    if hold:
        trms = s.get("torque_rms", {})
        lines.append(
            "Held-out torque (identified on the first 60 %, predicted on the last 40 %): "
            f"error {100 * s['torque_rms_holdout_ratio']:.1f} % of the torque RMS"
        )
        for j, v in hold.items():
            lines.append(
                f"  {j}: error RMS {v:.4g} N·m of torque RMS {trms.get(j, float('nan')):.4g}"
            )
    feas = s.get("feasibility")
    if feas:
        lines.append(
            "Physically feasible (M(q) positive definite, friction >= 0)"
            if feas["feasible"]
            else "NOT physically feasible: " + "; ".join(feas["problems"])
        )
    for note in s.get("model", {}).get("notes", []):
        lines.append(f"Note: {note}")
    if result.discovery is not None and hasattr(result.discovery, "report"):
        lines += result.discovery.report()
    return lines
