"""Any serial arm from its URDF, through pinocchio's joint-torque regressor.

pinocchio's ``computeJointTorqueRegressor(q, qd, qdd)`` gives ``tau = Y theta`` with ten
parameters per link (m, m*c, inertia about the joint frame). The momentum form is built from the
same function, so no hand-derived dynamics are needed for a new arm:

* ``p = M(q) qd`` is the regressor of the same model **without gravity** at zero velocity and
  acceleration ``qd``: ``Y_p(q, qd) = Y_0g(q, 0, qd)``;
* ``C(q, qd) qd + tau_g = Y(q, qd, 0)``, and ``M_dot qd`` is the directional derivative of
  ``Y_p(., qd)`` along ``qd`` (central difference, step 1e-6 rad), so that the rest of the
  momentum equation, ``-(C^T qd - tau_g) = C qd + tau_g - M_dot qd`` (using
  ``M_dot = C + C^T``), is ``Y_r = Y(q, qd, 0) - d/de Y_p(q + e qd, qd)``.

Each joint also gets a rotor (armature) inertia ``Ia`` on its own diagonal of M. A NAME instead of
a path loads the model of that name from the ``example-robot-data`` package (its URDFs sit under
``cmeel.prefix/share/example-robot-data/robots``). A URDF that welds to a link it never declares
(e.g. ``world``) is repaired by declaring it, and the repair is noted.

The URDF's ``<transmission>`` elements (ROS: what drives each joint and through which
mechanical reduction) are read by :func:`read_transmissions` with the standard library's expat
parser inside the same size budget, a depth budget, and no document type: a URDF that declares
a DOCTYPE or an entity is refused before either parser sees it (entities are never resolved).
urdfdom (pinocchio's parser) ignores transmissions, so they are read here; expat is used
directly rather than a tree builder so that the depth is counted as it is read.
"""

from __future__ import annotations

import math
import os
import re
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cached_property
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from calib.manipulator.model import ArmModelError, ParameterInfo
from calib.results import JsonRecord

__all__ = [
    "SerialArm",
    "Transmission",
    "example_robot_urdf",
    "load_serial_arm",
    "movable_joints",
    "read_transmissions",
    "urdf_path",
]

Array = NDArray[np.float64]

_LINK_PARAMS = (
    ("m", "kg"),
    ("mx", "kg*m"),
    ("my", "kg*m"),
    ("mz", "kg*m"),
    ("Ixx", "kg*m^2"),
    ("Ixy", "kg*m^2"),
    ("Iyy", "kg*m^2"),
    ("Ixz", "kg*m^2"),
    ("Iyz", "kg*m^2"),
    ("Izz", "kg*m^2"),
)
_FD_STEP = 1e-6
_TOOL_HINTS = ("tcp", "tool", "ee", "end_effector", "hand", "gripper")


def _robots_dir() -> Path | None:
    try:
        dist = metadata.distribution("example-robot-data")
    except metadata.PackageNotFoundError:
        return None
    path = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    return path if path.is_dir() else None


def example_robot_urdf(name: str) -> Path:
    """The URDF of ``name`` in example-robot-data (``panda``, ``tiago``, ``ur5_robot``, ...)."""
    root = _robots_dir()
    if root is None:
        raise ArmModelError(
            f"URDF {name!r}: not a file, and the example-robot-data package is not installed "
            "(pip install example-robot-data) to look it up by name."
        )
    if not _MODEL_NAME.fullmatch(name):  # a name, never a pattern: no globbing of user text
        raise ArmModelError(
            f"URDF {name!r}: not a file, and not a model name (letters, digits, '_', '-', '.')"
        )
    found = sorted(p for p in root.glob("*/**/*.urdf") if p.stem == name)
    if not found:
        known = sorted({p.stem for p in root.glob("*/**/*.urdf")})
        raise ArmModelError(
            f"URDF {name!r}: not a file and not a model of example-robot-data; expected a path "
            f"or one of {', '.join(known[:40])}, ..."
        )
    return found[0]


