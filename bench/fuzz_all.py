"""One fuzz run over every input class of "a log is data, never instructions": the readers
(ROS 1 bags, rosbag2 folders: metadata, ``.db3``, compression modes; MCAP; CSV), URDFs,
channel maps, log metadata, batch archives (names, symlinks, settings, manifests) and HTTP
requests to ``logcal serve``, with one total input count.

The builders are those of ``fuzz_parsers.py``, ``fuzz_logs.py`` and ``fuzz_archives.py``
(plus URDFs and ``logcal.toml`` robot options, here), and issue 34's classes in
``fuzz_ends.py``: MCAP statistics that lie, hostile rosbag2 structures, and a full, closed,
broken or narrow (ASCII, latin-1) stdout. Each input is built and run inside a
worker process under ``RLIMIT_AS`` (``--mem-gib``), a CPU-time bound (``--timeout-s``, so that
a loaded machine does not turn slow inputs into hangs) and a wall-clock alarm (``--wall-s``,
for waits); the driver kills a worker that does not answer in ``wall + 15`` s and starts
another. The worker's file
descriptors 1 and 2 point at a file per input, so that anything written (by Python or by C
code) is checked. Outcomes per input:

- ``ok`` / ``clean_error``: data, or one clear refusal (exit 2, ``LogcalError``,
  ``CalibError``);
- ``traceback``: an exception of another kind, or a command ending with exit code 1;
- ``hang``: either bound, or no answer from the worker (idle and half-sent HTTP requests
  are closed by the client after 0.5 s: the server's idle timeout is tested in tests/batch);
- ``crash``: the worker died of a signal other than SIGKILL;
- ``blowup``: ``MemoryError`` (or sqlite's / the OS's out-of-memory error) under the cap, or
  the worker killed (SIGKILL: the kernel's out-of-memory killer); the progress lines print the
  worker's address space, so that growth over many inputs shows;
- ``escape``: a raw control character (ESC, BEL, C0/C1, CR), a bidi control (U+202E ...) or a
  forged ``failed:`` line in anything written to stdout/stderr; the same characters (tab,
  newline and CR allowed) in a text file a batch writes or in an HTTP answer; a file written
  outside the allowed folder (the worker's cwd, ``HOME`` and ``TMPDIR`` must stay empty, the
  archive unchanged, the victim files next to it untouched); the secret (an environment
  variable, a file outside the archive) in any output.

A worker is replaced by a fresh one every ``--recycle`` inputs (default 2000): a long-lived
worker's address space grows (thread arenas of the report server and polars, caches; about
1.9 -> 2.3 GiB over 2,500 inputs, resident memory about 0.7 GiB), and under the address-space
cap the last inputs of a 20,000-input run without recycling failed to allocate, though each
passes alone.

Inputs are assigned to the classes in turn; input ``i`` is built from ``Random(seed, i)``, so
one input can be replayed alone with ``--only I``. Failures are saved under ``--save``.

    python bench/fuzz_all.py --inputs 500 --seed 1 --jobs 1          # smoke
    nice -n 19 python bench/fuzz_all.py --inputs 20000 --seed 7 --jobs 1 > /tmp/fuzz_all.log
"""

from __future__ import annotations

import argparse
import contextlib
import json
import multiprocessing as mp
import os
import queue
import random
import re
import resource
import shutil
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

ROOT = Path(__file__).resolve().parents[1]
for _p in (ROOT / "tests", ROOT / "tests" / "logtools", ROOT / "bench"):
    if str(_p) not in sys.path:
        sys.path.insert(0, str(_p))

