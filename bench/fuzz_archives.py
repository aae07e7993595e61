"""Fuzzing harness for ``logcal batch`` archives and output folders, and ``logcal serve``
requests (red-team round 2: "a log is data, never instructions").

Archive mode (default): every input is a small random archive and output folder built from
hostile entries, run through ``logcal batch`` (the command's code, in-process: logs are
analysed serially in the harness process instead of a spawned pool, so thousands of inputs fit
in minutes; the pool itself is covered by tests/batch):

- file names with control characters (ESC/CSI/OSC sequences, BEL, CR, newlines that forge a
  ``failed:`` line), U+202E and other bidi controls, bytes that are not UTF-8 (and two names
  that differ only in them), HTML markup, very long names;
- symbolic links named like logs: to /proc/self/environ, /proc/self/pagemap, /proc/self/mem,
  /dev/zero, a file outside the archive (holding a secret), a file inside, a folder outside,
  dangling and looping links;
- FIFOs and sockets named like logs, a FIFO as a rosbag2 storage file, rosbag2 folders with
  garbage metadata;
- ``logcal.toml`` naming files outside the archive (``../``, absolute, ``~``, links), glob
  patterns, garbage TOML, a FIFO or a link named ``logcal.toml``;
- folders deeper than PATH_MAX;
- output folders with a crafted ``manifest.json`` / ``journal.jsonl`` (paths outside ``--out``,
  ids with ``../``), planted links at the lock, the manifest and the report files, crafted
  records.

Checked per input: exit code 0 or 2 (1 or an exception escaping = a traceback), an alarm
(``--timeout-s``) = a hang, any control character or bidi override on stderr or a forged
``failed:`` line = an escape, the secret (an environment variable and the outside file's
content) in any output file or on stderr = a leak, a victim file outside ``--out`` changed or
deleted = an escape too.

Serve mode (``--serve``): one report server on 127.0.0.1 receives hostile requests over raw
sockets (NUL and control characters in paths, request lines and ``rrd=`` up to 100 KB, many
and long headers, bad methods and versions, traversal, absolute URIs, garbage bytes, idle and
half-sent connections). Counted: answered (a status line), closed without an answer (only
idle/half-sent connections may be), handler errors (tracebacks), hangs (no answer or close in
20 s), the most threads alive, and how long ``close`` takes at the end.

    python bench/fuzz_archives.py --n 2000 --seed 1 --workers 2
    python bench/fuzz_archives.py --serve --n 3000 --seed 1
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import multiprocessing as mp
import os
import random
import re
import resource
import signal
import socket
import sys
import tempfile
import threading
import time
import traceback
from collections import Counter
from pathlib import Path
from typing import Any

SECRET_VAR = "LOGCAL_FUZZ_SECRET"
SECRET = "s3cr3t-4a7f-never-in-outputs"
TINY = "t,cmd_v,cmd_kappa\n0.0,1.0,0.0\n0.1,1.0,0.0\n0.2,1.0,0.0\n"
_BAD_TERMINAL = re.compile(
    r"[\x00-\x09\x0b-\x1f\x7f-\x9f\u2028\u2029\u200e\u200f"
    r"\u202a-\u202e\u2066-\u2069\ud800-\udfff]"
)

HOSTILE_PARTS = [
    "\x1b[2J",
    "\x1b]0;owned\x07",
    "\x1b]8;;http://evil/\x1b\\x",
    "\x07",
    "\r",
    "\n",
    "\nfailed: forged.csv: ok",
    "\u202e",
    "\u2066",
    "\u200f",
    "\x7f",
    "\x9b",
    "<script>alert(1)</script>",
    "&amp;",
    "'\"",
    "%00",
    "..",
    "名前",
    " ",
    "\t",
]
UNDECODABLE = [b"\xff", b"\xfe", b"\xc3", b"\xed\xa0\x80", b"\x80\x80"]


def _name(rng: random.Random, suffix: str) -> bytes:
    parts = [rng.choice(HOSTILE_PARTS) for _ in range(rng.randint(0, 3))]
    text = "x" + "".join(parts) + str(rng.randint(0, 99))
    raw = text.replace("/", "_").replace("\0", "_").encode()
    if rng.random() < 0.3:
        raw += rng.choice(UNDECODABLE)
    if rng.random() < 0.05:
        raw = b"L" * rng.randint(200, 250)
    return raw + suffix.encode()


def _write(path: bytes, data: bytes | str) -> None:
    """Create ``path`` (never through a link the case planted: ``O_EXCL | O_NOFOLLOW``)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
    with open(fd, "wb") as fh:
        fh.write(data.encode() if isinstance(data, str) else data)


