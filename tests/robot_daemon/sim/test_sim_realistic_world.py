"""The simulated building differs from the map (issue 12), deterministically per seed, and the
UTM-30LX / odometry error models do what their docstrings say."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid, load_map
from interbot_core.topological_map import load_topological_map
from robot_daemon.scenarios.runner import (
    INITIAL_POSE_MAX_ERROR,
    ScenarioOptions,
    SimulatedSystem,
    person_set_pose_error,
)
from robot_daemon.sim.laser_sim import LaserConfig, LaserSim
from robot_daemon.sim.odometry_model import OdometryErrorModel, WheelOdometry
from robot_daemon.sim.realistic_world import (
    SimWorldSpec,
    WorldVariation,
    WorldVariationError,
    build_sim_world,
    plan_beside,
    warped_grid,
)
from robot_daemon.sim.world import World

REPO = Path(__file__).resolve().parents[3]
ISR_MAP = REPO / "maps" / "isr_floor0.yaml"
ISR_TOPO = REPO / "maps" / "isr_floor0_topo.yaml"


@pytest.fixture(scope="module")
def isr_world() -> tuple[OccupancyGrid, SimWorldSpec]:
    grid = load_map(ISR_MAP)
    spec = build_sim_world(
        grid,
        np.random.default_rng(3),
        plan_yaml=plan_beside(ISR_MAP),
        topo=load_topological_map(ISR_TOPO),
    )
    return grid, spec


def _resample(world: OccupancyGrid, like: OccupancyGrid) -> np.ndarray:
    """The world's blocked mask read at the map's cell centres."""
    rows, cols = np.mgrid[0 : like.height, 0 : like.width]
    x, y = like.cell_to_world(rows, cols)
    r, c = world.world_to_cell(x, y)
    result: np.ndarray = world.blocked()[
        np.clip(r, 0, world.height - 1), np.clip(c, 0, world.width - 1)
    ]
    return result


def test_isr_world_is_drawn_finer_and_differs_from_the_map(
    isr_world: tuple[OccupancyGrid, SimWorldSpec],
) -> None:
    grid, spec = isr_world
    assert spec.grid.resolution == pytest.approx(0.02)
    world_blocked = _resample(spec.grid, grid)
    differ = world_blocked != grid.blocked()
    # Walls a few cm off along most of the floor's wall length: thousands of 5 cm cells differ,
    # but the building is the same building (well under 5 % of the cells).
    assert 2_000 < int(differ.sum()) < 0.05 * grid.cells.size
    kinds = {item.kind for item in spec.items}
    assert {"box", "chair-leg", "corridor box"} <= kinds
    assert len(spec.glass) == WorldVariation().glass_panels
    text = spec.describe()
    assert "closed" in text and "extra door" in text and "moved" in text


def test_clutter_keeps_off_the_graph(isr_world: tuple[OccupancyGrid, SimWorldSpec]) -> None:
    _, spec = isr_world
    topo = load_topological_map(ISR_TOPO)
    v = WorldVariation()
    for item in spec.items:
        for node in topo.nodes:
            assert math.hypot(item.center_x - node.pose.x, item.center_y - node.pose.y) > (
                v.node_clearance - 0.01
            )


def test_same_seed_same_world_other_seed_other_world() -> None:
    grid = load_map(ISR_MAP)
    plan = plan_beside(ISR_MAP)

    def build(seed: int) -> SimWorldSpec:
        return build_sim_world(grid, np.random.default_rng(seed), plan_yaml=plan)

    a, b, c = build(5), build(5), build(6)
    assert np.array_equal(a.grid.cells, b.grid.cells) and a.items == b.items
    assert not np.array_equal(a.grid.cells, c.grid.cells)


def test_warped_grid_moves_walls_by_about_sigma() -> None:
    cells = np.full((200, 200), FREE, dtype=np.int8)
    cells[:, 100:102] = OCCUPIED  # one straight wall at x = 5.0-5.1 m
    grid = OccupancyGrid(cells, 0.05, 0.0, 0.0, source="wall")
    out, rms = warped_grid(grid, np.random.default_rng(1), WorldVariation(wall_sigma=0.05))
    assert out.resolution == pytest.approx(0.025)
    assert 0.03 < rms < 0.08  # RMS of the 2-D displacement field
    # The wall's west face, row by row, now wanders by centimetres around 5.0 m.
    occupied = out.occupied()
    faces = np.array([np.argmax(row) for row in occupied]) * out.resolution
    assert 0.005 < float(np.std(faces)) < 0.08
    assert abs(float(np.mean(faces)) - 5.0) < 0.1


def test_variation_is_validated() -> None:
    with pytest.raises(
        WorldVariationError,
        match=r"WorldVariation\.resolution = 0\.2 m is outside the allowed range \[0\.005, 0\.05\] m",
    ):
        WorldVariation(resolution=0.2)
    with pytest.raises(
        WorldVariationError,
        match=r"WorldVariation\.boxes = -1 is outside the allowed range 0\.\.200",
    ):
        WorldVariation(boxes=-1)
    with pytest.raises(WorldVariationError, match=r"WorldVariation\.chairs must be an integer"):
        WorldVariation(chairs=1.5)  # type: ignore[arg-type]


def _box_room() -> OccupancyGrid:
    cells = np.full((200, 200), FREE, dtype=np.int8)
    cells[:2, :] = cells[-2:, :] = OCCUPIED
    cells[:, :2] = cells[:, -2:] = OCCUPIED
    return OccupancyGrid(cells, 0.05, 0.0, 0.0, source="room")


def test_glass_returns_beams_near_its_normal_and_lets_the_others_through() -> None:
    # A pane across the room at x = 6.0-6.05 m; the far wall is at x = 9.9 m.
    world = World(_box_room(), glass=[(6.0, 1.0, 6.05, 9.0)])
    laser = LaserSim(world, LaserConfig(noise_sigma=0.0, mount_x=0.0), np.random.default_rng(0))
    scan = laser.scan(Pose2D(3.0, 5.0, 0.0), 0.0)
    angles = scan.angle_min + scan.angle_increment * np.arange(scan.ranges.size)
    straight = int(np.argmin(np.abs(angles)))
    assert scan.ranges[straight] == pytest.approx(3.0, abs=0.02)  # reflected by the pane
    oblique = int(np.argmin(np.abs(angles - 0.5)))  # 29 degrees off the normal
    assert scan.ranges[oblique] > 6.9 / math.cos(0.5) - 0.1  # through the pane to the far wall
    assert bool(world.is_blocked(6.02, 5.0)[()])  # but the robot cannot pass


def test_laser_noise_bias_dropouts_and_mixed_pixels() -> None:
    world = World(_box_room())
    config = LaserConfig.realistic()
    laser = LaserSim(world, config, np.random.default_rng(4))
    ideal = LaserSim(world, LaserConfig(noise_sigma=0.0), np.random.default_rng(4))
    pose = Pose2D(5.0, 5.0, 0.3)
    truth = ideal.scan(pose, 0.0).ranges.astype(np.float64)
    errors, biases, dropped = [], [], 0
    for k in range(40):
        ranges = laser.scan(pose, k * 0.025).ranges.astype(np.float64)
        ok = np.isfinite(ranges)
        dropped += int((~ok).sum())
        err = ranges[ok] - truth[ok]
        biases.append(float(np.median(err)))
        errors.append(err - np.median(err))
    spread = float(np.std(np.concatenate(errors)))
    assert 0.007 < spread < 0.013  # per-beam noise about 10 mm
    assert float(np.std(biases)) < 0.01  # a bias that varies slowly, not per scan
    assert 0.002 < dropped / (40 * truth.size) < 0.05
    # Mixed pixels: at a person's edge, beams between the person and the wall behind.
    circles = np.array([[7.0, 5.0, 0.25]])
    mixed = 0
    for k in range(20):
        r = laser.scan(Pose2D(5.0, 5.0, 0.0), k * 0.025, circles).ranges
        mixed += int(((r > 2.0) & (r < 4.5)).sum())
    assert mixed > 0


def test_turn_slip_makes_the_body_turn_less_than_the_wheels() -> None:
    model = OdometryErrorModel(turn_slip=0.05)
    odo = WheelOdometry(model, 0.5, np.random.default_rng(0))
    factors = [odo.slip_factor(1.0) for _ in range(200)]
    assert 0.93 < float(np.mean(factors)) < 0.98
    assert odo.slip_factor(0.0) == 1.0
    assert WheelOdometry(OdometryErrorModel(), 0.5, np.random.default_rng(0)).slip_factor(1.0) == 1


def test_initial_pose_error_is_what_a_person_does() -> None:
    max_xy, max_yaw = INITIAL_POSE_MAX_ERROR
    errors = [person_set_pose_error(np.random.default_rng(s)) for s in range(50)]
    assert all(0.1 <= math.hypot(e.x, e.y) <= max_xy for e in errors)
    assert all(math.radians(3) <= abs(e.yaw) <= max_yaw for e in errors)


def test_scenarios_use_the_realistic_world_unless_ideal() -> None:
    real = SimulatedSystem(ScenarioOptions(seed=2, people=0))
    assert real.world_spec is not None
    assert real.sim.world.resolution == pytest.approx(0.02)
    assert real.sim.config.laser.noise_sigma == pytest.approx(0.01)
    assert math.hypot(real.initial_pose_error.x, real.initial_pose_error.y) >= 0.1
    ideal = SimulatedSystem(ScenarioOptions(seed=2, people=0, ideal_world=True))
    assert ideal.world_spec is None
    assert ideal.sim.world.grid is ideal.grid
    assert ideal.initial_pose_error == Pose2D(0.0, 0.0, 0.0)
    # The localiser's wall model is the daemon's, whatever world is simulated.
    assert (
        real.stack.config.localiser.matcher.surface == ideal.stack.config.localiser.matcher.surface
    )


def test_real_map_world_keeps_unknown_as_walls(shared_data: Path) -> None:
    grid = load_map(shared_data / "maps" / "fetch_office.yaml")
    spec = build_sim_world(grid, np.random.default_rng(1), variation=WorldVariation(boxes=2))
    world_blocked = _resample(spec.grid, grid)
    # Unknown stays blocked (but for the warp's few cm at its border).
    unknown = grid.cells == -1
    inner_unknown = ndimage.binary_erosion(unknown, iterations=3)
    assert bool(world_blocked[inner_unknown].all())
    assert 0 < int((world_blocked != grid.blocked()).sum()) < 0.05 * grid.cells.size
