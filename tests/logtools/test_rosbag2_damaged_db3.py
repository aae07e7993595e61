"""A rosbag2 ``.db3`` damaged where the first checks do not look (sqlite reports it only while
the messages are read, through rosbags' ``apsw`` storage) is one clean ``NotARosbagError``, not
an ``apsw.CorruptError`` traceback. The input is bench/fuzz_all.py's input 18787 of seed 7
(class ``bag2_db3``: byte mutations of the database file), rebuilt by its builder."""

from __future__ import annotations

import random
import sys
from pathlib import Path

import pytest

from logtools.errors import NotARosbagError
from logtools.readers import read_log

ROOT = Path(__file__).resolve().parents[2]


def test_db3_corrupt_while_reading_messages_is_a_clean_error(tmp_path: Path) -> None:
    sys.path.insert(0, str(ROOT / "bench"))
    from fuzz_all import Seeds, build_reader

    path, _ = build_reader(
        "bag2_db3", random.Random("7:18787"), Seeds(tmp_path / "seeds"), tmp_path / "case"
    )
    with pytest.raises(NotARosbagError, match="malformed"):
        read_log(path)
