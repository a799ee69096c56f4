"""The layering rules of STYLE.md, enforced by walking every import statement.

- interbot_core imports only the standard library, numpy, scipy and yaml.
- robot_daemon imports no Qt.
- base_station_app and tablet_app never import each other.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
CORE_ALLOWED_THIRD_PARTY = {"numpy", "scipy", "yaml"}
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


# Issue 13/14: "no widget holds robot or task state". Widgets (qt_*.py, the main window) reach
# the station's state only through the controller: they may import value types (tasks, views,
# enums) but never a class that owns robot, route, queue, teleop or tablet state.
STATE_OWNERS = {
    "Supervisor",  # interbot_core.supervisor: queue, tour, requests
    "RouteMirror",
    "RobotMirror",
    "Fleet",
    "RobotState",
    "TeleopArbiter",
    "TeleopInput",
    "TabletPolicy",
    "TabletFeed",
    "AlertList",
    "AlertRules",
    "SpeedFreshness",
    "LatencyWatchdog",
    "StationLink",
    "FleetWatch",
}
STATION_QT_FREE = (
    "fleet.py",
    "robot_mirror.py",
    "teleop_arbiter.py",
    "tablet_policy.py",
    "tablet_feed.py",
    "robot_state.py",
    "alerts.py",
    "tablet_session.py",
)


def imported_names(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.Import):
            names.update(alias.name.rsplit(".", 1)[-1] for alias in node.names)
    return names


def widget_files() -> list[Path]:
    apps = [*package_files("base_station_app"), *package_files("tablet_app")]
    return [p for p in apps if p.name.startswith("qt_") or p.name == "main_window.py"]


@pytest.mark.parametrize("path", widget_files(), ids=lambda p: f"{p.parent.name}/{p.name}")
def test_no_widget_holds_robot_or_task_state(path: Path) -> None:
    bad = imported_names(path) & STATE_OWNERS
    assert not bad, (
        f"{path.relative_to(REPO)} imports {sorted(bad)}: widgets draw and forward input; "
        "robot, route, queue and teleop state live behind the controller"
    )


@pytest.mark.parametrize("name", STATION_QT_FREE)
def test_station_state_owners_are_qt_free(name: str) -> None:
    path = REPO / "base_station_app" / name
    bad = imported_top_levels(path) & {"PySide6", "pyqtgraph", "zenoh"}
    assert not bad, f"{path.relative_to(REPO)} imports {sorted(bad)}; it must stay plain Python"


def test_state_rule_catches_a_widget_that_imports_a_supervisor(tmp_path: Path) -> None:
    bad = tmp_path / "qt_bad.py"
    bad.write_text("from interbot_core.supervisor import GoTo, Supervisor\n", encoding="utf-8")
    assert imported_names(bad) & STATE_OWNERS == {"Supervisor"}
