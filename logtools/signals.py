"""Logical signals, where they come from, and the default topic/field mapping of LOG_FORMAT.md.

Besides the tables of default names this module holds the small pieces a channel map is made of:
:class:`SignalSource` (topic, field and how to turn the field into the signal),
:class:`SignalOrigin` (how a signal was obtained when it is derived or derivable), units,
:class:`RobotConfig` (the ``[robot]`` table) and :class:`Formula`, a safe evaluator of the
arithmetic a channel map may use to derive one signal from others (parsed with :mod:`ast`,
never ``eval``).
"""

from __future__ import annotations

import ast
import math
from collections.abc import Mapping
from dataclasses import dataclass
from dataclasses import field as dc_field
from enum import StrEnum
from typing import Any

import numpy as np

__all__ = [
    "BASE_BODY",
    "DEFAULT_JSON_MAP",
    "DEFAULT_ROS2_MAP",
    "DEFAULT_ROS_MAP",
    "DERIVED_TOPIC",
    "FORMULA_FUNCTIONS",
    "SHARED_SIGNALS",
    "SIGNAL_UNITS",
    "UNIT_FACTORS",
    "Formula",
    "FormulaError",
    "OriginKind",
    "RobotConfig",
    "RobotKey",
    "SignalOrigin",
    "SignalSource",
    "SignalSpec",
    "Stamp",
    "default_candidates",
]


SIGNAL_UNITS: dict[str, str] = {
    "v": "m/s",
    "omega": "rad/s",
    "x": "m",
    "y": "m",
    "yaw": "rad",
    "v_cmd": "m/s",
    "omega_cmd": "rad/s",
}
"""SI unit of the signals the shared core knows itself (a mobile base's speed, yaw rate, pose and
velocity commands: more than one robot reads them); every other signal's unit is declared by the
robot that reads it (``SignalSpec.unit`` in its plugin)."""

UNIT_FACTORS: dict[str, tuple[str, float]] = {
    "rad": ("rad", 1.0),
    "deg": ("rad", math.pi / 180),
    "rad/s": ("rad/s", 1.0),
    "deg/s": ("rad/s", math.pi / 180),
    "m": ("m", 1.0),
    "cm": ("m", 1e-2),
    "mm": ("m", 1e-3),
    "m/s": ("m/s", 1.0),
    "km/h": ("m/s", 1 / 3.6),
    "1/m": ("1/m", 1.0),
}
"""Units a channel map may give a field in: unit -> (SI unit of the signal, factor to SI)."""

DERIVED_TOPIC = "(derived)"
"""The ``topic`` of a :class:`SignalSource` computed from other signals (``field``: formula)."""


class Stamp(StrEnum):
    """Which time a signal's samples get: the log's receive time or the message header stamp."""

    LOG = "log"
    HEADER = "header"


@dataclass(frozen=True)
class SignalSource:
    """Where a logical signal comes from: a topic and a flattened field path, and how to read it.

    The value is ``(field * scale + offset)`` converted from ``unit`` to the signal's SI unit
    (e.g. ``deg`` -> rad), after ``transform`` when one is named.

    Attributes:
        topic: topic name (:data:`DERIVED_TOPIC` for a formula).
        field: flattened field path (``twist.twist.linear.x``); for a formula its text.
        transform: ``yaw_from_quaternion`` | ``deg_to_rad`` | None.
        scale: factor applied to the field (dimensionless).
        offset: added after ``scale``, in the field's unit.
        unit: unit of the field (a key of :data:`UNIT_FACTORS`); None: already SI.
        stamp: sample times from the log (receive time) or from ``header.stamp``.
        frame: for arrays of stamped transforms (``tf2_msgs/TFMessage``): take the element
            whose ``child_frame_id`` is this frame; None: not such an array.
        formula: for a derived signal, the expression over other signal names.
        origin: where the entry was written (``map.toml [signals.yaw]``), for messages; not
            part of equality.
    """

    topic: str
    field: str
    transform: str | None = None
    scale: float = 1.0
    offset: float = 0.0
    unit: str | None = None
    stamp: Stamp = Stamp.LOG
    frame: str | None = None
    formula: str | None = None
    origin: str | None = dc_field(default=None, compare=False)

    @property
    def is_derived(self) -> bool:
        """True for a signal computed by a formula from other signals."""
        return self.formula is not None

    def describe(self) -> str:
        """``topic:field`` plus what is done to it, e.g. ``/cmd_vel:angular.z (deg)``."""
        if self.formula is not None:
            return f"= {self.formula}"
        extra = [
            *([self.transform] if self.transform else []),
            *([f"frame {self.frame}"] if self.frame else []),
            *([f"x {self.scale:g}"] if self.scale != 1.0 else []),
            *([f"{self.offset:+g}"] if self.offset != 0.0 else []),
            *([self.unit] if self.unit else []),
            *(["header stamp"] if self.stamp is Stamp.HEADER else []),
        ]
        how = f" ({', '.join(extra)})" if extra else ""
        return f"{self.topic}:{self.field}{how}"


