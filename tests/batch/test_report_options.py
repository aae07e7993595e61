"""The per-log page of the batch report shows what the log was analysed with (its logcal.toml
settings, robot options, span and the batch's analysis options), escaped; and no page or index
carries a raw control or bidi character from a file name or a setting."""

from __future__ import annotations

import re
from pathlib import Path

from logtools.batch.report_html import _log_page
from logtools.cli.main import main

TINY = "t,cmd_v,cmd_kappa\n0.0,1.0,0.0\n0.1,1.0,0.0\n0.2,1.0,0.0\n"
RAW = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")


def test_page_shows_the_settings_escaped() -> None:
    record = {
        "id": "a-1",
        "log": "run\x1b[2J.csv",
        "status": "failed",
        "error": "bad\u202e",
        "robot_id": "<b>truck</b>",
        "settings": {
            "robot": "tractor_trailer",
            "channel_map": "/a/<map>.toml",
            "options": {
                "cutoff_hz": 8.0,
                "urdf": "/a/arm.urdf",
                "method_for_psi": "<script>x</script>",
                "flag": True,
            },
            "sources": ["/a/logcal.toml"],
        },
        "span": {"start_s": 2.0, "end_s": None},
    }
    page = _log_page(record, "repeats=3;seed=0;discovery=False").decode()
    section = page.split("<h2>Analysed with</h2>", 1)[1].split("<h2>", 1)[0]
    assert "tractor_trailer" in section
    assert "/a/&lt;map&gt;.toml" in section
    assert "<code>cutoff_hz</code></td><td>8.0</td><td>/a/logcal.toml" in section
    assert "/a/arm.urdf" in section
    assert "true" in section
    assert "&lt;script&gt;x&lt;/script&gt;" in section
    assert "<script>" not in page
    assert "&lt;b&gt;truck&lt;/b&gt;" in section
    assert "2 s to - s of the log" in section
    assert "repeats=3;seed=0;discovery=False" in section
    assert RAW.search(page) is None  # ESC and U+202E shown as visible escapes
    assert "run\\x1b[2J.csv" in page
    assert "bad\\u202e" in page


def test_page_without_settings_says_where_they_come_from() -> None:
    page = _log_page({"id": "b", "log": "x.csv", "status": "failed", "settings": None}).decode()
    section = page.split("<h2>Analysed with</h2>", 1)[1].split("<h2>", 1)[0]
    assert "from the log" in section
    assert "none (default topic names)" in section
    assert "analysis" not in section  # no batch options known: no row


def test_batch_pages_show_the_logcal_toml_options(tmp_path: Path) -> None:
    archive = tmp_path / "archive"
    (archive / "truck").mkdir(parents=True)
    (archive / "truck" / "run\x1b]0;owned\x07.csv").write_text(TINY)
    (archive / "truck" / "logcal.toml").write_text('robot_id = "truck-07\u202e"\ncutoff_hz = 8.0\n')
    out = tmp_path / "out"
    code = main(
        [
            "batch",
            str(archive),
            "--out",
            str(out),
            "--workers",
            "1",
            "--no-views",
            "--no-discovery",
            "--repeats",
            "2",
        ]
    )
    assert code in (0, 2)
    [page] = list((out / "pages").glob("*.html"))
    text = page.read_text()
    section = text.split("<h2>Analysed with</h2>", 1)[1].split("<h2>", 1)[0]
    assert "<code>cutoff_hz</code></td><td>8.0</td>" in section
    assert "truck-07\\u202e" in section
    assert "repeats=2" in section
    for written in [page, out / "index.html"]:
        assert RAW.search(written.read_text()) is None, written


def test_batch_options_never_read_through_a_planted_manifest(tmp_path: Path) -> None:
    import os

    from logtools.batch.report_html import _batch_options

    (tmp_path / "real.json").write_text('{"options": "repeats=9"}')
    (tmp_path / "manifest.json").symlink_to(tmp_path / "real.json")
    assert _batch_options(tmp_path) is None
    (tmp_path / "manifest.json").unlink()
    os.mkfifo(tmp_path / "manifest.json")  # would block an ordinary open
    assert _batch_options(tmp_path) is None
    (tmp_path / "manifest.json").unlink()
    (tmp_path / "manifest.json").write_text('{"options": "repeats=9"}')
    assert _batch_options(tmp_path) == "repeats=9"
