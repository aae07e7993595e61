"""Write a simulated arm run (:class:`calib.manipulator.simulate.ArmRun`) per LOG_FORMAT.md:
``/joint_states`` with ``name``, ``position``, ``velocity``, ``effort`` arrays, as a JSON MCAP,
a ROS 2 MCAP (``sensor_msgs/msg/JointState``), both through the one MCAP writer
(:func:`logtools.writers.mcap_writer.write_frames_mcap`), or a CSV (``t``, ``q1..``, ``qd1..``,
``tau1..``).
"""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np
import polars as pl

from calib.manipulator.simulate import ArmRun
from logtools.errors import LogWriteError
from logtools.writers.encoding import Encoding
from logtools.writers.mcap_writer import CdrEncoder, JsonEncoder, TopicBinding, write_frames_mcap

__all__ = ["JOINT_TOPIC", "arm_metadata", "write_arm_run"]

JOINT_TOPIC = "/joint_states"


def arm_metadata(
    run: ArmRun,
    *,
    model_terms: tuple[str, ...] | None = None,
    nominal: Mapping[str, float] | None = None,
    urdf: str | None = None,
    include_truth: bool = True,
    seed: int | None = None,
) -> dict[str, dict[str, str]]:
    """The ``logcal`` record: ``robot`` = manipulator, ``joints``, the model (``model``,
    ``urdf``), the terms the log's model declares (``model_terms``), the nominal link parameters
    it declares (``nominal.<name>``) and, when ``include_truth``, the true values."""
    rec: dict[str, str] = {"robot": "manipulator", "joints": ",".join(run.joint_names)}
    rec.update({k: v for k, v in run.meta.items() if k == "model"})
    if urdf:
        rec["urdf"] = urdf
    if seed is not None:
        rec["seed"] = str(seed)
    if model_terms is not None:
        rec["model_terms"] = ",".join(model_terms)
    for k, v in (nominal or {}).items():
        rec[f"nominal.{k}"] = repr(float(v))
    if include_truth:
        rec.update({k: repr(float(v)) for k, v in run.truth.items()})
    elif run.meta.get("model") == "planar2":
        rec.update({k: repr(float(run.truth[k])) for k in ("l1", "l2", "g") if k in run.truth})
    return {"logcal": rec}


def _stamps_ns(run: ArmRun) -> np.ndarray:
    ns = np.round((run.t_s - run.t_s[0]) * 1e9).astype(np.int64)
    ns[1:] = np.maximum(ns[1:], ns[:-1] + 1)
    return ns


def write_arm_run(
    path: str | os.PathLike[str],
    run: ArmRun,
    *,
    encoding: Encoding = "json",
    metadata: Mapping[str, Mapping[str, str]] | None = None,
) -> int:
    """Write ``run`` as ``json`` or ``ros2`` MCAP, or ``csv`` (no metadata). Returns the number
    of messages (rows for CSV).

    Raises:
        LogWriteError: the file cannot be written.
    """
    names = list(run.joint_names)
    ns = _stamps_ns(run)
    meta = arm_metadata(run) if metadata is None else metadata
    if str(encoding) == "csv":
        return _write_csv(path, run, ns)
    n = run.q.shape[1]
    columns: dict[str, np.ndarray] = {"t_ns": ns}
    fields: dict[str, str] = {}
    for array, values in (("position", run.q), ("velocity", run.qd), ("effort", run.tau)):
        for j in range(n):
            columns[f"{array}{j}"] = values[:, j]
            fields[f"{array}.{j}"] = f"{array}{j}"
    frames = {"joints": pl.DataFrame(columns)}
    if str(encoding) == "ros2":
        binding = TopicBinding(
            JOINT_TOPIC,
            "joints",
            "sensor_msgs/msg/JointState",
            fields,
            constants={"name": names, "header.frame_id": ""},
            stamp_field="header.stamp",
        )
        return write_frames_mcap(path, frames, [binding], CdrEncoder(), metadata=meta)
    if str(encoding) == "json":
        binding = TopicBinding(
            JOINT_TOPIC, "joints", "sensor_msgs/JointState", fields, constants={"name": names}
        )
        return write_frames_mcap(path, frames, [binding], JsonEncoder(), metadata=meta)
    raise LogWriteError(f"unknown log encoding {encoding!r}; expected json, ros2 or csv")