MAX_URDF_BYTES = 16 * 2**20
MAX_URDF_LINKS = 1024
MAX_CHAIN_DEPTH = 256
MAX_XML_DEPTH = 64
"""Budgets of a URDF read: its size, its links, the longest parent-to-child chain (the
parser recurses along it: a 4,000-link chain crashed the process) and the nesting of its
elements (a URDF nests a handful deep)."""
_DOCTYPE = re.compile(r"<!\s*(DOCTYPE|ENTITY)", re.IGNORECASE)
_MODEL_NAME = re.compile(r"[A-Za-z0-9_.-]{1,100}")


def _chain_depth(text: str) -> int:
    """The longest parent-to-child chain of the URDF's joints."""
    parent: dict[str, str] = {}
    for m in re.finditer(r"<joint\b.*?</joint>", text, flags=re.S):
        block = m.group(0)
        p = re.search(r"<parent\s+link\s*=\s*\"([^\"]+)\"", block)
        c = re.search(r"<child\s+link\s*=\s*\"([^\"]+)\"", block)
        if p and c:
            parent[c.group(1)] = p.group(1)
    depth: dict[str, int] = {}
    best = 0
    for start in parent:
        chain: list[str] = []
        node = start
        while node in parent and node not in depth and len(chain) <= len(parent):
            chain.append(node)
            node = parent[node]
        d = depth.get(node, 0)
        for n in reversed(chain):
            d += 1
            depth[n] = d
        best = max(best, d)
    return best


def _check_budget(path: Path, text: str) -> None:
    declared = _DOCTYPE.search(text)
    if declared:
        raise ArmModelError(
            f"{path}: declares a {declared.group(1).upper()}; a URDF logcal "
            "reads has no document type or entities (they are never resolved)"
        )
    links = len(re.findall(r"<link\b", text))
    if links > MAX_URDF_LINKS:
        raise ArmModelError(
            f"{path}: {links} links; a URDF logcal reads has at most {MAX_URDF_LINKS}"
        )
    depth = _chain_depth(text)
    if depth > MAX_CHAIN_DEPTH:
        raise ArmModelError(
            f"{path}: a chain of {depth} joints; a URDF logcal reads has chains "
            f"of at most {MAX_CHAIN_DEPTH}"
        )


@contextmanager
def _quiet_stderr() -> Iterator[list[str]]:
    """Capture what the C++ URDF parser writes to the process's stderr (it echoes attribute
    values of the file raw); the caller reports it escaped."""
    captured: list[str] = []
    try:
        saved = os.dup(2)
    except OSError:
        yield captured
        return
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield captured
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            captured.append(tmp.read(4096).decode("utf-8", "replace"))


def _escaped(text: str) -> str:
    return "".join(c if c.isprintable() else f"\\x{ord(c):02x}" for c in text.strip())


def _read_urdf(path: Path) -> str:
    """The URDF's text, within the size budget, with no document type (see the budgets)."""
    try:
        size = path.stat().st_size
    except OSError as err:
        raise ArmModelError(f"{path}: cannot read this URDF ({err.strerror or err})") from err
    if size > MAX_URDF_BYTES:
        raise ArmModelError(
            f"{path}: {size} bytes; a URDF logcal reads is at most {MAX_URDF_BYTES} bytes"
        )
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as err:
        raise ArmModelError(f"{path}: cannot read this URDF ({err.strerror or err})") from err
    _check_budget(path, text)
    return text