CLASSES = (
    "ros1",
    "bag2_meta",
    "bag2_db3",
    "bag2_zstd",
    "mcap",
    "mcap_json",
    "csv",
    "urdf",
    "cmap",
    "meta",
    "archive",
    "settings",
    "serve",
    "lying_mcap",
    "bag2_struct",
    "stdout",
)
SECRET_VAR = "LOGCAL_FUZZ_SECRET"
SECRET = "s3cr3t-4a7f-never-in-outputs"
# On a terminal: every C0 control but newline, DEL, C1, bidi and line-separator controls.
_TERMINAL = re.compile(
    r"[\x00-\x09\x0b-\x1f\x7f-\x9f\u2028\u2029\u200e\u200f"
    r"\u202a-\u202e\u2066-\u2069]"
)
# In a written text file or an HTTP answer: the same, tab, newline and CR allowed.
_IN_FILE = re.compile(
    r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f\u2028\u2029\u200e\u200f"
    r"\u202a-\u202e\u2066-\u2069]"
)
_MEMORY = re.compile(r"MemoryError|NoMemError|Cannot allocate memory|out of memory")
_TEXT_SUFFIXES = {".html", ".json", ".jsonl", ".txt", ".csv", ".md", ".toml"}


# ----------------------------------------------------------------------------- builders


class Seeds:
    """The valid logs the builders mutate (written once per worker)."""

    def __init__(self, folder: Path) -> None:
        from fuzz_logs import seed_logs  # type: ignore[import-not-found]
        from fuzz_parsers import seeds  # type: ignore[import-not-found]

        folder.mkdir(parents=True, exist_ok=True)
        self.paths: dict[str, Path] = seeds(folder)
        self.logs: dict[str, bytes] = seed_logs(folder)


_URDF = """<?xml version="1.0"?>
<robot name="{robot}">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="0 0 {c1}"/><mass value="{m1}"/>
    <inertia ixx="{i}" ixy="0" ixz="0" iyy="{i}" iyz="0" izz="{i}"/></inertial>
    <visual><geometry><mesh filename="{mesh}"/></geometry></visual></link>
  <link name="l2"><inertial><origin xyz="0 0 0.2"/><mass value="{m2}"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="{j1}" type="{t1}"><parent link="{p1}"/><child link="l1"/>
    <axis xyz="{axis}"/><limit effort="10" velocity="{vel}" lower="-3" upper="3"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="{c2}"/>
    <origin xyz="0 0 {len2}"/><axis xyz="0 1 0"/><limit effort="10" velocity="5"/></joint>
</robot>
"""
_URDF_VALUES = (
    "1",
    "0",
    "-1",
    "nan",
    "inf",
    "-inf",
    "1e308",
    "1e-320",
    "x",
    "",
    "1 2",
    "0x10",
    "1e999",
    "\x1b[2J",
    "\u202e1",
)


