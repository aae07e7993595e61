"""Reader throughput: logcal's read_log vs the stock mcap ``iter_decoded_messages``, same run.

Writes a JSON drive log (LOG_FORMAT topics, zstd chunks) and a ROS 2 log into a temporary
directory, then times (best of --repeat) reading every message into per-topic columns:

* stock: ``make_reader(...).iter_decoded_messages()`` with a json.loads / mcap_ros2 decoder,
  appending each decoded message to Python lists (the per-message baseline);
* logcal: ``logtools.readers.read_log`` (raw scan, then bulk decoding per channel).

Usage: python bench/bench_read.py [--messages 400000] [--ros2-messages 20000] [--repeat 3]
Prints messages per second and the ratio logcal/stock.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
from mcap.decoder import DecoderFactory as McapDecoderFactory
from mcap.reader import make_reader
from mcap.writer import Writer

from logtools.readers import read_log

TOPICS = {
    "/cmd/curvature": ("curvature",),
    "/odom": ("v", "omega"),
    "/pose": ("x", "y", "yaw"),
    "/hitch/angle": ("angle",),
}


class _JsonFactory(McapDecoderFactory):
    def decoder_for(self, message_encoding, schema):
        return json.loads if message_encoding == "json" else None


def write_json_log(path: Path, n_messages: int) -> None:
    rng = np.random.default_rng(0)
    per_topic = n_messages // len(TOPICS)
    with path.open("wb") as fh:
        w = Writer(fh)
        w.start("", "bench")
        ids = {
            t: w.register_channel(t, "json", w.register_schema(t, "jsonschema", b"{}"))
            for t in TOPICS
        }
        values = rng.normal(size=(per_topic, 3))
        for i in range(per_topic):
            t = 1_700_000_000_000_000_000 + i * 10_000_000
            for topic, fields in TOPICS.items():
                msg = {f: float(values[i, k]) for k, f in enumerate(fields)}
                w.add_message(ids[topic], t, json.dumps(msg).encode(), t)
        w.finish()


def write_ros2_log(path: Path, n_messages: int) -> None:
    from mcap_ros2.writer import Writer as Ros2Writer

    with path.open("wb") as fh:
        w = Ros2Writer(fh)
        schema = w.register_msgdef("std_msgs/msg/Float64", "float64 data")
        for i in range(n_messages):
            t = 1_700_000_000_000_000_000 + i * 10_000_000
            w.write_message("/hitch/angle", schema, {"data": 0.001 * i}, t, t)
        w.finish()


def stock_read(path: Path) -> int:
    from mcap_ros2.decoder import DecoderFactory as Ros2Factory

    columns: dict[str, list] = {}
    n = 0
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[_JsonFactory(), Ros2Factory()])
        for _, channel, message, decoded in reader.iter_decoded_messages():
            columns.setdefault(channel.topic, []).append((message.log_time, decoded))
            n += 1
    return n


def logcal_read(path: Path) -> int:
    return sum(f.height for f in read_log(path).topics.values())


def best_rate(fn, path: Path, repeat: int) -> tuple[float, int]:
    best = float("inf")
    n = 0
    for _ in range(repeat):
        t0 = time.perf_counter()
        n = fn(path)
        best = min(best, time.perf_counter() - t0)
    return n / best, n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--messages", type=int, default=400_000)
    ap.add_argument("--ros2-messages", type=int, default=20_000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        logs = {"json": Path(d) / "json.mcap", "ros2": Path(d) / "ros2.mcap"}
        write_json_log(logs["json"], args.messages)
        write_ros2_log(logs["ros2"], args.ros2_messages)
        for name, path in logs.items():
            stock, n_stock = best_rate(stock_read, path, args.repeat)
            ours, n_ours = best_rate(logcal_read, path, args.repeat)
            assert n_stock == n_ours, (n_stock, n_ours)
            size_mb = path.stat().st_size / 1e6
            print(
                f"{name:5s} {n_ours:>8d} msgs ({size_mb:.1f} MB): stock iter_decoded_messages "
                f"{stock:>10,.0f} msg/s | logcal read_log {ours:>10,.0f} msg/s | "
                f"ratio {ours / stock:.1f}x"
            )


if __name__ == "__main__":
    main()
