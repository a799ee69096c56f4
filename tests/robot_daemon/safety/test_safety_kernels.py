"""The safety layer's compiled kernels (`robot_daemon.jit`) equal the numpy code they replaced
(`numpy_reference`), bit for bit: the collision monitor's zones and times to contact, the
assistance's free paths, on random inputs and on a simulated robot's scans and commands;
compiled and plain Python agree."""

from __future__ import annotations

import math
import pickle
from collections.abc import Iterator

import numpy as np
import pytest

from interbot_core.laser_scan import INTERBOT_LASER_MOUNT, LaserScan
from interbot_core.velocity_mux import MuxOutput
from robot_daemon import jit
from robot_daemon.safety import arc_geometry, collision_monitor
from robot_daemon.safety.arc_geometry import (
    arc_poses,
    first_contact,
    near_arcs,
    point_in_polygon,
    point_to_polygon,
    polygon_box,
)
from robot_daemon.safety.assisted_teleop import AssistConfig, AssistedTeleop
from robot_daemon.safety.motion_guard import MotionGuard, default_guard_config
from tests.robot_daemon.planning.recorded_navigation import RecordedNavigation, record_tour
from tests.robot_daemon.safety.numpy_reference import (
    NumpyCollisionMonitor,
    numpy_first_contact,
    numpy_near_arcs,
)

BOX = np.array([[0.3, 0.275], [-0.3, 0.275], [-0.3, -0.275], [0.3, -0.275]])
POLYGONS = [
    BOX,
    BOX + np.array([0.1, -0.05]),  # a box off centre
    np.array([[0.4, 0.0], [-0.3, 0.3], [-0.3, -0.3]]),  # a triangle
    np.array([[0.3, 0.1], [0.1, 0.35], [-0.3, 0.2], [-0.35, -0.25], [0.2, -0.3]]),
    np.array([[0.3, 0.2], [0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]]),  # a 0-length edge
    BOX @ np.array([[math.cos(0.3), math.sin(0.3)], [-math.sin(0.3), math.cos(0.3)]]),
]


