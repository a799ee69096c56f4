"""The layering rules of STYLE.md, enforced by walking every import statement.

- interbot_core imports only the standard library, numpy, scipy, yaml and msgspec (the
  schema library every message and file is declared with, issue 13).
- robot_daemon imports no Qt.
- base_station_app and tablet_app never import each other.
"""

from __future__ import annotations

import ast
import importlib.util
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
        if is_test_double(p)
    ]
    assert doubles == []


def is_test_double(path: Path) -> bool:
    """A fake, stub or mock module, or a device emulator (tests/robot_daemon/hardware/emulators)."""
    stem = path.stem
    return stem.startswith(("fake_", "stub_", "mock_")) or stem.endswith(
        ("_fake", "_stub", "_emulator")
    )


# Issue 13: every YAML file is read by `interbot_core.schema.read_yaml` (one wording for "cannot
# read" / "invalid YAML", naming the file) and converted by its declaration. These may parse YAML
# themselves: the helper, and the collision monitor's Nav2 polygon, a YAML string *inside* a file.
YAML_PARSERS = {"interbot_core/schema.py", "robot_daemon/safety/collision_monitor.py"}


def yaml_parse_calls(path: Path) -> list[int]:
    """Lines of ``path`` that call ``yaml.safe_load`` / ``yaml.load`` / ``yaml.full_load``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    return [
        node.lineno
        for node in ast.walk(tree)
        if isinstance(node, ast.Call)
        and isinstance(node.func, ast.Attribute)
        and node.func.attr in {"safe_load", "load", "full_load", "unsafe_load"}
        and ast.unparse(node.func.value) == "yaml"
    ]


def test_yaml_files_are_read_through_the_schema_helper() -> None:
    offenders = [
        f"{p.relative_to(REPO)}:{line}"
        for package in PRODUCT_PACKAGES
        for p in sorted((REPO / package).rglob("*.py"))
        if str(p.relative_to(REPO)) not in YAML_PARSERS
        for line in yaml_parse_calls(p)
    ]
    assert offenders == [], "read YAML files with interbot_core.schema.read_yaml"


def test_yaml_and_test_double_rules_catch_violations(tmp_path: Path) -> None:
    loader = tmp_path / "loader.py"
    loader.write_text(
        "import yaml\nx = yaml.safe_load(open('a.yaml'))\ny = yaml.safe_dump({})\n"
        "z = yaml.load(t, Loader=yaml.SafeLoader)\n",
        encoding="utf-8",
    )
    assert yaml_parse_calls(loader) == [2, 4]
    assert is_test_double(Path("robot_daemon/hardware/hokuyo_emulator.py"))
    assert is_test_double(Path("tablet_app/fake_station.py"))
    assert not is_test_double(Path("robot_daemon/hardware/hokuyo_driver.py"))


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
    "TabletTeleop",
    "TeleopInput",
    "TabletPolicy",
    "TabletFeed",
    "AlertList",
    "AlertRules",
    "SpeedFreshness",
    "LatencyWatchdog",
    "StationLink",
    "FleetWatch",
    "FleetLink",
    "SupervisorEvents",
    "TabletRequests",
    "TabletLink",
}
STATION_QT_FREE = (
    "fleet.py",
    "fleet_link.py",
    "robot_mirror.py",
    "teleop_arbiter.py",
    "tablet_policy.py",
    "tablet_feed.py",
    "robot_state.py",
    "alerts.py",
    "tablet_session.py",
    "supervisor_events.py",
    "tablet_requests.py",
    "task_commands.py",
    "robot_reports.py",
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


# Issue 11/13: the operator's stop intent has one owner on the station, `FleetLink`: it alone
# sends ``stop`` / ``stop_release`` (to every robot, re-sent until heard), so no other part can
# release a robot's latch or forget to re-assert the stop.
STOP_TOPICS = {"Topic.STOP", "Topic.STOP_RELEASE"}


def stop_topic_uses(path: Path) -> list[int]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    return [
        node.lineno
        for node in ast.walk(tree)
        if isinstance(node, ast.Attribute) and ast.unparse(node) in STOP_TOPICS
    ]


def test_only_the_fleet_link_sends_the_operators_stop() -> None:
    offenders = [
        f"{p.relative_to(REPO)}:{line}"
        for p in package_files("base_station_app")
        if p.name != "fleet_link.py"
        for line in stop_topic_uses(p)
    ]
    assert offenders == [], "send the stop through FleetLink (base_station_app/fleet_link.py)"
    assert stop_topic_uses(REPO / "base_station_app" / "fleet_link.py")  # the rule still looks


def test_stop_owner_rule_catches_a_second_sender(tmp_path: Path) -> None:
    bad = tmp_path / "controller.py"
    bad.write_text(
        "from interbot_core.topics import Lock, Topic\n"
        "link.send(Topic.STOP, Lock(False))\nlink.send(Topic.STOP_RELEASE, r)\n"
        "link.send(Topic.PAUSE_NAV, Lock(True))\n",
        encoding="utf-8",
    )
    assert stop_topic_uses(bad) == [2, 3]


# ---------------------------------------------------------------------- one owner for each rule
# Issue 13: test doubles, benchmarks and map-authoring code stay out of what ships; the rooms of
# the floor have one model, `interbot_core/rooms.py`, which alone reads a node's ``area``.

NOT_SHIPPED = {"tests", "bench", "tools"}
ROOM_MODEL = REPO / "interbot_core" / "rooms.py"
# The building plan the simulator draws its world from has rooms of its own (rectangles with doors
# and furniture); they are the plan's, not the UI's.
BUILDING_PLAN = REPO / "robot_daemon" / "sim" / "floor_plan.py"
# What a second room model would define (the two old ones did: tablet_app/floor_plan.py and
# base_station_app/map_rooms.py).
ROOM_MODEL_NAMES = {"Room", "RoomArea", "RoomMap", "RoomMapError", "FloorPlan", "FloorPlanError"}
ROOM_MODEL_FUNCTIONS = {"load_floor_plan", "load_room_areas", "load_room_map", "room_at"}
# Functions that write maps (from a plan: tools/generate_isr_map.py; from logged scans: the
# real-data tests' log_replay.py).
AUTHORING_FUNCTIONS = {
    "topological_map_dict",
    "plan_nodes",
    "generate",
    "stale_files",
    "grid_from_scans",
}


def product_files() -> list[Path]:
    return [p for package in PRODUCT_PACKAGES for p in package_files(package)]


def _rel(path: Path) -> str:
    return str(path.relative_to(REPO))


def top_level_definitions(path: Path) -> tuple[set[str], set[str]]:
    """(function names, class names) defined anywhere in ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    functions = {
        n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)
    }
    classes = {n.name for n in ast.walk(tree) if isinstance(n, ast.ClassDef)}
    return functions, classes


