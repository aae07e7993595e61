"""The serial arm's part of the readable report: joints, excitation, held-out torque error,
feasibility (once), model notes, the estimate on each side of a parameter change and the
confounds the estimate spans. The adequacy verdict and discovery are printed by
:mod:`logtools.report` for every robot."""

from __future__ import annotations

from typing import Any

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
    lines += _scaling_lines(s.get("effort_scaling") or {})
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
        units = s.get("joint_units") or {}
        for j, v in hold.items():
            unit = units.get(j, "N·m")  # N for a prismatic joint's force
            lines.append(
                f"  {j}: error RMS {v:.4g} {unit} of effort RMS {trms.get(j, float('nan')):.4g}"
            )
    feas = s.get("feasibility")
    if feas:
        lines.append(
            "Physically feasible (M(q) positive definite, friction >= 0)"
            if feas["feasible"]
            else "NOT physically feasible: " + "; ".join(feas["problems"])
        )
    for note in s.get("model", {}).get("notes", []):
        if feas and not feas["feasible"] and note.startswith("identified parameters are not"):
            continue  # said once above
        lines.append(f"Note: {note}")
    lines += _adequacy_lines(result)
    # discovery's own lines are the report's "Model mismatch" panel (logtools.report)
    return lines


def _adequacy_lines(result: AnalysisResult) -> list[str]:
    """The arm's own additions to the shared adequacy lines (which ``logtools.report`` prints:
    verdict, channels, where, change, unexplained): the estimate on each side of a parameter
    change, and the confounds the recommended estimate spans."""
    lines: list[str] = []
    split = result.sections.get("parameter_change")
    if split:
        lines.append(
            f"Parameter change near t = {split['change']['t_s']:.1f} s: the log split "
            "there, each side fitted on its own:"
        )
        for piece in split["pieces"]:
            vals = ", ".join(
                f"{k} = {v['value']:.4g}"
                for k, v in piece["estimate"].items()
                if not k.startswith(("Fc", "Fv", "Fcs", "tau0"))
            )
            lines.append(f"  t {piece['t0_s']:.1f}-{piece['t1_s']:.1f} s: {vals}")
    for c in result.sections.get("confounds", []):
        lines.append(f"Confound: {c['note']}; the recommended estimate spans both")
    return lines


def _scaling_lines(scaling: dict[str, Any]) -> list[str]:
    """How the logged effort was scaled per joint (only when it was: ``--effort actuator``)."""
    if scaling.get("side") != "actuator":
        return []
    lines = [
        f"Effort logged actuator-side (--effort actuator), to the joint side through the "
        f"transmissions of {scaling.get('urdf')}:"
    ]
    for name, j in (scaling.get("joints") or {}).items():
        kt = j.get("torque_constant")
        lines.append(
            f"  {name}: x{j.get('factor', 1.0):g} = mechanical reduction "
            f"{j.get('reduction')} ({j.get('transmission')})"
            + (f" x torque constant {kt:g}" if kt is not None else "")
        )
    return lines
