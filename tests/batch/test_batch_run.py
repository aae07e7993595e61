"""End to end on an archive with good, corrupt, unknown-robot and hostile logs: every log
recorded, truth recovered, drift flagged where the hitch moved, Parquet and HTML sound."""

from __future__ import annotations

import json
import math
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import polars as pl
import pytest
from batch_archive import HOSTILE_FILE, HOSTILE_ROBOT_ID, HOSTILE_TOPIC

from logtools.batch.runner import BatchSummary, read_records

pytestmark = pytest.mark.slow  # a whole 13-log archive analysed (~17 s)

OK_LOGS = 10
FAILING = {"bad/corrupt.mcap", "unknown/u.mcap", f"hostile/{HOSTILE_FILE}"}


def test_every_log_is_recorded_and_failures_name_their_cause(
    batch_run: tuple[Path, BatchSummary],
) -> None:
    out, summary = batch_run
    assert summary.logs == OK_LOGS + len(FAILING)
    assert len(summary.analysed) == summary.logs
    assert not summary.skipped
    errors = dict(summary.failed)
    assert set(errors) == FAILING
    assert "corrupt.mcap" in errors["bad/corrupt.mcap"]
    assert "hovercraft" in errors["unknown/u.mcap"]
    assert HOSTILE_TOPIC in errors[f"hostile/{HOSTILE_FILE}"]  # the topics are listed
    records = {r["log"]: r for r in read_records(out)}
    assert len(records) == summary.logs
    assert {k for k, r in records.items() if r["status"] != "ok"} == FAILING
    assert all(r["error_kind"] == "input" for k, r in records.items() if k in FAILING)


def test_estimates_recover_the_simulated_truth(batch_run: tuple[Path, BatchSummary]) -> None:
    out, _ = batch_run
    for r in read_records(out):
        if r["status"] != "ok":
            continue
        truth = r["result"]["truth"]
        est = r["result"]["estimate"]
        for name in ("L1", "L2"):
            assert abs(est[name]["value"] - truth[name]) < 0.05, (r["log"], name)


def test_pooled_estimates_and_the_moved_hitch(batch_run: tuple[Path, BatchSummary]) -> None:
    out, _ = batch_run
    series = {
        (s["robot_id"], s["parameter"]): s
        for s in json.loads((out / "fleet.json").read_text())["series"]
    }
    a = series[("truck-A", "L1")]
    assert a["pooled"]["n_logs"] == 4
    assert abs(a["pooled"]["estimate"]["value"] - 1.25) < 0.02
    assert not a["drift"]["change_point"]
    b = series[("truckB", "L1")]
    assert b["drift"]["change_point"]
    assert b["drift"]["change_after"] == "truckB/b1.mcap"
    assert b["drift"]["change_before"] == "truckB/b2.mcap"
    assert abs(b["drift"]["shift"] - 0.20) < 0.05
    assert b["pooled"]["heterogeneous"]
    assert b["pooled"]["method"].startswith("random effects")
    samples = series[("samples", "L1")]  # relative-time-free sample log: one log, no drift
    assert samples["pooled"]["method"] == "single log"
    assert samples["drift"]["status"] == "too few logs"


def test_fleet_table_is_one_parquet_file_polars_reads(batch_run: tuple[Path, BatchSummary]) -> None:
    out, _ = batch_run
    table = pl.read_parquet(out / "fleet.parquet")
    est = table.filter(pl.col("kind") == "estimate")
    assert est.group_by("log").len()["len"].to_list() == [3] * OK_LOGS  # L1, L2, L1+L2
    assert set(est["parameter"]) == {"L1", "L2", "L1+L2"}
    assert table.filter(pl.col("kind") == "failure")["log"].to_list().__len__() == 3
    methods = table.filter(pl.col("kind") == "method")
    assert methods.height > 0
    assert set(methods["std_kind"]) == {"spread over bootstrap repeats"}
    assert table["value"].is_nan().sum() == 0
    assert table["robot_id"].to_list().count(HOSTILE_ROBOT_ID) > 0
    assert est["start_time"].null_count() == 0  # every MCAP here has absolute stamps


def test_views_are_written_and_linked(batch_run: tuple[Path, BatchSummary]) -> None:
    out, _ = batch_run
    for r in read_records(out):
        if r["status"] != "ok":
            assert r["views"] == {}
            continue
        rrd = out / r["views"][".rrd"]
        assert rrd.stat().st_size > 1000
        page = (out / "pages" / f"{r['id']}.html").read_text()
        assert f'href="../{r["views"][".rrd"]}"' in page


class _Tags(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.tags: set[str] = set()
        self.attrs: list[tuple[str, str, str | None]] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.add(tag)
        self.attrs += [(tag, k, v) for k, v in attrs]


ALLOWED = {
    "html",
    "head",
    "meta",
    "title",
    "style",
    "body",
    "h1",
    "h2",
    "p",
    "a",
    "table",
    "tr",
    "th",
    "td",
    "span",
    "figure",
    "img",
    "pre",
    "code",
    "details",
    "summary",
    "ul",
    "li",
}


@pytest.mark.parametrize("hostile", [HOSTILE_TOPIC, HOSTILE_FILE, HOSTILE_ROBOT_ID])
def test_html_escapes_everything_from_the_logs(
    batch_run: tuple[Path, BatchSummary], hostile: str
) -> None:
    out, _ = batch_run
    pages = [out / "index.html", *sorted((out / "pages").glob("*.html"))]
    joined = "".join(p.read_text() for p in pages)
    assert hostile not in joined
    import html

    assert html.escape(hostile, quote=True) in joined  # it is shown, escaped
    for page in pages:
        parser = _Tags()
        parser.feed(page.read_text())
        assert parser.tags <= ALLOWED, page
        for tag, key, value in parser.attrs:
            assert not key.startswith("on"), (page, tag, key)
            if key in ("src", "href") and value and not value.startswith("/rerun/open"):
                target = (page.parent / unquote(urlsplit(value).path)).resolve()
                assert target.exists(), (page, value)


def test_mapped_hostile_log_is_analysed(batch_run: tuple[Path, BatchSummary]) -> None:
    out, _ = batch_run
    rec = next(r for r in read_records(out) if r["log"] == "hostile_mapped/run&<i>.mcap")
    assert rec["status"] == "ok"
    assert rec["robot_id"] == HOSTILE_ROBOT_ID
    assert rec["result"]["source"]["signals"]["psi"].startswith(HOSTILE_TOPIC)
    assert math.isfinite(rec["result"]["estimate"]["L1"]["value"])
    page = (out / "pages" / f"{rec['id']}.html").read_text()
    import html

    assert html.escape(HOSTILE_TOPIC + "/hitch/angle", quote=True) in page  # signal sources
