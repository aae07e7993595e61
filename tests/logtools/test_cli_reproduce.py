"""`logcal reproduce patent`: in-process through main(argv), and once end to end."""

from __future__ import annotations

import json
import subprocess
import sys

from logtools.cli.main import main


def test_reproduce_patent_json(capsys) -> None:
    assert main(["reproduce", "patent", "--json", "--repeats", "3", "--seed", "2"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["repeats"] == 3
    assert doc["seed"] == 2
    assert [f["figure"] for f in doc["figures"]] == [8, 9, 10, 11, 12, 13]
    fig8 = doc["figures"][0]
    first_cn = next(c for c in fig8["cells"] if c["quantity"] == "condition_number")
    assert first_cn["published_text"] == "24.91"
    assert abs(first_cn["ours"] - 24.91) < 0.005
    assert doc["cls_split"]["rows"]


def test_reproduce_patent_tables(capsys) -> None:
    assert main(["reproduce", "patent", "--repeats", "2"]) == 0
    out = capsys.readouterr().out
    for title in ("Fig. 8", "Fig. 9", "Fig. 10", "Fig. 11", "Fig. 12", "Fig. 13", "CLS weakness"):
        assert title in out
    assert "2.42±0.03 (misprint of 3.42)" in out
    assert "24.91" in out


def test_reproduce_rejects_bad_repeats(capsys) -> None:
    assert main(["reproduce", "patent", "--repeats", "0"]) == 2
    assert "--repeats 0: expected a whole number >= 1" in capsys.readouterr().err


def test_reproduce_patent_end_to_end() -> None:
    proc = subprocess.run(
        [
            sys.executable,
            "-c",
            "from logtools.cli.main import run; run()",
            "reproduce",
            "patent",
            "--json",
            "--repeats",
            "2",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert len(doc["figures"]) == 6
