"""Work bounded by what is read (issue 34): an MCAP summary claiming 2^64 - 1 messages or an end
time 2^64 - 1, or a span of 100 years its chunks do not hold, is not believed (the extent is
learnt by reading); a real clock jump of 40 years cut into 10 s windows is a named error, the
window count worked out before any window is made."""

from __future__ import annotations

from pathlib import Path

import polars as pl
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from logtools.cli.main import launch
from logtools.errors import LogcalInputError
from logtools.readers import log_extent
from logtools.windows import MAX_WINDOWS, plan_windows

REPO = Path(__file__).resolve().parents[2]
MCAP = REPO / "sample_logs" / "tt_harmonic_clean.mcap"
CSV = REPO / "sample_logs" / "tt_mixed.csv"
U64 = 2**64 - 1
YEAR_NS = round(365.25 * 86400 * 1e9)


def _lying_copy(
    dst: Path, *, count: int | None = None, end: int | None = None, span_years: float = 0
) -> Path:
    """``MCAP`` rewritten with its statistics record changed (the messages as they were)."""
    with MCAP.open("rb") as f, dst.open("wb") as out:
        writer = Writer(out)
        writer.start(profile="", library="lying statistics")
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, msg in make_reader(f).iter_messages():
            if schema is not None and schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic,
                    channel.message_encoding,
                    schemas.get(channel.schema_id, 0),
                    channel.metadata,
                )
            writer.add_message(
                channels[channel.id], msg.log_time, msg.data, msg.publish_time, msg.sequence
            )
        stats = writer._Writer__statistics  # type: ignore[attr-defined]
        if count is not None:
            stats.message_count = count
            for cid in stats.channel_message_counts:
                stats.channel_message_counts[cid] = count
        if end is not None:
            stats.message_end_time = end
        if span_years:
            stats.message_end_time = stats.message_start_time + round(span_years * YEAR_NS)
        writer.finish()
    return dst


def test_statistics_the_file_cannot_hold_are_not_believed(tmp_path: Path) -> None:
    honest = log_extent(MCAP)
    assert honest is not None
    assert honest.duration_s < 1000
    claims_max = _lying_copy(tmp_path / "max.mcap", count=U64, end=U64)
    claims_century = _lying_copy(tmp_path / "century.mcap", span_years=100)
    assert log_extent(_lying_copy(tmp_path / "copy.mcap")) == honest
    assert log_extent(claims_max) is None
    assert log_extent(claims_century) is None
    assert plan_windows(claims_max, None) is None  # automatic: analysed whole, as read
    plan = plan_windows(claims_century, 10.0)  # the span read, not the span claimed
    assert plan is not None
    assert len(plan.spans_s) == round(honest.duration_s / 10)
    assert plan.extent.last_ns == honest.last_ns


def test_a_forty_year_clock_jump_in_ten_second_windows_is_a_named_error(tmp_path: Path) -> None:
    df = pl.read_csv(CSV)
    half = df.height // 2
    jumped = df.with_columns(
        pl.when(pl.int_range(pl.len()) >= half)
        .then(pl.col("t") + 40 * 365.25 * 86400)
        .otherwise(pl.col("t"))
        .alias("t")
    )
    log = tmp_path / "jump.csv"
    jumped.write_csv(log)
    with pytest.raises(LogcalInputError, match=r"spans 40 years") as err:
        plan_windows(log, 10.0)
    assert f"at most {MAX_WINDOWS:,}" in str(err.value)
    assert "--window" in str(err.value)
    assert plan_windows(log, 0) is None  # --window 0: whole, nothing planned


def test_cli_names_the_absurd_span(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "century.csv"
    df = pl.read_csv(CSV).head(400)
    df.with_columns(
        pl.when(pl.int_range(pl.len()) == 399)
        .then(100 * 365.25 * 86400)
        .otherwise(pl.col("t"))
        .alias("t")
    ).write_csv(log)
    code = launch(["analyze", str(log), "--window", "10", "--no-discovery", "--repeats", "2"])
    err = capsys.readouterr().err
    assert code == 2
    assert "spans 100 years" in err
    assert "internal error" not in err
