"""The differential drive's part of the readable report (plain lines from the result)."""

from __future__ import annotations

from typing import Any

from calib.results import AnalysisResult

__all__ = ["report_lines"]


def report_lines(result: AnalysisResult) -> list[Any]:
    """Methods, dead-reckoning drift before / after, effective track and discovery, as lines."""
    lines: list[str] = []
    for m in result.methods:
        lines.append(f"{m.method}:")
        lines += ["  " + e.report() for e in m.parameters.values()]
        lines.append("  " + m.verdict)
    et = result.sections.get("effective_track")
    if et:
        e = et["estimate"]
        lines.append(
            f"Effective track from the {et['from']}: {e['value']:.4f} ± {e['std']:.2g} m "
            f"(geometric {et['geometric_track_m']} m)"
        )
    dr = result.sections.get("dead_reckoning")
    if dr:
        lines.append(
            f"Dead-reckoning end-point error (calibrated with {dr.get('calibrated_with')}):"
        )
        for row in dr["runs"]:
            nom = row.get("nominal", {}).get("end_point_error_m")
            cal = row.get("calibrated", {}).get("end_point_error_m")
            fac = row.get("improvement_factor")
            lines.append(
                f"  {row['run']}: nominal "
                + ("-" if nom is None else f"{nom:.4f} m")
                + ", calibrated "
                + ("-" if cal is None else f"{cal:.4f} m")
                + ("" if fac is None else f" ({fac:.1f}x)")
            )
    if result.discovery is not None:
        lines += result.discovery.report()
    return lines
