"""The batch's HTML report: ``index.html`` (fleet summary, pooled estimates and drift, plots,
effects found, failures, every log) and ``pages/<id>.html`` per log (what it was analysed
with, estimate, stages, discovery, methods, its image and links to its ``.rrd``).

Hand-written HTML (no template engine): the pages are a few tables, and writing them with one
escaping helper keeps the one rule visible: every text that comes from a log, a file name, a
``logcal.toml`` or an error message goes through :func:`html.escape` (``_e``), attributes
included. Numbers are formatted by us. Static files: the report works opened from disk, and
``logcal serve DIR`` adds the rerun web viewer links (``/rerun/open?rrd=...``).
"""

from __future__ import annotations

import functools
import html
import math
from collections.abc import Iterable, Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any
from urllib.parse import quote

import polars as pl

from logtools.batch.fleet import ParameterSeries
from logtools.safe_text import printable_lines

__all__ = ["write_report"]

_CSS = """
body{font-family:system-ui,sans-serif;margin:1.5em;max-width:1200px;color:#222}
table{border-collapse:collapse;margin:.5em 0 1.5em;font-size:.9em}
th,td{border:1px solid #ccc;padding:.25em .5em;text-align:left;vertical-align:top}
th{background:#f0f0f0}td.num{text-align:right;font-variant-numeric:tabular-nums}
.failed{color:#a00}.ok{color:#070}.flag{color:#a00;font-weight:bold}
img{max-width:100%;border:1px solid #ddd}code{font-size:.9em}
pre{white-space:pre-wrap;background:#f7f7f7;padding:.5em;font-size:.85em}
"""


def _e(x: Any) -> str:
    """Escaped text of anything (None -> ""): HTML markup escaped, and control and bidi
    characters (ESC, BEL, U+202E, ... from a file name or a log) shown as visible escapes
    (``\\x1b``), line breaks kept."""
    return "" if x is None else html.escape(printable_lines(str(x)), quote=True)


def _num(x: Any, digits: int = 4) -> str:
    if isinstance(x, bool) or not isinstance(x, int | float) or not math.isfinite(x):
        return "-"
    return f"{x:.{digits}g}"


def _pm(value: Any, std: Any, unit: Any = "") -> str:
    """``value ± std unit`` in significant digits (a clean log's std may be 1e-6 m)."""
    if _num(value) == "-":
        return "-"
    tail = f" {_e(unit)}" if unit else ""
    if _num(std) == "-" or std == 0:
        return f"{_num(value, 5)}{tail}"
    return f"{_num(value, 5)} ± {_num(std, 2)}{tail}"


def _p(p: Any) -> str:
    """``p = 0.63`` or ``p < 0.0001``."""
    if _num(p) == "-":
        return "p = -"
    return "p &lt; 0.0001" if p < 1e-4 else f"p = {p:.2g}"


def _effect_value(name: str, est: Any) -> str:
    """One effect parameter as "name = value unit [lo, hi]" (an Estimate record)."""
    est = est if isinstance(est, Mapping) else {}
    lo, hi = (est.get("ci95") or [None, None])[:2]
    return f"{_e(name)} = {_num(est.get('value'))} {_e(est.get('unit') or '')} {_ci(lo, hi)}"


def _ci(lo: Any, hi: Any) -> str:
    if _num(lo) == "-" or _num(hi) == "-":
        return "-"
    return f"[{_num(lo)}, {_num(hi)}]"


def _time(start_ns: Any) -> str:
    if not isinstance(start_ns, int):
        return "-"
    return datetime.fromtimestamp(start_ns / 1e9, tz=UTC).strftime("%Y-%m-%d %H:%M:%S UTC")


