"""Fuzzing harness for the log readers and ``analyze`` (issue #13).

Every input must end in data or a clean ``LogcalError``/``CalibError``, within a per-input time
bound and a memory cap. Inputs are mutations of small valid logs written by the independent
generator (tests/indgen: MCAP JSON and ROS 2, CSV, ROS 1 bag) and by logcal's own writer:

- byte-level: bit flips, random overwrites, truncation, insertions, duplicated and zeroed
  regions, 8-byte length fields overwritten with huge values (2^31, 2^63, 2^64 - 1),
  concatenation of two files;
- CSV-level: numbers replaced by 1e308, -1e308, nan, inf, empty, text; time in epoch ms/ns;
  rows shuffled or duplicated;
- value-level (``--analyze``): structurally valid logs whose values are hostile (a huge speed
  sample, duplicates 1 us apart, constant signals), run through the whole ``analyze``.

Each input runs in a worker process with ``RLIMIT_AS`` (``--mem-gib``) and an alarm
(``--timeout-s``); a worker that dies is a memory blow-up or crash, an alarm a hang. Inputs that
fail are saved under ``--save`` with their traceback for replay.

    python bench/fuzz_logs.py --n 100000 --seed 1            # readers (read_log + load_log)
    python bench/fuzz_logs.py --n 300 --analyze --seed 2     # whole analyze, hostile values
"""

from __future__ import annotations

import argparse
import contextlib
import io
import multiprocessing as mp
import os
import random
import resource
import signal
import sys
import tempfile
import time
import traceback
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

KINDS = ("mcap_json", "mcap_ros2", "csv", "bag1")


def seed_logs(folder: Path) -> dict[str, bytes]:
    """Small valid logs of each kind (bytes), from the independent generator."""
    import numpy as np
    from indgen import generate, random_scenario
    from indgen.writers import write_csv, write_mcap_json, write_mcap_ros2, write_rosbag1

    out: dict[str, bytes] = {}
    gen = generate(random_scenario(np.random.default_rng(3), duration_s=6.0), seed=3)
    for kind, write, name in (
        ("mcap_json", write_mcap_json, "a.mcap"),
        ("mcap_ros2", write_mcap_ros2, "b.mcap"),
        ("csv", write_csv, "c.csv"),
        ("bag1", write_rosbag1, "d.bag"),
    ):
        path = folder / name
        write(path, gen)
        out[kind] = path.read_bytes()
    return out


def _huge_length(rng: random.Random, buf: bytearray) -> None:
    if len(buf) < 16:
        return
    at = rng.randrange(0, len(buf) - 8)
    value = rng.choice([2**31, 2**32 - 1, 2**63, 2**64 - 1, rng.getrandbits(64)])
    buf[at:at + 8] = value.to_bytes(8, "little")


def mutate_bytes(rng: random.Random, data: bytes, other: bytes) -> bytes:
    """One to three random byte-level mutations of ``data``."""
    buf = bytearray(data)
    for _ in range(rng.randint(1, 3)):
        op = rng.choice(("flip", "overwrite", "truncate", "insert", "dup", "zero", "length",
                         "concat", "header"))
        n = len(buf)
        if n == 0:
            break
        at = rng.randrange(n)
        if op == "flip":
            buf[at] ^= 1 << rng.randrange(8)
        elif op == "overwrite":
            k = rng.randint(1, 16)
            buf[at:at + k] = os.urandom(k)
        elif op == "truncate":
            del buf[at:]
        elif op == "insert":
            buf[at:at] = os.urandom(rng.randint(1, 64))
        elif op == "dup":
            k = rng.randint(1, 4096)
            buf[at:at] = buf[at:at + k]
        elif op == "zero":
            k = rng.randint(1, 8192)
            buf[at:at + k] = bytes(min(k, n - at))
        elif op == "length":
            _huge_length(rng, buf)
        elif op == "concat":
            buf += other
        elif op == "header":
            k = rng.randrange(min(64, n))
            buf[k] ^= 1 << rng.randrange(8)
    return bytes(buf)


HOSTILE_NUMBERS = ("1e308", "-1e308", "nan", "inf", "-inf", "", "x", "1e-320", "0", "-0")


def mutate_csv(rng: random.Random, data: bytes) -> bytes:
    """Hostile values in a CSV: numbers replaced, time rescaled, rows shuffled or repeated."""
    lines = data.decode("utf-8", "replace").splitlines()
    head, rows = lines[0], lines[1:]
    op = rng.choice(("values", "time_ms", "time_ns", "shuffle", "repeat", "cut_row"))
    if op == "values" and rows:
        for _ in range(rng.randint(1, 5)):
            i = rng.randrange(len(rows))
            cells = rows[i].split(",")
            cells[rng.randrange(len(cells))] = rng.choice(HOSTILE_NUMBERS)
            rows[i] = ",".join(cells)
    elif op in ("time_ms", "time_ns"):
        scale = 1e3 if op == "time_ms" else 1e9
        offset = 1.7e9 * scale
        fixed = []
        for r in rows:
            cells = r.split(",")
            with contextlib.suppress(ValueError):
                cells[0] = repr(float(cells[0]) * scale + offset)
            fixed.append(",".join(cells))
        rows = fixed
    elif op == "shuffle":
        rng.shuffle(rows)
    elif op == "repeat" and rows:
        i = rng.randrange(len(rows))
        rows[i:i] = [rows[i]] * rng.randint(1, 50)
    elif op == "cut_row" and rows:
        i = rng.randrange(len(rows))
        rows[i] = rows[i][: rng.randrange(max(1, len(rows[i])))]
    return ("\n".join([head, *rows]) + "\n").encode()


