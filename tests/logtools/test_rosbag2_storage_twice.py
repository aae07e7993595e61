"""A rosbag2 ``metadata.yaml`` that lists one storage file twice is refused with one clear
message naming the file, not a ``FileExistsError`` traceback (found by bench/fuzz_all.py, class
``bag2_meta``: a duplicated line of ``relative_file_paths``)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from bagmaker import Drive, write_foxy_db3

from logtools.cli.main import main
from logtools.errors import NotARosbagError
from logtools.readers import read_log


@pytest.fixture
def bag_listing_a_file_twice(tmp_path: Path) -> Path:
    bag = write_foxy_db3(tmp_path / "bag", Drive(duration_s=2.0, stall=None))
    meta = bag / "metadata.yaml"
    lines = meta.read_text().splitlines()
    [i] = [k for k, ln in enumerate(lines) if re.match(r"\s*- \S+\.db3$", ln)]
    lines.insert(i, lines[i])
    meta.write_text("\n".join(lines) + "\n")
    return bag


def test_read_refuses_a_storage_file_listed_twice(bag_listing_a_file_twice: Path) -> None:
    with pytest.raises(NotARosbagError, match=r"relative_file_paths names '\S+\.db3'"):
        read_log(bag_listing_a_file_twice)


def test_info_exits_2_naming_it(
    bag_listing_a_file_twice: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["info", str(bag_listing_a_file_twice)]) == 2
    err = capsys.readouterr().err
    assert "each file once" in err
    assert "internal error" not in err