class OriginKind(StrEnum):
    """The kinds of :class:`SignalOrigin` the shared resolution gives; a robot's derivation
    (``RobotPlugin.derived_signals``) names its own kinds."""

    LOGGED = "logged"  # a field of the log
    FORMULA = "formula"  # a channel-map formula


@dataclass(frozen=True)
class SignalOrigin:
    """How a signal was obtained: kept for every signal computed from others (a channel-map
    formula, a robot's derivation) and for a signal a robot could derive but the log holds.

    Attributes:
        kind: ``logged``, ``formula`` (:class:`OriginKind`) or the derivation's own kind.
        source: ``topic:field`` when logged, else the expression evaluated (e.g.
            ``v_cmd / 0.42``).
        description: one sentence for reports (the inputs, the constants and where they came
            from).
    """

    kind: str
    source: str
    description: str

    @property
    def by_robot(self) -> bool:
        """True when a robot's derivation computed the signal (neither logged nor a formula)."""
        return self.kind not in (OriginKind.LOGGED, OriginKind.FORMULA)

    def to_dict(self) -> dict[str, str]:
        """JSON-safe dictionary."""
        return {"kind": str(self.kind), "source": self.source, "description": self.description}


@dataclass(frozen=True)
class RobotKey:
    """A key of the channel map's ``[robot]`` table that a robot declares
    (``RobotPlugin.robot_keys``) because it is more than a nominal number: a text, a length
    that must be positive, a number the ``logcal`` metadata record may give.

    Attributes:
        name: the key.
        meaning: what it holds, for messages ("a file path or a model name").
        text: a string (a file, a model name), not a number.
        positive: a number that must be > 0 (in ``unit``).
        unit: the number's unit, for messages.
        from_metadata: when the channel map lacks it, the ``logcal`` metadata record's entry of
            that name gives it.
    """

    name: str
    meaning: str
    text: bool = False
    positive: bool = False
    unit: str = "m"
    from_metadata: bool = False


@dataclass(frozen=True)
class RobotConfig:
    """The ``[robot]`` table of a channel map.

    Attributes:
        type: robot type (a plugin's name, see ``logtools.robots``), None: from the log's
            metadata or its signals.
        params: nominal numbers by name (m or rad; the keys a robot declares, see
            :class:`RobotKey`, checked as it says).
        texts: text entries by name (the keys a robot declares as text).
    """

    type: str | None = None
    params: dict[str, float] = dc_field(default_factory=dict)
    texts: dict[str, str] = dc_field(default_factory=dict)

    def constants(self) -> dict[str, float]:
        """Named numbers a formula may use: the table's numbers."""
        return dict(self.params)

    def number(self, name: str) -> float | None:
        """The number ``name`` of the table; None without it."""
        return self.params.get(name)

    def text(self, name: str) -> str | None:
        """The text entry ``name`` of the table; None without it."""
        return self.texts.get(name)