def _write_csv(path: str | os.PathLike[str], run: ArmRun, ns: np.ndarray) -> int:
    n = run.q.shape[1]
    header = ["t"] + [f"{p}{j + 1}" for p in ("q", "qd", "tau") for j in range(n)]
    data = np.column_stack([ns / 1e9, run.q, run.qd, run.tau])
    try:
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(",".join(header) + "\n")
            np.savetxt(fh, data, delimiter=",", fmt="%.17g")
    except OSError as err:
        raise LogWriteError(f"{os.fspath(path)}: cannot write the log ({err.strerror})") from err
    return len(data)


def write_simulated_arm(
    path: str | os.PathLike[str],
    *,
    arm: str = "planar2",
    encoding: Encoding = "json",
    duration_s: float = 20.0,
    rate_hz: float | None = None,
    seed: int = 0,
    torque_noise: float = 0.05,
    payload: float = 0.0,
    conceal: str | None = None,
) -> tuple[ArmRun, int]:
    """Simulate an arm and write its log; ``arm`` is ``planar2`` (the paper's arm, torque
    driven) or a URDF path / example-robot-data name (exciting trajectory, inverse dynamics).

    ``conceal``: ``friction`` (the metadata's model declares no friction and carries no friction
    truth) or ``payload`` (the metadata declares the links without the payload); None: the
    metadata declares everything simulated. Returns the run and the number of messages.
    """
    from calib.manipulator.planar import Planar2Params
    from calib.manipulator.simulate import Friction, Sensors, simulate_planar, simulate_trajectory

    sensors = Sensors(torque_noise=torque_noise)
    terms: tuple[str, ...] = (
        () if conceal == "friction" else ("coulomb_friction", "viscous_friction")
    )
    nominal: dict[str, float] = {}
    urdf = None
    if arm == "planar2":
        p = Planar2Params(payload=payload)
        run = simulate_planar(
            p,
            Friction(),
            duration_s=duration_s,
            dt=1.0 / (rate_hz or 500.0),
            sensors=sensors,
            seed=seed,
        )
        nominal = {k: getattr(p, k) for k in ("m1", "m2", "r1", "r2", "I1", "I2")}
        nominal["payload"] = 0.0 if conceal == "payload" else payload
    else:
        from calib.manipulator.serial import load_serial_arm

        model = load_serial_arm(arm, None, _movable_count(arm))
        n = len(model.joint_names)
        lo, hi = model.limits()
        center = np.where(np.isfinite(lo + hi), (lo + hi) / 2, 0.0)
        amp = np.where(np.isfinite(hi - lo), 0.35 * (hi - lo), 1.0)
        run = simulate_trajectory(
            model,
            Friction(coulomb=(0.3,) * n, viscous=(0.2,) * n),
            duration_s=duration_s,
            rate_hz=rate_hz or 1000.0,
            payload=payload,
            sensors=sensors,
            seed=seed,
            center=center,
            amplitude=amp,
        )
        urdf = arm
    meta = arm_metadata(
        run, model_terms=terms, nominal=nominal, urdf=urdf, include_truth=True, seed=seed
    )
    rec = meta["logcal"]
    if arm != "planar2":
        rec["nominal"] = "false" if conceal != "payload" else "true"
    if conceal == "friction":
        for k in [k for k in rec if k.startswith(("Fc[", "Fv["))]:
            del rec[k]
    if conceal == "payload":
        rec.pop("payload", None)
    return run, write_arm_run(path, run, encoding=encoding, metadata=meta)


def _movable_count(arm: str) -> int:
    """Joints to simulate of a URDF arm: its arm joints (fingers and grippers left out)."""
    from calib.manipulator.serial import movable_joints

    names = movable_joints(arm)
    return len([n for n in names if not any(h in n for h in ("finger", "gripper", "hand"))])