def area_key_uses(path: Path) -> list[int]:
    """Lines where ``"area"`` is used as a mapping key: ``x["area"]``, ``x.get("area")``,
    ``{"area": ...}``."""

    def is_area(node: ast.AST | None) -> bool:
        return isinstance(node, ast.Constant) and node.value == "area"

    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Subscript) and is_area(node.slice):
            lines.append(node.lineno)
        elif isinstance(node, ast.Call) and any(is_area(a) for a in node.args[:1]):
            func = node.func
            if isinstance(func, ast.Attribute) and func.attr in {"get", "pop", "setdefault"}:
                lines.append(node.lineno)
        elif isinstance(node, ast.Dict) and any(is_area(k) for k in node.keys):
            lines.append(node.lineno)
    return lines


def test_product_packages_import_no_tests_benchmarks_or_tools() -> None:
    offenders = {
        _rel(p): sorted(imported_top_levels(p) & NOT_SHIPPED)
        for p in product_files()
        if imported_top_levels(p) & NOT_SHIPPED
    }
    assert offenders == {}


def test_no_benchmark_or_synthetic_test_world_code_in_product_packages() -> None:
    """Timing loops live in bench/, test worlds in tests/ (the ray-cast bench and the synthetic
    office used to ship in robot_daemon)."""
    offenders = []
    for path in product_files():
        functions, _ = top_level_definitions(path)
        offenders += [f"{_rel(path)}: {f}()" for f in functions if f.startswith("bench_")]
        if path.stem.startswith(("synthetic_", "bench_")):
            offenders.append(_rel(path))
    assert offenders == []


