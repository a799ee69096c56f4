"""The compiled sphere tracer (`robot_daemon/sim/sphere_tracing.py`) gives the numpy caster's
ranges bit for bit, and compiles nothing once warmed up.

The reference, ``numpy_caster.numpy_cast_walls``, is ``RayCaster.cast_walls`` (with ``_refine``)
as it was before the kernel (session 12's `main`): its two phases round differently,
so equality holds only if the kernel follows the same schedule (which beams reach phase 2, and
when). Worlds: random grids, the speed tests' office with glass, and the tours' buildings (ISR,
Willow Garage, Fetch office; seed 1); inputs: random poses (free space, in walls, off the grid),
random beam sets and ranges, and every scan of a short tour (walls, glass and people against
``numpy_caster.numpy_cast``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from interbot_core.occupancy_grid import FREE, OCCUPIED, OccupancyGrid
from robot_daemon import jit
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem
from robot_daemon.sim import analytic_rays, range_errors, sphere_tracing
from robot_daemon.sim.laser_sim import LaserConfig, RayCaster
from robot_daemon.sim.world import PAD, RectObstacle, World
from tests.robot_daemon.sim.numpy_caster import numpy_cast, numpy_cast_walls
from tests.robot_daemon.sim.test_sim_speed_equivalence import _office
from tests.robot_daemon.stack_route import localise_and_send_route

FloatArray = npt.NDArray[np.float64]
REPO = Path(__file__).resolve().parents[3]

# --- worlds and inputs ------------------------------------------------------------------------


def _random_world(rng: np.random.Generator) -> World:
    """Walls round a room of random size and resolution, random blocks and thin walls inside,
    and sometimes furniture and glass."""
    rows, cols = (int(k) for k in rng.integers(20, 260, 2))
    cells = np.full((rows, cols), FREE, dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    for _ in range(int(rng.integers(0, 12))):
        r, c = int(rng.integers(0, rows)), int(rng.integers(0, cols))
        h, w = (int(k) for k in rng.integers(1, 20, 2))
        cells[r : r + h, c : c + w] = OCCUPIED
    resolution = float(rng.choice([0.02, 0.025, 0.05, 0.1]))
    grid = OccupancyGrid(cells, resolution, float(rng.uniform(-5, 5)), float(rng.uniform(-5, 5)))
    size_x, size_y = cols * resolution, rows * resolution
    obstacles, glass = [], []
    if rng.random() < 0.5:
        obstacles.append(
            RectObstacle(
                grid.origin_x + size_x * float(rng.uniform(0.2, 0.8)),
                grid.origin_y + size_y * float(rng.uniform(0.2, 0.8)),
                float(rng.uniform(0.05, 0.5)),
                float(rng.uniform(0.05, 0.5)),
                float(rng.uniform(-3, 3)),
            )
        )
    if rng.random() < 0.5:
        x0 = grid.origin_x + size_x * float(rng.uniform(0.1, 0.7))
        y0 = grid.origin_y + size_y * float(rng.uniform(0.1, 0.7))
        glass.append((x0, y0, x0 + 4 * resolution, y0 + size_y * 0.2))
    return World(grid, obstacles, glass)


def _poses(world: World, rng: np.random.Generator, n: int) -> list[tuple[float, float, float]]:
    """Mostly free-space poses, some anywhere on the padded grid (walls included), a few off it."""
    res = world.resolution
    free = np.argwhere(world.edt_cells > 1.0)
    poses = []
    for k in range(n):
        if k % 5 == 4 or free.size == 0:  # anywhere, in walls and off the grid too
            u = float(rng.uniform(-3, world.padded_width + 3))
            v = float(rng.uniform(-3, world.padded_height + 3))
        else:
            r, c = free[rng.integers(0, free.shape[0])]
            u, v = c + float(rng.uniform(0, 1)), r + float(rng.uniform(0, 1))
        x = world.grid.origin_x + (u - PAD) * res
        y = world.grid.origin_y + (v - PAD) * res
        poses.append((x, y, float(rng.uniform(-4.0, 4.0))))
    return poses


def _beams(rng: np.random.Generator, yaw: float) -> tuple[FloatArray, float]:
    """A scan's beams most of the time, else a random beam set; 30 m or a shorter range."""
    kind = int(rng.integers(0, 4))
    if kind <= 1:
        angles = LaserConfig().beam_angles() + yaw
    elif kind == 2:
        angles = rng.uniform(-7.0, 7.0, int(rng.integers(1, 1500)))
    else:  # few beams: phase 1 is skipped (n <= 64)
        angles = rng.uniform(-3.2, 3.2, int(rng.integers(1, 80)))
    max_range = 30.0 if rng.random() < 0.6 else float(rng.uniform(0.05, 8.0))
    return angles, max_range