@dataclass(frozen=True)
class SignalSpec:
    """One logical signal a robot reads: canonical name, SI unit and meaning (LOG_FORMAT.md), and
    what the shared resolution must know of it. A robot's plugin declares its own signals this
    way (``RobotPlugin.signals``); the shared core declares only :data:`SHARED_SIGNALS`.

    ``sources`` are default topic/field places to find it (tried after the shared defaults of
    :func:`default_candidates`, in order); a CSV column of the signal's name is always read.

    Attributes:
        name: the signal's name (a family of per-element signals stands for NAME1, NAME2, …).
        unit: its SI unit.
        meaning: one phrase for ``logcal info`` and the docs.
        required: the robot cannot be analysed without it.
        sources: default sources, in the order they are tried.
        command: a command: held between samples and allowed to be constant (never evidence
            that two logs hold one recording).
        empty_when_zero: zero in every sample means the field was never filled (an empty
            twist, an unconnected encoder): the source is not used and the next one is tried.
        within_turn: an angle that stays within one turn; beyond 2π it is in degrees.
        heading: an angle that may be unwrapped (a heading); its unit is told from its wraps
            and from ``heading_rate`` when the log has that signal.
        heading_rate: the signal that is this heading's rate (``omega`` for ``yaw``); None.
        joint_words: in a ``JointState``-like array (``name.i`` beside ``position.i``), the
            element is the one whose name contains the first word; on the default joint-state
            topic the name must hold every word. Empty: not picked by name.
        body: for a pose signal, the body whose pose it is (``base`` for ``x``, ``y``,
            ``yaw``): a topic the channel map reads one body's pose from gives no other body's
            pose by the default names. None: not a pose.
        per_element: the signal is a family of per-element signals ``NAME1``, ``NAME2``, …
            (one per joint), read from this array of the joint-state topic (``position``:
            ``position.0`` is ``NAME1``). None: a single signal.
    """

    name: str
    unit: str
    meaning: str
    required: bool = False
    sources: tuple[SignalSource, ...] = ()
    command: bool = False
    empty_when_zero: bool = False
    within_turn: bool = False
    heading: bool = False
    heading_rate: str | None = None
    joint_words: tuple[str, ...] = ()
    body: str | None = None
    per_element: str | None = None


BASE_BODY = "base"
"""The body whose pose ``x``, ``y``, ``yaw`` are (the robot's base)."""

SHARED_SIGNALS: tuple[SignalSpec, ...] = (
    SignalSpec("v_cmd", "m/s", "speed command", command=True),
    SignalSpec("omega_cmd", "rad/s", "yaw-rate command", command=True),
    SignalSpec("v", "m/s", "forward speed", empty_when_zero=True),
    SignalSpec("omega", "rad/s", "yaw rate", empty_when_zero=True),
    SignalSpec("x", "m", "position", body=BASE_BODY),
    SignalSpec("y", "m", "position", body=BASE_BODY),
    SignalSpec(
        "yaw",
        "rad",
        "heading",
        empty_when_zero=True,
        heading=True,
        heading_rate="omega",
        body=BASE_BODY,
    ),
)
"""The signals of a mobile base that more than one robot reads, with their default sources in
:func:`default_candidates` (LOG_FORMAT.md's topics, the standard ROS names, ``/tf``)."""


# Default mapping for the JSON encoding that `logcal simulate` writes.
DEFAULT_JSON_MAP: dict[str, SignalSource] = {
    "v_cmd": SignalSource("/cmd/vel", "v"),
    "omega_cmd": SignalSource("/cmd/vel", "omega"),
    "v": SignalSource("/odom", "v"),
    "omega": SignalSource("/odom", "omega"),
    "x": SignalSource("/pose", "x"),
    "y": SignalSource("/pose", "y"),
    "yaw": SignalSource("/pose", "yaw"),
}