def test_no_map_authoring_in_product_packages() -> None:
    offenders = [
        f"{_rel(path)}: {name}()"
        for path in product_files()
        for name in sorted(top_level_definitions(path)[0] & AUTHORING_FUNCTIONS)
    ]
    assert offenders == []


def test_only_the_room_model_reads_area() -> None:
    offenders = {
        _rel(path): area_key_uses(path)
        for path in product_files()
        if path != ROOM_MODEL and area_key_uses(path)
    }
    assert offenders == {}
    assert area_key_uses(ROOM_MODEL), "the rule no longer sees the room model read 'area'"


def test_no_other_room_or_floor_plan_model_in_the_apps_or_the_core() -> None:
    offenders = []
    for path in product_files():
        if path in (ROOM_MODEL, BUILDING_PLAN):
            continue
        functions, classes = top_level_definitions(path)
        offenders += [f"{_rel(path)}: class {n}" for n in sorted(classes & ROOM_MODEL_NAMES)]
        offenders += [f"{_rel(path)}: {n}()" for n in sorted(functions & ROOM_MODEL_FUNCTIONS)]
    assert offenders == []


GOAL_CHECKER = REPO / "robot_daemon" / "planning" / "goal_checker.py"
GOAL_LOGIC = {"RouteFollower", "next_goal_index", "final_goal_reached", "final_reached_at"}
ROBOT_TOLERANCE_FUDGE = "ROBOT_TOLERANCE_SHARE"


def test_one_intermediate_goal_logic_on_the_robot() -> None:
    """Arrival is judged by the robot's goal checker alone; the station mirrors route_progress
    (there used to be a station-side RouteFollower reconciled by a 0.8 tolerance share)."""
    offenders = []
    for path in product_files():
        text = path.read_text(encoding="utf-8")
        if ROBOT_TOLERANCE_FUDGE in text:
            offenders.append(f"{_rel(path)}: {ROBOT_TOLERANCE_FUDGE}")
        if path == GOAL_CHECKER:
            continue
        functions, classes = top_level_definitions(path)
        offenders += [f"{_rel(path)}: {n}" for n in sorted((functions | classes) & GOAL_LOGIC)]
    assert offenders == []
    assert GOAL_LOGIC & top_level_definitions(GOAL_CHECKER)[0]


def test_the_new_rules_catch_violations(tmp_path: Path) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text(
        "import tools.x\n"
        "def bench_raycast(): pass\n"
        "def topological_map_dict(): pass\n"
        "class RoomArea: pass\n"
        "a = raw['area']\nb = raw.get('area')\nc = {'area': []}\nd = 'area'\n",
        encoding="utf-8",
    )
    functions, classes = top_level_definitions(bad)
    assert "tools" in imported_top_levels(bad)
    assert {"bench_raycast", "topological_map_dict"} <= functions and "RoomArea" in classes
    assert area_key_uses(bad) == [5, 6, 7]


# ---------------------------------------------------------------------- nothing ships unused
# Issue 13: code that only tests and benchmarks use (the real-log replay used to sit in
# robot_daemon/localisation/) lives in tests/ or bench/. Every product module is imported by
# another product module, or is one of these entry points, each started by name, not imported:
ENTRY_MODULES = {
    # console scripts: pyproject.toml [project.scripts] (checked below)
    "interbot_cli.screens": "`python -m` child of the demo launcher (asks Qt for the screens)",
    **{
        f"robot_daemon.scenarios.{name}": "`interbot scenario NAME` (imported by name)"
        for name in ("kidnap", "latency", "mission", "odometry", "teleop", "tour")
    },
}


