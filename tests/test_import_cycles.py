"""No import cycles among calib, logtools and viz (scripts/import_cycles.py: imports inside
functions and under ``if TYPE_CHECKING:`` count too)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "import_cycles.py"


def _checker():  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location("import_cycles", SCRIPT)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_no_import_cycles() -> None:
    assert _checker().cycles() == []


def test_the_checker_sees_a_cycle_hidden_inside_a_function(tmp_path: Path) -> None:
    checker = _checker()
    pkg = tmp_path / "logtools"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from logtools.b import x\n")
    (pkg / "b.py").write_text("x = 1\n\ndef f():\n    from logtools import a\n    return a\n")
    checker.ROOT = tmp_path
    checker.PACKAGES = ("logtools",)
    assert checker.cycles() == [["logtools.a", "logtools.b"]]


def test_the_checker_sees_a_cycle_through_a_type_checking_import(tmp_path: Path) -> None:
    checker = _checker()
    pkg = tmp_path / "logtools"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from logtools.b import x\n")
    (pkg / "b.py").write_text(
        "from typing import TYPE_CHECKING\n\nif TYPE_CHECKING:\n    from logtools.a import A\n"
        "x = 1\n"
    )
    (pkg / "c.py").write_text("from logtools.b import x\n")  # one way only: no cycle
    checker.ROOT = tmp_path
    checker.PACKAGES = ("logtools",)
    assert checker.cycles() == [["logtools.a", "logtools.b"]]