def build_urdf(rng: random.Random, folder: Path) -> tuple[Path, tuple[str, ...] | None, int]:
    """A hostile URDF file (or a link/FIFO/folder named like one); the joint names and count
    the arm log would ask for."""
    op = rng.choice(
        (
            "values",
            "values",
            "laughs",
            "external",
            "deep",
            "many_links",
            "cycle",
            "names",
            "mesh",
            "bytes",
            "truncate",
            "empty",
            "special",
            "model_name",
            "big",
        )
    )
    fields = {
        "robot": "arm",
        "c1": "0.1",
        "m1": "1",
        "i": "0.01",
        "m2": "0.5",
        "j1": "j1",
        "t1": "revolute",
        "p1": "base",
        "axis": "0 1 0",
        "vel": "5",
        "c2": "l2",
        "len2": "0.3",
        "mesh": "package://arm/l1.stl",
    }
    path = folder / rng.choice(("arm.urdf", "arm.xml", "arm"))
    text: str | None = None
    if op == "values":
        for key in rng.sample(sorted(fields), rng.randint(1, 4)):
            fields[key] = rng.choice(_URDF_VALUES)
    elif op == "cycle":
        fields.update(
            rng.choice(
                ({"p1": "l1"}, {"c2": "base"}, {"p1": "l2"}, {"c2": "l1"}, {"p1": "nowhere"})
            )
        )
    elif op == "names":
        fields[rng.choice(("robot", "j1"))] = rng.choice(
            ("\x1b]0;owned\x07", "\u202ej1", "j1\nfailed: forged", "<x>", "j2", "名前", "%s")
        )
    elif op == "mesh":
        fields["mesh"] = rng.choice(
            (
                "/etc/passwd",
                "file:///proc/self/environ",
                "/dev/zero",
                "../../../../etc/shadow",
                "http://evil/x.stl",
            )
        )
    if op not in ("special", "model_name"):
        text = _URDF.format(**fields)
    if op == "laughs":
        depth = rng.choice((3, 6, 9))
        ents = ['<!ENTITY l0 "lol">'] + [
            f'<!ENTITY l{k} "{("&l" + str(k - 1) + ";") * 10}">' for k in range(1, depth + 1)
        ]
        text = (
            f'<?xml version="1.0"?>\n<!DOCTYPE robot [{"".join(ents)}]>\n'
            f'<robot name="&l{depth};"><link name="base"/></robot>\n'
        )
    elif op == "external":
        target = rng.choice(
            ("/etc/passwd", "/proc/self/environ", "/dev/zero", "http://127.0.0.1:9/x")
        )
        text = (
            f'<?xml version="1.0"?>\n<!DOCTYPE robot [<!ENTITY x SYSTEM "{target}">]>\n'
            + _URDF.format(**fields).split("\n", 1)[1].replace('name="arm"', 'name="&x;"')
        )
    elif op == "deep":
        d = rng.choice((100, 5000, 200_000))
        text = '<robot name="a"><link name="base">' + "<x>" * d + "</x>" * d + "</link></robot>"
    elif op == "many_links":
        n = rng.choice((50, 2000, 20_000))
        parts = ['<robot name="a"><link name="l0"/>']
        for k in range(1, n):
            parts.append(
                f'<link name="l{k}"/><joint name="j{k}" type="revolute">'
                f'<parent link="l{k - 1 if rng.random() < 0.9 else 0}"/>'
                f'<child link="l{k}"/><axis xyz="0 0 1"/></joint>'
            )
        text = "".join(parts) + "</robot>"
    elif op == "big":
        text = _URDF.format(**fields) + "<!--" + "x" * rng.choice((10**6, 40 * 10**6)) + "-->"
    if text is not None:
        data = text.encode("utf-8")
        if op == "bytes":
            from fuzz_logs import mutate_bytes  # type: ignore[import-not-found]

            data = mutate_bytes(rng, data, data)
        elif op == "truncate":
            data = data[: rng.randrange(len(data))]
        elif op == "empty":
            data = rng.choice(
                (
                    b"",
                    b"\xef\xbb\xbf",
                    b"\xff\xfe<\x00r\x00",
                    b"<robot/>",
                    b"<?xml version='1.0' encoding='ebcdic'?><robot/>",
                )
            )
        path.write_bytes(data)
    elif op == "special":
        kind = rng.choice(("fifo", "dir", "zero", "environ", "dangling", "loop"))
        if kind == "fifo":
            os.mkfifo(path)
        elif kind == "dir":
            path.mkdir()
        else:
            target = {
                "zero": "/dev/zero",
                "environ": "/proc/self/environ",
                "dangling": "/nonexistent.urdf",
                "loop": path.name,
            }[kind]
            path.symlink_to(target)
    else:
        name = rng.choice(
            (
                "panda",
                "../../etc/passwd",
                "\x1b[2Jpanda",
                "x" * 5000,
                "ur5",
                "nope",
                "",
                " ",
                "\u202epanda",
                "%n%n",
                "panda\x00",
            )
        )
        return Path(name), None, rng.randint(1, 7)
    names = rng.choice((None, ("j1", "j2"), ("j2", "j1"), ("jx",), ("j1", "j1")))
    return path, names, rng.choice((1, 2, 2, 3, 7)) if names is None else len(names)


def build_reader(
    kind: str, rng: random.Random, seeds: Seeds, folder: Path
) -> tuple[Path, Path | None]:
    """A hostile log of a reader class (and the channel map it comes with)."""
    from fuzz_logs import mutate_bytes, mutate_csv  # type: ignore[import-not-found]
    from fuzz_parsers import build  # type: ignore[import-not-found]

    mapping = {
        "ros1": "ros1",
        "bag2_meta": "bag2_meta",
        "bag2_db3": "bag2_db3",
        "bag2_zstd": "bag2_zstd",
        "mcap_json": "json",
        "cmap": "cmap",
        "meta": "meta",
    }
    if kind in mapping:
        path, cmap = build(mapping[kind], rng, seeds.paths, folder)
        return Path(path), Path(cmap) if cmap else None
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    if kind == "csv":
        if rng.random() < 0.5:
            build("csv", rng, seeds.paths, folder)
            return folder / "in.csv", None
        data = seeds.logs["csv"]
        data = mutate_csv(rng, data) if rng.random() < 0.6 else mutate_bytes(rng, data, data)
        (folder / "in.csv").write_bytes(data)
        return folder / "in.csv", None
    src = rng.choice(("mcap_json", "mcap_ros2", "bag1"))  # kind == "mcap": byte mutations
    other = seeds.logs[rng.choice(sorted(seeds.logs))]
    name = "in.bag" if src == "bag1" else "in.mcap"
    (folder / name).write_bytes(mutate_bytes(rng, seeds.logs[src], other))
    return folder / name, None