def module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(path: Path) -> set[str]:
    """Every module ``path`` imports, and ``pkg.name`` for each ``from pkg import name``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    me = module_name(path)
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = me.split(".") if path.name == "__init__.py" else me.split(".")[:-1]
            if node.level:
                base = base[: len(base) - node.level + 1]
                module = ".".join([*base, *([node.module] if node.module else [])])
            else:
                module = node.module or ""
            found.add(module)
            found.update(f"{module}.{alias.name}" for alias in node.names)
    return found - {me}


def unused_product_modules(files: list[Path], entries: set[str]) -> list[str]:
    imported = set().union(*(imported_modules(p) for p in files))
    return sorted(
        module_name(p)
        for p in files
        if p.name not in ("__init__.py", "__main__.py") and module_name(p) not in imported | entries
    )


def console_script_modules() -> set[str]:
    import tomllib

    scripts = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    return {target.split(":")[0] for target in scripts["scripts"].values()}


def test_every_product_module_is_used_by_the_product() -> None:
    entries = console_script_modules() | set(ENTRY_MODULES)
    assert unused_product_modules(product_files(), entries) == []
    stale = sorted(m for m in ENTRY_MODULES if m not in {module_name(p) for p in product_files()})
    assert stale == [], "entry modules that no longer exist"


def test_unused_module_rule_catches_a_test_only_module(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(sys.modules[__name__], "REPO", tmp_path)
    package = tmp_path / "robot_daemon"
    (package / "localisation").mkdir(parents=True)
    (package / "__init__.py").write_text("", encoding="utf-8")
    (package / "main.py").write_text(
        "from robot_daemon.localisation import localiser\n", encoding="utf-8"
    )
    (package / "localisation" / "__init__.py").write_text("", encoding="utf-8")
    (package / "localisation" / "localiser.py").write_text("from . import maps\n", "utf-8")
    (package / "localisation" / "maps.py").write_text("", encoding="utf-8")
    (package / "localisation" / "log_replay.py").write_text("from .localiser import x\n", "utf-8")
    files = sorted(package.rglob("*.py"))
    assert unused_product_modules(files, {"robot_daemon.main"}) == [
        "robot_daemon.localisation.log_replay"
    ]


# Issue 13, the controller's split: what a supervisor event or a tablet request becomes is decided
# in one Qt-free place each, so the controller stays a composition root. In base_station_app only
# `SupervisorEvents` (and `RobotMirror`, for what an event changes in one robot's mirror) name a
# supervisor event class; only `TabletRequests` (and `permission_for`, which says what permission
# each needs) name a tablet request class.
SUPERVISOR_EVENT_NAMES = {
    "TaskStarted", "TaskFinished", "QueueChanged", "RouteStarted", "RouteCancelled",
    "IntermediateGoalReached", "GoalReached", "PauseNavigation", "TourStopReached",
    "RequestShown", "RequestAccepted", "RequestDeclined", "RequestTimedOut",
}  # fmt: skip
TABLET_REQUEST_NAMES = {
    "Goal", "Pause", "Stop", "Tour", "Home", "RequestFrom", "TourControl", "InitialPoseRoom",
    "Malfunction", "RequestAnswer",
}  # fmt: skip
DECIDED_IN = {
    "supervisor event": (SUPERVISOR_EVENT_NAMES, {"supervisor_events.py", "robot_mirror.py"}),
    "tablet request": (TABLET_REQUEST_NAMES, {"tablet_requests.py", "tablet_session.py"}),
}


def names_used(path: Path) -> set[str]:
    """Every name a module imports, reads or reaches as an attribute (``p.Goal`` -> Goal)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    names = imported_names(path)
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            names.add(node.id)
        elif isinstance(node, ast.Attribute):
            names.add(node.attr)
    return names


