"""A batch killed at random moments and resumed each time ends with the records of an
uninterrupted run: every log exactly once, none lost, every file whole (issue 34).

The archive holds ``--logs`` logs: small CSV drives that are analysed (``--good`` of them) and
damaged MCAP files that fail at once (their records are records too). The batch
(``logcal batch --workers 2``) is run once uninterrupted (the reference), then in a second
folder started and killed with SIGKILL ``--kills`` times at a random moment (the whole process
group, or the driver alone: its workers must then end by themselves), each kill followed by a
check that every JSON file of the folder is whole and that no worker is left; a last run
finishes it. The records (per log: status, error, result; timings left out) must equal the
reference's. With ``--full-disk N`` (root, Linux) the batch also writes N times into a tmpfs of
a random size (out of space at a random byte count): exit 2 with one message or 0, never a
traceback, whole files; the tmpfs is then enlarged and the batch resumed, and its records
compared the same way.

    nice -n 10 python bench/batch_kill_resume.py --logs 1000 --good 40 --kills 20 --seed 1
"""

from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "sample_logs" / "tt_mixed.csv"
CORRUPT = b"\x89MCAP0\r\n" + bytes(range(256)) * 4
_VOLATILE = ("seconds", "elapsed", "wall", "duration_ms", "started", "finished")


def build_archive(root: Path, logs: int, good: int, rng: random.Random) -> None:
    import polars as pl

    root.mkdir(parents=True)
    df = pl.read_csv(SAMPLE)
    for i in range(logs):
        sub = root / f"d{i % 17:02d}"
        sub.mkdir(exist_ok=True)
        if i < good:
            start = rng.randrange(0, max(1, df.height - 600))
            df.slice(start, 500).write_csv(sub / f"good{i:04d}.csv")
        else:
            (sub / f"bad{i:04d}.mcap").write_bytes(CORRUPT + i.to_bytes(4, "little"))


def batch_cmd(archive: Path, out: Path) -> list[str]:
    return [
        sys.executable,
        "-m",
        "logtools.cli.main",
        "batch",
        str(archive),
        "--out",
        str(out),
        "--workers",
        "2",
        "--repeats",
        "2",
        "--no-discovery",
        "--no-views",
    ]


def _strip(doc: Any) -> Any:
    if isinstance(doc, dict):
        return {k: _strip(v) for k, v in doc.items() if not any(w in k for w in _VOLATILE)}
    if isinstance(doc, list):
        return [_strip(v) for v in doc]
    return doc


def records(out: Path) -> dict[str, Any]:
    from logtools.batch.runner import load_manifest, read_records

    manifest = load_manifest(out)
    names = [str(e["log"]) for e in manifest.values()]
    if len(names) != len(set(names)):
        raise AssertionError("a log recorded twice in the manifest")
    return {
        str(r["log"]): _strip({k: r.get(k) for k in ("status", "error", "result", "content_hash")})
        for r in read_records(out)
    }


def whole_files(out: Path) -> list[str]:
    """JSON files of ``out`` (temporaries left out) that do not parse."""
    bad = []
    for p in out.rglob("*.json"):
        if ".partial" in p.name:
            continue
        try:
            json.loads(p.read_bytes())
        except ValueError:
            bad.append(str(p.relative_to(out)))
    return bad


def _descendants(pid: int) -> list[tuple[int, int]]:
    """(pid, start time) of every live process below ``pid``."""
    from logtools.batch.lifeline import _start_ticks

    parents: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                raw = Path(f"/proc/{entry}/stat").read_bytes()
            except OSError:
                continue
            ppid = int(raw[raw.rfind(b")") + 2 :].split()[1])
            parents.setdefault(ppid, []).append(int(entry))
    out, stack = [], [pid]
    while stack:
        for child in parents.get(stack.pop(), []):
            stack.append(child)
            ticks = _start_ticks(child)
            if ticks is not None:
                out.append((child, ticks))
    return out


def _left(procs: list[tuple[int, int]], bound_s: float = 60.0) -> list[int]:
    from logtools.batch.lifeline import _start_ticks

    deadline = time.monotonic() + bound_s
    while time.monotonic() < deadline:
        alive = [p for p, t in procs if _start_ticks(p) == t]
        if not alive:
            return []
        time.sleep(0.2)
    return alive


