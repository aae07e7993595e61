"""TOML handed to us (channel maps, ``logcal.toml``) is parsed only when it nests at most
``MAX_DEPTH`` deep: a file of 100,000 ``[`` is refused before ``tomllib`` recurses (found by
bench/fuzz_all.py: the RecursionError path left a worker's interpreter broken, "SystemError:
error return without exception set", then a crash in later inputs)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from logtools import toml_bounded
from logtools.batch.settings import SettingsError, settings_for
from logtools.channel_map import load_channel_map
from logtools.errors import ChannelMapError

DEEP = "x = " + "[" * 100_000 + "]" * 100_000 + "\n"


@pytest.mark.parametrize(
    ("text", "depth"),
    [
        ("a = [[1], {b = [2]}]", 3),
        ('a = "[[[[{{"', 0),
        ("a = '[[[['  # [[[[", 0),
        ('a = """\n[[[\n\\""" [[ """', 0),
        ("a = '''[[[\n[[['''", 0),
        ('a = "\\"[[[" \n b = [1]', 1),
        ("[[tables]]\nx = 1", 2),
    ],
)
def test_nesting_is_counted_outside_strings_and_comments(text: str, depth: int) -> None:
    assert toml_bounded.nesting_depth(text) == depth


def _no_tomllib(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*_: object) -> None:
        raise AssertionError("tomllib must not see a too-deep file")

    monkeypatch.setattr(toml_bounded.tomllib, "loads", refuse)


def test_too_deep_is_refused_before_parsing(monkeypatch: pytest.MonkeyPatch) -> None:
    ok = "x = " + "[" * toml_bounded.MAX_DEPTH + "]" * toml_bounded.MAX_DEPTH
    assert toml_bounded.loads(ok) == {"x": toml_bounded.loads(ok)["x"]}
    _no_tomllib(monkeypatch)
    with pytest.raises(toml_bounded.TomlTooDeepError, match="nested more than 100 deep"):
        toml_bounded.loads(ok.replace("x = [", "x = [["))
    with pytest.raises(toml_bounded.TomlTooDeepError):
        toml_bounded.loads(DEEP)


def test_deep_channel_map_is_one_clean_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _no_tomllib(monkeypatch)
    path = tmp_path / "map.toml"
    path.write_text(DEEP)
    with pytest.raises(
        ChannelMapError,
        match=re.escape(f"{path}: not a readable TOML channel map (arrays or tables nested"),
    ):
        load_channel_map(path)


def test_deep_logcal_toml_is_a_settings_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _no_tomllib(monkeypatch)
    archive = tmp_path / "archive"
    archive.mkdir()
    (archive / "run.csv").write_text("t,v\n0,1\n")
    (archive / "logcal.toml").write_text(DEEP)
    with pytest.raises(
        SettingsError,
        match=re.escape(f"{archive / 'logcal.toml'}: not a readable TOML file (arrays or tables"),
    ):
        settings_for(archive, archive / "run.csv")
