"""Log writers: simulated runs -> MCAP (JSON or ROS 2) and CSV drive logs (LOG_FORMAT.md).

The generic writers (:func:`write_frames_mcap_json`, :func:`write_frames_mcap_ros2`,
:func:`write_frames_csv`) map sensor-group frames onto topics through :class:`TopicBinding`
lists; the tractor-trailer writers declare theirs.
"""

from __future__ import annotations

from logtools.writers.csv_writer import frames_to_table, write_frames_csv
from logtools.writers.mcap_writer import (
    TopicBinding,
    json_schema,
    write_frames_mcap_json,
    write_frames_mcap_ros2,
)
from logtools.writers.ros2_msgdefs import MSGDEFS, msgdef
from logtools.writers.tractor_trailer import (
    ENCODINGS,
    run_metadata,
    write_csv,
    write_mcap_json,
    write_mcap_ros2,
    write_run,
)

__all__ = [
    "ENCODINGS",
    "MSGDEFS",
    "TopicBinding",
    "frames_to_table",
    "json_schema",
    "msgdef",
    "run_metadata",
    "write_csv",
    "write_frames_csv",
    "write_frames_mcap_json",
    "write_frames_mcap_ros2",
    "write_mcap_json",
    "write_mcap_ros2",
    "write_run",
]