@pytest.fixture
def numpy_geometry(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Session 12's `first_contact` and `near_arcs` in place of the kernels' (for the monitor
    and the assistance, which call them through their modules)."""
    with monkeypatch.context() as patch:
        patch.setattr(arc_geometry, "first_contact", numpy_first_contact)
        patch.setattr(collision_monitor, "near_arcs", numpy_near_arcs)
        yield


def test_point_tests_equal_the_numpy_polygon_functions() -> None:
    rng = np.random.default_rng(41)
    x, y = rng.uniform(-0.6, 0.6, (2, 4000))
    x[:50], y[:50] = BOX[rng.integers(0, 4, 50)].T  # on the corners and edges
    x[50:100] = 0.3
    for poly in POLYGONS:
        box = polygon_box(poly)
        with np.errstate(invalid="ignore"):
            inside = arc_geometry.inside_polygon(x, y, poly)
            distance = arc_geometry.distance_to_polygon(x, y, poly)
        ours = np.array([point_in_polygon(a, b, poly, box) for a, b in zip(x, y, strict=True)])
        assert np.array_equal(ours, inside)
        ours_d = np.array([point_to_polygon(a, b, poly, box) for a, b in zip(x, y, strict=True)])
        assert np.array_equal(ours_d, distance, equal_nan=True)


def test_first_contact_equals_numpys() -> None:
    rng = np.random.default_rng(42)
    contacts = 0
    for trial in range(200):
        poly = POLYGONS[trial % len(POLYGONS)]
        n = int(rng.choice([0, 1, 5, 80, 400]))
        px, py = rng.uniform(-1.5, 1.5, (2, n))
        curvatures = rng.uniform(-3.0, 3.0, (int(rng.integers(1, 14)), 1))
        curvatures[0] = 0.0
        length = float(rng.uniform(-1.2, 1.2))
        steps = int(rng.integers(1, 30))
        s = (length / steps) * np.arange(1, steps + 1, dtype=np.float64)[None, :]
        poses = arc_poses(curvatures, s)
        min_points = int(rng.integers(1, 4))
        ours = first_contact(px, py, *poses, poly, min_points)
        assert np.array_equal(ours, numpy_first_contact(px, py, *poses, poly, min_points))
        contacts += int(np.count_nonzero(ours < steps))
    assert contacts > 200


def test_near_arcs_equals_numpys() -> None:
    rng = np.random.default_rng(43)
    for _ in range(300):
        px, py = rng.uniform(-4.0, 4.0, (2, int(rng.choice([0, 3, 500]))))
        curvatures = rng.uniform(-5.0, 5.0, int(rng.integers(1, 5)))
        curvatures[rng.random(curvatures.size) < 0.3] = float(rng.choice([0.0, 1e-7, -2e-6]))
        radius, length = float(rng.uniform(0.2, 0.6)), float(rng.uniform(-1.5, 1.5))
        ours = near_arcs(px, py, curvatures, radius, length)
        assert np.array_equal(ours, numpy_near_arcs(px, py, curvatures, radius, length))


def _scans(rng: np.random.Generator, count: int) -> list[LaserScan]:
    """UTM-30LX-like scans close round the robot: walls, a person, doorways, no-returns."""
    scans = []
    for _ in range(count):
        near = float(rng.choice([0.2, 0.5, 1.5]))
        ranges = np.repeat(rng.uniform(near, 3.0, 55), 20)[:1081] + rng.normal(0.0, 0.01, 1081)
        ranges[rng.random(1081) < 0.05] = np.inf
        ranges[rng.random(1081) < 0.01] = np.nan
        scans.append(LaserScan(0.0, -2.356194490192345, math.radians(0.25), 0.02, 30.0,
                               ranges.astype(np.float32)))  # fmt: skip
    return scans


def _commands(rng: np.random.Generator, count: int) -> list[tuple[float, float]]:
    choices = [(0.0, 0.0), (0.25, 0.0), (0.0, 0.6), (-0.1, 0.0), (-0.3, 0.2), (0.2, -0.4)]
    out = [choices[int(rng.integers(0, len(choices)))] for _ in range(count)]
    return [(v + float(rng.normal(0, 0.02)), w) if rng.random() < 0.5 else (v, w) for v, w in out]


def _monitor_run(
    monitor_type: type[collision_monitor.CollisionMonitor],
    scans: list[LaserScan],
    commands: list[tuple[float, float]],
) -> list[object]:
    monitor = monitor_type(default_guard_config().monitor, INTERBOT_LASER_MOUNT)
    out: list[object] = []
    for k, (scan, (v, w)) in enumerate(zip(scans, commands, strict=True)):
        now = 0.1 * k
        monitor.on_scan(scan, now)
        zones = [(z.active, z.members.tobytes()) for z in monitor._zones]
        out.append((monitor.distance, zones, monitor.update(v, w, now), monitor.update(w, v, now)))
    return out


def test_collision_monitor_equals_numpys_on_random_scans(numpy_geometry: None) -> None:
    rng = np.random.default_rng(44)
    scans, commands = _scans(rng, 300), _commands(rng, 300)
    ref = _monitor_run(NumpyCollisionMonitor, scans, commands)
    with pytest.MonkeyPatch.context() as patch:  # the kernels back in place
        patch.setattr(arc_geometry, "first_contact", first_contact)
        patch.setattr(collision_monitor, "near_arcs", near_arcs)
        ours = _monitor_run(collision_monitor.CollisionMonitor, scans, commands)
    assert ours == ref
    zones = {r[3].zone for r in ours} | {r[2].zone for r in ours}  # type: ignore[attr-defined]
    assert {"none", "stop", "slowdown", "approach"} <= zones, zones


@pytest.fixture(scope="module")
def recorded() -> RecordedNavigation:
    """600 loop steps of the realistic tour with 12 people: 250 scans and commands."""
    return record_tour(600, seed=3, people=12)[1]


def test_motion_guard_equals_numpys_on_a_simulated_robots_scans(
    recorded: RecordedNavigation, numpy_geometry: None
) -> None:
    updates = [(args, command) for (name, args, _), command in zip(
        [c for c in recorded.calls if c[0] == "update"], recorded.commands, strict=True
    )]  # fmt: skip
    assert len(updates) > 200

    def run() -> list[MuxOutput]:
        guard = MotionGuard(default_guard_config(), INTERBOT_LASER_MOUNT)
        outputs = []
        for (now, _, scan), command in updates:
            guard.on_scan(scan, now)
            for v, w in ((command.linear, command.angular), (0.25, 0.0), (0.0, -0.6)):
                outputs.append(guard.limit(MuxOutput(v, w, "planner_vel", "", ()), now))
                outputs.append(MuxOutput(*guard.on_teleop("tablet_vel", v, w, now), None, ""))
        return outputs

    old = pickle.dumps(run())
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(arc_geometry, "first_contact", first_contact)
        patch.setattr(collision_monitor, "near_arcs", near_arcs)
        assert pickle.dumps(run()) == old


def test_assistance_equals_numpys(numpy_geometry: None) -> None:
    rng = np.random.default_rng(45)
    problems = []
    for _ in range(150):
        px, py = rng.uniform(-2.5, 2.5, (2, int(rng.choice([0, 50, 600]))))
        v, w = float(rng.uniform(-0.4, 0.4)), float(rng.uniform(-1.0, 1.0))
        if rng.random() < 0.2:
            v = 0.0
        problems.append((v, w, px, py))
    old = [AssistedTeleop(AssistConfig()).assist(*p) for p in problems]
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(arc_geometry, "first_contact", first_contact)
        new = [AssistedTeleop(AssistConfig()).assist(*p) for p in problems]
    assert new == old
    assert {"free", "scaled", "slid", "stopped"} <= {r.mode for r in new}


def test_safety_kernels_compiled_equal_plain_python() -> None:
    rng = np.random.default_rng(46)
    px, py = rng.uniform(-1.5, 1.5, (2, 300))
    for poly in POLYGONS:
        box = polygon_box(poly)
        for kernel, args in (
            (collision_monitor.nearest_distance, (px, py, 1.4, poly, box)),
            (collision_monitor.zone_members, (px, py, 1.0, poly, box, 0.02)),
            (arc_geometry.near_arc_points, (px, py, np.array([0.0, 1.5, -2.0]), 0.4, 1.0)),
        ):
            compiled, plain = kernel(*args), jit.python_function(kernel)(*args)
            assert np.array_equal(compiled, plain, equal_nan=True)
        s = 0.05 * np.arange(1, 25, dtype=np.float64)[None, :]
        poses = [np.ascontiguousarray(a) for a in arc_poses(np.array([[0.0], [1.0]]), s)]
        args = (px, py, *poses, poly, box, 2)
        assert np.array_equal(
            arc_geometry.first_contacts(*args),
            jit.python_function(arc_geometry.first_contacts)(*args),
        )