def _classify(exc: BaseException) -> str:
    from calib.errors import CalibError
    from logtools.errors import LogcalError

    return "clean_error" if isinstance(exc, LogcalError | CalibError) else "traceback"


def _run_one(path: Path, analyze: bool) -> None:
    from logtools.load import load_log
    from logtools.readers import read_log

    if analyze:
        from logtools.analyze import AnalysisConfig, analyze_log

        _, result = analyze_log(path, config=AnalysisConfig(repeats=1, discovery=True))
        result.to_dict()
        from rich.console import Console

        from logtools.report import render_analysis

        Console(file=io.StringIO()).print(render_analysis(result))
    else:
        read_log(path)
        load_log(path)


class _AlarmError(Exception):
    pass


def _on_alarm(signum: int, frame: object) -> None:
    raise _AlarmError


def worker(tasks: mp.Queue, results: mp.Queue, mem_gib: float, timeout_s: int,
           analyze: bool) -> None:
    limit = int(mem_gib * 2**30)
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    signal.signal(signal.SIGALRM, _on_alarm)
    import logtools.load

    if analyze:
        import logtools.analyze  # noqa: F401
    while True:
        item = tasks.get()
        if item is None:
            return
        idx, path = item
        t0 = time.perf_counter()
        signal.alarm(timeout_s)
        try:
            _run_one(Path(path), analyze)
            outcome, detail = "data", ""
        except _AlarmError:
            outcome, detail = "hang", f"over {timeout_s} s"
        except MemoryError:
            outcome, detail = "memory", "MemoryError"
        except BaseException as exc:
            outcome = _classify(exc)
            detail = traceback.format_exc() if outcome == "traceback" else str(exc)[:200]
        finally:
            signal.alarm(0)
        results.put((idx, outcome, detail, time.perf_counter() - t0))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--n", type=int, default=2000, help="inputs to try")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--analyze", action="store_true", help="run the whole analyze")
    ap.add_argument("--mem-gib", type=float, default=3.0, help="address-space cap per worker")
    ap.add_argument("--timeout-s", type=int, default=20, help="time bound per input")
    ap.add_argument("--save", type=Path, default=Path("/tmp/logcal_fuzz_failures"))
    args = ap.parse_args()

    rng = random.Random(args.seed)
    work = Path(tempfile.mkdtemp(prefix="logcal_fuzz_"))
    seeds = seed_logs(work)
    args.save.mkdir(parents=True, exist_ok=True)
    ctx = mp.get_context("fork")
    tasks: mp.Queue = ctx.Queue()
    results: mp.Queue = ctx.Queue()

    def start() -> mp.Process:
        p = ctx.Process(target=worker,
                        args=(tasks, results, args.mem_gib, args.timeout_s, args.analyze))
        p.start()
        return p

    proc = start()
    counts: Counter[str] = Counter()
    per_kind: Counter[tuple[str, str]] = Counter()
    t_start = time.perf_counter()
    slowest = 0.0
    for i in range(args.n):
        kind = rng.choice(KINDS)
        data = seeds[kind]
        if kind == "csv" and rng.random() < 0.5:
            data = mutate_csv(rng, data)
        else:
            data = mutate_bytes(rng, data, seeds[rng.choice(KINDS)])
        suffix = {"csv": ".csv", "bag1": ".bag"}.get(kind, ".mcap")
        path = work / f"in{suffix}"
        path.write_bytes(data)
        tasks.put((i, str(path)))
        outcome = None
        while outcome is None:
            try:
                _, outcome, detail, dt = results.get(timeout=args.timeout_s + 10)
            except Exception:  # the queue timed out: the worker is gone or stuck
                outcome, detail, dt = ("memory" if not proc.is_alive() else "hang"), "", 0.0
            if outcome is None or not proc.is_alive():
                proc.kill()
                proc.join()
                proc = start()
        slowest = max(slowest, dt)
        counts[outcome] += 1
        per_kind[(kind, outcome)] += 1
        if outcome in ("traceback", "hang", "memory"):
            keep = args.save / f"{i:06d}_{outcome}{suffix}"
            keep.write_bytes(data)
            keep.with_suffix(".txt").write_text(detail)
        if (i + 1) % max(1, args.n // 20) == 0:
            rate = (i + 1) / (time.perf_counter() - t_start)
            print(f"  {i + 1}/{args.n}  {dict(counts)}  {rate:.0f} inputs/s", flush=True)
    tasks.put(None)
    proc.join(timeout=5)
    print(f"\ninputs: {args.n} ({'analyze' if args.analyze else 'read + load'}), "
          f"seed {args.seed}, cap {args.mem_gib} GiB, bound {args.timeout_s} s")
    print(f"outcomes: {dict(counts)}; slowest input {slowest:.2f} s")
    for kind in KINDS:
        row = {o: c for (k, o), c in per_kind.items() if k == kind}
        print(f"  {kind:10s} {row}")
    bad = counts["traceback"] + counts["hang"] + counts["memory"]
    print(f"failures saved under {args.save}" if bad else "no tracebacks, hangs or blow-ups")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