def _deep(base: bytes, levels: int) -> None:
    fd = os.open(base, os.O_RDONLY | os.O_DIRECTORY)
    try:
        for _ in range(levels):
            name = b"d" * 250
            with contextlib.suppress(FileExistsError):
                os.mkdir(name, dir_fd=fd)
            new = os.open(name, os.O_RDONLY | os.O_DIRECTORY, dir_fd=fd)
            os.close(fd)
            fd = new
        with open(os.open("deep.csv", os.O_WRONLY | os.O_CREAT, 0o644, dir_fd=fd), "w") as fh:
            fh.write(TINY)
    finally:
        os.close(fd)


def _socket_file(path: bytes) -> None:
    s = socket.socket(socket.AF_UNIX)
    try:
        s.bind(path)
    except OSError:
        pass
    finally:
        s.close()


def build_case(rng: random.Random, root: Path) -> dict[str, Any]:
    """A random hostile archive and output folder below ``root``; returns what to check."""
    arch = os.fsencode(root / "archive")
    out = root / "out"
    os.makedirs(arch)
    outside = root / "outside.csv"
    outside.write_text(TINY.replace("cmd_v", SECRET))
    victims = {root / "victim.json": "precious", root / "victim.rrd": "precious"}
    for v, text in victims.items():
        v.write_text(text)
    kinds = []
    for _ in range(rng.randint(1, 6)):
        kind = rng.choice(
            [
                "csv",
                "csv",
                "pair",
                "link_environ",
                "link_pagemap",
                "link_mem",
                "link_zero",
                "link_outside",
                "link_inside",
                "link_dir",
                "link_dangling",
                "link_loop",
                "fifo",
                "socket",
                "bag_fifo",
                "bag_garbage",
                "toml_outside",
                "toml_abs",
                "toml_home",
                "toml_glob",
                "toml_garbage",
                "toml_fifo",
                "toml_link",
                "toml_urdf",
                "deep",
            ]
        )
        kinds.append(kind)
        sub = os.path.join(arch, _name(rng, "")) if rng.random() < 0.4 else arch
        os.makedirs(sub, exist_ok=True)
        name = os.path.join(sub, _name(rng, rng.choice([".csv", ".mcap", ".bag"])))
        with contextlib.suppress(FileExistsError):
            if kind == "csv":
                _write(name, TINY)
            elif kind == "pair":  # differ only in undecodable bytes
                _write(os.path.join(sub, b"p\xff.csv"), TINY)
                _write(os.path.join(sub, b"p\xfe.csv"), TINY)
            elif kind.startswith("link_"):
                target = {
                    "link_environ": "/proc/self/environ",
                    "link_pagemap": "/proc/self/pagemap",
                    "link_mem": "/proc/self/mem",
                    "link_zero": "/dev/zero",
                    "link_outside": str(outside),
                    "link_inside": "../../x.csv",
                    "link_dir": str(root),
                    "link_dangling": "/nonexistent/x.csv",
                    "link_loop": os.fsdecode(os.path.basename(name)),
                }[kind]
                os.symlink(target, name)
            elif kind == "fifo":
                os.mkfifo(name)
            elif kind == "socket":
                _socket_file(name[:100])
            elif kind.startswith("bag_"):
                bag = os.path.join(sub, _name(rng, ""))
                os.makedirs(bag, exist_ok=True)
                _write(
                    os.path.join(bag, b"metadata.yaml"),
                    "rosbag2_bagfile_information:\n  relative_file_paths: [bag_0.db3]\n"
                    if kind == "bag_fifo"
                    else bytes(rng.randbytes(64)),
                )
                if kind == "bag_fifo":
                    os.mkfifo(os.path.join(bag, b"bag_0.db3"))
            elif kind.startswith("toml_"):
                toml = os.path.join(sub, b"logcal.toml")
                if os.path.lexists(toml):
                    continue
                if kind == "toml_fifo":
                    os.mkfifo(toml)
                elif kind == "toml_link":
                    os.symlink(str(outside), toml)
                else:
                    value = {
                        "toml_outside": "../../outside.csv",
                        "toml_abs": str(outside),
                        "toml_home": "~/.bashrc",
                        "toml_glob": "../*",
                        "toml_urdf": "../../../etc/passwd",
                    }.get(kind)
                    if kind == "toml_garbage":
                        _write(toml, rng.randbytes(rng.randint(1, 200)))
                    elif kind == "toml_urdf":
                        _write(toml, f"urdf = {json.dumps(value)}\n")
                    else:
                        _write(toml, f"channel_map = {json.dumps(value)}\n")
                _write(os.path.join(sub, _name(rng, ".csv")), TINY)
            elif kind == "deep":
                _deep(arch, rng.choice([3, 20]))
    if rng.random() < 0.5:
        _craft_out(rng, out, root)
    return {"archive": Path(os.fsdecode(arch)), "out": out, "victims": victims, "kinds": kinds}