def hostile_settings(rng: random.Random, arch: Path) -> None:
    """A ``logcal.toml`` at a random folder of ``arch`` with registered keys and hostile
    values: robot options that name files outside, of the wrong type, with control
    characters."""
    from logtools.batch.settings import accepted_keys

    keys = accepted_keys()
    values = (
        '"../../outside.csv"',
        '"/etc/passwd"',
        '"~/.ssh/id_rsa"',
        '"panda"',
        '"\\u001b[2J"',
        '"\\u202e"',
        "-1",
        "0",
        "nan",
        "inf",
        "1e400",
        "true",
        "[1, 2]",
        "{a = 1}",
        '""',
        '"x\\nfailed: forged"',
        '"a.urdf"',
        '"sub/../../x.urdf"',
        '"link.urdf"',
        "9999999999999999999999",
    )
    folders = [arch, *[Path(d) for d, _, _ in os.walk(arch) if Path(d) != arch][:5]]
    target = rng.choice(folders) / "logcal.toml"
    if os.path.lexists(target):
        return
    lines = [f"{k} = {rng.choice(values)}" for k in rng.sample(keys, rng.randint(1, len(keys)))]
    if rng.random() < 0.3:
        lines.append(f"unknown_{rng.randint(0, 9)} = 1")
    target.write_text("\n".join(lines) + "\n")
    (target.parent / "a.urdf").write_text("<robot name='a'><link name='b'/></robot>")
    with contextlib.suppress(OSError):
        (target.parent / "link.urdf").symlink_to(
            rng.choice(("/etc/passwd", "/dev/zero", "../outside.csv"))
        )


# ----------------------------------------------------------------------------- checks


class _AlarmError(Exception):
    pass


def _alarm(*_: object) -> None:
    raise _AlarmError


def _bad(text: str, pattern: re.Pattern[str]) -> str:
    m = pattern.search(text)
    if m is None:
        return ""
    return f"{m.group()!r} at {m.start()}: {text[max(0, m.start() - 60) : m.start() + 20]!r}"


def _listing(root: Path) -> set[str]:
    out = set()
    for d, dirs, files in os.walk(root):
        for n in dirs + files:
            out.add(os.path.join(d, n))
    return out


def _scan_written(out: Path) -> str:
    """A raw control character or the secret in a text file below ``out``, or ""."""
    if not out.is_dir():
        return ""
    for d, _, files in os.walk(out):
        for n in files:
            p = Path(d) / n
            if p.is_symlink() or not p.is_file():
                continue
            data = p.read_bytes()
            if SECRET.encode() in data:
                return f"secret in {p}"
            if p.suffix in _TEXT_SUFFIXES:
                bad = _bad(data.decode("utf-8", "replace"), _IN_FILE)
                if bad:
                    return f"{p.relative_to(out)}: {bad}"
    return ""


def run_reader(path: Path, cmap: Path | None) -> tuple[str, str]:
    from logtools.cli.main import launch

    args = ["info", str(path)] + (["--channel-map", str(cmap)] if cmap else [])
    code = launch(args)
    return ("ok" if code == 0 else "clean_error" if code == 2 else "traceback"), f"exit {code}"