# Default mapping for ROS 2 standard types on our topic names (field paths flattened with dots).
DEFAULT_ROS2_MAP: dict[str, SignalSource] = {
    "v_cmd": SignalSource("/cmd/vel", "linear.x"),
    "omega_cmd": SignalSource("/cmd/vel", "angular.z"),
    "v": SignalSource("/odom", "twist.twist.linear.x"),
    "omega": SignalSource("/odom", "twist.twist.angular.z"),
    "x": SignalSource("/pose", "pose.pose.position.x"),
    "y": SignalSource("/pose", "pose.pose.position.y"),
    "yaw": SignalSource("/pose", "pose.pose.orientation", transform="yaw_from_quaternion"),
}

_YAW = "yaw_from_quaternion"

# The standard ROS names, tried after ours: /cmd_vel (Twist), /odom (Odometry: pose and
# twist), /pose as a PoseStamped.
DEFAULT_ROS_MAP: dict[str, list[SignalSource]] = {
    "v_cmd": [SignalSource("/cmd_vel", "linear.x")],
    "omega_cmd": [SignalSource("/cmd_vel", "angular.z")],
    "x": [
        SignalSource("/pose", "pose.position.x"),
        SignalSource("/odom", "pose.pose.position.x"),
    ],
    "y": [
        SignalSource("/pose", "pose.position.y"),
        SignalSource("/odom", "pose.pose.position.y"),
    ],
    "yaw": [
        SignalSource("/pose", "pose.orientation", transform=_YAW),
        SignalSource("/odom", "pose.pose.orientation", transform=_YAW),
    ],
}

TF_TOPIC = "/tf"
TF_DEFAULT_FRAMES = ("base_link", "base_footprint")
"""Child frames of ``/tf`` taken as the pose (x, y, yaw) when no channel map names one."""


def tf_pose_sources(frame: str) -> dict[str, SignalSource]:
    """x, y, yaw from the ``/tf`` transform whose child frame is ``frame``."""
    return {
        "x": SignalSource(TF_TOPIC, "transform.translation.x", frame=frame),
        "y": SignalSource(TF_TOPIC, "transform.translation.y", frame=frame),
        "yaw": SignalSource(TF_TOPIC, "transform.rotation", transform=_YAW, frame=frame),
    }


def default_candidates(tf_frame: str | None = None) -> dict[str, list[SignalSource]]:
    """Per logical signal, the default sources in the order they are tried.

    Ours (JSON names, then ROS 2 types on our topics) come first, then the standard ROS names,
    then ``/tf``: the child frame ``tf_frame`` when given (then it comes before ``/odom``'s
    pose, since the user chose it), else ``base_link`` / ``base_footprint``.
    """
    out: dict[str, list[SignalSource]] = {}
    for table in (DEFAULT_JSON_MAP, DEFAULT_ROS2_MAP):
        for name, src in table.items():
            out.setdefault(name, []).append(src)
    for name, srcs in DEFAULT_ROS_MAP.items():
        out.setdefault(name, []).extend(srcs)
    frames = (tf_frame,) if tf_frame else TF_DEFAULT_FRAMES
    for fr in frames:
        for name, src in tf_pose_sources(fr).items():
            if tf_frame:
                out[name].insert(0, src)
            else:
                out[name].append(src)
    return out


# ---------------------------------------------------------------- formulas


class FormulaError(ValueError):
    """A formula that is not the small arithmetic a channel map allows (message says why)."""