def _table(head: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """A table; ``head`` is escaped here, cells must be escaped HTML already."""
    body = "".join("<tr>" + "".join(rows_cell(c) for c in r) + "</tr>" for r in rows)
    return "<table><tr>" + "".join(f"<th>{_e(h)}</th>" for h in head) + "</tr>" + body + "</table>"


def rows_cell(cell: str) -> str:
    if cell.startswith("\0num"):
        return f'<td class="num">{cell[4:]}</td>'
    return f"<td>{cell}</td>"


def _n(text: str) -> str:
    """Mark a (escaped) cell as numeric (right-aligned)."""
    return "\0num" + text


def _page(title: str, body: str) -> bytes:
    return (
        f'<!doctype html><html lang="en"><head><meta charset="utf-8"><title>{_e(title)}'
        f"</title><style>{_CSS}</style></head><body>{body}</body></html>\n"
    ).encode()


def _page_link(record: Mapping[str, Any], prefix: str = "pages/") -> str:
    return f'<a href="{_e(prefix + quote(str(record["id"])) + ".html")}">{_e(record["log"])}</a>'


def _estimate_cells(result: Mapping[str, Any]) -> str:
    est = result.get("estimate")
    if not isinstance(est, Mapping):
        return "no estimate"
    parts = []
    for key, d in est.items():
        if isinstance(d, Mapping) and "value" in d and "std" in d:
            if d.get("identifiable") is False or _num(d.get("std")) == "-":
                parts.append(f"{_e(d.get('name') or key)}: not determined")
            else:
                parts.append(f"{_e(d.get('name') or key)} = {_pm(d['value'], d['std'])}")
    return "; ".join(parts) or "no parameters"


def _series_rows(series: list[ParameterSeries]) -> list[list[str]]:
    rows = []
    for s in series:
        p = s.pooled
        est = p.estimate
        het = (
            "-"
            if p.p_heterogeneity is None
            else (f"{_p(p.p_heterogeneity)}, I² = {100 * (p.i2 or 0):.0f} %")
        )
        if p.heterogeneous:
            het = f'<span class="flag">logs disagree</span> ({het})'
        d = s.drift
        drift = _e(d.note)
        if d.change_point:
            drift = f'<span class="flag">step change</span>: {drift}'
        if d.p_trend is not None:
            drift += (
                f"; trend {_num(d.slope_per_day, 3)} ± {_num(d.slope_std, 2)} "
                f"{_e(s.unit)}/day ({_p(d.p_trend)})"
            )
        value = (
            "not determined"
            if not math.isfinite(est.std)
            else f"{_pm(est.value, est.std, s.unit)} {_ci(*est.ci95)}"
        )
        rows.append(
            [
                _e(s.robot_id),
                _e(s.robot),
                _e(s.parameter),
                value,
                _e(p.method),
                _n(str(p.n_logs)),
                het,
                drift,
            ]
        )
    return rows


def _index(
    records: list[dict[str, Any]],
    table: pl.DataFrame,
    series: list[ParameterSeries],
    plots: dict[int, str],
) -> bytes:
    ok = [r for r in records if r.get("status") == "ok"]
    failed = [r for r in records if r.get("status") != "ok"]
    robots = sorted({(str(r.get("robot_id")), str(r.get("robot"))) for r in ok})
    body = [
        "<h1>logcal batch report</h1>",
        f"<p>{len(records)} logs: <span class='ok'>{len(ok)} analysed</span>, "
        f"<span class='failed'>{len(failed)} failed</span>; {len(robots)} robot(s). "
        "± is one standard error; [lo, hi] the 95 % interval. Fleet table: "
        "<a href='fleet.parquet'>fleet.parquet</a>; pooled and drift: "
        "<a href='fleet.json'>fleet.json</a>.</p>",
    ]
    body.append("<h2>Parameters per robot, pooled across its logs</h2>")
    body.append(
        "<p>Pooled: inverse-variance weighting of each log's recommended estimate "
        "(random effects when Cochran's Q says the logs disagree). Drift: a step change "
        "(likelihood ratio, bootstrap p &lt; 0.01) and a linear trend over time.</p>"
    )
    body.append(
        _table(
            [
                "robot id",
                "robot",
                "parameter",
                "pooled",
                "method",
                "logs",
                "heterogeneity",
                "drift",
            ],
            _series_rows(series),
        )
    )
    if series:
        body.append("<h2>Parameters across logs and over time</h2>")
        body.append(
            "<p>Robots with two or more logs; each log's estimate with its 95 % "
            "interval, the pooled value as a band, a flagged step change dashed.</p>"
        )
        for i, s in enumerate(series):
            if i in plots:
                body.append(
                    f'<figure><img src="{_e(plots[i])}" alt="{_e(s.parameter)} of '
                    f'{_e(s.robot_id)} across its logs"></figure>'
                )
    effects = table.filter(pl.col("kind") == "effect")
    body.append(f"<h2>Effects found ({effects.height})</h2>")
    by_id = {r["log"]: r for r in records}
    body.append(
        _table(
            ["log", "robot id", "effect", "value", "95 %", "explanation"],
            [
                [
                    _page_link(by_id[row["log"]]),
                    _e(row["robot_id"]),
                    _e(row["parameter"]),
                    _n(_pm(row["value"], row["std"], row["unit"])),
                    _n(_ci(row["ci95_lo"], row["ci95_hi"])),
                    _e(row["note"]),
                ]
                for row in effects.iter_rows(named=True)
            ],
        )
    )
    body.append(f"<h2>Failed logs ({len(failed)})</h2>")
    body.append(_table(["log", "error"], [[_page_link(r), _e(r.get("error"))] for r in failed]))
    body.append("<h2>Every log</h2>")
    body.append(
        _table(
            ["log", "robot id", "robot", "start", "status", "recommended estimate"],
            [
                [
                    _page_link(r),
                    _e(r.get("robot_id")),
                    _e(r.get("robot")),
                    _e(_time(r.get("start_ns"))),
                    f"<span class='{'ok' if r.get('status') == 'ok' else 'failed'}'>"
                    f"{_e(r.get('status'))}</span>"
                    + (" (log gone from the archive; kept)" if r.get("gone") else ""),
                    _estimate_cells(r.get("result") or {}) if r.get("status") == "ok" else "-",
                ]
                for r in records
            ],
        )
    )
    return _page("logcal batch report", "\n".join(body))


def _analysed_with(r: Mapping[str, Any], batch_options: str | None) -> list[list[str]]:
    """Rows (setting, value, where it came from) of what ``r``'s log was analysed with: its
    ``logcal.toml`` settings (robot type, channel map, robot id, every robot option), the span,
    and the batch's analysis options; every text escaped."""
    s = r.get("settings")
    s = s if isinstance(s, Mapping) else {}
    sources = [str(x) for x in s.get("sources") or [] if isinstance(x, str)]
    toml = _e(sources[-1]) if sources else ""
    rows = [
        [
            "robot type",
            _e(s.get("robot")) if s.get("robot") else "from the log",
            toml if s.get("robot") else "the log",
        ],
        [
            "channel map",
            _e(s.get("channel_map")) if s.get("channel_map") else "none (default topic names)",
            toml if s.get("channel_map") else "",
        ],
        ["robot id", _e(r.get("robot_id")), ""],
    ]
    options = s.get("options")
    for key, value in options.items() if isinstance(options, Mapping) else ():
        shown = str(value).lower() if isinstance(value, bool) else value
        rows.append([f"option <code>{_e(key)}</code>", _e(shown), toml])
    span = r.get("span")
    if isinstance(span, Mapping) and (
        span.get("start_s") is not None or span.get("end_s") is not None
    ):
        rows.append(
            ["span", f"{_num(span.get('start_s'))} s to {_num(span.get('end_s'))} s of the log", ""]
        )
    if batch_options:
        rows.append(["analysis", f"<code>{_e(batch_options)}</code>", "logcal batch"])
    return rows


def _batch_options(out: Path) -> str | None:
    """The batch's analysis options as the manifest records them (None: not readable; a link
    or FIFO planted at the manifest is not read)."""
    import json
    import os

    from logtools.batch.files import open_regular

    try:
        with os.fdopen(open_regular(out / "manifest.json"), "rb") as fh:
            doc = json.loads(fh.read())
    except (OSError, ValueError):
        return None
    value = doc.get("options") if isinstance(doc, dict) else None
    return value if isinstance(value, str) else None


def _log_page(r: Mapping[str, Any], batch_options: str | None = None) -> bytes:
    res: Mapping[str, Any] = r.get("result") or {}
    body = [
        '<p><a href="../index.html">← fleet report</a></p>',
        f"<h1>{_e(r['log'])}</h1>",
        _table(
            ["", ""],
            [
                [
                    "status",
                    f"<span class='{'ok' if r.get('status') == 'ok' else 'failed'}'>"
                    f"{_e(r.get('status'))}</span>",
                ],
                ["robot id", _e(r.get("robot_id"))],
                ["robot", _e(r.get("robot"))],
                ["start", _e(_time(r.get("start_ns")))],
                ["content SHA-256", f"<code>{_e(r.get('content_hash'))}</code>"],
                [
                    "logcal.toml",
                    _e(", ".join((r.get("settings") or {}).get("sources") or []) or "none"),
                ],
            ],
        ),
    ]
    body.append("<h2>Analysed with</h2>")
    body.append(_table(["setting", "value", "from"], _analysed_with(r, batch_options)))
    if r.get("status") != "ok":
        body.append(f"<h2>Error</h2><pre>{_e(r.get('error'))}</pre>")
        if r.get("detail"):
            body.append(
                f"<details><summary>traceback</summary><pre>{_e(r['detail'])}</pre></details>"
            )
        return _page(str(r["log"]), "\n".join(body))
    views = r.get("views") or {}
    body.append("<h2>Recording</h2>")
    if ".rrd" in views:
        rrd = str(views[".rrd"])
        body.append(
            f'<p><a href="../{_e(quote(rrd))}">download the rerun recording (.rrd)</a> '
            f'(open with <code>rerun FILE</code>) · <a class="rerun-web" '
            f'href="/rerun/open?rrd={_e(quote(rrd, safe=""))}">open in the rerun web viewer</a>'
            " (needs <code>logcal serve</code>)</p>"
        )
    else:
        body.append(
            "<p>No rerun recording: "
            + _e("; ".join(r.get("notes") or []) or "views were not drawn")
            + ".</p>"
        )
    if ".png" in views:
        body.append(
            f'<figure><img src="../{_e(quote(str(views[".png"])))}" '
            f'alt="report image of {_e(r["log"])}"></figure>'
        )
    signals = (res.get("source") or {}).get("signals")
    if isinstance(signals, Mapping) and signals:
        body.append("<h2>Signals</h2>")
        body.append(_table(["signal", "topic:field"], [[_e(k), _e(v)] for k, v in signals.items()]))
    est = res.get("estimate")
    body.append("<h2>Recommended estimate</h2>")
    if isinstance(est, Mapping):
        rows = []
        for key, d in est.items():
            if isinstance(d, Mapping) and "value" in d and "std" in d:
                ci = d.get("ci95") or [None, None]
                determined = d.get("identifiable") is not False and _num(d.get("std")) != "-"
                rows.append(
                    [
                        _e(d.get("name") or key),
                        _n(_pm(d["value"], d["std"], d.get("unit")))
                        if determined
                        else "not determined",
                        _n(_ci(*ci)),
                        _e(d.get("note")),
                    ]
                )
        body.append(f"<p>{_e(est.get('method'))}: {_e(est.get('verdict'))}</p>")
        body.append(_table(["parameter", "value ± std", "95 %", "note"], rows))
    else:
        body.append("<p>No estimate (see the stages).</p>")
    body.append("<h2>Stages</h2>")
    body.append(
        _table(
            ["stage", "status", "reason"],
            [
                [_e(s.get("stage")), _e(s.get("status")), _e(s.get("reason"))]
                for s in res.get("stages") or []
                if isinstance(s, Mapping)
            ],
        )
    )
    disc = res.get("discovery")
    body.append("<h2>Model-mismatch discovery</h2>")
    if isinstance(disc, Mapping):
        effects = [e for e in disc.get("effects") or [] if isinstance(e, Mapping)]
        body.append(
            f"<p>status {_e(disc.get('status'))}; {len(effects)} effect(s) "
            f"{_e(disc.get('remaining') or '')}</p>"
        )
        body.append(
            _table(
                ["effect", "parameters [95 %]", "physics"],
                [
                    [
                        _e(f"{e.get('status') or 'named'} {e.get('key') or e.get('id')}"),
                        "; ".join(
                            _effect_value(k, v) for k, v in (e.get("parameters") or {}).items()
                        ),
                        _e(e.get("physics")),
                    ]
                    for e in effects
                ],
            )
        )
    else:
        body.append("<p>Not run.</p>")
    methods = [m for m in res.get("methods") or [] if isinstance(m, Mapping)]
    if methods:
        from logtools.batch.table import parameter_rows

        method_rows = parameter_rows({"methods": methods})
        body.append(f"<h2>Methods ({len(methods)})</h2>")
        body.append(
            _table(
                ["method", "segment", "parameter", "value ± std", "std is"],
                [
                    [
                        _e(m["estimator"]),
                        _e(m["segment"]),
                        _e(m["parameter"]),
                        _n(_pm(m["value"], m["std"], m["unit"])),
                        _e(m["std_kind"]),
                    ]
                    for m in method_rows
                ],
            )
        )
    if res.get("warnings"):
        body.append(
            "<h2>Warnings</h2><ul>"
            + "".join(f"<li>{_e(w)}</li>" for w in res["warnings"])
            + "</ul>"
        )
    return _page(str(r["log"]), "\n".join(body))


def _write(data: bytes, path: Path) -> None:
    path.write_bytes(data)


def _draw(series: ParameterSeries, path: Path) -> None:
    from logtools.batch.plots import series_png

    series_png(series, path)


def write_report(
    out: Path, records: list[dict[str, Any]], table: pl.DataFrame, series: list[ParameterSeries]
) -> Path:
    """Write ``index.html``, ``pages/<id>.html`` and ``plots/*.png`` into ``out``; returns the
    index. Every file is written atomically."""
    from logtools.outputs import write_atomically

    plots: dict[int, str] = {}
    (out / "plots").mkdir(exist_ok=True)
    for i, s in enumerate(series):
        if len(s.logs) < 2:  # one point: the table says it all
            continue
        rel = f"plots/series-{i:03d}.png"
        write_atomically(out / rel, functools.partial(_draw, s))
        plots[i] = rel
    for stale in (out / "plots").glob("series-*.png"):
        if stale.name not in {Path(p).name for p in plots.values()}:
            stale.unlink()
    (out / "pages").mkdir(exist_ok=True)
    keep = set()
    batch_options = _batch_options(out)
    for r in records:
        name = f"{r['id']}.html"
        keep.add(name)
        write_atomically(
            out / "pages" / name, functools.partial(_write, _log_page(r, batch_options))
        )
    for stale in (out / "pages").glob("*.html"):
        if stale.name not in keep:
            stale.unlink()
    write_atomically(
        out / "index.html", functools.partial(_write, _index(records, table, series, plots))
    )
    return out / "index.html"
