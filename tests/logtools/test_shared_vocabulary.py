"""The shared rooms name no robot: every signal name only a robot declares (its
``SignalSpec``s, beyond the shared core's ``SHARED_SIGNALS``), every robot's name and every
``[robot]`` key a robot declares is absent, as a quoted word, from the shared resolution, the
checks, the alignment and the shared palette; they read what a robot declares instead."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from logtools.channel_map.names import command_signals, heading_signals, signal_spec
from logtools.robots import plugins
from logtools.signals import SHARED_SIGNALS

ROOT = Path(__file__).resolve().parents[2]
SHARED_ROOMS = sorted(
    [
        ROOT / "logtools" / "signals.py",
        ROOT / "logtools" / "validate.py",
        ROOT / "logtools" / "align.py",
        *(ROOT / "logtools" / "channel_map").glob("*.py"),
        ROOT / "viz" / "style.py",
        ROOT / "viz" / "screenshot.py",
    ]
)


def _robot_words() -> set[str]:
    shared = {s.name for s in SHARED_SIGNALS}
    own = {s.name for p in plugins() for s in p.signals} - shared
    keys = {k.name for p in plugins() for k in p.robot_keys}
    return own | keys | {p.name for p in plugins()}


@pytest.mark.parametrize("room", SHARED_ROOMS, ids=lambda p: str(p.relative_to(ROOT)))
def test_a_shared_room_quotes_no_robot_word(room: Path) -> None:
    text = room.read_text(encoding="utf-8")
    found = sorted(w for w in _robot_words() if re.search(rf"[\"'`]{re.escape(w)}[\"'`]", text))
    assert found == [], f"{room.name} names {found}"


def test_what_the_rooms_read_comes_from_the_declarations() -> None:
    assert {"v_cmd", "omega_cmd", "kappa_cmd", "steer_cmd"} <= command_signals()
    assert {"yaw", "yaw2"} == heading_signals()
    psi, q3 = signal_spec("psi"), signal_spec("q3")
    assert psi is not None
    assert psi.within_turn
    assert psi.empty_when_zero
    assert q3 is not None
    assert (q3.name, q3.per_element) == ("q", "position")