def _build(path: Path) -> tuple[Any, list[str]]:
    import pinocchio as pin

    text = _read_urdf(path)
    notes: list[str] = []
    declared = set(re.findall(r"<link\s+name\s*=\s*\"([^\"]+)\"", text))
    used = set(re.findall(r"<(?:parent|child)\s+link\s*=\s*\"([^\"]+)\"", text))
    missing = sorted(used - declared)
    if missing:  # repaired before parsing, so urdfdom does not print its own error
        text = re.sub(
            r"(<robot\b[^>]*>)",
            lambda m: m.group(1) + "".join(f'<link name="{n}"/>' for n in missing),
            text,
            count=1,
        )
        notes.append(f"{path.name}: declared the missing link(s) {', '.join(missing)} to load it")
    with _quiet_stderr() as said:
        try:
            model = pin.buildModelFromXML(text)
        except (RuntimeError, ValueError) as err:
            failure: Exception | None = err
        else:
            failure = None
    echoed = _escaped(said[0]) if said and said[0].strip() else ""
    if failure is not None:
        raise ArmModelError(
            f"{path}: pinocchio cannot read this URDF ({_escaped(str(failure))})"
            + (f"; the parser said: {echoed[:300]}" if echoed else "")
        )
    if echoed:
        notes.append(f"{path.name}: the URDF parser said: {echoed[:300]}")
    return model, notes


def movable_joints(urdf: str) -> tuple[str, ...]:
    """Names of the URDF's moving joints, in its order (``urdf``: path or example-robot NAME)."""
    path = Path(urdf).expanduser()
    full, _ = _build(path if _is_file(path) else example_robot_urdf(urdf))
    return tuple(full.names[i] for i in range(1, full.njoints) if full.joints[i].nv > 0)


def _is_file(path: Path) -> bool:
    """``path.is_file()``, False when the name cannot even be looked up (too long, ...)."""
    try:
        return path.is_file()
    except OSError:
        return False


def urdf_path(urdf: str) -> Path:
    """The file of ``urdf``: a path, else an example-robot-data model NAME.

    Raises:
        ArmModelError: no such file, and not a model name.
    """
    path = Path(urdf).expanduser()
    if not _is_file(path):
        if any(sep in urdf for sep in ("/", "\\")) or urdf.endswith(".urdf"):
            raise ArmModelError(f"URDF {urdf}: no such file")
        path = example_robot_urdf(urdf)
    return path


@dataclass(frozen=True)
class Transmission(JsonRecord):
    """One ``<transmission>`` of a URDF.

    Attributes:
        name: its ``name``.
        kind: the last part of its type (``SimpleTransmission``, ``DifferentialTransmission``,
            ...): the ``<type>`` (or ROS 2's ``<plugin>``) element, or the older ``type``
            attribute.
        joints: the joints it drives.
        actuators: the actuators driving them.
        reduction: a simple transmission's mechanical reduction (joint effort = reduction x
            actuator effort): the actuator's ``<mechanicalReduction>``, else the one directly
            under ``<transmission>`` (the older form), else the joint's (ROS 2's
            ``mechanical_reduction`` alike); None when none is given or the transmission is not
            simple.
    """

    name: str
    kind: str
    joints: tuple[str, ...]
    actuators: tuple[str, ...]
    reduction: float | None

    @property
    def simple(self) -> bool:
        """One actuator drives one joint through one reduction."""
        return (
            self.kind == "SimpleTransmission" and len(self.joints) == 1 and len(self.actuators) <= 1
        )

    def describe(self) -> str:
        """One line for people: name, type, joint(s), actuator(s), reduction."""
        red = f", mechanical reduction {self.reduction:g}" if self.reduction is not None else ""
        return (
            f"{self.name} ({self.kind or 'no type'}): joint {', '.join(self.joints) or '-'}"
            f" <- actuator {', '.join(self.actuators) or '-'}{red}"
        )


_REDUCTION_TAGS = ("mechanicalReduction", "mechanical_reduction")


