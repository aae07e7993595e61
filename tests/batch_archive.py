"""Archives for the batch tests: copies of sample_logs, simulated tractor-trailer logs with
known truth and start times, a corrupt file, a log of an unknown robot and logs with hostile
file and topic names (one unmapped: fails; one mapped by a channel map: analysed)."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

from calib.tractor_trailer.sim.presets import preset
from calib.tractor_trailer.sim.tractor_trailer import simulate_tractor_trailer
from logtools.batch.worker import AnalysisOptions
from logtools.writers.mcap_writer import JsonEncoder, write_frames_mcap
from logtools.writers.tractor_trailer import JSON_BINDINGS, run_frames, run_metadata, write_run

REPO = Path(__file__).resolve().parents[1]
DAY_NS = 86_400 * 10**9
T0_NS = 1_760_000_000 * 10**9
HOSTILE_TOPIC = '/<script>alert("t")</script>&x'
HOSTILE_FILE = "<img src=x onerror=alert(1)>.mcap"
HOSTILE_ROBOT_ID = '<b onmouseover="alert(2)">robot</b>'
FAST = AnalysisOptions(repeats=2, discovery=False, views=False)


def sim_log(
    path: Path,
    *,
    L1: float = 1.25,
    seed: int = 0,
    day: int = 0,
    duration_s: float = 63.0,
    hostile_topics: bool = False,
) -> Path:
    """A 63 s harmonic drive at 20 Hz (JSON MCAP) starting ``day`` days after T0."""
    cfg = preset("harmonic", L1=L1, duration_s=duration_s, rate_hz=20.0)
    cfg = dataclasses.replace(cfg, start_time_ns=T0_NS + day * DAY_NS)
    run = simulate_tractor_trailer(cfg, seed=seed)
    path.parent.mkdir(parents=True, exist_ok=True)
    if hostile_topics:
        bindings = tuple(
            dataclasses.replace(b, topic=HOSTILE_TOPIC + b.topic) for b in JSON_BINDINGS
        )
        write_frames_mcap(
            path, run_frames(run), bindings, JsonEncoder(), metadata=run_metadata(run)
        )
    else:
        write_run(path, run, metadata=run_metadata(run))
    return path


def hostile_map(path: Path) -> Path:
    """A channel map naming the hostile topics."""
    lines = []
    for b in JSON_BINDINGS:
        for field, signal in b.fields.items():
            topic = (HOSTILE_TOPIC + b.topic).replace("\\", "\\\\").replace('"', '\\"')
            lines.append(f'[signals.{signal}]\ntopic = "{topic}"\nfield = "{field}"\n')
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def small_archive(root: Path, n: int = 6) -> Path:
    """``n`` simulated logs of one robot (days 0..n-1) and a corrupt file."""
    for i in range(n):
        sim_log(root / "truckA" / f"a{i:02d}.mcap", seed=10 + i, day=i)
    (root / "bad").mkdir(parents=True)
    (root / "bad" / "corrupt.mcap").write_bytes(b"\x89MCAP0\r\n" + bytes(range(256)) * 4)
    return root


def full_archive(root: Path) -> Path:
    """The archive of the end-to-end tests (10 analysable logs, 4 failing)."""
    (root / "truckA").mkdir(parents=True)
    (root / "truckA" / "logcal.toml").write_text('robot_id = "truck-A"\n')
    for i in range(4):
        sim_log(root / "truckA" / f"a{i}.mcap", seed=1 + i, day=i)
    for i, L1 in enumerate((1.25, 1.25, 1.45, 1.45)):  # the hitch was moved after day 1
        sim_log(root / "truckB" / f"b{i}.mcap", L1=L1, seed=20 + i, day=i)
    (root / "samples").mkdir()
    shutil.copy(REPO / "sample_logs" / "tt_harmonic_clean.mcap", root / "samples")
    (root / "bad").mkdir()
    (root / "bad" / "corrupt.mcap").write_bytes(b"\x89MCAP0\r\n" + bytes(range(256)) * 4)
    sim_log(root / "unknown" / "u.mcap", seed=30)
    (root / "unknown" / "logcal.toml").write_text('robot = "hovercraft"\n')
    sim_log(root / "hostile" / HOSTILE_FILE, seed=31, hostile_topics=True)
    mapped = root / "hostile_mapped"
    sim_log(mapped / "run&<i>.mcap", seed=32, hostile_topics=True)
    hostile_map(mapped / "map.toml")
    robot_id = HOSTILE_ROBOT_ID.replace('"', '\\"')
    (mapped / "logcal.toml").write_text(f'channel_map = "map.toml"\nrobot_id = "{robot_id}"\n')
    return root
