"""A robot option that names a file says so in its declaration (``option(..., file=True)``), and a
``logcal.toml`` may then name only a file inside its archive: the confinement follows the
declaration, not how the option's flag or metavar is spelled. Checked with a robot declared
here (a fourth robot's options as a plugin author would write them)."""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

import logtools.robots as robots
from logtools.batch.settings import SettingsError, settings_for
from logtools.robot_options import RobotOptions, option, options_fields
from logtools.robots import RobotPlugin, SignalSpec


@dataclass(frozen=True)
class RoverOptions(RobotOptions):
    """Options of a robot declared only in this test."""

    gain_table: str | None = option(
        flag="--gain-table", metavar="TABLE", file=True, help="The rover's gain table (a file)."
    )
    model: str | None = option(
        flag="--rover-model",
        metavar="MODEL",
        file=True,
        or_name=True,
        help="A model file, or a built-in model name.",
    )
    label_path: str | None = option(
        flag="--label-path", metavar="PATH", help="A label that looks like a path but is only text."
    )
    calibration: Path | None = option(  # noqa: RUF009
        flag="--rover-calibration", help="A calibration file (a Path option)."
    )


def _never(_: frozenset[str]) -> str | None:
    return None


PLUGIN = RobotPlugin(
    name="rover",
    title="test rover",
    signals=(SignalSpec("v", "m/s", "speed"),),
    identify=_never,
    analyze=lambda *a: None,  # type: ignore[arg-type,return-value]
    report=lambda r: [],
    options=RoverOptions,
)


@pytest.fixture
def rover() -> Iterator[None]:
    saved = list(robots._registered)
    robots.register(PLUGIN)
    yield
    robots._registered[:] = saved


def _archive(tmp_path: Path, toml: str) -> tuple[Path, Path]:
    archive = tmp_path / "archive"
    (archive / "r1").mkdir(parents=True)
    log = archive / "r1" / "run.csv"
    log.write_text("t,v\n0,1\n0.1,1\n")
    (archive / "r1" / "gains.txt").write_text("k = 1\n")
    (tmp_path / "outside.txt").write_text("secret\n")
    (archive / "r1" / "logcal.toml").write_text(toml)
    return archive, log


def test_declarations_say_which_options_name_files() -> None:
    specs = {s.key: s for s in options_fields(RoverOptions)}
    assert (specs["gain_table"].file, specs["gain_table"].or_name) == (True, False)
    assert (specs["model"].file, specs["model"].or_name) == (True, True)
    assert specs["label_path"].file is False  # its metavar says PATH; it is not declared a file
    assert specs["calibration"].file is True  # a Path option names a file
    assert specs["calibration"].metavar == "PATH"
    with pytest.raises(ValueError, match="or_name=True needs file=True"):
        option(flag="--x", help="x", or_name=True)


@pytest.mark.parametrize("value", ["../../outside.txt", "/etc/passwd", "~/.bashrc"])
@pytest.mark.parametrize("key", ["gain_table", "calibration", "model"])
def test_a_file_option_is_confined_to_the_archive(
    rover: None, tmp_path: Path, key: str, value: str
) -> None:
    archive, log = _archive(tmp_path, f"{key} = {value!r}\n")
    with pytest.raises(SettingsError, match=re.escape(f"[{key}] names {value!r}")):
        settings_for(archive, log)


def test_a_file_option_inside_the_archive_is_resolved(rover: None, tmp_path: Path) -> None:
    archive, log = _archive(tmp_path, 'gain_table = "gains.txt"\nmodel = "gains.txt"\n')
    s = settings_for(archive, log)
    gains = str((archive / "r1" / "gains.txt").resolve())
    assert s.options["gain_table"] == gains
    assert s.options["model"] == gains
    before = s.fingerprint
    (archive / "r1" / "gains.txt").write_text("k = 2\n")  # a named file's content counts
    assert settings_for(archive, log).fingerprint != before


def test_a_name_or_a_text_is_not_a_file(rover: None, tmp_path: Path) -> None:
    archive, log = _archive(tmp_path, 'model = "rover-mk2"\nlabel_path = "../../outside.txt"\n')
    s = settings_for(archive, log)
    assert s.options["model"] == "rover-mk2"  # or_name: a plain name stays a name
    assert s.options["label_path"] == "../../outside.txt"  # text: never opened, never resolved
    archive, log = _archive(tmp_path / "b", 'gain_table = "rover-mk2"\n')
    with pytest.raises(SettingsError, match="which is not a file"):  # file=True: always a file
        settings_for(archive, log)


def test_robots_sharing_a_flag_agree_on_files(rover: None) -> None:
    from logtools.cli._robot_options import _cli_options

    @dataclass(frozen=True)
    class Other(RobotOptions):
        gain_table: str | None = option(flag="--gain-table", help="A text here.")

    other = RobotPlugin(
        name="other",
        title="other",
        signals=PLUGIN.signals,
        identify=_never,
        analyze=PLUGIN.analyze,
        report=PLUGIN.report,
        options=Other,
    )
    robots.register(other)
    with pytest.raises(TypeError, match="disagree on whether its value names a file"):
        _cli_options("analyze")