def test_the_event_and_tablet_request_sets_are_the_real_ones() -> None:
    import typing

    from interbot_core import protocol, supervisor

    assert {c.__name__ for c in typing.get_args(supervisor.Event)} == SUPERVISOR_EVENT_NAMES
    requests = {c.__name__ for c in typing.get_args(protocol.TabletMessage)}
    assert requests - {"Speed", "Hello", "Ping", "Pong", "ErrorReport"} == TABLET_REQUEST_NAMES


@pytest.mark.parametrize("what", sorted(DECIDED_IN))
def test_events_and_tablet_requests_are_decided_in_one_place_each(what: str) -> None:
    names, owners = DECIDED_IN[what]
    offenders = {
        p.name: sorted(names_used(p) & names)
        for p in package_files("base_station_app")
        if p.name not in owners and names_used(p) & names
    }
    assert offenders == {}, f"act on a {what} in {sorted(owners)[0]}, not elsewhere"
    assert all(names_used(REPO / "base_station_app" / o) & names for o in owners)  # still looks


def test_the_decided_in_one_place_rule_catches_a_controller_that_matches_events(
    tmp_path: Path,
) -> None:
    bad = tmp_path / "station_controller.py"
    bad.write_text(
        "from interbot_core import protocol as p\n"
        "if isinstance(event, supervisor.TourStopReached) or isinstance(msg, p.Goal):\n"
        "    pass\n",
        encoding="utf-8",
    )
    assert names_used(bad) & SUPERVISOR_EVENT_NAMES == {"TourStopReached"}
    assert names_used(bad) & TABLET_REQUEST_NAMES == {"Goal"}


# Issue 14 (the e-stop wins over a tablet command in flight): what gates the tablet thread's
# speed path - the operator's stop, a robot's online flag, the tablet's permissions: everything
# `TabletTeleop`'s refusal check reads - is written only under a ``lock`` (the speed path's,
# ``tablet_teleop.lock``), outside constructors, whichever part writes it (the controller,
# `TabletLink`, `RobotReports`); one that wrote it without the lock would let a command slip
# past a stop.
TABLET_GATES = {"estop_latched", "online", "permissions"}


def unlocked_gate_writes(path: Path) -> list[int]:
    """Lines that assign a tablet gate outside ``with ....lock:`` and outside ``__init__``."""
    found: list[int] = []

    def visit(node: ast.AST, locked: bool, in_init: bool) -> None:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            in_init = node.name == "__init__"
        if isinstance(node, ast.With):
            locked = locked or any(
                ast.unparse(item.context_expr).endswith(".lock") for item in node.items
            )
        targets: list[ast.expr] = []
        if isinstance(node, ast.Assign):
            targets = node.targets
        elif isinstance(node, ast.AugAssign | ast.AnnAssign):
            targets = [node.target]
        for target in targets:
            for t in target.elts if isinstance(target, ast.Tuple) else [target]:
                gate = isinstance(t, ast.Attribute) and t.attr in TABLET_GATES
                if gate and not (locked or in_init):
                    found.append(t.lineno)
        for child in ast.iter_child_nodes(node):
            visit(child, locked, in_init)

    visit(ast.parse(path.read_text(encoding="utf-8"), filename=str(path)), False, False)
    return found


def test_what_gates_the_tablet_is_written_under_the_speed_paths_lock() -> None:
    offenders = {
        p.name: lines
        for p in package_files("base_station_app")
        if (lines := unlocked_gate_writes(p))
    }
    assert offenders == {}, "write the e-stop, online and permissions under tablet_teleop.lock"


