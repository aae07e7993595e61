"""Map a log's topics and fields onto the logical signals of LOG_FORMAT.md.

One module per concern:

* :mod:`~logtools.channel_map.toml`: channel-map files and ``--signal`` entries (parsing and
  checking every table, key and formula): :func:`load_channel_map`, :class:`ChannelMap`.
* :mod:`~logtools.channel_map.resolve`: the signals of one log (entries, defaults, formulas,
  the robots' derived signals; cleaned and checked): :func:`resolve_signals`.
* :mod:`~logtools.channel_map.extract`: one signal out of a topic (field, unit, stamp, a tf
  child frame, a joint by name).
* :mod:`~logtools.channel_map.names`: the logical signal names and units (the shared core's
  and those the robot plugins declare).
* :mod:`~logtools.channel_map.transforms`: the transforms an entry may name, open to a format's
  own (:func:`register_transform`, a quaternion's :class:`QuaternionLayout`).

What resolution gives, :class:`ResolvedSignals`, is a record of :mod:`logtools.loaded`.
"""

from __future__ import annotations

from logtools.channel_map.names import (
    JOINT_TOPIC,
    is_logical_signal,
    logical_signals,
)
from logtools.channel_map.resolve import PLAUSIBLE_LIMITS, resolve_signals
from logtools.channel_map.toml import (
    ChannelMap,
    load_channel_map,
    parse_signal_option,
    with_signal_options,
)
from logtools.channel_map.transforms import (
    TRANSFORMS,
    QuaternionLayout,
    Transform,
    quaternion_yaw,
    register_transform,
)
from logtools.loaded import FlatSignal, ResolvedSignals

__all__ = [
    "JOINT_TOPIC",
    "PLAUSIBLE_LIMITS",
    "TRANSFORMS",
    "ChannelMap",
    "FlatSignal",
    "QuaternionLayout",
    "ResolvedSignals",
    "Transform",
    "is_logical_signal",
    "load_channel_map",
    "logical_signals",
    "parse_signal_option",
    "quaternion_yaw",
    "register_transform",
    "resolve_signals",
    "with_signal_options",
]