def run_urdf(path: Path, names: tuple[str, ...] | None, n: int) -> tuple[str, str]:
    from calib.errors import CalibError
    from calib.manipulator.serial import load_serial_arm
    from logtools.errors import LogcalError
    from logtools.safe_text import printable

    try:
        arm = load_serial_arm(str(path), names, n)
        _ = arm.n if hasattr(arm, "n") else None
    except (CalibError, LogcalError) as err:
        print(f"logcal: error: {printable(err)}", file=sys.stderr)  # as the CLI prints it
        return "clean_error", str(err)[:300]
    return "ok", ""


def run_archive(rng: random.Random, case: Path, settings: bool) -> tuple[str, str]:
    from fuzz_archives import build_case, check_case  # type: ignore[import-not-found]

    try:
        built = build_case(rng, case)
    except OSError as err:
        return "not_built", str(err)
    if settings or rng.random() < 0.3:
        hostile_settings(rng, built["archive"])
    before = _listing(built["archive"])
    PHASE[0] = "run"
    outcome, detail = check_case(built)
    if outcome == "leak":
        return "escape", f"leak: {detail}"
    if outcome not in ("ok", "clean_error"):
        return outcome, detail
    if _listing(built["archive"]) != before:
        return "escape", "the archive changed: " + repr(
            sorted(_listing(built["archive"]) ^ before)[:3]
        )
    bad = _scan_written(built["out"])
    if bad:
        return "escape", bad
    return outcome, detail


class _Server:
    """One report server per worker process, started on first use."""

    server: Any = None
    root: Path | None = None

    @classmethod
    def get(cls, base: Path) -> Any:
        if cls.server is None:
            from logtools.batch.serve import start_server

            root = base / "serve_root"
            (root / "views").mkdir(parents=True, exist_ok=True)
            (root / "pages").mkdir(exist_ok=True)
            (root / "index.html").write_text("<p>report</p>")
            (root / "views" / "x.rrd").write_bytes(b"RRF2....")
            (root / "pages" / "a.html").write_text("<p>page</p>")
            cls.server, cls.root = start_server(root, port=0, viewer=False), root
        return cls.server


def run_serve(rng: random.Random, base: Path) -> tuple[str, str]:
    from fuzz_archives import _request  # type: ignore[import-not-found]

    server = _Server.get(base)
    port = int(server.httpd.server_address[1])
    data, kind = _request(rng)
    PHASE[0] = "run"
    got = b""
    idle = kind in ("idle", "half")  # the server's idle timeout is tested in tests/batch; here
    with socket.create_connection(("127.0.0.1", port), timeout=0.5 if idle else 20) as s:
        try:
            with contextlib.suppress(ConnectionError, OSError):  # the server may answer and
                if data:  # close before all is sent
                    s.sendall(data)
                if kind not in ("idle", "half"):
                    s.shutdown(socket.SHUT_WR)
            while len(got) < 2**20:
                chunk = s.recv(65536)
                if not chunk:
                    break
                got += chunk
        except TimeoutError:
            if not idle:
                return "hang", kind
        except ConnectionError:
            pass
    errors = list(server.httpd.errors)
    server.httpd.errors.clear()
    if errors:
        return "traceback", f"{kind}: {errors[0]}"
    if not got.startswith(b"HTTP/") and kind not in ("idle", "half", "garbage"):
        return "traceback", f"{kind}: closed without an answer"
    head, _, body = got.partition(b"\r\n\r\n")
    bad = _bad(head.decode("latin-1"), _IN_FILE) or _bad(body.decode("utf-8", "replace"), _IN_FILE)
    if bad:
        return "escape", f"{kind}: answer holds {bad}"
    return (
        "ok"
        if got.startswith(b"HTTP/1.0 200") or got.startswith(b"HTTP/1.1 200")
        else "clean_error"
    ), kind


PHASE = ["build"]  # what the worker is doing: a builder's failure is the harness's, not logcal's


