"""The differential drive's part of the readable report (plain lines from the result); the
adequacy verdict and discovery are drawn around it by :mod:`logtools.report`."""

from __future__ import annotations

from typing import Any

from calib.results import AnalysisResult

__all__ = ["pooled_summary_lines", "report_lines", "summary_lines"]


def _ground_truth_lines(result: AnalysisResult) -> list[str]:
    gt = result.sections.get("ground_truth")
    if not gt:
        return []
    if gt.get("verdict") == "ground truth":
        return [
            f"Ground truth: {gt['topic']} (independent of the encoders: whole-log heading "
            f"residual {gt['heading_residual_rms_rad']:.2g} rad)"
        ]
    line = f"Ground truth: NOT {gt['topic']}, which is the encoders' own dead reckoning"
    line += (
        f"; using {gt['used_instead']}"
        if gt.get("used_instead")
        else "; no other pose in the log: radii and track not determined"
    )
    return [line]


def _adequacy_lines(result: AnalysisResult) -> list[str]:
    lines = []
    ad = result.adequacy
    if ad is not None and ad.channels:
        lines.append(
            f"Adequacy ({ad.model}): {ad.verdict}; "
            + ", ".join(
                f"{c.channel} {c.judged_ratio:.2g}x its noise floor ({c.noise_floor:.3g} {c.unit})"
                for c in ad.channels
            )
        )
    runs = [r for r in result.runs if r.adequacy is not None and r.adequacy.channels]
    if runs:
        lines.append("Adequacy per run:")
        for r in runs:
            worst = max(r.adequacy.channels, key=lambda c: c.judged_ratio)
            lines.append(
                f"  {r.source.get('path', '?')}: {r.adequacy.verdict} "
                f"({worst.channel} {worst.judged_ratio:.2g}x)"
            )
    change = result.sections.get("parameter_change")
    if change:
        lines.append(change["change"]["note"] + "; each part estimated:")
        for part in change["pieces"]:
            est = part["estimate"]
            lines.append(
                f"  {part['part']}: "
                + ", ".join(
                    f"{k} {v['value'] * 1e3:.3f} ± {v['std'] * 1e3:.2g} mm" for k, v in est.items()
                )
            )
    return lines


def report_lines(result: AnalysisResult) -> list[Any]:
    """Ground truth, methods, dead-reckoning drift before / after, effective track, the
    odometry-vs-gyro gain, per-run adequacy and a mid-log change, as lines."""
    lines: list[str] = _ground_truth_lines(result)
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
    oi = result.artifacts.get("odometry_imu")
    if oi is not None and hasattr(oi, "summary_lines"):
        lines += oi.summary_lines()
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
    lines += _adequacy_lines(result)
    return lines


def _dead_reckoning_lines(result: AnalysisResult) -> list[str]:
    """End-point error before (nominal) and after (calibrated) per run, each run named by its
    file, and plainly which runs calibration made worse."""
    dr = result.sections.get("dead_reckoning")
    if not dr:
        return []
    from logtools.runs import short_names

    rows = dr["runs"]
    names = short_names([str(r["run"]) for r in rows])
    method = dr.get("calibrated_with") or (result.estimate.method if result.estimate else "")
    lines = [
        "Dead reckoning, end-point error nominal -> calibrated"
        + (f" ({method}):" if method else ":")
    ]
    worse = []
    for name, row in zip(names, rows, strict=True):
        nom = row.get("nominal", {}).get("end_point_error_m")
        cal = row.get("calibrated", {}).get("end_point_error_m")
        if nom is None or cal is None:
            lines.append(f"  {name}: -")
            continue
        tag = ""
        if cal > nom:
            worse.append(name)
            tag = "  WORSE"
        lines.append(f"  {name}: {nom:.4f} m -> {cal:.4f} m{tag}")
    if worse:
        lines.append(
            f"Calibration made the end-point error worse on {len(worse)} of {len(rows)} "
            f"run(s): {', '.join(worse)}"
        )
    return lines


def _umbmark_lines(result: AnalysisResult) -> list[str]:
    """UMBmark's answer: what it determines with its interval (the radii's ratio, the track
    width), and the radii it does not determine said once."""
    out = []
    for m in result.methods:
        if not getattr(m, "method", "").startswith("UMBmark"):
            continue
        shown = [e for e in [*m.derived.values(), *m.parameters.values()] if e.identifiable]
        hidden = [e.name for e in m.parameters.values() if not e.identifiable]
        text = "; ".join(e.report() for e in shown)
        if hidden:
            text += (
                f"; not determined: {', '.join(hidden)} (UMBmark keeps the nominal mean radius; "
                "its track width holds for that radius)"
            )
        out.append(f"{m.method}: {text}")
    return out


def summary_lines(result: AnalysisResult) -> list[Any]:
    """Beside the answer in every report: where the ground truth came from, dead reckoning
    before and after (and which runs got worse), UMBmark where the runs are square."""
    return [*_ground_truth_lines(result), *_dead_reckoning_lines(result), *_umbmark_lines(result)]


def pooled_summary_lines(result: AnalysisResult) -> list[Any]:
    """The same for several runs pooled: each run's dead reckoning before and after."""
    return summary_lines(result)