def _craft_out(rng: random.Random, out: Path, root: Path) -> None:
    out.mkdir()
    (out / "logs").mkdir()
    ids = ["gone-0123456789", "../../victim", "/abs-0123456789", "x" * 80, "a/b-0123456789"]
    entries = {}
    for ident in rng.sample(ids, rng.randint(1, len(ids))):
        entries[ident] = {
            "id": ident,
            "log": "gone\x1b[2J.csv",
            "status": "failed",
            "record": rng.choice(
                ["../victim.json", str(root / "victim.json"), f"logs/{ident}.json"]
            ),
            "views": rng.choice([{".rrd": "../victim.rrd"}, {"../x": "y"}, {}]),
            "error": "\x1b]0;owned\x07",
        }
    fmt = rng.choice(["logcal-batch/1", "logcal-batch/2"])
    (out / "manifest.json").write_text(json.dumps({"format": fmt, "logs": entries}))
    if rng.random() < 0.5:
        (out / "journal.jsonl").write_text(
            "\n".join(json.dumps({"id": i, "entry": e}) for i, e in entries.items()) + "\n{torn"
        )
    if rng.random() < 0.3:
        (out / "logs" / "gone-0123456789.json").write_text(
            json.dumps(
                {"id": "../../evil", "log": "<script>", "views": {".rrd": "../../victim.rrd"}}
            )
        )
    for name in rng.sample(
        ["index.html", "fleet.json", "fleet.parquet", "manifest.json"], rng.randint(0, 2)
    ):
        with contextlib.suppress(FileNotFoundError):
            (out / name).unlink()
        (out / name).symlink_to(root / "victim.json")


def _serial_jobs(jobs: Any, options: Any, **_: Any) -> Any:
    from logtools.batch.worker import analyse_job

    return (analyse_job(j, options) for j in jobs)


def check_case(case: dict[str, Any]) -> tuple[str, str]:
    """Run ``logcal batch`` on the case; (outcome, detail)."""
    from logtools.batch import runner
    from logtools.cli.main import main

    runner.run_jobs = _serial_jobs  # type: ignore[assignment]
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(
            [
                "batch",
                str(case["archive"]),
                "--out",
                str(case["out"]),
                "--workers",
                "1",
                "--no-views",
                "--no-discovery",
                "--repeats",
                "1",
            ]
        )
    text = err.getvalue()
    if "_AlarmError" in text:  # the alarm went off inside the command, which reported it
        return "hang", text[-2000:]
    if code not in (0, 2):
        return "traceback", text[-2000:]
    if _BAD_TERMINAL.search(text):
        return "escape", repr(_BAD_TERMINAL.search(text))
    if any(line.startswith("failed:") for line in text.splitlines()):
        return "escape", "forged line"
    if SECRET in text or "precious" in text:
        return "leak", "stderr"
    for v, content in case["victims"].items():
        if not v.is_file() or v.read_text() != content:
            return "escape", f"victim {v.name} changed"
    out: Path = case["out"]
    for p in out.rglob("*") if out.is_dir() else []:
        if p.is_file() and not p.is_symlink():
            data = p.read_bytes()
            if SECRET.encode() in data or b"precious" in data:
                return "leak", str(p)
    return ("clean_error" if code == 2 else "ok"), ""


class _AlarmError(Exception):
    pass


def _alarm(*_: object) -> None:
    raise _AlarmError


