"""The adequacy verdict for people: whether the model explains the log, each channel's residual
against its noise floor, where the misfit sits, what changed mid-log and what nothing explains.
The same lines for every robot (the verdict is :class:`calib.adequacy.Adequacy`)."""

from __future__ import annotations

from typing import Any

from rich.text import Text

from logtools.safe_text import printable

__all__ = ["adequacy_lines", "adequacy_text"]


def _num(x: Any, unit: str = "") -> str:
    if x is None:
        return "-"
    tail = f" {unit}" if unit else ""
    return f"{x:.3g}{tail}"


def adequacy_lines(adequacy: Any) -> list[str]:
    """The verdict in a few plain lines (no markup: names print literally)."""
    d = adequacy.to_dict()
    verdict = d["verdict"]
    if verdict == "not assessed":
        return [f"Model adequacy: not assessed ({d.get('reason') or 'no residual to judge'})"]
    head = "explains" if verdict == "explains" else "DOES NOT EXPLAIN"
    lines = [f"Model adequacy: the model {head} the log ({d['model']})"]
    for c in d["channels"]:
        held = f", held out {c['heldout_ratio']:.2g}x" if c.get("heldout_ratio") is not None else ""
        white = (
            f", whiteness p = {c['whiteness_p']:.2g}" if c.get("whiteness_p") is not None else ""
        )
        lines.append(
            f"  {c['channel']}: residual {_num(c['residual_rms'], c['unit'])} = "
            f"{c['ratio']:.2g}x the noise floor {_num(c['noise_floor'], c['unit'])} "
            f"(from {c['noise']['source']}){held}{white}"
        )
    if verdict != "explains" and d["located"]:
        lines.append(
            "  where: "
            + "; ".join(
                f"{loc['label']} ({loc['channel']}, {loc['ratio']:.2g}x the floor, "
                f"{100 * loc['share']:.0f} % of the excess)"
                for loc in d["located"][:4]
            )
        )
    before = d.get("before")
    if before and before.get("channels"):
        worst_b = max(c["judged_ratio"] or 0.0 for c in before["channels"])
        worst = max((c["judged_ratio"] or 0.0 for c in d["channels"]), default=0.0)
        lines.append(
            f"  before discovery ({before['model']}): {before['verdict']}, worst "
            f"residual {worst_b:.2g}x the floor -> now {worst:.2g}x"
        )
    for ch in d["changes"]:
        lines.append(f"  change mid-log: {ch['note']}")
    if d.get("unexplained"):
        lines.append(f"  unexplained: {d['unexplained']}")
    for n in d.get("notes") or []:
        lines.append(f"  note: {n}")
    return lines


def adequacy_text(adequacy: Any) -> Text:
    """:func:`adequacy_lines` as a rich Text, escaped for the terminal, coloured by verdict."""
    lines = adequacy_lines(adequacy)
    verdict = adequacy.verdict
    style = (
        "green"
        if verdict == "explains"
        else ("yellow" if verdict == "not assessed" else "bold red")
    )
    text = Text(printable(lines[0]) + "\n", style=style)
    text.append("\n".join(printable(x) for x in lines[1:]))
    return text
