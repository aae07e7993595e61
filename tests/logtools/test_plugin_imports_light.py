"""Loading every robot plugin's declaration imports none of the robots' analysis stacks.

Resolving any log's robot loads all plugins (``logtools.robots.plugins()``), so a plugin's
declaration module must keep scipy.stats, pinocchio and its ``calib`` estimators out of its
imports (they cost ~0.7 s CPU per run of ``logcal``). Checked in a fresh interpreter,
since this test session has imported them already.
"""

from __future__ import annotations

import json
import subprocess
import sys

HEAVY = (
    "scipy.stats",
    "pinocchio",
    "example_robot_data",
    "calib.diff_drive.odometry_lsq",
    "calib.manipulator.identify",
)

_CODE = f"""
import json, sys
import logtools.robots as r
names = [p.name for p in r.plugins()]
before = [m for m in {HEAVY!r} if m in sys.modules]
import logtools.robots.diff_drive.pipeline, logtools.robots.manipulator.pipeline
after = [m for m in {HEAVY!r} if m in sys.modules]
print(json.dumps({{"names": names, "before": before, "after": after}}))
"""


def test_plugin_declarations_import_no_analysis_stack() -> None:
    out = subprocess.run(
        [sys.executable, "-c", _CODE], capture_output=True, text=True, check=True, timeout=120
    )
    found = json.loads(out.stdout.strip().splitlines()[-1])
    assert {"tractor_trailer", "diff_drive", "manipulator"} <= set(found["names"])
    assert found["before"] == [], f"plugin declarations imported {found['before']}"
    # the check sees these modules when they are imported: the pipelines do bring them in
    assert {"scipy.stats", "calib.diff_drive.odometry_lsq", "calib.manipulator.identify"} <= set(
        found["after"]
    )
