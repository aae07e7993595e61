"""``logcal batch`` at 100 / 1,000 / 10,000 logs on the local pool, on Ray with one node and on
Ray with several nodes on this machine: time per log (flat = linear), throughput per worker,
and whether every engine gives the same per-log results as the local pool.

    python bench/batch_10k.py [--sizes 100 1000 10000] [--engines local ray ray-nodes]
                              [--workers 2] [--nodes 2] [--distinct 50] [--duration 20]

The logs are simulated differential-drive drives (``--duration`` s, mixed driving; the
analysis takes ~15 ms each) so that 10,000 of them are analysed in minutes: ``--distinct``
different simulations (seeds and wheel-radius asymmetries), hard-linked to N paths in folders
of one robot each (10 robots). Each engine analyses each archive into a fresh output folder
(``run_batch(..., report=False)``: repeats 1, no discovery, no views), then the fleet table and
HTML report are written and timed apart.

Engines:

- ``local``: the process pool, ``--workers`` processes;
- ``ray``: a Ray cluster of one node with ``--workers`` CPUs (``ray start --head``);
- ``ray-nodes``: a head node with no CPU for tasks and ``--nodes`` worker nodes
  (``ray start --address=127.0.0.1:PORT``) sharing ``--workers`` CPUs, all on this machine.

The batch joins the clusters with ``run_batch(engine=Engine.RAY, address=...)`` (what
``logcal batch --engine ray --address ADDR`` does). The clusters use token authentication with
a token of their own (a file in the run's temporary folder) and a temporary folder of their own;
every Ray process this script starts is stopped by its process id when its engine is done (also
on Ctrl-C or an error), and the script checks that none is left.

Output: per engine and size, wall seconds of the analysis phase, ms per log, the ratio of that
to the 100-log figure of the same engine in the same run (1.0 = linear; the smallest archive
also carries the start-up of the workers, so later ratios below 1 are expected), the marginal
ms per added log, logs per second per worker, the mean analysis seconds per log (the workers'
own clock), the report's seconds, the load average before, and whether the per-log records
(the ``AnalysisResult`` JSON of each log) and the fleet table equal the local pool's. No timed
assertions: the machine is shared; compare ratios within one run.
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import json
import os
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import polars as pl

from logtools.batch.engines import Engine
from logtools.batch.runner import read_records, run_batch, write_fleet_outputs
from logtools.batch.worker import AnalysisOptions
from logtools.cli.main import main as logcal

ROBOTS = 10
OPTIONS = AnalysisOptions(repeats=1, discovery=False, views=False)


def make_sources(folder: Path, distinct: int, duration: float) -> list[Path]:
    """``distinct`` simulated diff-drive logs (seeds 0.., asymmetries -1 % .. +1 %)."""
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for i in range(distinct):
        path = folder / f"src{i:03d}.mcap"
        asym = -0.01 + 0.02 * i / max(distinct - 1, 1)
        with contextlib.redirect_stdout(None):
            code = logcal(
                [
                    "simulate",
                    "diff-drive",
                    "--out",
                    str(path),
                    "--duration",
                    f"{duration:g}",
                    "--seed",
                    str(i),
                    "--asymmetry",
                    f"{asym:.4f}",
                ]
            )
        assert code == 0, f"simulate diff-drive failed for seed {i}"
        out.append(path)
    return out


def make_archive(root: Path, n: int, sources: list[Path]) -> Path:
    """``n`` logs below ``root`` (``robotK/logNNNNN.mcap``), hard links to ``sources``."""
    for i in range(n):
        path = root / f"robot{i % ROBOTS}" / f"log{i:05d}.mcap"
        path.parent.mkdir(parents=True, exist_ok=True)
        src = sources[i % len(sources)]
        try:
            os.link(src, path)
        except OSError:
            shutil.copyfile(src, path)
    return root


# ------------------------------------------------------------------------------------- Ray


def _ray_bin() -> str:
    found = Path(sys.executable).parent / "ray"
    return str(found) if found.exists() else "ray"


def _children() -> dict[int, list[int]]:
    kids: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as fh:
                ppid = int(fh.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        kids.setdefault(ppid, []).append(int(entry))
    return kids


def _cluster_pids(temp_dir: str) -> set[int]:
    """Processes of the cluster whose temporary folder is ``temp_dir``: those naming it on
    their command line (GCS, raylets, agents, monitors) and all their descendants."""
    roots = set()
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/cmdline", "rb") as fh:
                cmd = fh.read()
        except OSError:
            continue
        if temp_dir.encode() in cmd:
            roots.add(int(entry))
    kids = _children()
    found, todo = set(), list(roots)
    while todo:
        pid = todo.pop()
        if pid in found or pid == os.getpid():
            continue
        found.add(pid)
        todo.extend(kids.get(pid, []))
    return found


def _stop_cluster(temp_dir: str) -> None:
    """Stop every process of the cluster by its process id (SIGTERM, then SIGKILL)."""
    for sig, wait in ((signal.SIGTERM, 5.0), (signal.SIGKILL, 2.0)):
        pids = _cluster_pids(temp_dir)
        if not pids:
            return
        for pid in pids:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.kill(pid, sig)
        deadline = time.monotonic() + wait
        while time.monotonic() < deadline and _cluster_pids(temp_dir):
            time.sleep(0.2)
    left = _cluster_pids(temp_dir)
    if left:
        raise RuntimeError(f"Ray processes {sorted(left)} of {temp_dir} did not stop")


@dataclass
class Cluster:
    address: str
    temp_dir: str
    nodes: int


@contextlib.contextmanager
def ray_cluster(*, cpus: int, nodes: int, port: int) -> Iterator[Cluster]:
    """A Ray cluster on this machine: one head (``nodes`` == 0: with ``cpus`` CPUs), or a head
    without CPUs for tasks and ``nodes`` worker nodes sharing ``cpus`` CPUs."""
    temp_dir = tempfile.mkdtemp(prefix="lcray", dir="/tmp")  # short: socket paths are limited
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}  # with the token of use_own_token
    common = [
        "--temp-dir",
        temp_dir,
        "--object-store-memory",
        str(300 * 2**20),
        "--disable-usage-stats",
    ]
    address = f"127.0.0.1:{port}"
    try:
        head_cpus = cpus if nodes == 0 else 0
        subprocess.run(
            [
                _ray_bin(),
                "start",
                "--head",
                "--port",
                str(port),
                "--node-ip-address",
                "127.0.0.1",
                "--num-cpus",
                str(head_cpus),
                "--include-dashboard",
                "false",
                *common,
            ],
            env=env,
            check=True,
            capture_output=True,
            timeout=180,
        )
        shares = [cpus // nodes + (i < cpus % nodes) for i in range(nodes)]
        for share in shares:
            subprocess.run(
                [_ray_bin(), "start", "--address", address, "--num-cpus", str(share), *common],
                env=env,
                check=True,
                capture_output=True,
                timeout=180,
            )
        yield Cluster(address, temp_dir, 1 + nodes)
    except subprocess.CalledProcessError as err:
        raise RuntimeError(
            f"ray start failed: {err.stderr.decode(errors='replace')[-2000:]}"
        ) from err
    finally:
        _stop_cluster(temp_dir)
        shutil.rmtree(temp_dir, ignore_errors=True)


def use_own_token(folder: Path) -> None:
    """Token authentication with a fresh token of this run (a file in ``folder``), for the
    clusters started here and this process (set before Ray is imported: it reads the mode
    once)."""
    token = folder / "ray_token"
    token.write_text(secrets.token_hex(32))
    token.chmod(0o600)
    os.environ["RAY_AUTH_MODE"] = "token"
    os.environ["RAY_AUTH_TOKEN_PATH"] = str(token)


def _cluster_nodes(address: str) -> int:
    import ray

    ray.init(address=address, log_to_driver=False)
    try:
        return sum(1 for n in ray.nodes() if n.get("Alive"))
    finally:
        ray.shutdown()


# ------------------------------------------------------------------------------ the bench


@dataclass
class Row:
    engine: str
    n: int
    wall: float
    report: float
    mean_s: float
    failed: int
    load: float
    same: str


def _outputs(out: Path) -> tuple[str, pl.DataFrame]:
    return (json.dumps(read_records(out), sort_keys=True), pl.read_parquet(out / "fleet.parquet"))


def run_engine(
    name: str,
    engine: Engine,
    workers: int,
    address: str | None,
    archives: dict[int, Path],
    work: Path,
    reference: dict[int, tuple[str, pl.DataFrame]],
) -> list[Row]:
    rows = []
    for n, archive in archives.items():
        out = work / f"out_{name}_{n}"
        load = os.getloadavg()[0]
        t0 = time.perf_counter()
        summary = run_batch(
            archive,
            out,
            options=OPTIONS,
            engine=engine,
            workers=workers,
            address=address,
            report=False,
        )
        wall = time.perf_counter() - t0
        t1 = time.perf_counter()
        write_fleet_outputs(out)
        report = time.perf_counter() - t1
        logs = json.loads((out / "manifest.json").read_text())["logs"].values()
        mean_s = sum(float(e["seconds"]) for e in logs) / max(len(logs), 1)
        outputs = _outputs(out)
        if n not in reference:
            reference[n] = outputs
            same = "(reference)"
        else:
            same = str(outputs[0] == reference[n][0] and outputs[1].equals(reference[n][1]))
        row = Row(name, n, wall, report, mean_s, len(summary.failed), load, same)
        rows.append(row)
        print(
            f"  {name:<10} {n:6d} logs: {wall:8.1f} s ({1e3 * wall / n:6.1f} ms/log), report "
            f"{report:6.1f} s, failed {row.failed}, load {load:.1f}, same as local: {same}",
            flush=True,
        )
        shutil.rmtree(out, ignore_errors=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 1000, 10000])
    ap.add_argument(
        "--engines",
        nargs="+",
        default=["local", "ray", "ray-nodes"],
        choices=["local", "ray", "ray-nodes"],
    )
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--nodes", type=int, default=2, help="worker nodes of ray-nodes")
    ap.add_argument("--distinct", type=int, default=50)
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--port", type=int, default=6391)
    args = ap.parse_args()
    sizes = sorted(args.sizes)
    with tempfile.TemporaryDirectory(prefix="logcal-bench-10k-") as tmp:
        work = Path(tmp)
        use_own_token(work)
        t0 = time.perf_counter()
        sources = make_sources(work / "sources", args.distinct, args.duration)
        archives = {n: make_archive(work / f"archive_{n}", n, sources) for n in sizes}
        print(
            f"archives {sizes}: {args.distinct} distinct {args.duration:g} s diff-drive "
            f"logs, hard-linked, {ROBOTS} robots ({time.perf_counter() - t0:.1f} s); "
            f"options {OPTIONS.fingerprint()}; {os.cpu_count()} CPUs, load "
            f"{os.getloadavg()[0]:.1f}",
            flush=True,
        )
        reference: dict[int, tuple[str, pl.DataFrame]] = {}
        rows: list[Row] = []
        workers_of: dict[str, int] = {}
        nodes_of: dict[str, int] = {}
        engines = sorted(dict.fromkeys(args.engines), key=lambda e: e != "local")
        for name in engines:  # the first (local when asked for) is the reference
            workers_of[name] = args.workers
            if name == "local":
                nodes_of[name] = 1
                rows += run_engine(
                    name, Engine.LOCAL, args.workers, None, archives, work, reference
                )
                continue
            try:
                import ray  # noqa: F401
            except ImportError:
                print(f"{name}: ray is not installed (pip install 'logcal[ray]'); skipped")
                continue
            nodes = 0 if name == "ray" else args.nodes
            try:
                with ray_cluster(cpus=args.workers, nodes=nodes, port=args.port) as c:
                    nodes_of[name] = _cluster_nodes(c.address)
                    print(
                        f"{name}: Ray cluster at {c.address}, {nodes_of[name]} nodes alive, "
                        f"{args.workers} CPUs for tasks",
                        flush=True,
                    )
                    rows += run_engine(
                        name, Engine.RAY, args.workers, c.address, archives, work, reference
                    )
            except RuntimeError as err:
                print(f"{name}: Ray could not run here: {err}")
        print(
            "\nengine      nodes workers   logs   wall s  ms/log  x100  marginal ms  "
            "logs/s/worker  mean analysis s  report s  load  same as local"
        )
        for name, group in itertools.groupby(rows, key=lambda r: r.engine):
            group_rows = list(group)
            base = group_rows[0]
            prev: Row | None = None
            for r in group_rows:
                marginal = (
                    "" if prev is None else f"{1e3 * (r.wall - prev.wall) / (r.n - prev.n):.1f}"
                )
                print(
                    f"{name:<11} {nodes_of.get(name, 1):5d} {workers_of[name]:7d} {r.n:6d} "
                    f"{r.wall:8.1f} {1e3 * r.wall / r.n:7.1f} "
                    f"{(r.wall / r.n) / (base.wall / base.n):5.2f} {marginal:>12} "
                    f"{r.n / r.wall / workers_of[name]:14.1f} {r.mean_s:16.4f} "
                    f"{r.report:9.1f} {r.load:5.1f}  {r.same}"
                )
                prev = r
    leftover = [p for p in _children().get(1, []) if _is_ray(p)]
    if leftover:
        print(f"warning: Ray processes still running: {leftover}")


def _is_ray(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as fh:
            cmd = fh.read()
    except OSError:
        return False
    return b"lcray" in cmd


if __name__ == "__main__":
    main()
