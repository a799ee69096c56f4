"""Relocaliser: accepts a place only when it clearly wins; look-alike rooms stay ambiguous.

Worlds are boxes ray-cast exactly (`synthetic_office`): one asymmetric room, and the same room
twice (identical to the cell), where no scan from inside can say which one the robot is in.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import Executor, Future

import numpy as np

from interbot_core.geometry import Pose2D
from robot_daemon.localisation.global_search import GlobalSearchConfig
from robot_daemon.localisation.localiser import Localiser
from robot_daemon.localisation.relocaliser import Relocaliser, RelocaliserConfig
from tests.robot_daemon.localisation.synthetic_office import rasterise, square, utm_scan

ROOM = np.vstack(
    [
        np.array([[0, 0, 6, 0.1], [0, 4.9, 6, 5], [0, 0, 0.1, 5], [5.9, 0, 6, 5]]),
        np.array([[1.0, 3.5, 2.2, 4.0], [4.4, 0.1, 5.9, 0.7]]),
        square(3.8, 2.6, 0.15),
    ]
)
TWIN_SHIFT = 8.0  # [m] the second room, a whole number of cells to the east
TWINS = np.vstack([ROOM, ROOM + np.array([TWIN_SHIFT, 0.0, TWIN_SHIFT, 0.0])])
CONFIG = RelocaliserConfig(
    search=GlobalSearchConfig(angular_step_rad=math.radians(3.0)), help_after_s=2.0
)


def _run(boxes: np.ndarray, size: tuple[float, float], laser: Pose2D, scans: int) -> tuple:
    grid = rasterise(boxes, size=size)
    reloc = Relocaliser(grid, Localiser(grid), CONFIG)
    reloc.start(0.0, "test")
    rng = np.random.default_rng(7)
    accepted: list[tuple[float, Pose2D]] = []
    for k in range(scans):
        now = 0.1 * (k + 1)
        reloc.on_odometry(Pose2D(0.0, 0.0, 0.0))  # standing
        pose = reloc.on_scan(utm_scan(boxes, laser, now, rng), now)
        if pose is not None:
            accepted.append((now, pose))
            break
    return reloc, accepted


def test_a_distinct_room_is_accepted_at_the_true_pose_after_several_scans() -> None:
    laser = Pose2D(2.0, 1.5, 0.4)
    reloc, accepted = _run(ROOM, (6.0, 5.0), laser, 30)
    assert accepted, f"not accepted: {reloc.last_failure}"
    when, pose = accepted[0]
    assert pose.distance_to(laser) < 0.05
    assert abs(math.remainder(pose.yaw - laser.yaw, math.tau)) < 0.02
    assert when >= CONFIG.accept_s  # consistent over several scans, not one
    assert not reloc.active


def test_identical_twin_rooms_stay_ambiguous_and_ask_for_help() -> None:
    laser = Pose2D(2.0, 1.5, 0.4)
    reloc, accepted = _run(TWINS, (TWIN_SHIFT + 6.0, 5.0), laser, 40)
    assert accepted == []  # never a guess
    assert reloc.active
    places = sorted(round(c.pose.x) for c in reloc.candidates if c.streak > 0)
    assert places == [2, 2 + round(TWIN_SHIFT)], reloc.candidates  # both rooms, both kept
    status = reloc.status(4.0)
    assert status.help_needed and status.candidates == 2
    assert "look-alike" in status.text


def test_motion_that_contradicts_a_candidate_removes_it() -> None:
    """Odometry moves every candidate; one whose scan then stops fitting is dropped."""
    grid = rasterise(TWINS, size=(TWIN_SHIFT + 6.0, 5.0))
    reloc = Relocaliser(grid, Localiser(grid), CONFIG)
    reloc.start(0.0, "test")
    rng = np.random.default_rng(3)
    laser = Pose2D(2.0, 1.5, 0.4)
    for k in range(5):
        reloc.on_odometry(Pose2D(0.0, 0.0, 0.0))
        reloc.on_scan(utm_scan(TWINS, laser, 0.1 * (k + 1), rng), 0.1 * (k + 1))
    assert len(reloc.candidates) == 2
    # Odometry claims a 1.5 m move the scans do not show: both candidates fail at once.
    reloc.on_odometry(Pose2D(1.5, 0.0, 0.0))
    assert reloc.on_scan(utm_scan(TWINS, laser, 0.6, rng), 0.6) is None
    old = [c for c in reloc.candidates if c.first_seen < 0.5]
    assert old and all(c.streak == 0 and c.failures == 1 for c in old)
    reloc.on_scan(utm_scan(TWINS, laser, 0.7, rng), 0.7)
    assert all(c.first_seen > 0.5 for c in reloc.candidates)  # dropped after two failures


class DeferredExecutor(Executor):
    """Runs what is submitted only when told (a worker thread that is slow, deterministically)."""

    def __init__(self) -> None:
        self.queue: list[tuple[Future[object], Callable[..., object], tuple[object, ...]]] = []

    def submit(self, fn: Callable[..., object], /, *args: object, **kwargs: object) -> Future:  # type: ignore[override]
        future: Future[object] = Future()
        self.queue.append((future, fn, args))
        return future

    def run_all(self) -> None:
        for future, fn, args in self.queue:
            future.set_result(fn(*args))
        self.queue.clear()


def test_a_search_finishing_later_is_moved_by_the_odometry_since_its_scan() -> None:
    """In the daemon searches run on a worker thread: the robot may have moved by the time the
    result arrives, and the hypotheses must be moved with it before they are verified."""
    grid = rasterise(ROOM, size=(6.0, 5.0))
    reloc = Relocaliser(grid, Localiser(grid), CONFIG)
    executor = DeferredExecutor()
    reloc.executor = executor
    reloc.start(0.0, "test")
    rng = np.random.default_rng(5)
    start = Pose2D(2.0, 1.5, 0.4)
    reloc.on_odometry(Pose2D(0.0, 0.0, 0.0))
    assert reloc.on_scan(utm_scan(ROOM, start, 0.1, rng), 0.1) is None
    assert len(executor.queue) == 1 and reloc.candidates == ()
    # The robot drives 0.8 m forward and turns a little before the search is done.
    step = Pose2D(0.8, 0.0, 0.2)
    moved = start.compose(step)
    reloc.on_odometry(step)
    executor.run_all()
    assert reloc.on_scan(utm_scan(ROOM, moved, 0.2, rng), 0.2) is None
    (cand,) = reloc.candidates  # from the search of the first scan, moved by odometry
    assert cand.first_seen == 0.2 and cand.pose.distance_to(moved) < 0.05
    accepted = None
    for k in range(3, 30):
        now = 0.1 * k
        accepted = reloc.on_scan(utm_scan(ROOM, moved, now, rng), now)
        executor.run_all()
        if accepted is not None:
            break
    assert accepted is not None, reloc.last_failure
    assert accepted.distance_to(moved) < 0.05
    assert abs(math.remainder(accepted.yaw - moved.yaw, math.tau)) < 0.02