def run_input(cls: str, rng: random.Random, seeds: Seeds, base: Path) -> tuple[str, str]:
    case = base / "case"
    PHASE[0] = "build"
    if cls in ("archive", "settings"):
        return run_archive(rng, case, cls == "settings")
    if cls == "serve":
        return run_serve(rng, base)
    if cls == "urdf":
        path, names, n = build_urdf(rng, case)
        PHASE[0] = "run"
        return run_urdf(path, names, n)
    if cls in ("lying_mcap", "bag2_struct", "stdout"):  # issue 34 (bench/fuzz_ends.py)
        import fuzz_ends  # type: ignore[import-not-found]

        if cls == "stdout":
            PHASE[0] = "run"
            return fuzz_ends.run_stdout(rng, seeds.logs["csv"], case)
        if cls == "lying_mcap":
            path = fuzz_ends.build_lying_mcap(rng, seeds.logs["mcap_json"], case)
            PHASE[0] = "run"
            return fuzz_ends.run_lying_mcap(rng, path)
        path = fuzz_ends.build_bag2_struct(rng, base / "seeds", case)
        PHASE[0] = "run"
        return run_reader(path, None)
    path, cmap = build_reader(cls, rng, seeds, case)
    PHASE[0] = "run"
    return run_reader(path, cmap)


# ----------------------------------------------------------------------------- worker


def _clean_dir(d: Path) -> None:
    shutil.rmtree(d, ignore_errors=True)
    d.mkdir(parents=True, exist_ok=True)