class _TransmissionReader:
    """expat handlers collecting ``<transmission>`` elements within the depth budget; any
    document type or entity declaration is refused as it is met."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.stack: list[str] = []
        self.text: list[str] = []
        self.found: list[Transmission] = []
        self.current: dict[str, Any] | None = None
        self.at = 0  # depth of the open <transmission>

    def refuse(self, *_: Any) -> Any:
        raise ArmModelError(
            f"{self.path}: declares a DOCTYPE or an entity; a URDF logcal reads "
            "has no document type or entities (they are never resolved)"
        )

    def start(self, tag: str, attrs: dict[str, str]) -> None:
        self.stack.append(tag)
        if len(self.stack) > MAX_XML_DEPTH:
            raise ArmModelError(
                f"{self.path}: elements nested more than {MAX_XML_DEPTH} deep; "
                f"a URDF logcal reads nests at most {MAX_XML_DEPTH}"
            )
        self.text = []
        depth = len(self.stack)
        if tag == "transmission" and self.current is None:
            self.current = {
                "name": attrs.get("name", ""),
                "type": attrs.get("type", ""),
                "joints": [],
                "actuators": [],
                "red": {},
            }
            self.at = depth
        elif self.current is not None and depth == self.at + 1 and tag in ("joint", "actuator"):
            self.current[tag + "s"].append(attrs.get("name", ""))

    def chars(self, data: str) -> None:
        self.text.append(data)

    def end(self, tag: str) -> None:
        depth = len(self.stack)
        self.stack.pop()
        cur = self.current
        if cur is None:
            return
        text = "".join(self.text).strip()
        self.text = []
        if depth == self.at:
            self.found.append(self._finish(cur))
            self.current = None
        elif depth == self.at + 1 and tag in ("type", "plugin"):
            cur["type"] = text
        elif tag in _REDUCTION_TAGS and depth in (self.at + 1, self.at + 2):
            where = "transmission" if depth == self.at + 1 else self.stack[-1]
            cur["red"].setdefault(where, self._number(cur["name"], text))

    def _number(self, name: str, text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value) or value == 0:
            raise ArmModelError(
                f"{self.path}: transmission {name!r}: mechanicalReduction "
                f"{text[:40]!r} is not a nonzero finite number"
            )
        return value

    @staticmethod
    def _finish(cur: dict[str, Any]) -> Transmission:
        kind = re.split(r"[/:]+", cur["type"])[-1] if cur["type"] else ""
        red = cur["red"]
        reduction = red.get("actuator", red.get("transmission", red.get("joint")))
        simple = kind == "SimpleTransmission"
        return Transmission(
            cur["name"],
            kind,
            tuple(cur["joints"]),
            tuple(cur["actuators"]),
            reduction if simple else None,
        )


def read_transmissions(urdf: str | Path) -> tuple[Transmission, ...]:
    """The ``<transmission>`` elements of ``urdf`` (a path or an example-robot-data NAME), in
    the file's order (none: an empty tuple).

    Raises:
        ArmModelError: the URDF cannot be found or read, is beyond a budget, declares a
            document type or an entity, is not well-formed XML, or gives a reduction that is
            not a nonzero number.
    """
    from xml.parsers import expat

    path = urdf if isinstance(urdf, Path) else urdf_path(urdf)
    text = _read_urdf(path)
    reader = _TransmissionReader(path)
    parser = expat.ParserCreate()
    parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
    parser.StartDoctypeDeclHandler = reader.refuse
    parser.EntityDeclHandler = reader.refuse
    parser.UnparsedEntityDeclHandler = reader.refuse
    parser.ExternalEntityRefHandler = reader.refuse
    parser.StartElementHandler = reader.start
    parser.EndElementHandler = reader.end
    parser.CharacterDataHandler = reader.chars
    try:
        parser.Parse(text, True)
    except expat.ExpatError as err:
        raise ArmModelError(f"{path}: not well-formed XML ({_escaped(str(err))})") from err
    return tuple(reader.found)


def load_serial_arm(urdf: str, joint_names: tuple[str, ...] | None, n_joints: int) -> SerialArm:
    """The arm of ``urdf`` (a path, or an example-robot-data NAME) reduced to the logged joints.

    Args:
        urdf: URDF path or example-robot-data model name.
        joint_names: the log's joint names in column order; None: the first ``n_joints`` moving
            joints of the URDF, in its order.
        n_joints: how many joints the log has.

    Raises:
        ArmModelError: the URDF cannot be found or read, or the joints are not in it.
    """
    path = urdf_path(urdf)
    full, notes = _build(path)
    return SerialArm(full, joint_names, n_joints, source=str(path), notes=tuple(notes))


class SerialArm:
    """A pinocchio model reduced to the logged joints (others locked at their neutral value)."""

    def __init__(
        self,
        full: Any,
        joint_names: tuple[str, ...] | None,
        n_joints: int,
        source: str = "",
        notes: tuple[str, ...] = (),
    ) -> None:
        import pinocchio as pin

        movable = [full.names[i] for i in range(1, full.njoints) if full.joints[i].nv > 0]
        if joint_names is None or not any(joint_names):
            if len(movable) < n_joints:
                raise ArmModelError(
                    f"{source}: the log has {n_joints} joints, the URDF only {len(movable)}"
                )
            joint_names = tuple(movable[:n_joints])
        missing = [j for j in joint_names if j not in movable]
        if missing:
            raise ArmModelError(
                f"{source}: joint(s) {', '.join(missing)} of the log are not moving joints of "
                f"the URDF; expected names among {', '.join(movable)}"
            )
        lock = [full.getJointId(j) for j in movable if j not in joint_names]
        model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
        for name in joint_names:
            jid = model.getJointId(name)
            if model.joints[jid].nq != 1 or model.joints[jid].nv != 1:
                raise ArmModelError(
                    f"{source}: joint {name} is not a 1-DOF revolute or prismatic joint"
                )
        self.model = model
        self.source = source
        self.notes = notes
        self._names = tuple(joint_names)
        order = [model.joints[model.getJointId(j)].idx_v for j in joint_names]
        self._order = np.array(order)
        if sorted(order) != list(range(model.nv)):
            raise ArmModelError(f"{source}: the reduced model has joints the log does not name")
        self._data = model.createData()
        self._ng = pin.Model(model)
        self._ng.gravity = pin.Motion.Zero()
        self._ng_data = self._ng.createData()
        self._links = [
            model.names[model.getJointId(j)] for j in sorted(joint_names, key=model.getJointId)
        ]

    # ---------------------------------------------------------------- description
    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._names

    @cached_property
    def parameters(self) -> tuple[ParameterInfo, ...]:
        out = [
            ParameterInfo(f"{p}[{self.model.names[j]}]", u)
            for j in range(1, self.model.njoints)
            for p, u in _LINK_PARAMS
        ]
        out += [ParameterInfo(f"Ia[{n}]", "kg*m^2") for n in self._names]
        return tuple(out)

    @cached_property
    def nominal(self) -> Array:
        dyn = [self.model.inertias[j].toDynamicParameters() for j in range(1, self.model.njoints)]
        arm = np.asarray(self.model.armature, dtype=float)[self._order]
        return np.concatenate([*dyn, arm])

    @cached_property
    def transmissions(self) -> tuple[Transmission, ...]:
        """The URDF's transmissions (:func:`read_transmissions`; none without a file)."""
        path = Path(self.source)
        return read_transmissions(path) if self.source and _is_file(path) else ()

    def joint_kinds(self) -> tuple[str, ...]:
        """``revolute`` or ``prismatic`` per logged joint."""
        out = []
        for n in self._names:
            short = self.model.joints[self.model.getJointId(n)].shortname()
            out.append("prismatic" if "P" in short.replace("JointModel", "")[:2] else "revolute")
        return tuple(out)

    def limits(self) -> tuple[Array, Array]:
        lo = np.asarray(self.model.lowerPositionLimit, dtype=float)[self._order]
        hi = np.asarray(self.model.upperPositionLimit, dtype=float)[self._order]
        return lo, hi

    @cached_property
    def _tool(self) -> tuple[int, Array]:
        """(joint id, position in that joint's frame) of the tool point."""
        best: tuple[tuple[int, int, float], Array] | None = None
        for f in self.model.frames:
            score = int(any(h in f.name.lower() for h in _TOOL_HINTS))
            p = np.array(f.placement.translation, dtype=float)
            key = (f.parentJoint, score, float(np.linalg.norm(p)))
            if best is None or key > best[0]:
                best = (key, p)
        if best is None:
            raise ArmModelError(f"{self.source}: the model has no frames")
        return best[0][0], best[1]

    def payload_increment(self) -> Array:
        import pinocchio as pin

        joint, p = self._tool
        out = np.zeros(len(self.parameters))
        dyn = pin.Inertia(1.0, p, np.zeros((3, 3))).toDynamicParameters()
        out[(joint - 1) * 10 : joint * 10] = dyn
        return out

    # ---------------------------------------------------------------- regressors
    def _q(self, q: Array) -> Array:
        """Logged joint order -> the model's velocity order."""
        out = np.empty_like(q)
        out[:, self._order] = q
        return out

    def _stack(self, model: Any, data: Any, q: Array, v: Array, a: Array) -> Array:
        import pinocchio as pin

        Q, V, A = self._q(q), self._q(v), self._q(a)
        out = np.empty((len(q), q.shape[1], 10 * (self.model.njoints - 1)))
        for k in range(len(q)):
            out[k] = pin.computeJointTorqueRegressor(model, data, Q[k], V[k], A[k])
        return out[:, self._order, :]

    def _with_armature(self, Y: Array, x: Array) -> Array:
        n = x.shape[1]
        arm = np.zeros((len(x), n, n))
        idx = np.arange(n)
        arm[:, idx, idx] = x
        return np.concatenate([Y, arm], axis=2)

    def regressor(self, q: Array, qd: Array, qdd: Array) -> Array:
        return self._with_armature(self._stack(self.model, self._data, q, qd, qdd), qdd)

    def momentum(self, q: Array, qd: Array) -> Array:
        Y = self._stack(self._ng, self._ng_data, q, np.zeros_like(qd), qd)
        return self._with_armature(Y, qd)

    def rest(self, q: Array, qd: Array) -> Array:
        Ycg = self._stack(self.model, self._data, q, qd, np.zeros_like(qd))
        speed = np.maximum(np.linalg.norm(qd, axis=1, keepdims=True), 1e-12)
        eps = _FD_STEP / speed
        zero = np.zeros_like(qd)
        plus = self._stack(self._ng, self._ng_data, q + eps * qd, zero, qd)
        minus = self._stack(self._ng, self._ng_data, q - eps * qd, zero, qd)
        mdot = (plus - minus) / (2 * eps[:, :, None])
        return self._with_armature(Ycg - mdot, np.zeros_like(qd))

    # ---------------------------------------------------------------- drawing and simulation
    def points(self, q: Array) -> Array:
        import pinocchio as pin

        Q = self._q(q)
        joint, p = self._tool
        ids = [self.model.getJointId(n) for n in self._names]
        out = np.zeros((len(q), len(ids) + 2, 3))
        for k in range(len(q)):
            pin.forwardKinematics(self.model, self._data, Q[k])
            for i, j in enumerate(ids):
                out[k, i + 1] = self._data.oMi[j].translation
            out[k, -1] = self._data.oMi[joint].act(p)
        return out

    def inverse_dynamics(
        self, q: Array, qd: Array, qdd: Array, theta: Array | None = None
    ) -> Array:
        """(N, n) joint torques of the rigid body with parameters ``theta`` (default nominal)."""
        th = self.nominal if theta is None else theta
        return self.regressor(q, qd, qdd) @ th
