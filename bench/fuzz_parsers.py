"""Fuzzing harness for the bounded parsers ("a log is data, never instructions").

Builds random hostile inputs of the classes the red team found and runs each through
``read_log`` + ``load_log`` (channel maps: ``load_channel_map`` + ``load_log`` with the map)
in a worker under ``RLIMIT_AS`` (``--mem-gib``) and an alarm (``--timeout-s``); counts data,
clean errors (``LogcalError``/``CalibError``), tracebacks, hangs and memory blow-ups, and saves
failures under ``--save``. Classes (``KINDS``):

- ``ros1``: a ROS 1 bag whose chunk is recompressed (bz2, lz4) honestly or with up to 4 GiB
  of hidden zeros, its declared size changed, then byte mutations;
- ``bag2_meta``: a rosbag2 folder whose ``metadata.yaml`` has values replaced by values of
  other YAML types, lines dropped or duplicated, aliases (small and exponential) added;
- ``bag2_db3``: SQL changes to the ``.db3`` (payloads that are integers, text or NULL; record
  times as text or reals; unknown topic ids; topics rows of the wrong type or deleted) and
  byte mutations of the file;
- ``bag2_zstd``: file- and message-compression modes, honest, bombs, non-zstd, truncated;
- ``json``: MCAP JSON channels with many distinct keys, arrays of objects with differing keys,
  ``"a.b"`` beside ``{"a": {"b": …}}``, deep nesting, numbers as strings;
- ``csv``: wide headers (up to 10,000 columns), time in relative ms/us, hostile cells;
- ``cmap``: channel-map TOML with values of random types, deep formulas and arrays;
- ``meta``: MCAP metadata records ``logcal``/``logcal.nominal`` with non-numeric values.

    python bench/fuzz_parsers.py --n 3000 --seed 1 --workers 2
"""

from __future__ import annotations

import argparse
import bz2
import contextlib
import json
import multiprocessing as mp
import random
import resource
import shutil
import signal
import sqlite3
import struct
import sys
import tempfile
import time
import traceback
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "tests" / "logtools"))
sys.path.insert(0, str(ROOT / "bench"))

KINDS = ("ros1", "bag2_meta", "bag2_db3", "bag2_zstd", "json", "csv", "cmap", "meta")


# ----------------------------------------------------------------------------- seeds


def seeds(work: Path) -> dict[str, Path]:
    from bagmaker import Drive, write_foxy_db3, write_ros1  # type: ignore[import-not-found]

    drive = Drive(duration_s=3.0, stall=None)
    return {
        "ros1": write_ros1(work / "seed.bag", drive),
        "bag2": write_foxy_db3(work / "seed_bag2", drive),
    }


def _records(buf: bytes) -> list[tuple[int, dict[str, bytes], int, int]]:
    from test_bounded_parsers import _ros1_records  # type: ignore[import-not-found]

    return _ros1_records(buf)  # type: ignore[no-any-return]


def mutate_bytes(rng: random.Random, data: bytes) -> bytes:
    from fuzz_logs import mutate_bytes as mb  # type: ignore[import-not-found]

    return mb(rng, data, data)  # type: ignore[no-any-return]


