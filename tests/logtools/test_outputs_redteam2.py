"""Red-team round 2, outputs: temporary files are created exclusively under a random name
(``mkstemp``: no predictable name a planted link could redirect), a link at the target is
replaced and never written through, and kernel file systems (/proc, /sys, /dev) are refused
before any work."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from logtools.outputs import (
    OutputPathError,
    check_output,
    special_filesystem,
    write_atomically,
)

REPO = Path(__file__).resolve().parents[2]


def test_a_link_planted_at_the_old_temporary_name_is_not_followed(tmp_path: Path) -> None:
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    target = tmp_path / "out.rrd"
    for pid in range(os.getpid() - 2, os.getpid() + 3):  # the old predictable names
        (tmp_path / f".out.{pid}.partial.rrd").symlink_to(victim)
    write_atomically(target, lambda tmp: tmp.write_bytes(b"RRF2"))
    assert victim.read_text() == "precious"
    assert target.read_bytes() == b"RRF2"


def test_the_temporary_file_is_created_exclusively_under_a_random_name(tmp_path: Path) -> None:
    seen: list[Path] = []

    def write(tmp: Path) -> None:
        st = os.lstat(tmp)  # created by us before the writer runs: a new, empty regular file
        assert stat.S_ISREG(st.st_mode)
        assert st.st_size == 0
        assert st.st_nlink == 1
        assert tmp.parent == tmp_path
        assert tmp.name.startswith(".out.png.partial-")
        assert tmp.suffix == ".png"
        seen.append(tmp)
        tmp.write_bytes(b"png")

    write_atomically(tmp_path / "out.png", write)
    write_atomically(tmp_path / "out.png", write)
    assert (tmp_path / "out.png").read_bytes() == b"png"
    assert seen[0] != seen[1]  # not predictable
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.png"]


def test_a_link_at_the_target_is_replaced_not_written_through(tmp_path: Path) -> None:
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    target = tmp_path / "out.json"
    target.symlink_to(victim)
    write_atomically(target, lambda tmp: tmp.write_text("{}"))
    assert victim.read_text() == "precious"
    assert not target.is_symlink()
    assert target.read_text() == "{}"


def test_a_failed_write_leaves_nothing(tmp_path: Path) -> None:
    def fail(tmp: Path) -> None:
        tmp.write_bytes(b"half")
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError):
        write_atomically(tmp_path / "out.rrd", fail)
    assert list(tmp_path.iterdir()) == []


def test_the_written_file_has_the_usual_permissions(tmp_path: Path) -> None:
    old = os.umask(0o022)
    try:
        write_atomically(tmp_path / "out.csv", lambda tmp: tmp.write_text("t\n"))
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(tmp_path / "out.csv").st_mode) == 0o644


@pytest.mark.parametrize(
    "path", ["/proc/x.rrd", "/proc/self/x.rrd", "/sys/x.rrd", "/dev/x.rrd", "/dev/shm/x.rrd"]
)
def test_kernel_file_systems_are_refused_before_the_work(path: str) -> None:
    if not Path(path).parent.is_dir():
        pytest.skip(f"{Path(path).parent} does not exist here")
    with pytest.raises(OutputPathError, match="kernel file system"):
        check_output(Path(path), option="--rrd", suffixes=(".rrd",))


def test_a_link_into_proc_is_on_proc(tmp_path: Path) -> None:
    (tmp_path / "p").symlink_to("/proc/self")
    assert special_filesystem(tmp_path / "p" / "x.rrd") == Path("/proc")
    assert special_filesystem(tmp_path / "x.rrd") is None


def test_cli_refuses_rrd_on_proc_before_analysing(capsys: pytest.CaptureFixture[str]) -> None:
    from logtools.cli.main import main

    log = REPO / "sample_logs" / "tt_harmonic_clean.mcap"
    assert main(["view", str(log), "--rrd", "/proc/x.rrd", "--no-viewer"]) == 2
    assert "kernel file system" in capsys.readouterr().err