def kill_and_resume(
    archive: Path, out: Path, kills: int, rng: random.Random, full_s: float
) -> dict[str, Any]:
    counts = {"kills": 0, "driver_only": 0, "torn_files": 0, "left_behind": 0, "tracebacks": 0}
    for _ in range(kills):
        proc = subprocess.Popen(
            batch_cmd(archive, out),
            start_new_session=True,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
        )
        time.sleep(rng.uniform(1.0, max(1.5, 2 * full_s / kills)))  # spread over one run
        if proc.poll() is not None:  # finished before the kill: nothing left to kill
            err = proc.stderr.read().decode() if proc.stderr else ""
            counts["tracebacks"] += "Traceback" in err or "internal error" in err
            continue
        procs = _descendants(proc.pid)
        driver_only = rng.random() < 0.3
        if driver_only:
            os.kill(proc.pid, signal.SIGKILL)
        else:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        if proc.stderr:
            proc.stderr.close()
        counts["kills"] += 1
        counts["driver_only"] += driver_only
        left = _left(procs)
        counts["left_behind"] += len(left)
        for pid in left:
            os.kill(pid, signal.SIGKILL)
        counts["torn_files"] += len(whole_files(out))
    final = subprocess.run(batch_cmd(archive, out), capture_output=True, text=True, check=False)
    counts["final_exit"] = final.returncode
    counts["tracebacks"] += "Traceback" in final.stderr or "internal error" in final.stderr
    return counts


def _bytes_under(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())


def full_disk(
    archive: Path, base: Path, rounds: int, rng: random.Random, need: int
) -> dict[str, Any] | None:
    if os.geteuid() != 0:
        return None
    counts = {"rounds": 0, "exit_2": 0, "exit_0": 0, "other_exit": 0, "torn_files": 0}
    mounts = []
    try:
        for r in range(rounds):
            mnt = base / f"tmpfs{r}"
            mnt.mkdir()
            size = rng.randrange(16 * 1024, max(32 * 1024, need))  # out of space midway
            ok = subprocess.run(
                ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(mnt)],
                capture_output=True,
                check=False,
            )
            if ok.returncode != 0:
                return None
            mounts.append(mnt)
            out = mnt / "out"
            proc = subprocess.run(
                batch_cmd(archive, out), capture_output=True, text=True, check=False
            )
            counts["rounds"] += 1
            key = {0: "exit_0", 2: "exit_2"}.get(proc.returncode, "other_exit")
            counts[key] += 1
            if key == "other_exit" or "Traceback" in proc.stderr:
                counts.setdefault("bad", []).append(proc.stderr[-500:])
            counts["torn_files"] += len(whole_files(out)) if out.exists() else 0
            subprocess.run(["mount", "-o", "remount,size=256m", str(mnt)], check=True)
            resumed = subprocess.run(
                batch_cmd(archive, out), capture_output=True, text=True, check=False
            )
            counts.setdefault("resumed_exits", []).append(resumed.returncode)
            counts.setdefault("outs", []).append(str(out))
        return counts
    except BaseException:
        for mnt in mounts:
            subprocess.run(["umount", str(mnt)], check=False)
        raise


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--logs", type=int, default=1000)
    ap.add_argument("--good", type=int, default=40)
    ap.add_argument("--kills", type=int, default=20)
    ap.add_argument("--full-disk", type=int, default=0)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    rng = random.Random(args.seed)
    base = Path(tempfile.mkdtemp(prefix="logcal_kill_resume_"))
    mounted: list[Path] = []
    try:
        archive = base / "archive"
        build_archive(archive, args.logs, args.good, rng)
        t0 = time.perf_counter()
        ref_run = subprocess.run(
            batch_cmd(archive, base / "ref"), capture_output=True, text=True, check=False
        )
        full_s = time.perf_counter() - t0
        reference = records(base / "ref")
        print(f"reference: {len(reference)} records in {full_s:.1f} s (exit {ref_run.returncode})")
        counts = kill_and_resume(archive, base / "killed", args.kills, rng, full_s)
        got = records(base / "killed")
        lost = sorted(set(reference) - set(got))
        extra = sorted(set(got) - set(reference))
        differ = sorted(k for k in set(reference) & set(got) if reference[k] != got[k])
        summary: dict[str, Any] = {
            "logs": args.logs,
            "reference_records": len(reference),
            "final_records": len(got),
            "lost": len(lost),
            "extra": len(extra),
            "differ": len(differ),
            **counts,
        }
        if args.full_disk:
            disk = full_disk(archive, base, args.full_disk, rng, _bytes_under(base / "ref"))
            if disk is None:
                summary["full_disk"] = "skipped (needs root and tmpfs)"
            else:
                outs = [Path(o) for o in disk.pop("outs", [])]
                mounted = [o.parent for o in outs]
                disk["records_equal"] = sum(records(o) == reference for o in outs)
                summary["full_disk"] = disk
        print(json.dumps(summary, indent=1))
        if differ:
            print("first differing log:", differ[0])
        bad = lost or extra or differ or counts["torn_files"] or counts["left_behind"]
        bad = bad or counts["tracebacks"] or counts["final_exit"] != 0
        return 1 if bad else 0
    finally:
        for m in mounted:
            subprocess.run(["umount", str(m)], check=False)
        shutil.rmtree(base, ignore_errors=True)


if __name__ == "__main__":
    raise SystemExit(main())
