"""A URDF named by a log, a channel map or a settings file is data: a name the file system cannot
even look up (longer than NAME_MAX) is one clean ``ArmModelError``, not an ``OSError``
traceback (found by bench/fuzz_all.py, class ``urdf``)."""

from __future__ import annotations

import pytest

from calib.manipulator.model import ArmModelError
from calib.manipulator.serial import load_serial_arm, movable_joints, urdf_path


@pytest.mark.parametrize("name", ["x" * 5000, "a/" + "y" * 300 + ".urdf", "z" * 300])
def test_a_name_too_long_to_look_up_is_a_clean_error(name: str) -> None:
    with pytest.raises(ArmModelError, match="URDF"):
        urdf_path(name)
    with pytest.raises(ArmModelError, match="URDF"):
        load_serial_arm(name, None, 2)
    with pytest.raises(ArmModelError, match="URDF"):
        movable_joints(name)