def test_the_gate_rule_catches_a_write_without_the_lock(tmp_path: Path) -> None:
    bad = tmp_path / "part.py"
    bad.write_text(
        "class Part:\n"
        "    def __init__(self):\n"
        "        self.online = False\n"  # a constructor: fine
        "    def ok(self, link):\n"
        "        with self.tablet_teleop.lock:\n"
        "            link.estop_latched = True\n"
        "    def bad(self, mirror, policy):\n"
        "        mirror.online = True\n"
        "        policy.permissions, x = 1, 2\n",
        encoding="utf-8",
    )
    assert unlocked_gate_writes(bad) == [8, 9]


# Issue 13 (lines down, one owner): the product's classes keep no API that only tests call - a
# test drives the path the product uses (`StationLink.request_state` and its events, not a
# blocking fetch the station never makes; the tablet server's ping timer, not a ping() only
# tests call), so it cannot pass on a path that is dead in the product. Every top-level class
# of the station, tablet, link, core, CLI and Qt packages is checked (robot_daemon is trimmed
# by its own rule of thumb).
NO_TEST_ONLY_API_PACKAGES = (
    "base_station_app",
    "interbot_core",
    "interbot_link",
    "tablet_app",
    "interbot_cli",
    "interbot_qt",
)
# Read by tests only, on purpose: what a test must observe and the product never needs to.
TEST_PROBES = {
    # The e-stop's latch and the refusal of non-finite velocities (safety tests, kept as is).
    "interbot_core/velocity_mux.py:VelocityMux": {"latched_locks", "rejected_count"},
    # The bounded-memory promise of the stream framing is only visible here.
    "interbot_core/protocol.py:JsonStreamDecoder": {"buffered_bytes"},
    # The watchdog's period statistics (watchdog tests, kept as is).
    "interbot_core/watchdog.py:PeriodStats": {"capacity", "total_count"},
    # Tests put the threads they raised back to normal priority; the daemon logs the outcome.
    "interbot_link/command_priority.py:NamedThreadRaiser": {"raised"},
    "interbot_link/robot.py:RobotLink": {"callback_priority"},
    # End-to-end tests tap the robot where the tablet's map draws it.
    "tablet_app/qt_map_view.py:QtMapView": {"robot_widget_pos", "transform"},
    # pyqtgraph calls it (an override, lower case).
    "base_station_app/qt_scan_points.py:ScanPointsItem": {"paint"},
}


def checked_classes() -> dict[str, str]:
    """``path:Class`` -> path for every top-level class the test-only-API rule checks."""
    found = {}
    for package in NO_TEST_ONLY_API_PACKAGES:
        for path in package_files(package):
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
            for cls in (n for n in tree.body if isinstance(n, ast.ClassDef)):
                found[f"{_rel(path)}:{cls.name}"] = _rel(path)
    return found


def public_members(path: Path, class_name: str) -> set[str]:
    """Public methods and properties of ``class_name`` (Qt overrides and dunders excluded)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    (cls,) = (n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == class_name)
    return {
        n.name
        for n in cls.body
        if isinstance(n, ast.FunctionDef) and not n.name.startswith("_") and n.name.islower()
    }


def attribute_uses(paths: list[Path]) -> set[str]:
    """Every ``x.name`` read or called in ``paths``."""
    used: set[str] = set()
    for path in paths:
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        used |= {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)}
    return used


def test_the_product_classes_have_no_api_only_tests_use() -> None:
    shipped = [*product_files(), *(REPO / "bench").glob("*.py"), *(REPO / "tools").glob("*.py")]
    used = attribute_uses(shipped)
    classes = checked_classes()
    assert "base_station_app/station_controller.py:StationController" in classes
    unused = {
        name: sorted(
            public_members(REPO / path, name.split(":")[1]) - used - TEST_PROBES.get(name, set())
        )
        for name, path in classes.items()
    }
    assert {k: v for k, v in unused.items() if v} == {}
    assert set(TEST_PROBES) <= set(classes)  # no stale entry


def test_the_test_only_api_rule_catches_a_method_nobody_calls(tmp_path: Path) -> None:
    part = tmp_path / "part.py"
    part.write_text(
        "class Link:\n"
        "    def poll(self): return self._wait()\n"
        "    def _wait(self): pass\n"
        "    def fetch_map(self): pass\n"
        "    def keyPressEvent(self, e): pass\n",
        encoding="utf-8",
    )
    user = tmp_path / "user.py"
    user.write_text("link.poll()\n", encoding="utf-8")
    assert public_members(part, "Link") - attribute_uses([part, user]) == {"fetch_map"}


# One declaration per thing (issue 13): what the tablet may do is the protocol's `Permissions`
# (the station file's `tablet:` section is its on-disk form), and the tablet's widgets follow a
# language change through one mixin (`tablet_app.translations.Retranslated`).
PERMISSION_FIELDS = {"teleop", "goals", "tours", "requests"}
PERMISSION_OWNERS = {
    "interbot_core/protocol.py:Permissions",
    "base_station_app/station_file.py:TabletSection",
}


def classes_with_fields(path: Path, fields: set[str]) -> set[str]:
    """Classes of ``path`` whose annotated class attributes include all of ``fields``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found = set()
    for cls in (n for n in ast.walk(tree) if isinstance(n, ast.ClassDef)):
        names = {
            n.target.id
            for n in cls.body
            if isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name)
        }
        if fields <= names:
            found.add(cls.name)
    return found