def worker(
    tasks: Any, results: Any, base: str, mem_gib: float, timeout_s: int, wall_s: int
) -> None:
    root = Path(base)
    allowed = {root / "case", root / "seeds", root / "serve_root", root / "out.txt"}
    watched = [root / "cwd", root / "home", root / "tmp"]
    for d in watched:
        d.mkdir(parents=True, exist_ok=True)
    os.chdir(root / "cwd")
    os.environ.update(
        HOME=str(root / "home"),
        TMPDIR=str(root / "tmp"),
        TMP=str(root / "tmp"),
        TEMP=str(root / "tmp"),
        **{SECRET_VAR: SECRET},
    )
    tempfile.tempdir = str(root / "tmp")
    limit = int(mem_gib * 2**30)
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    signal.signal(signal.SIGALRM, _alarm)
    signal.signal(signal.SIGPROF, _alarm)
    import logtools.cli.main  # imported once, outside the inputs' budget
    import logtools.load  # noqa: F401

    seeds = Seeds(root / "seeds")
    out_txt = root / "out.txt"
    saved = (os.dup(1), os.dup(2))
    while True:
        item = tasks.get()
        if item is None:
            return
        i, cls, seed = item
        _clean_dir(root / "case")
        rng = random.Random(f"{seed}:{i}")
        fd = os.open(out_txt, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(fd, 1)
        os.dup2(fd, 2)
        os.close(fd)
        results.put(("start", i))
        t0 = time.perf_counter()
        signal.alarm(wall_s)
        signal.setitimer(signal.ITIMER_PROF, timeout_s)
        try:
            outcome, detail = run_input(cls, rng, seeds, root)
        except _AlarmError:
            outcome, detail = "hang", f"over {timeout_s} s of CPU or {wall_s} s"
        except MemoryError:
            outcome, detail = "blowup", "MemoryError"
        except BaseException:
            outcome, detail = "traceback", traceback.format_exc()[-3000:]
        finally:
            signal.alarm(0)
            signal.setitimer(signal.ITIMER_PROF, 0)
            with contextlib.suppress(Exception):
                sys.stdout.flush()
                sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
        if PHASE[0] == "build":  # the builder failed (the harness's limit, not logcal's)
            outcome, detail = "not_built", f"{outcome} while building: {detail[-300:]}"
        dt = time.perf_counter() - t0
        printed = out_txt.read_bytes().decode("utf-8", "replace")
        if outcome == "traceback" and _MEMORY.search(printed):
            outcome, detail = "blowup", printed[-500:]
        elif outcome == "traceback" and "_AlarmError" in printed:
            outcome, detail = "hang", printed[-500:]
        elif outcome == "traceback" and detail.startswith("exit"):
            detail += ": " + printed[-2000:]
        if outcome in ("ok", "clean_error"):
            bad = _bad(printed, _TERMINAL)
            forged = [ln for ln in printed.splitlines() if ln.startswith("failed: forged")]
            if bad or forged:
                outcome, detail = "escape", f"output: {bad or forged[0]!r}"
            elif SECRET in printed:
                outcome, detail = "escape", "the secret in the output"
        written = [p for d in watched for p in d.iterdir()]
        written += [p for p in root.iterdir() if p not in allowed and p not in watched]
        if written and outcome in ("ok", "clean_error", "not_built"):
            outcome, detail = "escape", f"written outside the allowed folder: {written[:3]}"
        for d in watched:
            _clean_dir(d)
        with open("/proc/self/statm") as fh:  # the worker's address space (what RLIMIT_AS caps)
            vm = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        results.put(("done", i, outcome, detail, dt, printed[-3000:], vm))


# ----------------------------------------------------------------------------- driver

BAD = ("traceback", "hang", "crash", "blowup", "escape")


class Job:
    """One worker process and the inputs it runs, one at a time."""

    def __init__(self, j: int, args: argparse.Namespace, work: Path) -> None:
        self.j, self.args = j, args
        self.base = work / f"job{j}"
        self.ctx = mp.get_context("spawn")
        self.proc: Any = None
        self.vm = 0
        self.ran = 0
        self.start()

    def start(self) -> None:
        if self.proc is not None:
            with contextlib.suppress(Exception):
                self.proc.kill()
                self.proc.join(5)
        shutil.rmtree(self.base, ignore_errors=True)
        self.base.mkdir(parents=True)
        self.tasks = self.ctx.Queue()
        self.results = self.ctx.Queue()
        self.proc = self.ctx.Process(
            target=worker,
            args=(
                self.tasks,
                self.results,
                str(self.base),
                self.args.mem_gib,
                self.args.timeout_s,
                self.args.wall_s,
            ),
        )
        self.proc.start()

    def run(self, i: int, cls: str) -> tuple[str, str, float]:
        self.ran += 1
        if self.args.recycle and self.ran % self.args.recycle == 0:
            self.start()  # a fresh worker: the cap then bounds one input, not the address
        self.tasks.put((i, cls, self.args.seed))  # space thousands of inputs left behind
        started = False
        deadline = time.monotonic() + self.args.wall_s + 15 + 120  # first: seeds, imports
        while True:
            try:
                msg = self.results.get(timeout=1.0)
            except queue.Empty:
                if not self.proc.is_alive():
                    code = self.proc.exitcode
                    self.start()
                    if not started:
                        return "harness", f"worker died before the input ({code})", 0.0
                    if code == -signal.SIGKILL:
                        return "blowup", "worker killed (SIGKILL)", 0.0
                    return (
                        "crash" if code is not None and code < 0 else "traceback",
                        f"worker exit {code}",
                        0.0,
                    )
                if time.monotonic() > deadline:
                    self.start()
                    return "hang", "no answer from the worker", 0.0
                continue
            if msg[0] == "start":
                started = True
                deadline = time.monotonic() + self.args.wall_s + 15
                continue
            _, _, outcome, detail, dt, printed, self.vm = msg
            self.printed = printed
            return outcome, detail, dt

    def stop(self) -> None:
        with contextlib.suppress(Exception):
            self.tasks.put(None)
            self.proc.join(10)
        if self.proc.is_alive():
            self.proc.kill()
        shutil.rmtree(self.base, ignore_errors=True)


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--inputs", type=int, default=500, help="total inputs over all classes")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=1, help="worker processes")
    ap.add_argument("--classes", default=",".join(CLASSES))
    ap.add_argument("--only", type=int, default=None, help="run input I alone (replay)")
    ap.add_argument("--mem-gib", type=float, default=3.0)
    ap.add_argument("--timeout-s", type=int, default=30, help="CPU seconds per input")
    ap.add_argument(
        "--wall-s",
        type=int,
        default=120,
        help="wall-clock seconds per input (a wait on a FIFO, a socket)",
    )
    ap.add_argument("--save", type=Path, default=Path("/tmp/logcal_fuzz_all"))
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument(
        "--recycle", type=int, default=2000, help="start a fresh worker every N inputs (0: never)"
    )
    ap.add_argument(
        "--minutes",
        type=float,
        default=None,
        help="take no new input after this long (the table counts what ran)",
    )
    args = ap.parse_args()
    classes = args.classes.split(",")
    unknown = set(classes) - set(CLASSES)
    if unknown:
        ap.error(f"unknown classes {sorted(unknown)}; expected some of {', '.join(CLASSES)}")
    indices = [args.only] if args.only is not None else list(range(args.inputs))
    work = Path(tempfile.mkdtemp(prefix="logcal_fuzz_all_"))
    jobs = [Job(j, args, work) for j in range(args.jobs)]
    counts: dict[str, Counter[str]] = {c: Counter() for c in classes}
    slowest: dict[str, float] = dict.fromkeys(classes, 0.0)
    spent: dict[str, float] = dict.fromkeys(classes, 0.0)
    lock = threading.Lock()
    todo = iter(indices)
    done = 0
    t0 = time.perf_counter()
    step = max(1, len(indices) // 40)

    stop_at = None if args.minutes is None else t0 + 60 * args.minutes

    def drive(job: Job) -> None:
        nonlocal done
        while True:
            with lock:
                late = stop_at is not None and time.perf_counter() > stop_at
                i = None if late else next(todo, None)
            if i is None:
                return
            cls = classes[i % len(classes)]
            outcome, detail, dt = job.run(i, cls)
            with lock:
                counts[cls][outcome] += 1
                slowest[cls] = max(slowest[cls], dt)
                spent[cls] += dt
                done += 1
                if outcome in BAD or outcome == "harness":
                    args.save.mkdir(parents=True, exist_ok=True)
                    (args.save / f"{i:06d}_{cls}_{outcome}.txt").write_text(
                        f"replay: python bench/fuzz_all.py --seed {args.seed} --only {i} "
                        f"--classes {args.classes}\n{detail}\n"
                    )
                    print(f"  input {i} ({cls}): {outcome}: {detail[:300]!r}", flush=True)
                if done % step == 0:
                    rate = done / (time.perf_counter() - t0)
                    bad = sum(c[k] for c in counts.values() for k in BAD)
                    vm = ", ".join(f"{j.vm / 2**30:.2f}" for j in jobs)
                    print(
                        f"  {done}/{len(indices)} inputs, {rate:.2f} inputs/s, failures {bad}, "
                        f"worker address space {vm} GiB",
                        flush=True,
                    )

    threads = [threading.Thread(target=drive, args=(job,)) for job in jobs]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for job in jobs:
        job.stop()
    elapsed = time.perf_counter() - t0
    shutil.rmtree(work, ignore_errors=True)
    cols = ("inputs", "ok", "clean_error", *BAD, "not_built", "harness", "mean_s", "slowest_s")
    print(
        f"\nseed {args.seed}, {args.jobs} job(s), cap {args.mem_gib} GiB, bound "
        f"{args.timeout_s} s of CPU and {args.wall_s} s per input"
    )
    print(f"{'class':10s} " + " ".join(f"{c:>11s}" for c in cols))
    total: Counter[str] = Counter()
    for cls in classes:
        c = counts[cls]
        total.update(c)
        row = [sum(c.values()), *(c[k] for k in cols[1:-2])]
        print(
            f"{cls:10s} "
            + " ".join(f"{v:>11d}" for v in row)
            + f" {spent[cls] / max(1, row[0]):>11.3f} {slowest[cls]:>11.2f}"
        )
    row = [sum(total.values()), *(total[k] for k in cols[1:-2])]
    print(
        f"{'TOTAL':10s} "
        + " ".join(f"{v:>11d}" for v in row)
        + f" {sum(spent.values()) / max(1, row[0]):>11.3f} {max(slowest.values()):>11.2f}"
    )
    print(
        f"{sum(total.values())} inputs in {elapsed:.0f} s: {sum(total.values()) / elapsed:.2f} "
        f"inputs/s; failures (tracebacks, hangs, crashes, blow-ups, escapes): "
        f"{sum(total[k] for k in BAD)}"
    )
    if args.json is not None:
        args.json.write_text(
            json.dumps(
                {
                    "seed": args.seed,
                    "elapsed_s": elapsed,
                    "per_class": {k: dict(v) for k, v in counts.items()},
                    "slowest_s": slowest,
                },
                indent=1,
            )
        )
    return 1 if any(total[k] for k in BAD) else 0


if __name__ == "__main__":
    raise SystemExit(main())
