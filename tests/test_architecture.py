"""The layering rules of STYLE.md, enforced by walking every import statement.

- interbot_core imports only the standard library, numpy, scipy, yaml and msgspec (the
  schema library every message and file is declared with, issue 13).
- robot_daemon imports no Qt.
- base_station_app and tablet_app never import each other.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
CORE_ALLOWED_THIRD_PARTY = {"numpy", "scipy", "yaml", "msgspec"}
FIRST_PARTY = {"interbot_core"}


def imported_top_levels(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def package_files(package: str) -> list[Path]:
    return sorted((REPO / package).rglob("*.py"))


@pytest.mark.parametrize("path", package_files("interbot_core"), ids=lambda p: p.name)
def test_core_imports_only_stdlib_numpy_scipy_yaml(path: Path) -> None:
    stdlib = set(sys.stdlib_module_names)
    bad = imported_top_levels(path) - stdlib - CORE_ALLOWED_THIRD_PARTY - FIRST_PARTY
    assert not bad, (
        f"{path.relative_to(REPO)} imports {sorted(bad)}; interbot_core must stay Qt-free"
    )


@pytest.mark.parametrize("path", package_files("robot_daemon"), ids=lambda p: p.name)
def test_robot_daemon_has_no_qt(path: Path) -> None:
    qt = {"PySide6", "PyQt5", "PyQt6", "pyqtgraph", "base_station_app", "tablet_app"}
    bad = imported_top_levels(path) & qt
    assert not bad, f"{path.relative_to(REPO)} imports {sorted(bad)}; the daemon is headless"


@pytest.mark.parametrize(
    ("package", "forbidden"),
    [("base_station_app", "tablet_app"), ("tablet_app", "base_station_app")],
)
def test_apps_do_not_import_each_other(package: str, forbidden: str) -> None:
    offenders = [
        str(p.relative_to(REPO))
        for p in package_files(package)
        if forbidden in imported_top_levels(p)
    ]
    assert not offenders, f"{package} must not import {forbidden}: {offenders}"


def test_rule_catches_a_violation(tmp_path: Path) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text("import PySide6.QtCore\nfrom zenoh import open\n", encoding="utf-8")
    assert {"PySide6", "zenoh"} <= imported_top_levels(bad)


@pytest.mark.parametrize("path", package_files("interbot_link"), ids=lambda p: p.name)
def test_link_has_no_qt(path: Path) -> None:
    bad = imported_top_levels(path) & {"PySide6", "pyqtgraph", "base_station_app", "tablet_app"}
    assert not bad, f"{path.relative_to(REPO)} imports {sorted(bad)}; the link is Qt-free"


@pytest.mark.parametrize("path", package_files("interbot_qt"), ids=lambda p: p.name)
def test_shared_qt_helpers_import_no_app(path: Path) -> None:
    bad = imported_top_levels(path) & {"base_station_app", "tablet_app", "robot_daemon"}
    assert not bad, f"{path.relative_to(REPO)} imports {sorted(bad)}; interbot_qt serves both apps"


PRODUCT_PACKAGES = (
    "interbot_core",
    "interbot_link",
    "interbot_qt",
    "robot_daemon",
    "base_station_app",
    "tablet_app",
    "interbot_cli",
)


def test_no_test_doubles_in_product_packages() -> None:
    """Fakes and stubs live in tests/, not in what is installed on a robot or a tablet."""
    doubles = [
        str(p.relative_to(REPO))
        for package in PRODUCT_PACKAGES
        for p in (REPO / package).rglob("*.py")
        if p.stem.startswith(("fake_", "stub_", "mock_")) or p.stem.endswith(("_fake", "_stub"))
    ]
    assert doubles == []
