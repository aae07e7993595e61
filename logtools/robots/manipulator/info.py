"""The manipulator's part of ``logcal info`` (``RobotPlugin.info``): with ``--urdf``, the URDF's
transmissions (what ``--effort actuator`` uses), each with its line for people."""

from __future__ import annotations

from logtools.robots.info import InfoSection
from logtools.robots.manipulator.options import ManipulatorOptions

__all__ = ["info_section"]


def info_section(options: ManipulatorOptions) -> InfoSection | None:
    """The transmissions of ``options.urdf`` (``calib.manipulator.serial.read_transmissions``)
    under the JSON key ``urdf``; None without ``--urdf``.

    Raises:
        LogcalInputError: the URDF cannot be read (the message names ``--urdf`` and the file).
    """
    if not options.urdf:
        return None
    from calib.errors import CalibError
    from calib.manipulator.serial import read_transmissions, urdf_path
    from logtools.errors import LogcalInputError

    try:
        path = urdf_path(options.urdf)
        found = read_transmissions(path)
    except CalibError as err:
        raise LogcalInputError(f"--urdf {options.urdf}: {err}") from err
    rows = [{**t.to_dict(), "simple": t.simple, "line": t.describe()} for t in found]
    shown = [f"  {row['line']}" for row in rows] or ["  none"]
    return InfoSection(
        "urdf", {"source": str(path), "transmissions": rows}, (f"Transmissions in {path}:", *shown)
    )