def archive_worker(
    seed: int, n: int, timeout_s: int, mem_gib: float, save: Path, results: Any
) -> None:
    resource.setrlimit(resource.RLIMIT_AS, (int(mem_gib * 2**30), int(mem_gib * 2**30)))
    os.environ[SECRET_VAR] = SECRET
    signal.signal(signal.SIGALRM, _alarm)
    rng = random.Random(seed)
    counts: Counter[str] = Counter()
    kinds: Counter[str] = Counter()
    slowest = 0.0
    for i in range(n):
        with tempfile.TemporaryDirectory(prefix="logcal-fuzz-arch-") as tmp:
            case_rng = random.Random(rng.getrandbits(64))
            t0 = time.perf_counter()
            signal.alarm(timeout_s)
            try:
                try:
                    case = build_case(case_rng, Path(tmp))
                except OSError:  # the harness could not build this case (not logcal's)
                    counts["not_built"] += 1
                    continue
                kinds.update(case["kinds"])
                outcome, detail = check_case(case)
            except _AlarmError:
                outcome, detail = "hang", ""
            except MemoryError:
                outcome, detail = "blowup", ""
            except Exception:
                outcome, detail = "traceback", traceback.format_exc()
            finally:
                signal.alarm(0)
            slowest = max(slowest, time.perf_counter() - t0)
            counts[outcome] += 1
            if outcome not in ("ok", "clean_error"):
                save.mkdir(parents=True, exist_ok=True)
                (save / f"arch-{seed}-{i}.txt").write_text(f"{outcome}\n{detail}\n")
    results.put((dict(counts), dict(kinds), slowest))


# --- serve ---------------------------------------------------------------------------------


def _request(rng: random.Random) -> tuple[bytes, str]:
    kind = rng.choice(
        [
            "nul",
            "control",
            "long_line",
            "long_rrd",
            "headers",
            "long_header",
            "method",
            "version",
            "traversal",
            "absolute",
            "garbage",
            "ok",
            "rrd",
            "host",
            "idle",
            "half",
            "unicode",
            "keepalive",
        ]
    )
    path = "/" + rng.choice(["index.html", "views/x.rrd", "pages/", "", "rerun/open?rrd="])
    if kind == "nul":
        path += "%00" * rng.randint(1, 3)
    elif kind == "control":
        path += "".join(f"%{rng.randint(0, 31):02x}" for _ in range(rng.randint(1, 5)))
    elif kind == "long_line":
        path += "a" * rng.choice([8000, 8193, 65536, 70000, 100_000])
    elif kind == "long_rrd":
        path = "/rerun/open?rrd=" + "v/" * rng.randint(1, 50_000) + ".rrd"
    elif kind == "traversal":
        path = rng.choice(
            [
                "/../../etc/passwd",
                "/rerun/open?rrd=../../etc/passwd.rrd",
                "/%2e%2e/%2e%2e/etc/passwd",
                "/views/..%2f..%2fetc%2fpasswd",
            ]
        )
    elif kind == "absolute":
        path = "http://evil.example/index.html"
    elif kind == "rrd":
        path = "/rerun/open?rrd=views/x.rrd"
    elif kind == "unicode":
        path = "/" + rng.choice(["%e2%80%ae", "%ff%fe", "名前", "%c0%ae%c0%ae/"])
    method = "GET" if kind != "method" else rng.choice(["BREW", "POST", "", "G\x00T", "OPTIONS"])
    version = "HTTP/1.0" if kind != "version" else rng.choice(["HTTP/9.9", "", "HTTP/1.1x"])
    head = f"{method} {path} {version}\r\n"
    headers = ""
    if kind == "headers":
        headers = "X: y\r\n" * rng.choice([50, 101, 500])
    elif kind == "long_header":
        headers = "X: " + "y" * rng.choice([8000, 70_000]) + "\r\n"
    elif kind == "host":
        headers = "Host: evil.example\r\n"
    elif kind == "keepalive":
        head = f"GET {path} HTTP/1.1\r\n"
        headers = "Host: 127.0.0.1\r\nConnection: keep-alive\r\n"
    data = (head + headers + "\r\n").encode("utf-8", "surrogateescape")
    if kind == "garbage":
        data = rng.randbytes(rng.randint(1, 3000))
    elif kind == "idle":
        data = b""
    elif kind == "half":
        data = data[: rng.randint(1, max(1, len(data) - 3))]
    return data, kind


def _send(port: int, data: bytes, kind: str) -> str:
    with socket.create_connection(("127.0.0.1", port), timeout=20) as s:
        try:
            if data:
                s.sendall(data)
            if kind not in ("idle", "half"):
                s.shutdown(socket.SHUT_WR)
            first = s.recv(16)
            while s.recv(65536):
                pass
        except TimeoutError:
            return "hang"
        except ConnectionError:
            first = b""
    if first.startswith(b"HTTP/"):
        return "answered"
    return "closed_idle" if kind in ("idle", "half", "garbage") else "no_answer"