def test_the_tablets_permissions_are_declared_once() -> None:
    declared = {
        f"{_rel(p)}:{name}"
        for p in product_files()
        for name in classes_with_fields(p, PERMISSION_FIELDS)
    }
    assert declared == PERMISSION_OWNERS


def test_only_the_mixin_handles_a_language_change() -> None:
    handlers = {
        _rel(p)
        for p in package_files("tablet_app")
        if "LanguageChange" in p.read_text(encoding="utf-8")
    }
    assert handlers == {"tablet_app/translations.py"}


def test_the_declared_once_rule_catches_a_copy(tmp_path: Path) -> None:
    copy = tmp_path / "tablet_session.py"
    copy.write_text(
        "class TabletPermissions:\n"
        "    teleop: bool = True\n    goals: bool = True\n"
        "    tours: bool = True\n    requests: bool = True\n"
        "class Other:\n    teleop: bool\n",
        encoding="utf-8",
    )
    assert classes_with_fields(copy, PERMISSION_FIELDS) == {"TabletPermissions"}


# Issue 13 (a thin composition root): the station controller wires its parts (fleet, link,
# arbiter, tablet policy, alerts, ...) to Qt and keeps no state of its own beyond them. What
# it may still change after construction: the operator's configuration (handed to every part
# on a change). A new piece of state belongs in the part that owns it.
CONTROLLER_OWN_STATE = {"config"}


def _assigned(node: ast.AST) -> list[ast.expr]:
    """The targets of an assignment statement (tuples unpacked), else nothing."""
    if isinstance(node, ast.Assign):
        targets = list(node.targets)
    elif isinstance(node, ast.AnnAssign | ast.AugAssign):
        targets = [node.target]
    else:
        return []
    while any(isinstance(t, ast.Tuple) for t in targets):
        targets = [e for t in targets for e in (t.elts if isinstance(t, ast.Tuple) else [t])]
    return targets


