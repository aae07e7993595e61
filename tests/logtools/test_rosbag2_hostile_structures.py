"""rosbag2 structures that are not what rosbag2 writes (issue 34) end in a named error: a
``.db3`` whose ``messages`` or ``schema`` is a view (an endless recursive one here: it used to
run past 60 s), ``metadata.yaml`` nested 50,000 brackets deep (past 60 s), garbage QoS profiles
in the database or the YAML, and a ``schema`` table of the wrong type (TypeError/AttributeError
"internal error" before). Each error names the file and the object; none waits on the data."""

from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path

import pytest
from bagmaker import Drive, write_foxy_db3

from logtools.errors import NotARosbagError
from logtools.readers import read_log
from logtools.readers.rosbag_bounds import qos_problem

ENDLESS = "WITH RECURSIVE r(x) AS (SELECT 1 UNION ALL SELECT x + 1 FROM r)"


@pytest.fixture(scope="module")
def base_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_foxy_db3(tmp_path_factory.mktemp("bags") / "base", Drive(duration_s=3.0))


def _copy(base: Path, dst: Path, sql: str | None = None, yaml_tail: str = "") -> Path:
    shutil.copytree(base, dst)
    if sql is not None:
        con = sqlite3.connect(next(dst.glob("*.db3")))
        con.executescript(sql)
        con.commit()
        con.close()
    if yaml_tail:
        meta = dst / "metadata.yaml"
        meta.write_text(meta.read_text() + yaml_tail)
    return dst


CASES = {
    "messages_view": (
        "ALTER TABLE messages RENAME TO m0; CREATE VIEW messages AS "
        f"{ENDLESS} SELECT x AS id, 1 AS topic_id, x AS timestamp, X'00' AS data FROM r;",
        "",
        "messages is a view, not a table",
    ),
    "schema_view": (
        f"CREATE VIEW schema AS {ENDLESS} SELECT x AS schema_version FROM r WHERE x < 0;",
        "",
        "schema is a view, not a table",
    ),
    "schema_text": (
        "CREATE TABLE schema(schema_version TEXT, ros_distro TEXT);"
        "INSERT INTO schema VALUES ('four', 7);",
        "",
        "schema_version holds text, not an integer",
    ),
    "qos_int": (
        "UPDATE topics SET offered_qos_profiles = '42';",
        "",
        "offered_qos_profiles is int, not a list of profiles",
    ),
    "qos_policy_list": (
        "UPDATE topics SET offered_qos_profiles = '- history: [1]';",
        "",
        "[0].history is list; expected an integer or a name",
    ),
    "qos_blob": (
        "UPDATE topics SET offered_qos_profiles = X'00ff';",
        "",
        "offered_qos_profiles is bytes, not text",
    ),
    "deep_yaml": (None, "  custom_data: " + "[" * 50_000 + "]" * 50_000 + "\n", "deeper than 64"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_hostile_structure_is_a_named_error(base_bag: Path, tmp_path: Path, case: str) -> None:
    sql, tail, message = CASES[case]
    bag = _copy(base_bag, tmp_path / case, sql, tail)
    with pytest.raises(NotARosbagError) as err:
        read_log(bag)
    assert message in str(err.value)
    assert case in str(err.value)  # the bag's name


def test_the_untouched_bag_reads(base_bag: Path, tmp_path: Path) -> None:
    log = read_log(_copy(base_bag, tmp_path / "same"))
    assert log.topics


def test_qos_profiles_as_rosbag2_writes_them_pass() -> None:
    humble = (
        "- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n"
        "  deadline:\n    sec: 9223372036\n    nsec: 854775807\n"
        "  lifespan:\n    sec: 9223372036\n    nsec: 854775807\n  liveliness: 1\n"
        "  liveliness_lease_duration:\n    sec: 9223372036\n    nsec: 854775807\n"
        "  avoid_ros_namespace_conventions: false"
    )
    assert qos_problem(humble) is None
    assert qos_problem("") is None
    assert qos_problem([]) is None
    assert qos_problem("[1, 2]") == "[0] is int, not a mapping"
    assert qos_problem("{") is not None
    assert qos_problem("x" * 70_000) is not None