def run_serve(n: int, seed: int, concurrency: int) -> None:
    import socketserver

    from logtools.batch.serve import start_server

    base_errors: list[str] = []  # handler errors of a server without its own count (older)

    def _count(self: Any, request: Any, address: Any) -> None:
        base_errors.append(repr(sys.exc_info()[1])[:200])

    socketserver.BaseServer.handle_error = _count  # type: ignore[method-assign]
    rng = random.Random(seed)
    with tempfile.TemporaryDirectory(prefix="logcal-fuzz-serve-") as tmp:
        root = Path(tmp)
        (root / "views").mkdir()
        (root / "pages").mkdir()
        (root / "index.html").write_text("<p>report</p>")
        (root / "views" / "x.rrd").write_bytes(b"RRF2....")
        server = start_server(root, port=0, viewer=False)
        port = int(server.httpd.server_address[1])
        counts: Counter[str] = Counter()
        by_kind: Counter[str] = Counter()
        max_threads = threading.active_count()
        lock = threading.Lock()
        requests = [_request(random.Random(rng.getrandbits(64))) for _ in range(n)]
        t0 = time.perf_counter()

        def client(items: list[tuple[bytes, str]]) -> None:
            nonlocal max_threads
            for data, kind in items:
                try:
                    outcome = _send(port, data, kind)
                except OSError as err:
                    outcome = f"client_error:{type(err).__name__}"
                with lock:
                    counts[outcome] += 1
                    by_kind[f"{kind}:{outcome}"] += 1
                    max_threads = max(max_threads, threading.active_count())

        chunks = [requests[i::concurrency] for i in range(concurrency)]
        threads = [threading.Thread(target=client, args=(c,)) for c in chunks]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        elapsed = time.perf_counter() - t0
        print(
            f"serve: {n} requests ({concurrency} clients, {elapsed:.1f} s): {dict(counts)}",
            flush=True,
        )
        idle = []
        flood = "1000 idle connections"
        for _ in range(1000):  # a flood of idle connections, then close under that load
            with contextlib.suppress(OSError):
                idle.append(socket.create_connection(("127.0.0.1", port), timeout=5))
        time.sleep(1.0)
        flood_threads = threading.active_count()
        try:
            release = threading.Timer(60.0, lambda: [s.close() for s in idle])
            release.start()  # bounds a close that waits for the idle clients (60 s at most)
        except RuntimeError as err:  # the server's threads exhausted the process's
            flood += f" ({err}: closing them first)"
            for s in idle:
                s.close()
            release = None
        t1 = time.perf_counter()
        server.close()
        close_s = time.perf_counter() - t1
        if release is not None:
            release.cancel()
        for s in idle:
            s.close()
        errors = list(getattr(server.httpd, "errors", [])) + base_errors
    print(f"handler errors (tracebacks): {len(errors)} {errors[:3]}")
    print(
        f"most threads alive: {max_threads} (client threads included: {concurrency}); "
        f"with {flood}: {flood_threads}; close under that load: {close_s:.2f} s"
    )
    print("by kind:", dict(sorted(by_kind.items())))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=200)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--timeout-s", type=int, default=30)
    ap.add_argument("--mem-gib", type=float, default=3.0)
    ap.add_argument("--save", type=Path, default=Path("/tmp/logcal_fuzz_archive_failures"))
    ap.add_argument("--serve", action="store_true")
    ap.add_argument("--concurrency", type=int, default=8)
    args = ap.parse_args()
    if args.serve:
        run_serve(args.n, args.seed, args.concurrency)
        return
    ctx = mp.get_context("fork")
    results = ctx.Queue()
    per = [args.n // args.workers + (j < args.n % args.workers) for j in range(args.workers)]
    t0 = time.perf_counter()
    procs = [
        ctx.Process(
            target=archive_worker,
            args=(args.seed * 1000 + j, per[j], args.timeout_s, args.mem_gib, args.save, results),
        )
        for j in range(args.workers)
    ]
    for p in procs:
        p.start()
    counts: Counter[str] = Counter()
    kinds: Counter[str] = Counter()
    slowest = 0.0
    for _ in procs:
        c, k, s = results.get()
        counts.update(c)
        kinds.update(k)
        slowest = max(slowest, s)
    for p in procs:
        p.join()
        if p.exitcode != 0:
            counts["worker_died"] += 1
    print(
        f"archives: {args.n} inputs (seed {args.seed}, {args.workers} workers, "
        f"{time.perf_counter() - t0:.0f} s): {dict(counts)}; slowest {slowest:.1f} s"
    )
    print("entries built:", dict(sorted(kinds.items())))


if __name__ == "__main__":
    main()
