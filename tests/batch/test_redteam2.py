"""Red-team round 2, batch side: a log archive (and an output folder, and HTTP requests) is data,
never instructions. Links, special files, settings naming files outside the archive, crafted
manifests, hostile file names, ``--out`` inside an input, and ``logcal serve`` under hostile
requests. Deterministic: no analysis of real logs (every entry here fails fast or is refused),
HTTP to 127.0.0.1 only, bounded loops, an alarm around anything that could block."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from batch_archive import FAST

from logtools.batch import archive as archive_mod
from logtools.batch.archive import find_logs, log_id
from logtools.batch.runner import JOURNAL, MANIFEST, load_manifest, read_records, run_batch
from logtools.batch.serve import MAX_REQUEST_LINE, WORKERS, start_server
from logtools.batch.settings import SettingsError, settings_for
from logtools.errors import LogcalInputError

TINY = "t,cmd_v,cmd_kappa\n0.0,1.0,0.0\n0.1,1.0,0.0\n"
SECRET = "LOGCAL_REDTEAM_SECRET_4f1d"


@contextlib.contextmanager
def _alarm(seconds: int) -> Iterator[None]:
    """Fail (instead of hanging the suite) when the block takes longer than ``seconds``."""

    def _timeout(*_: object) -> None:
        raise TimeoutError(f"blocked for more than {seconds} s")

    old = signal.signal(signal.SIGALRM, _timeout)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def _all_output_bytes(out: Path) -> bytes:
    return b"".join(p.read_bytes() for p in out.rglob("*") if p.is_file())


# --- links and special files --------------------------------------------------------------


def test_links_are_refused_and_never_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from logtools.cli.main import main

    monkeypatch.setenv(SECRET, "leaked-value")
    arch = tmp_path / "archive"
    arch.mkdir()
    (arch / "env.csv").symlink_to("/proc/self/environ")
    outside = tmp_path / "outside.csv"
    outside.write_text(TINY)
    (arch / "elsewhere.csv").symlink_to(outside)
    (arch / "linked_dir").symlink_to(tmp_path)
    jobs = {j.rel: j for j in find_logs(arch)}
    assert set(jobs) == {"env.csv", "elsewhere.csv", "linked_dir"}
    for job in jobs.values():
        assert job.entry_error is not None
        assert "symbolic link" in job.entry_error
        assert job.content_hash == ""
    out = tmp_path / "out"
    assert (
        main(
            [
                "batch",
                str(arch),
                "--out",
                str(out),
                "--workers",
                "1",
                "--no-views",
                "--no-discovery",
                "--repeats",
                "1",
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    assert "leaked-value" not in err
    assert SECRET not in err
    assert err.count("failed: ") == 3
    data = _all_output_bytes(out)
    assert b"leaked-value" not in data
    assert SECRET.encode() not in data


def test_special_files_never_block_the_batch(tmp_path: Path) -> None:
    arch = tmp_path / "archive"
    (arch / "bag").mkdir(parents=True)
    (arch / "bag" / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    os.mkfifo(arch / "bag" / "bag_0.db3")  # a FIFO as the rosbag2 storage file
    os.mkfifo(arch / "pipe.csv")
    (arch / "pagemap.mcap").symlink_to("/proc/self/pagemap")
    (arch / "mem.bag").symlink_to("/proc/self/mem")
    (arch / "ok.csv").write_text(TINY)
    with _alarm(30):
        jobs = {j.rel: j for j in find_logs(arch)}
        summary = run_batch(arch, tmp_path / "out", options=FAST, report=False)
    assert "FIFO" in str(jobs["bag"].entry_error)
    assert "FIFO" in str(jobs["pipe.csv"].entry_error)
    assert "symbolic link" in str(jobs["pagemap.mcap"].entry_error)
    assert "symbolic link" in str(jobs["mem.bag"].entry_error)
    assert jobs["ok.csv"].entry_error is None
    assert summary.logs == 5
    assert len(summary.failed) == 5  # ok.csv is too short to analyse: a clean failure


def test_fifo_in_a_rosbag2_folder_is_refused_by_the_reader(tmp_path: Path) -> None:
    from logtools.errors import NotARosbagError
    from logtools.readers import read_log

    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    os.mkfifo(bag / "bag_0.db3")
    with _alarm(20), pytest.raises(NotARosbagError, match="FIFO"):
        read_log(bag)


def test_a_folder_deeper_than_path_max_is_one_failed_entry(tmp_path: Path) -> None:
    arch = tmp_path / "archive"
    arch.mkdir()
    (arch / "a.csv").write_text(TINY)
    fd = os.open(arch, os.O_RDONLY | os.O_DIRECTORY)
    try:
        for _ in range(20):  # 20 x 250 bytes: beyond PATH_MAX (4096)
            name = "d" * 250
            os.mkdir(name, dir_fd=fd)
            new = os.open(name, os.O_RDONLY | os.O_DIRECTORY, dir_fd=fd)
            os.close(fd)
            fd = new
        with open(os.open("deep.csv", os.O_WRONLY | os.O_CREAT, 0o644, dir_fd=fd), "w") as fh:
            fh.write(TINY)
    finally:
        os.close(fd)
    jobs = find_logs(arch)
    assert jobs[0].rel == "a.csv"
    assert jobs[0].entry_error is None
    refused = [j for j in jobs if j.entry_error]
    assert len(refused) == 1
    assert "File name too long" in str(refused[0].entry_error)


def test_each_entry_is_isolated(tmp_path: Path) -> None:
    arch = tmp_path / "archive"
    (arch / "locked").mkdir(parents=True)
    (arch / "locked" / "x.csv").write_text(TINY)
    (arch / "z.csv").write_text(TINY)
    os.chmod(arch / "locked", 0)
    try:
        if os.access(arch / "locked", os.R_OK):  # root reads it anyway
            pytest.skip("running as root: permissions do not apply")
        jobs = {j.rel: j for j in find_logs(arch)}
    finally:
        os.chmod(arch / "locked", 0o755)
    assert "cannot list" in str(jobs["locked"].entry_error)
    assert jobs["z.csv"].entry_error is None


# --- logcal.toml ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "reason"),
    [
        ("../../outside.toml", "outside the archive"),
        ("/etc/passwd", "absolute path"),
        ("~/map.toml", "absolute path"),
        ("link.toml", "outside the archive"),  # a link inside pointing out
        ("*.toml", "not a file"),  # no globbing of the text
    ],
)
def test_settings_name_only_files_inside_the_archive(
    tmp_path: Path, value: str, reason: str
) -> None:
    arch = tmp_path / "archive"
    (arch / "r").mkdir(parents=True)
    (tmp_path / "outside.toml").write_text("")
    (arch / "r" / "link.toml").symlink_to(tmp_path / "outside.toml")
    (arch / "r" / "in.toml").write_text("")
    (arch / "r" / "logcal.toml").write_text(f"channel_map = {json.dumps(value)}\n")
    log = arch / "r" / "a.csv"
    log.write_text(TINY)
    with pytest.raises(SettingsError, match=reason):
        settings_for(arch, log)
    (arch / "r" / "logcal.toml").write_text('channel_map = "in.toml"\nurdf = "../r/in.toml"\n')
    s = settings_for(arch, log)
    assert s.channel_map == str((arch / "r" / "in.toml").resolve())
    (arch / "r" / "logcal.toml").write_text('urdf = "/etc/robot.urdf"\n')
    with pytest.raises(SettingsError, match="absolute path"):
        settings_for(arch, log)
    (arch / "r" / "logcal.toml").write_text('urdf = "panda"\n')  # a model name: no path
    assert settings_for(arch, log).options == {"urdf": "panda"}


def test_a_linked_or_special_logcal_toml_is_refused(tmp_path: Path) -> None:
    arch = tmp_path / "archive"
    arch.mkdir()
    (tmp_path / "real.toml").write_text('robot_id = "x"\n')
    (arch / "logcal.toml").symlink_to(tmp_path / "real.toml")
    (arch / "a.csv").write_text(TINY)
    with pytest.raises(SettingsError, match="not a readable TOML"):
        settings_for(arch, arch / "a.csv")
    (arch / "logcal.toml").unlink()
    os.mkfifo(arch / "logcal.toml")
    with _alarm(10), pytest.raises(SettingsError, match="FIFO"):
        settings_for(arch, arch / "a.csv")


# --- output folder -------------------------------------------------------------------------


def test_crafted_manifest_cannot_delete_or_read_outside_out(tmp_path: Path) -> None:
    arch = tmp_path / "archive"
    arch.mkdir()
    (arch / "a.csv").write_text(TINY)
    out = tmp_path / "out"
    out.mkdir()
    victims = [tmp_path / "victim.json", tmp_path / "victim.rrd"]
    for v in victims:
        v.write_text("precious")
    crafted_id = "gone-0123456789"
    manifest = {
        "format": "logcal-batch/2",
        "logs": {
            crafted_id: {
                "id": crafted_id,
                "log": "gone.csv",
                "record": "../victim.json",
                "views": {".rrd": "../victim.rrd"},
            },
            "../../victim": {"record": "../victim.json"},
            "/abs-0123456789": {"record": str(victims[0])},
        },
    }
    (out / MANIFEST).write_text(json.dumps(manifest))
    (out / JOURNAL).write_text(
        json.dumps(
            {"id": "x-0123456789", "entry": {"record": str(victims[0]), "views": {"../../x": "y"}}}
        )
        + "\n"
        + "{torn"
    )
    old = {
        "format": "logcal-batch/1",
        "logs": {"gone2.csv": {"id": "../../victim", "record": "../victim.json"}},
    }
    assert load_manifest(out).keys() == {crafted_id}  # others: not ids of ours
    assert load_manifest(out)[crafted_id]["record"] == f"logs/{crafted_id}.json"
    summary = run_batch(arch, out, options=FAST)
    assert summary.logs == 1
    for v in victims:
        assert v.read_text() == "precious"
    (out / MANIFEST).write_text(json.dumps(old))
    run_batch(arch, out, options=FAST)
    for v in victims:
        assert v.read_text() == "precious"
    # a crafted record cannot name where its page goes
    ident = next(iter(load_manifest(out)))
    rec = json.loads((out / "logs" / f"{ident}.json").read_text())
    rec["id"] = "../../evil"
    (out / "logs" / f"{ident}.json").write_text(json.dumps(rec))
    assert [r["id"] for r in read_records(out)] == [ident]


def test_planted_links_in_out_are_not_written_through(tmp_path: Path) -> None:
    arch = tmp_path / "archive"
    arch.mkdir()
    (arch / "a.csv").write_text(TINY)
    out = tmp_path / "out"
    out.mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    (out / ".lock").symlink_to(victim)
    for name in (
        "manifest.json",
        "fleet.json",
        "index.html",
        f".manifest.{os.getpid()}.partial.json",
    ):
        (out / name).symlink_to(victim)
    with pytest.raises(LogcalInputError, match="lock"):
        run_batch(arch, out, options=FAST)
    (out / ".lock").unlink()
    run_batch(arch, out, options=FAST)
    assert victim.read_text() == "precious"
    assert not (out / "manifest.json").is_symlink()
    (tmp_path / "elsewhere").mkdir()
    (out / "logs").rename(tmp_path / "logs_old")
    (out / "logs").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(LogcalInputError, match="logs is not a folder"):
        run_batch(arch, out, options=FAST, force=True)
    assert not list((tmp_path / "elsewhere").iterdir())


def test_out_is_never_inside_an_input_or_on_proc(tmp_path: Path) -> None:
    arch = tmp_path / "archive"
    (arch / "bag").mkdir(parents=True)
    (arch / "bag" / "metadata.yaml").write_text("x: 1\n")
    with pytest.raises(LogcalInputError, match="rosbag2 folder"):
        run_batch(arch, arch / "bag" / "out", options=FAST)
    assert not (arch / "bag" / "out").exists()  # refused before anything was created
    with pytest.raises(LogcalInputError, match="rosbag2 folder"):
        run_batch(arch, arch / "bag" / "x" / "y", options=FAST)
    with pytest.raises(LogcalInputError, match="kernel file system"):
        run_batch(arch, Path("/proc/logcal-out"), options=FAST)
    with pytest.raises(LogcalInputError, match="holds it"):
        run_batch(arch, tmp_path, options=FAST)


# --- names ---------------------------------------------------------------------------------


def test_names_differing_in_undecodable_bytes_stay_two_records(tmp_path: Path) -> None:
    arch = tmp_path / "archive"
    arch.mkdir()
    for b in (b"a\xff.csv", b"a\xfe.csv", "a\ufffd.csv".encode()):
        with open(os.path.join(os.fsencode(arch), b), "w") as fh:
            fh.write(TINY)
    jobs = find_logs(arch)
    assert len({j.id for j in jobs}) == 3
    assert len({j.rel for j in jobs}) == 3
    assert {j.rel for j in jobs} == {"a\\xff.csv", "a\\xfe.csv", "a\ufffd.csv"}
    summary = run_batch(arch, tmp_path / "out", options=FAST)
    assert summary.logs == 3
    assert len(summary.analysed) == 3
    assert len(load_manifest(tmp_path / "out")) == 3
    assert len(read_records(tmp_path / "out")) == 3


def test_a_crafted_collision_of_short_ids_gets_long_ids(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real = archive_mod.log_id

    def colliding(rel: str | bytes, digits: int = 10) -> str:
        return "a_csv-0000000000" if digits == 10 else real(rel, digits)

    monkeypatch.setattr(archive_mod, "log_id", colliding)
    arch = tmp_path / "archive"
    arch.mkdir()
    (arch / "a.csv").write_text(TINY)
    (arch / "b.csv").write_text(TINY)
    ids = [j.id for j in find_logs(arch)]
    assert len(set(ids)) == 2
    assert ids[1] == real("b.csv", 64)
    assert log_id("a.csv") == real("a.csv")


HOSTILE_NAMES = [
    "esc\x1b[2J\x1b]0;owned\x07.csv",
    "line\nfailed: forged.csv",
    "rtl\u202eorez.csv",
    "bell\x07\r.csv",
]


def test_failed_lines_escape_hostile_names(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from logtools.cli.main import main

    arch = tmp_path / "archive"
    arch.mkdir()
    for name in HOSTILE_NAMES:
        (arch / name).write_text(TINY)
    with open(os.path.join(os.fsencode(arch), b"undecodable\xff\x1b.csv"), "w") as fh:
        fh.write(TINY)
    assert (
        main(
            [
                "batch",
                str(arch),
                "--out",
                str(tmp_path / "out"),
                "--workers",
                "1",
                "--no-views",
                "--no-discovery",
                "--repeats",
                "1",
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    for bad in ("\x1b", "\x07", "\r", "\u202e", "\udcff"):
        assert bad not in err
    lines = err.splitlines()
    assert sum(line.startswith("  failed: ") for line in lines) == len(HOSTILE_NAMES) + 1
    assert not any(line.startswith("failed: forged") for line in lines)


# --- journal -------------------------------------------------------------------------------


def test_manifest_is_written_twice_per_run_not_once_per_log(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from logtools.batch import runner

    arch = tmp_path / "archive"
    arch.mkdir()
    for i in range(12):
        (arch / f"s{i:02d}.csv").write_text(TINY)  # stays: one bad-settings entry each
    (arch / "logcal.toml").write_text("bogus = 1\n")
    writes: list[str] = []
    real = runner.write_atomic

    def counting(path: Path, data: bytes) -> None:
        writes.append(path.name)
        real(path, data)

    monkeypatch.setattr(runner, "write_atomic", counting)
    out = tmp_path / "out"
    run_batch(arch, out, options=FAST, report=False)
    assert writes.count(MANIFEST) == 2
    assert writes.count(MANIFEST) + 12 == len(writes)  # + one record per log
    assert not (out / JOURNAL).exists()  # folded into the manifest at the end
    assert len(load_manifest(out)) == 12


def test_journal_replay_after_a_kill(tmp_path: Path) -> None:
    arch = tmp_path / "archive"
    arch.mkdir()
    for i in range(3):
        (arch / f"s{i}.csv").write_text(TINY)
    out = tmp_path / "out"
    run_batch(arch, out, options=FAST, report=False)
    manifest = json.loads((out / MANIFEST).read_text())
    entries = manifest["logs"]
    first = sorted(entries)[0]
    # as if killed mid-run: manifest without two logs, journal with one line and a torn one
    keep = {first: entries[first]}
    (out / MANIFEST).write_text(json.dumps({**manifest, "logs": keep}))
    second = sorted(entries)[1]
    (out / JOURNAL).write_text(
        json.dumps({"id": second, "entry": entries[second]}) + "\n" + '{"id": "torn'
    )
    assert load_manifest(out).keys() == {first, second}
    summary = run_batch(arch, out, options=FAST, report=False)
    assert len(summary.skipped) == 2
    assert len(summary.analysed) == 1


# --- logcal serve ---------------------------------------------------------------------------


def _raw(url_port: int, payload: bytes, timeout: float = 10.0) -> bytes:
    with socket.create_connection(("127.0.0.1", url_port), timeout=timeout) as s:
        s.sendall(payload)
        chunks = []
        while chunk := s.recv(65536):
            chunks.append(chunk)
    return b"".join(chunks)


def _status(response: bytes) -> int:
    return int(response.split(b" ", 2)[1])


@pytest.fixture
def report_server(tmp_path: Path) -> Iterator[tuple[object, int]]:
    (tmp_path / "views").mkdir()
    (tmp_path / "index.html").write_text("<p>report</p>")
    (tmp_path / "views" / "x.rrd").write_bytes(b"RRF2....")
    server = start_server(tmp_path, port=0, viewer=False)
    try:
        yield server, int(server.httpd.server_address[1])
    finally:
        server.close()


def test_serve_answers_hostile_requests(report_server: tuple[object, int]) -> None:
    server, port = report_server
    assert _status(_raw(port, b"GET /views/%00 HTTP/1.0\r\n\r\n")) == 400
    assert _status(_raw(port, b"GET /views/x%00.rrd HTTP/1.0\r\n\r\n")) == 400
    assert _status(_raw(port, b"HEAD /%1b%5b2J HTTP/1.0\r\n\r\n")) == 400
    long_line = b"GET /" + b"a" * (64 * 1024 + 10) + b" HTTP/1.0\r\n\r\n"
    assert _status(_raw(port, long_line)) == 414
    assert (
        _status(_raw(port, b"GET /" + b"a" * (MAX_REQUEST_LINE + 1) + b" HTTP/1.0\r\n\r\n")) == 414
    )
    rrd = b"GET /rerun/open?rrd=" + b"v" * 60_000 + b".rrd HTTP/1.0\r\n\r\n"
    assert _status(_raw(port, rrd)) == 414
    assert (
        _status(_raw(port, b"GET /rerun/open?rrd=" + b"v/" * 500 + b".rrd HTTP/1.0\r\n\r\n")) == 404
    )
    assert _status(_raw(port, b"GET /rerun/open?rrd=views/%00.rrd HTTP/1.0\r\n\r\n")) == 404
    many_headers = b"GET / HTTP/1.0\r\n" + b"X: y\r\n" * 200 + b"\r\n"
    assert _status(_raw(port, many_headers)) == 431
    assert _status(_raw(port, b"BREW / HTTP/1.0\r\n\r\n")) == 501
    assert _status(_raw(port, b"GET /index.html\r\n\r\n")) == 400  # HTTP/0.9: no status line
    assert _status(_raw(port, b" /index.html HTTP/1.0\r\n\r\n")) == 400
    assert _status(_raw(port, b"GET /index.html HTTP/9.9\r\n\r\n")) == 505
    assert _status(_raw(port, b"GET /index.html HTTP/1.1x\r\n\r\n")) == 400
    # kept: traversal refused, loopback only
    assert _status(_raw(port, b"GET /rerun/open?rrd=../../etc/passwd HTTP/1.0\r\n\r\n")) == 404
    assert _status(_raw(port, b"GET /../../etc/passwd HTTP/1.0\r\n\r\n")) == 404
    assert _status(_raw(port, b"GET /index.html HTTP/1.0\r\nHost: evil.example\r\n\r\n")) == 200
    assert server.httpd.errors == []  # type: ignore[attr-defined]


def test_serve_bounds_threads_and_stops_under_load(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from logtools.batch import serve

    monkeypatch.setattr(serve, "MAX_WAITING", 100)  # the waiting room overflows below
    (tmp_path / "index.html").write_text("<p>report</p>")
    server = start_server(tmp_path, port=0, viewer=False)
    port = int(server.httpd.server_address[1])
    before = threading.active_count()
    idle = []
    try:
        for _ in range(300):  # idle connections: they never send a byte
            idle.append(socket.create_connection(("127.0.0.1", port), timeout=5))
        time.sleep(0.5)
        assert threading.active_count() == before  # no thread per connection
        # idle connections hold no worker: a real request is still served
        for _ in range(5):
            assert _status(_raw(port, b"GET /index.html HTTP/1.0\r\n\r\n")) == 200
        # beyond the waiting room the oldest idle connections were closed
        idle[0].settimeout(5)
        assert idle[0].recv(10) == b""
        t0 = time.monotonic()
        server.close()
        assert time.monotonic() - t0 < 5.0
        assert threading.active_count() <= before - WORKERS - 1
    finally:
        for s in idle:
            s.close()
        server.close()


def test_serve_cuts_a_slow_sender(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from logtools.batch import serve

    monkeypatch.setattr(serve, "REQUEST_DEADLINE_S", 1.0)
    monkeypatch.setattr(serve._Handler, "timeout", 1.0)
    (tmp_path / "index.html").write_text("<p>report</p>")
    server = start_server(tmp_path, port=0, viewer=False)
    port = int(server.httpd.server_address[1])
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
            s.sendall(b"GET /index")  # half a request line, then nothing
            t0 = time.monotonic()
            assert s.recv(100) == b""  # closed by the server, no answer owed
            assert time.monotonic() - t0 < 8.0
        with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
            t0 = time.monotonic()
            assert s.recv(100) == b""  # never sent a byte: closed at the deadline
            assert time.monotonic() - t0 < 8.0
        assert _status(_raw(port, b"GET /index.html HTTP/1.0\r\n\r\n")) == 200
    finally:
        server.close()


def test_analyze_folder_walk_names_a_folder_it_cannot_list(tmp_path: Path) -> None:
    from logtools.runs import expand_runs

    (tmp_path / "a.csv").write_text(TINY)
    os.mkfifo(tmp_path / "pipe.csv")  # not a log: never listed
    (tmp_path / "linked").symlink_to(tmp_path)  # not followed
    assert expand_runs([tmp_path]) == [tmp_path / "a.csv"]
    fd = os.open(tmp_path, os.O_RDONLY | os.O_DIRECTORY)
    try:
        for _ in range(20):
            os.mkdir("d" * 250, dir_fd=fd)
            new = os.open("d" * 250, os.O_RDONLY | os.O_DIRECTORY, dir_fd=fd)
            os.close(fd)
            fd = new
    finally:
        os.close(fd)
    with pytest.raises(LogcalInputError, match="cannot list this folder"):
        expand_runs([tmp_path])