def build_ros1(rng: random.Random, seed: Path, out: Path) -> Path:
    import lz4.frame

    buf = bytearray(seed.read_bytes())
    records = _records(bytes(buf))
    chunks = [r for r in records if r[1].get("op") == b"\x05"]
    pos, fields, at, dlen = rng.choice(chunks)
    raw = bytes(buf[at : at + dlen])
    kind = rng.choice(("bz2", "lz4", "none"))
    extra = rng.choice((0, 0, 2**20, 64 * 2**20, 2**30, 2**32))
    if kind == "bz2":
        block = bz2.compress(bytes(8 * 2**20), 1)
        data = bz2.compress(raw) + block * (extra // (8 * 2**20))
    elif kind == "lz4":
        data = lz4.frame.compress(raw + bytes(min(extra, 64 * 2**20)))
    else:
        data = raw
    size = len(raw) + rng.choice((0, 0, 1, -1, 2**31, -len(raw)))
    fields = {
        **fields,
        "compression": kind.encode(),
        "size": struct.pack("<I", max(0, size) % 2**32),
    }
    header = b"".join(
        struct.pack("<I", len(k) + 1 + len(v)) + k.encode() + b"=" + v for k, v in fields.items()
    )
    new = struct.pack("<I", len(header)) + header + struct.pack("<I", len(data)) + data
    delta = len(new) - (at + dlen - pos)
    buf[pos : at + dlen] = new
    bh = records[0]
    (index_pos,) = struct.unpack("<Q", bh[1]["index_pos"])
    f_at = bytes(buf).index(b"index_pos=", bh[0]) + len(b"index_pos=")
    buf[f_at : f_at + 8] = struct.pack("<Q", index_pos + delta)
    result = bytes(buf)
    if rng.random() < 0.3:
        result = mutate_bytes(rng, result)
    out.write_bytes(result)
    return out


_YAML_VALUES = (
    "[]",
    "{}",
    "[1, 2]",
    "{a: 1}",
    "null",
    "''",
    "-1",
    "99999999999999999999999",
    "1.5",
    "true",
    "x",
    "'12'",
    "!!binary aGVsbG8=",
    "[[[[[[[[]]]]]]]]",
    "&a [1]",
    "*nope",
)


def _alias_bomb(depth: int, width: int) -> str:
    lines = [f"  l0: &l0 [{', '.join(['x'] * width)}]"]
    lines += [f"  l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * width)}]" for i in range(1, depth)]
    return "bombs:\n" + "\n".join(lines) + "\n"


def build_bag2_meta(rng: random.Random, seed: Path, out: Path) -> Path:
    shutil.copytree(seed, out)
    meta = out / "metadata.yaml"
    lines = meta.read_text().splitlines()
    for _ in range(rng.randint(1, 3)):
        op = rng.choice(("value", "value", "drop", "dup", "bomb", "custom", "truncate", "tab"))
        i = rng.randrange(len(lines))
        if op == "value" and ":" in lines[i]:
            key = lines[i].split(":", 1)[0]
            lines[i] = f"{key}: {rng.choice(_YAML_VALUES)}"
        elif op == "drop":
            del lines[i]
        elif op == "dup":
            lines.insert(i, lines[i])
        elif op == "bomb":
            depth, width = rng.choice(((3, 3), (6, 6), (9, 9), (12, 10)))
            lines = [
                *_alias_bomb(depth, width).splitlines(),
                *lines,
                f"  custom_data:\n    k: *l{depth - 1}",
            ]
        elif op == "custom":
            lines.append(f"  custom_data: {rng.choice(_YAML_VALUES)}")
        elif op == "truncate":
            lines = lines[:i]
        elif op == "tab":
            lines[i] = "\t" + lines[i]
        if not lines:
            lines = ["x"]
    meta.write_text("\n".join(lines) + "\n")
    return out


_SQL = (
    "UPDATE messages SET data = {big} WHERE id % {k} = 0",
    "UPDATE messages SET data = 'text' WHERE id % {k} = 0",
    "UPDATE messages SET data = NULL WHERE id % {k} = 0",
    "UPDATE messages SET timestamp = 'soon' WHERE id % {k} = 0",
    "UPDATE messages SET timestamp = 1.5 WHERE id % {k} = 0",
    "UPDATE messages SET timestamp = -{big} WHERE id % {k} = 0",
    "UPDATE messages SET topic_id = {big} WHERE id % {k} = 0",
    "UPDATE messages SET topic_id = 'one' WHERE id % {k} = 0",
    "UPDATE topics SET name = X'00ff' WHERE id = 1",
    "UPDATE topics SET type = 42 WHERE id = 2",
    "UPDATE topics SET type = 'nope/msg/Nope' WHERE id = 2",
    "UPDATE topics SET serialization_format = 'json' WHERE id = 3",
    "DELETE FROM topics WHERE id = 1",
    "DROP TABLE topics",
    "UPDATE messages SET data = randomblob(20) WHERE id % {k} = 0",
    "UPDATE messages SET data = zeroblob(1000000) WHERE id % {k} = 0",
)


def build_bag2_db3(rng: random.Random, seed: Path, out: Path) -> Path:
    shutil.copytree(seed, out)
    db = next(out.glob("*.db3"))
    if rng.random() < 0.2:
        db.write_bytes(mutate_bytes(rng, db.read_bytes()))
        return out
    con = sqlite3.connect(db)
    for _ in range(rng.randint(1, 3)):
        sql = rng.choice(_SQL).format(
            big=rng.choice((3_000_000_000, 2**62, 7)), k=rng.choice((1, 2, 50))
        )
        with contextlib.suppress(sqlite3.Error):
            con.execute(sql)
    con.commit()
    con.close()
    return out


def build_bag2_zstd(rng: random.Random, seed: Path, out: Path) -> Path:
    import zstandard

    shutil.copytree(seed, out)
    db = next(out.glob("*.db3"))
    meta = out / "metadata.yaml"
    text = meta.read_text()
    zc = zstandard.ZstdCompressor(level=1)
    bomb = rng.choice((0, 2**20, 128 * 2**20, 2**30))
    if rng.random() < 0.5:  # file mode
        op = rng.choice(("honest", "bomb", "garbage", "cut"))
        target = out / (db.name + ".zstd")
        if op == "honest":
            target.write_bytes(zc.compress(db.read_bytes()))
        elif op == "bomb":
            with open(target, "wb") as fh, zc.stream_writer(fh) as w:
                w.write(db.read_bytes())
                for _ in range(bomb // (16 * 2**20)):
                    w.write(bytes(16 * 2**20))
        elif op == "garbage":
            target.write_bytes(rng.randbytes(5000))
        else:
            z = zc.compress(db.read_bytes())
            target.write_bytes(z[: rng.randrange(len(z))])
        db.unlink()
        text = text.replace(f"- {db.name}", f"- {target.name}")
        mode = "FILE"
    else:
        con = sqlite3.connect(db)
        rows = con.execute("SELECT id, data FROM messages").fetchall()
        for mid, data in rows:
            payload = zc.compress(data)
            r = rng.random()
            if r < 0.02:
                payload = rng.randbytes(30)
            elif r < 0.03 and bomb:
                payload = zc.compress(bytes(bomb))
            con.execute("UPDATE messages SET data = ? WHERE id = ?", (payload, mid))
        con.commit()
        con.close()
        mode = "MESSAGE"
    fmt = rng.choice(("zstd", "zstd", "zstd", "lz4", ""))
    text = text.replace(
        "compression_format: ''\n  compression_mode: ''",
        f"compression_format: {fmt!r}\n  compression_mode: {mode}",
    )
    meta.write_text(text)
    return out


def _json_value(rng: random.Random, depth: int) -> object:
    r = rng.random()
    if depth > 3 or r < 0.4:
        return rng.choice((1, 2.5, -3, "s", None, True, "1e3", 10**30))
    if r < 0.7:
        return {
            f"k{rng.randrange(100000)}": _json_value(rng, depth + 1)
            for _ in range(rng.randint(1, 8))
        }
    return [_json_value(rng, depth + 1) for _ in range(rng.randint(0, 12))]


def build_json(rng: random.Random, out: Path) -> Path:
    from mcap.writer import Writer

    op = rng.choice(("distinct", "array_objects", "dotted", "deep", "random", "strings"))
    n = rng.choice((10, 200, 3000))
    if op in ("deep", "array_objects"):  # the shape is the point: 3000 such messages only
        n = min(n, 200)  # multiply the run time
    msgs: list[bytes] = []
    for i in range(n):
        if op == "distinct":
            obj: object = {"v": i, f"x{rng.randrange(10**6)}": 1}
        elif op == "array_objects":
            obj = {
                "v": i,
                "arr": [{f"k{rng.randrange(10**6)}": j} for j in range(rng.choice((1, 10, 2000)))],
            }
        elif op == "dotted":
            obj = {"a.b": i, "a": {"b": -i}, "c": rng.choice((1, "x"))}
        elif op == "deep":
            d = rng.choice((10, 200, 5000, 100_000))
            msgs.append(b'{"v":' + str(i).encode() + b',"d":' + b"[" * d + b"]" * d + b"}")
            continue
        elif op == "strings":
            obj = {"v": str(i), "w": rng.choice((1, "1", None))}
        else:
            obj = {"v": i, "r": _json_value(rng, 0)}
        msgs.append(json.dumps(obj).encode())
    with open(out, "wb") as fh:
        w = Writer(fh)
        w.start()
        sid = w.register_schema("s", "jsonschema", b"{}")
        cid = w.register_channel("/fuzz", "json", sid)
        for i, data in enumerate(msgs):
            w.add_message(cid, log_time=10**9 + i * 10**7, data=data, publish_time=0)
        w.finish()
    return out


def build_csv(rng: random.Random, out: Path) -> Path:
    op = rng.choice(("wide", "relative", "cells", "width_mismatch"))
    n = rng.choice((5, 300, 3000))
    cols = ["t", "v", "omega"]
    if op == "wide":
        cols += [f"c{i}" for i in range(rng.choice((100, 4095, 4096, 10_000)))]
    step = {"relative": rng.choice((1.0, 10.0, 33.0, 1000.0, 1e6))}.get(op, 0.01)
    lines = [",".join(cols)]
    for i in range(n):
        cells = [repr(i * step), repr(0.1 * i), "0.5"] + ["1"] * (len(cols) - 3)
        if op == "cells" and rng.random() < 0.1:
            cells[rng.randrange(len(cells))] = rng.choice(("x", "", "1e400", "nan", '"'))
        if op == "width_mismatch" and rng.random() < 0.05:
            cells = cells[: rng.randrange(len(cells))] or [*cells, "9"]
        lines.append(",".join(cells))
    out.write_text("\n".join(lines) + "\n")
    return out


_TOML_VALUES = (
    '["deg"]',
    "{x = 1}",
    "1",
    "-0.0",
    "nan",
    "inf",
    "true",
    '"deg"',
    '"rad/s"',
    '""',
    '"yaw_from_quaternion"',
    '"header"',
    "[1, [2]]",
    '"\\u0000"',
)


def build_cmap(rng: random.Random, out: Path) -> Path:
    parts = ["[signals.omega]"]
    op = rng.choice(("types", "formula", "deep", "robot"))
    if op == "types":
        parts += ['topic = "csv"', 'field = "omega"']
        for key in rng.sample(
            ("unit", "transform", "stamp", "frame", "scale", "offset", "off"), rng.randint(1, 3)
        ):
            parts.append(f"{key} = {rng.choice(_TOML_VALUES)}")
    elif op == "formula":
        depth = rng.choice((3, 100, 400, 998, 5000))
        kind = rng.choice(("paren", "unary", "sum", "call", "junk"))
        text = {
            "paren": "(" * depth + "v" + ")" * depth,
            "unary": "-" * depth + "v",
            "sum": "+".join(["v"] * depth),
            "call": "sin(" * depth + "v" + ")" * depth,
            "junk": rng.choice(("__import__('os')", "v.real", "v**2", "[v]", "lambda: 1")),
        }
        parts.append(f'formula = "{text[kind]}"')
    elif op == "deep":
        d = rng.choice((10, 1000, 100_000))
        parts = ["x = " + "[" * d + "]" * d]
    else:
        parts = [
            "[robot]",
            f"wheelbase = {rng.choice(_TOML_VALUES)}",
            f"type = {rng.choice(_TOML_VALUES)}",
        ]
    out.write_text("\n".join(parts) + "\n")
    return out


def build_meta(rng: random.Random, out: Path) -> Path:
    from mcap.writer import Writer

    values = ("wide", "", "nan", "inf", "1e400", "[1]", "0.1", "-1", "\x00")
    with open(out, "wb") as fh:
        w = Writer(fh)
        w.start()
        sid = w.register_schema("s", "jsonschema", b"{}")
        cid = w.register_channel("/cmd", "json", sid)
        for i in range(50):
            w.add_message(
                cid,
                log_time=10**9 + i * 10**8,
                data=json.dumps({"v": 0.3, "omega": 0.1 * (i % 7)}).encode(),
                publish_time=0,
            )
        robot = rng.choice(("diff_drive", "manipulator_2link", "tractor_trailer", "x"))
        w.add_metadata(
            "logcal",
            {
                "robot": robot,
                "nominal.m1": rng.choice(values),
                "l1": rng.choice(values),
                "wheelbase": rng.choice(values),
            },
        )
        w.add_metadata(
            "logcal.nominal",
            {
                k: rng.choice(values)
                for k in (
                    "track_width",
                    "wheel_radius_left",
                    "wheel_radius_right",
                    "l_a",
                    "square_side",
                )
            },
        )
        w.finish()
    return out


def build(
    kind: str, rng: random.Random, base: dict[str, Path], folder: Path
) -> tuple[Path, Path | None]:
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    if kind == "ros1":
        return build_ros1(rng, base["ros1"], folder / "in.bag"), None
    if kind == "bag2_meta":
        return build_bag2_meta(rng, base["bag2"], folder / "bag"), None
    if kind == "bag2_db3":
        return build_bag2_db3(rng, base["bag2"], folder / "bag"), None
    if kind == "bag2_zstd":
        return build_bag2_zstd(rng, base["bag2"], folder / "bag"), None
    if kind == "json":
        return build_json(rng, folder / "in.mcap"), None
    if kind == "csv":
        return build_csv(rng, folder / "in.csv"), None
    if kind == "cmap":
        log = folder / "log.csv"
        log.write_text("t,v,omega\n" + "".join(f"{i * 0.01},{0.3},{0.1}\n" for i in range(300)))
        return log, build_cmap(rng, folder / "map.toml")
    return build_meta(rng, folder / "in.mcap"), None


# ----------------------------------------------------------------------------- running


class _AlarmError(Exception):
    pass


def _on_alarm(signum: int, frame: object) -> None:
    raise _AlarmError


def _run_one(path: Path, cmap: Path | None) -> None:
    from logtools.channel_map import load_channel_map
    from logtools.load import load_log
    from logtools.readers import read_log

    if cmap is not None:
        load_log(path, load_channel_map(cmap))
        return
    read_log(path)
    from calib.errors import CalibError
    from logtools.errors import LogcalError

    with contextlib.suppress(LogcalError, CalibError):  # the read gave data: a missing signal
        load_log(path)  # is the analysis's clean refusal


def worker(tasks: mp.Queue, results: mp.Queue, mem_gib: float, timeout_s: int) -> None:
    limit = int(mem_gib * 2**30)
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    signal.signal(signal.SIGALRM, _on_alarm)
    import logtools.load  # noqa: F401
    from calib.errors import CalibError
    from logtools.errors import LogcalError

    while True:
        item = tasks.get()
        if item is None:
            return
        idx, path, cmap = item
        t0 = time.perf_counter()
        signal.alarm(timeout_s)
        try:
            _run_one(Path(path), Path(cmap) if cmap else None)
            outcome, detail = "data", ""
        except _AlarmError:
            outcome, detail = "hang", f"over {timeout_s} s"
        except MemoryError:
            outcome, detail = "memory", "MemoryError"
        except BaseException as exc:
            clean = isinstance(exc, LogcalError | CalibError)
            outcome = "clean_error" if clean else "traceback"
            detail = str(exc)[:300] if clean else traceback.format_exc()
        finally:
            signal.alarm(0)
        results.put((idx, outcome, detail, time.perf_counter() - t0))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--n", type=int, default=500)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--mem-gib", type=float, default=2.0)
    ap.add_argument("--timeout-s", type=int, default=20)
    ap.add_argument("--save", type=Path, default=Path("/tmp/logcal_fuzz_parsers"))
    args = ap.parse_args()
    if args.workers > 1:
        return run_parallel(args)
    kinds = args.kinds.split(",")
    rng = random.Random(args.seed)
    work = Path(tempfile.mkdtemp(prefix="logcal_fuzzp_"))
    base = seeds(work)
    args.save.mkdir(parents=True, exist_ok=True)
    ctx = mp.get_context("fork")
    tasks: mp.Queue = ctx.Queue()
    results: mp.Queue = ctx.Queue()

    def start() -> mp.process.BaseProcess:
        p = ctx.Process(target=worker, args=(tasks, results, args.mem_gib, args.timeout_s))
        p.start()
        return p

    proc = start()
    counts: Counter[str] = Counter()
    per_kind: Counter[tuple[str, str]] = Counter()
    slowest = 0.0
    t_start = time.perf_counter()
    for i in range(args.n):
        kind = rng.choice(kinds)
        folder = work / "case"
        try:
            path, cmap = build(kind, rng, base, folder)
        except Exception:  # a builder that fails is the harness's bug, counted apart
            counts["harness_error"] += 1
            continue
        tasks.put((i, str(path), str(cmap) if cmap else ""))
        outcome = None
        while outcome is None:
            try:
                _, outcome, detail, dt = results.get(timeout=args.timeout_s + 15)
            except Exception:
                outcome, detail, dt = ("memory" if not proc.is_alive() else "hang"), "", 0.0
            if outcome is None or not proc.is_alive():
                proc.kill()
                proc.join()
                proc = start()
        slowest = max(slowest, dt)
        counts[outcome] += 1
        per_kind[(kind, outcome)] += 1
        if outcome in ("traceback", "hang", "memory"):
            keep = args.save / f"{i:06d}_{kind}_{outcome}"
            shutil.copytree(folder, keep, dirs_exist_ok=True)
            (keep / "detail.txt").write_text(detail)
        if (i + 1) % max(1, args.n // 10) == 0:
            rate = (i + 1) / (time.perf_counter() - t_start)
            print(f"  {i + 1}/{args.n}  {dict(counts)}  {rate:.1f} inputs/s", flush=True)
    tasks.put(None)
    proc.join(timeout=5)
    print(
        f"\ninputs: {args.n}, seed {args.seed}, cap {args.mem_gib} GiB, bound "
        f"{args.timeout_s} s\noutcomes: {dict(counts)}; slowest {slowest:.2f} s"
    )
    for kind in kinds:
        print(f"  {kind:10s} { ({o: c for (k, o), c in per_kind.items() if k == kind}) }")
    if args.json is not None:
        args.json.write_text(
            json.dumps(
                {
                    "counts": dict(counts),
                    "slowest_s": slowest,
                    "per_kind": {f"{k}:{o}": c for (k, o), c in per_kind.items()},
                }
            )
        )
    bad = counts["traceback"] + counts["hang"] + counts["memory"]
    print(f"failures saved under {args.save}" if bad else "no tracebacks, hangs or blow-ups")
    shutil.rmtree(work, ignore_errors=True)
    return 1 if bad else 0


def run_parallel(args: argparse.Namespace) -> int:
    import subprocess

    out = Path(tempfile.mkdtemp(prefix="logcal_fuzzp_par_"))
    procs = []
    for j in range(args.workers):
        n = args.n // args.workers + (1 if j < args.n % args.workers else 0)
        cmd = [
            sys.executable,
            __file__,
            "--n",
            str(n),
            "--seed",
            str(args.seed * 1000 + j),
            "--mem-gib",
            str(args.mem_gib),
            "--timeout-s",
            str(args.timeout_s),
            "--kinds",
            args.kinds,
            "--save",
            str(args.save / f"w{j}"),
            "--json",
            str(out / f"w{j}.json"),
        ]
        procs.append(subprocess.Popen(cmd))
    from fuzz_workers import merge_workers

    return merge_workers(procs, out, args.json)


if __name__ == "__main__":
    raise SystemExit(main())