def _assert_same(world: World, rng: np.random.Generator, n_poses: int) -> int:
    """Kernel == numpy reference on ``n_poses`` random inputs; beams that hit a wall."""
    caster = RayCaster(world)
    hits = 0
    for x, y, yaw in _poses(world, rng, n_poses):
        angles, max_range = _beams(rng, yaw)
        new = caster.cast_walls(x, y, angles, max_range)
        old = numpy_cast_walls(world, x, y, angles, max_range)
        assert np.array_equal(new, old), (x, y, yaw, angles.size, max_range)
        hits += int(np.count_nonzero(np.isfinite(new) & (new > 0)))
    return hits


@pytest.fixture(scope="module")
def tour_worlds(shared_data: Path) -> dict[str, World]:
    """The simulated buildings of the tours, seed 1 (`interbot scenario tour`)."""
    maps = {
        "isr": (REPO / "maps" / "isr_floor0.yaml", REPO / "maps" / "isr_floor0_topo.yaml"),
        "willow": (shared_data / "maps" / "willow.yaml", REPO / "maps" / "willow_topo.yaml"),
        "fetch": (
            shared_data / "maps" / "fetch_office.yaml",
            REPO / "maps" / "fetch_office_topo.yaml",
        ),
    }
    return {
        name: SimulatedSystem(ScenarioOptions(map_yaml=m, topo_yaml=t, seed=1, people=0)).sim.world
        for name, (m, t) in maps.items()
    }


# --- tests ------------------------------------------------------------------------------------


def test_equal_to_the_numpy_caster_on_random_worlds() -> None:
    rng = np.random.default_rng(21)
    hits = sum(_assert_same(_random_world(rng), rng, 12) for _ in range(60))
    assert hits > 100_000  # the comparison saw real hits, not only misses


def test_equal_to_the_numpy_caster_in_the_office_with_grazing_walls_and_glass() -> None:
    rng = np.random.default_rng(22)
    assert _assert_same(_office(), rng, 300) > 100_000


@pytest.mark.parametrize("name", ["isr", "willow", "fetch"])
def test_equal_to_the_numpy_caster_in_the_tour_buildings(
    tour_worlds: dict[str, World], name: str
) -> None:
    rng = np.random.default_rng(23)
    assert _assert_same(tour_worlds[name], rng, 300) > 100_000


def test_compiled_equals_its_plain_python_function() -> None:
    rng = np.random.default_rng(24)
    plain = jit.python_function(sphere_tracing.wall_ranges)
    for world in (_office(), _random_world(rng), _random_world(rng)):
        for x, y, yaw in _poses(world, rng, 6):
            angles, max_range = _beams(rng, yaw)
            u0, v0 = (float(c) for c in world.to_padded_cells(x, y))
            if not (0 <= u0 < world.padded_width and 0 <= v0 < world.padded_height):
                continue
            args = (
                world.ray_step_flat,
                world.padded_width,
                u0,
                v0,
                np.cos(angles),
                np.sin(angles),
                max_range / world.resolution,
                world.resolution,
                max_range,
            )
            compiled, python = np.empty(angles.size), np.empty(angles.size)
            sphere_tracing.wall_ranges(*args, compiled)
            plain(*args, python)
            assert np.array_equal(compiled, python)


def _signatures() -> list[int]:
    kernels = (
        sphere_tracing.wall_ranges,
        analytic_rays.circle_ranges,
        analytic_rays.pane_ranges,
        range_errors.jump_pairs,
        range_errors.mix_pairs,
        range_errors.apply_errors,
    )
    return [len(getattr(kernel, "signatures", ())) for kernel in kernels]


def test_a_short_tour_compiles_nothing_after_the_warm_up_and_casts_as_numpy_did() -> None:
    system = SimulatedSystem(ScenarioOptions(seed=1))  # warms the kernels up
    before = _signatures()
    assert min(before) >= 1 or not jit.ENABLED
    caster = system.sim.laser.caster
    cast = caster.cast
    compared = []

    def checked(
        x: float,
        y: float,
        angles: FloatArray,
        max_range: float,
        circles: FloatArray | None = None,
        glass_return_angle: float = 0.0,
    ) -> FloatArray:
        ranges = cast(x, y, angles, max_range, circles, glass_return_angle)
        old = numpy_cast(caster.world, x, y, angles, max_range, circles, glass_return_angle)
        assert np.array_equal(ranges, old)
        compared.append(int(np.count_nonzero(np.isfinite(ranges))))
        return ranges

    caster.cast = checked  # type: ignore[method-assign]
    localise_and_send_route(system, 2)
    system.run_until(lambda: False, 30.0)  # 10 scans a second, leaving home among people
    assert len(compared) > 250 and sum(compared) > 0.5 * 1081 * len(compared)  # walls seen
    for _ in range(3):  # the daemon's camera casts too
        system.sim.camera_frame()
    assert _signatures() == before