def _atan2(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    return np.arctan2(y, x)


FORMULA_FUNCTIONS: dict[str, tuple[int, Any]] = {
    "tan": (1, np.tan),
    "sin": (1, np.sin),
    "cos": (1, np.cos),
    "atan": (1, np.arctan),
    "atan2": (2, _atan2),
    "sqrt": (1, np.sqrt),
    "abs": (1, np.abs),
}
"""Functions a formula may call: name -> (number of arguments, numpy function)."""

_CONSTANTS = {"pi": math.pi}
_BINARY = {ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply, ast.Div: np.divide}


@dataclass(frozen=True)
class Formula:
    """An arithmetic expression over signal names and numbers, parsed once with :mod:`ast`.

    Allowed: numbers, names, ``+ - * /``, unary ``-``/``+``, parentheses, ``pi`` and the
    functions of :data:`FORMULA_FUNCTIONS`. Anything else (attributes, subscripts, other calls,
    ``**``, comparisons, …) is refused, so evaluating a formula runs no user code.

    Attributes:
        text: the expression as written.
        names: the names it uses (signals or constants), sorted.
    """

    text: str
    names: tuple[str, ...]
    _tree: ast.expr = dc_field(repr=False, compare=False)

    @classmethod
    def parse(cls, text: str) -> Formula:
        """Parse ``text``.

        Raises:
            FormulaError: a syntax error or a construct that is not allowed.
        """
        try:
            tree = ast.parse(text.strip(), mode="eval").body
        except SyntaxError as err:
            raise FormulaError(f"formula {text!r} does not parse: {err.msg}") from err
        names: set[str] = set()
        _check(tree, text, names)
        return cls(text, tuple(sorted(names - set(_CONSTANTS))), tree)

    def evaluate(self, values: Mapping[str, np.ndarray | float]) -> np.ndarray:
        """Evaluate on arrays (float64, broadcast together) or numbers given by name.

        Raises:
            FormulaError: a name without a value.
        """
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return np.asarray(_eval(self._tree, values, self.text), dtype=float)


def _check(node: ast.AST, text: str, names: set[str]) -> None:
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            raise FormulaError(f"formula {text!r}: {node.value!r} is not a number")
    elif isinstance(node, ast.Name):
        names.add(node.id)
    elif isinstance(node, ast.BinOp):
        if type(node.op) not in _BINARY:
            raise FormulaError(f"formula {text!r}: only + - * / are allowed")
        _check(node.left, text, names)
        _check(node.right, text, names)
    elif isinstance(node, ast.UnaryOp):
        if not isinstance(node.op, (ast.USub, ast.UAdd)):
            raise FormulaError(f"formula {text!r}: only unary - and + are allowed")
        _check(node.operand, text, names)
    elif isinstance(node, ast.Call):
        fn = node.func.id if isinstance(node.func, ast.Name) else None
        if fn not in FORMULA_FUNCTIONS or node.keywords:
            raise FormulaError(
                f"formula {text!r}: calls only {', '.join(FORMULA_FUNCTIONS)} (positional "
                "arguments)"
            )
        nargs = FORMULA_FUNCTIONS[fn][0]
        if len(node.args) != nargs:
            raise FormulaError(f"formula {text!r}: {fn} takes {nargs} argument(s)")
        for arg in node.args:
            _check(arg, text, names)
    else:
        raise FormulaError(
            f"formula {text!r}: {type(node).__name__} is not allowed; use signal names, numbers, "
            f"+ - * / and {', '.join(FORMULA_FUNCTIONS)}"
        )


def _eval(node: ast.expr, values: Mapping[str, np.ndarray | float], text: str) -> Any:
    if isinstance(node, ast.Constant):
        return float(node.value)  # type: ignore[arg-type]  # _check allows numbers only
    if isinstance(node, ast.Name):
        if node.id in values:
            return values[node.id]
        if node.id in _CONSTANTS:
            return _CONSTANTS[node.id]
        raise FormulaError(f"formula {text!r}: no value for {node.id!r}")
    if isinstance(node, ast.BinOp):
        op = _BINARY[type(node.op)]
        return op(_eval(node.left, values, text), _eval(node.right, values, text))
    if isinstance(node, ast.UnaryOp):
        operand = _eval(node.operand, values, text)
        return np.negative(operand) if isinstance(node.op, ast.USub) else operand
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
        fn = FORMULA_FUNCTIONS[node.func.id][1]
        return fn(*(_eval(a, values, text) for a in node.args))
    raise FormulaError(f"formula {text!r}: {type(node).__name__} is not allowed")