def state_written_after_init(path: Path, class_name: str) -> set[str]:
    """Attributes ``self.name`` (not ``self.part.name``) that methods other than ``__init__``
    of ``class_name`` assign."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    (cls,) = (n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == class_name)
    methods = [f for f in cls.body if isinstance(f, ast.FunctionDef) and f.name != "__init__"]
    return {
        target.attr
        for method in methods
        for node in ast.walk(method)
        for target in _assigned(node)
        if isinstance(target, ast.Attribute)
        and isinstance(target.value, ast.Name)
        and target.value.id == "self"
    }


def test_the_station_controller_keeps_no_state_of_its_own() -> None:
    path = REPO / "base_station_app/station_controller.py"
    assert state_written_after_init(path, "StationController") == CONTROLLER_OWN_STATE


def test_the_own_state_rule_sees_a_counter_kept_in_a_method(tmp_path: Path) -> None:
    part = tmp_path / "part.py"
    part.write_text(
        "class Root:\n"
        "    def __init__(self):\n        self.parts = []\n        self.n = 0\n"
        "    def tick(self):\n        self.n += 1\n        self.parts[0].x = 1\n"
        "    def reset(self):\n        self.seen: int = 0\n",
        encoding="utf-8",
    )
    assert state_written_after_init(part, "Root") == {"n", "seen"}


# Issue 13 (a thin composition root, continued): the controller builds its parts, wires them to
# Qt and runs the clock; what it decides lives in the parts, and the window and panels call a
# part directly (`controller.commands`, `controller.tablet_link`, `controller.alerts`) rather
# than through a method that only passes the call on. Kept on purpose: ``submit`` and
# ``resume_queue``, which the e-stop tests drive (this issue changes no safety test), and
# ``_send``, which the fault tests wrap to see what reaches the robot. Properties that name a
# part's state for the views (``selected``, ``estop_latched``, ...) are not methods and are
# not counted. A code-line budget (tools/loc_report.py's count: no blanks, comments or
# docstrings) holds the split: 418 lines after it (630 before); a new duty goes to a part.
CONTROLLER_FORWARDERS_KEPT = {"submit", "resume_queue", "_send"}
CONTROLLER_CODE_LINES_MAX = 420


def forwarders(path: Path, class_name: str) -> set[str]:
    """Methods of ``class_name`` whose whole body (docstring aside) passes its own arguments
    on to one part: ``return self.part.method(a, b)`` or ``self.part.method(a, b)``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    (cls,) = (n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == class_name)
    found = set()
    for f in cls.body:
        if not isinstance(f, ast.FunctionDef) or f.name == "__init__" or f.decorator_list:
            continue
        body = f.body[1:] if ast.get_docstring(f) is not None else f.body
        call = (
            body[0].value if len(body) == 1 and isinstance(body[0], ast.Return | ast.Expr) else None
        )
        if not isinstance(call, ast.Call):
            continue
        target = ast.unparse(call.func)
        params = {a.arg for a in [*f.args.args[1:], *f.args.kwonlyargs]}
        args = [*call.args, *(k.value for k in call.keywords)]
        passed_on = all(isinstance(a, ast.Name) and a.id in params for a in args)
        if target.startswith("self.") and target.count(".") >= 2 and passed_on:
            found.add(f.name)
    return found


def code_lines(path: Path) -> int:
    spec = importlib.util.spec_from_file_location("loc_report", REPO / "tools" / "loc_report.py")
    assert spec is not None and spec.loader is not None
    loc = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("loc_report", loc)
    spec.loader.exec_module(loc)
    return int(loc.count_source(path.read_text(encoding="utf-8"), str(path)).code)


def test_the_station_controller_stays_a_thin_composition_root() -> None:
    path = REPO / "base_station_app/station_controller.py"
    assert forwarders(path, "StationController") == CONTROLLER_FORWARDERS_KEPT
    assert code_lines(path) <= CONTROLLER_CODE_LINES_MAX


def test_the_forwarder_rule_sees_a_method_that_only_passes_a_call_on(tmp_path: Path) -> None:
    root = tmp_path / "root.py"
    root.write_text(
        "class Root:\n"
        "    def stop_tablet_speed(self, why):\n"
        '        """Forget the tablet\'s command."""\n'
        "        self.tablet_teleop.stop(why)\n"
        "    def log(self, level, text):\n"
        "        self.state.add_log(self.clock(), level, text)\n"  # adds the time: not flagged
        "    def pause(self):\n"
        "        return self.commands.pause()\n"
        "    def tick(self):\n        self.tick_parts()\n",
        encoding="utf-8",
    )
    assert forwarders(root, "Root") == {"stop_tablet_speed", "pause"}
    assert code_lines(root) == 9  # the docstring is not code
