"""Fuzzing harness for the log readers and ``analyze`` (issue #13).

Every input must end in data or a clean ``LogcalError``/``CalibError``, within a per-input time
bound and a memory cap. Inputs are mutations of small valid logs written by the independent
generator (tests/indgen: MCAP JSON and ROS 2, CSV, ROS 1 bag) and by logcal's own writer:

- byte-level: bit flips, random overwrites, truncation, insertions, duplicated and zeroed
  regions, 8-byte length fields overwritten with huge values (2^31, 2^63, 2^64 - 1),
  concatenation of two files;
- CSV-level: numbers replaced by 1e308, -1e308, nan, inf, empty, text; time in epoch ms/ns;
  rows shuffled or duplicated;
- value-level (``--values``): structurally valid logs written by tests/indgen's writers (MCAP
  JSON, MCAP ROS 2, CSV) whose values are hostile -- one sample of 100, 1e4, 1e7, +-1e308, NaN
  or inf; every message duplicated 1 us or 1 ns after the original; a constant, zero or 1e300-
  scaled field; one stamp 11 days off; or nothing changed (to count false outlier reports) --
  run through the whole ``analyze``;
- ``--analyze``: the byte-level mutations above, through the whole ``analyze``.

Each input runs in a worker process with ``RLIMIT_AS`` (``--mem-gib``) and an alarm
(``--timeout-s``); a worker that dies is a memory blow-up or crash, an alarm a hang. Inputs that
fail are saved under ``--save`` with their traceback for replay. ``--workers K`` runs K
harnesses with seeds ``seed * 1000 + j`` and adds up their counts. The same seed gives the same
inputs (every random byte comes from the seeded generator).

    python bench/fuzz_logs.py --n 100000 --seed 1 --workers 2    # readers (read_log + load_log)
    python bench/fuzz_logs.py --n 300 --values --seed 2          # whole analyze, hostile values
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import json
import multiprocessing as mp
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
    from indgen import generate, random_scenario  # type: ignore[import-not-found]
    from indgen.writers import (  # type: ignore[import-not-found]
        write_csv,
        write_mcap_json,
        write_mcap_ros2,
        write_rosbag1,
    )

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
    buf[at : at + 8] = value.to_bytes(8, "little")


def mutate_bytes(rng: random.Random, data: bytes, other: bytes) -> bytes:
    """One to three random byte-level mutations of ``data``."""
    buf = bytearray(data)
    for _ in range(rng.randint(1, 3)):
        op = rng.choice(
            ("flip", "overwrite", "truncate", "insert", "dup", "zero", "length", "concat", "header")
        )
        n = len(buf)
        if n == 0:
            break
        at = rng.randrange(n)
        if op == "flip":
            buf[at] ^= 1 << rng.randrange(8)
        elif op == "overwrite":
            k = rng.randint(1, 16)
            buf[at : at + k] = rng.randbytes(k)
        elif op == "truncate":
            del buf[at:]
        elif op == "insert":
            buf[at:at] = rng.randbytes(rng.randint(1, 64))
        elif op == "dup":
            k = rng.randint(1, 4096)
            buf[at:at] = buf[at : at + k]
        elif op == "zero":
            k = rng.randint(1, 8192)
            buf[at : at + k] = bytes(min(k, n - at))
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


VALUE_OPS = ("spike", "dup_1us", "dup_1ns", "constant", "zeros", "scale", "stamp_jump", "none")
SPIKES = (100.0, -100.0, 1e4, 1e7, 1e308, -1e308, float("nan"), float("inf"))


def value_bases() -> list[object]:
    """Small valid generated logs (indgen) that the value-level mode spoils."""
    import numpy as np
    from indgen import generate, random_scenario

    return [
        generate(random_scenario(np.random.default_rng(s), duration_s=30.0), seed=s)
        for s in (3, 4, 5)
    ]


def mutate_values(rng: random.Random, gen: object) -> tuple[object, str]:
    """``gen`` (an indgen ``Generated``) with one hostile change of its values or stamps."""
    import numpy as np

    op = rng.choice(VALUE_OPS)
    topics = dict(gen.topics)  # type: ignore[attr-defined]
    name = rng.choice(sorted(topics))
    td = topics[name]
    fields = {f: a.copy() for f, a in td.fields.items()}
    stamps = td.stamps_ns.copy()
    f = rng.choice(sorted(fields))
    n = stamps.size
    if op == "spike" and n:
        fields[f][rng.randrange(n)] = rng.choice(SPIKES)
    elif op in ("dup_1us", "dup_1ns"):
        step = 1000 if op == "dup_1us" else 1
        order = np.argsort(np.concatenate([stamps, stamps + step]), kind="stable")
        stamps = np.concatenate([stamps, stamps + step])[order]
        fields = {k: np.concatenate([a, a])[order] for k, a in fields.items()}
    elif op == "constant":
        fields[f][:] = fields[f][0] if n else 0.0
    elif op == "zeros":
        fields = {k: np.zeros_like(a) for k, a in fields.items()}
    elif op == "scale":
        fields[f] = fields[f] * 1e300
    elif op == "stamp_jump" and n:
        stamps[rng.randrange(n)] += 10**15
    topics[name] = dataclasses.replace(td, stamps_ns=stamps, fields=fields)
    return dataclasses.replace(gen, topics=topics), f"{op} {name}.{f}"  # type: ignore[type-var]


def write_value_log(rng: random.Random, gen: object, folder: Path) -> Path:
    from indgen.writers import write_csv, write_mcap_json, write_mcap_ros2

    kind, write, suffix = rng.choice(
        (
            ("json", write_mcap_json, ".mcap"),
            ("ros2", write_mcap_ros2, ".mcap"),
            ("csv", write_csv, ".csv"),
        )
    )
    path = folder / f"value_{kind}{suffix}"
    write(path, gen)
    return path


def _classify(exc: BaseException) -> str:
    from calib.errors import CalibError
    from logtools.errors import LogcalError

    return "clean_error" if isinstance(exc, LogcalError | CalibError) else "traceback"


def _run_one(path: Path, analyze: bool) -> str:
    """Run one input; return "outlier" when the analysis excluded outliers, else ""."""
    from logtools.load import load_log
    from logtools.readers import read_log

    if analyze:
        from logtools.analyze import AnalysisConfig, analyze_log

        loaded, result = analyze_log(path, config=AnalysisConfig(repeats=1, discovery=True))
        result.to_dict()
        from rich.console import Console

        from logtools.report import render_analysis

        Console(file=io.StringIO()).print(render_analysis(result))
        return "outlier" if any(p.kind == "outlier" for p in loaded.problems) else ""
    read_log(path)
    load_log(path)
    return ""


class _AlarmError(Exception):
    pass


def _on_alarm(signum: int, frame: object) -> None:
    raise _AlarmError


def worker(
    tasks: mp.Queue, results: mp.Queue, mem_gib: float, timeout_s: int, analyze: bool
) -> None:
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
            outcome, detail = "data", _run_one(Path(path), analyze)
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
    ap.add_argument(
        "--values",
        action="store_true",
        help="valid logs with hostile values, through the whole analyze",
    )
    ap.add_argument("--workers", type=int, default=1, help="harnesses run side by side")
    ap.add_argument("--json", type=Path, default=None, help="write the counts here")
    ap.add_argument("--mem-gib", type=float, default=3.0, help="address-space cap per worker")
    ap.add_argument("--timeout-s", type=int, default=20, help="time bound per input")
    ap.add_argument("--save", type=Path, default=Path("/tmp/logcal_fuzz_failures"))
    args = ap.parse_args()
    if args.workers > 1:
        return run_parallel(args)
    args.analyze = args.analyze or args.values

    rng = random.Random(args.seed)
    work = Path(tempfile.mkdtemp(prefix="logcal_fuzz_"))
    seeds = seed_logs(work)
    bases = value_bases() if args.values else []
    outlier_notes: Counter[str] = Counter()
    args.save.mkdir(parents=True, exist_ok=True)
    ctx = mp.get_context("fork")
    tasks: mp.Queue = ctx.Queue()
    results: mp.Queue = ctx.Queue()

    def start() -> mp.process.BaseProcess:
        p = ctx.Process(
            target=worker, args=(tasks, results, args.mem_gib, args.timeout_s, args.analyze)
        )
        p.start()
        return p

    proc = start()
    counts: Counter[str] = Counter()
    per_kind: Counter[tuple[str, str]] = Counter()
    t_start = time.perf_counter()
    slowest = 0.0
    for i in range(args.n):
        if args.values:
            gen, what = mutate_values(rng, rng.choice(bases))
            path = write_value_log(rng, gen, work)
            kind, suffix, data = what.split()[0], path.suffix, path.read_bytes()
        else:
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
        if outcome == "data" and detail:
            outlier_notes[kind] += 1
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
    print(
        f"\ninputs: {args.n} ({'analyze' if args.analyze else 'read + load'}), "
        f"seed {args.seed}, cap {args.mem_gib} GiB, bound {args.timeout_s} s"
    )
    print(f"outcomes: {dict(counts)}; slowest input {slowest:.2f} s")
    for kind in VALUE_OPS if args.values else KINDS:
        row = {o: c for (k, o), c in per_kind.items() if k == kind}
        print(f"  {kind:10s} {row}")
    if args.values:
        print(f"analyses that reported outliers, per change: {dict(outlier_notes)}")
    bad = counts["traceback"] + counts["hang"] + counts["memory"]
    if args.json is not None:
        args.json.write_text(
            json.dumps(
                {
                    "n": args.n,
                    "seed": args.seed,
                    "counts": dict(counts),
                    "slowest_s": slowest,
                    "per_kind": {f"{k}:{o}": c for (k, o), c in per_kind.items()},
                    "outlier_reports": dict(outlier_notes),
                }
            )
        )
    print(f"failures saved under {args.save}" if bad else "no tracebacks, hangs or blow-ups")
    return 1 if bad else 0


def run_parallel(args: argparse.Namespace) -> int:
    """Run ``args.workers`` harnesses (seeds ``seed * 1000 + j``) and add up their counts."""
    import subprocess

    out = Path(tempfile.mkdtemp(prefix="logcal_fuzz_par_"))
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
            "--save",
            str(args.save / f"w{j}"),
            "--json",
            str(out / f"w{j}.json"),
        ]
        cmd += ["--values"] if args.values else ["--analyze"] if args.analyze else []
        procs.append(subprocess.Popen(cmd))
    from fuzz_workers import merge_workers

    return merge_workers(procs, out, args.json)


if __name__ == "__main__":
    raise SystemExit(main())
