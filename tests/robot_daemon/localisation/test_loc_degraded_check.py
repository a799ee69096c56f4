"""The kidnap check while the localiser reports ``degraded`` (issue 16).

A robot carried off whose new scan still fits its old pose a little (a hit fraction above the
loss test's, below the degraded threshold) is neither lost nor ``ok``: the background check
(standing, ``ok``) never ran and no search started, so it drove on 32 m off for 14 s (Willow
kidnap seed 3 #7). While degraded the same comparison now runs, standing or driving, and a
clearly better place elsewhere starts the search; the decision stays the relocaliser's.

Worlds are a box room ray-cast exactly (`synthetic_office`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import Executor, Future

import numpy as np

from interbot_core.geometry import Pose2D
from robot_daemon.localisation.localiser import Localiser, LocaliserState
from robot_daemon.localisation.relocalisation import Relocalisation, RelocalisationConfig
from robot_daemon.localisation.relocaliser import Relocaliser, RelocaliserConfig
from tests.robot_daemon.localisation.synthetic_office import rasterise, square, utm_scan

ROOM = np.vstack(
    [
        np.array([[0, 0, 6, 0.1], [0, 4.9, 6, 5], [0, 0, 0.1, 5], [5.9, 0, 6, 5]]),
        np.array([[1.0, 3.5, 2.2, 4.0], [4.4, 0.1, 5.9, 0.7]]),
        square(3.8, 2.6, 0.15),
    ]
)
SIZE = (6.0, 5.0)
TRUTH = Pose2D(2.0, 1.5, 0.4)  # the laser, where it is
TRACKED = Pose2D(3.2, 2.3, 0.4)  # where the localiser believes it is: 1.4 m off
CONFIG = RelocaliserConfig(kidnap_min_range_m=0.0)


class DeferredExecutor(Executor):
    """Runs what is submitted only when told (a slow worker thread, deterministically)."""

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


def _relocaliser(executor: Executor | None = None) -> Relocaliser:
    grid = rasterise(ROOM, size=SIZE)
    reloc = Relocaliser(grid, Localiser(grid), CONFIG)
    reloc.executor = executor
    return reloc


def test_the_degraded_check_compares_the_places_while_the_robot_drives() -> None:
    """The background check waits for the robot to stand; the degraded check does not."""
    reloc = _relocaliser()
    rng = np.random.default_rng(21)
    driving = 0.3  # [m/s]
    for k in range(10):
        now = 0.1 * (k + 1)
        scan = utm_scan(ROOM, TRUTH, now, rng)
        assert reloc.check_standing(scan, TRACKED, driving, now) is None
    found = reloc.check_degraded(utm_scan(ROOM, TRUTH, 1.1, rng), TRACKED, 1.1)
    assert found is not None and found.pose.distance_to(TRUTH) < 0.1
    # Tracked where it is (degraded by its covariance, say): nothing fits better.
    assert reloc.check_degraded(utm_scan(ROOM, TRUTH, 2.2, rng), TRUTH, 2.2) is None


def test_a_degraded_check_finishing_later_moves_its_places_by_the_odometry_since() -> None:
    """On the daemon's worker thread the search ends scans later; the robot drove meanwhile,
    so the places it found are moved by the odometry since its scan before they are judged."""
    executor = DeferredExecutor()
    reloc = _relocaliser(executor)
    rng = np.random.default_rng(22)
    reloc.on_odometry(Pose2D(0.0, 0.0, 0.0))
    assert reloc.check_degraded(utm_scan(ROOM, TRUTH, 0.1, rng), TRACKED, 0.1) is None
    assert len(executor.queue) == 1
    step = Pose2D(1.2, 0.3, 0.9)  # driven and turned before the search is done
    truth_now, tracked_now = TRUTH.compose(step), TRACKED.compose(step)
    reloc.on_odometry(step)
    executor.run_all()
    found = reloc.check_degraded(utm_scan(ROOM, truth_now, 0.2, rng), tracked_now, 0.2)
    assert found is not None and found.pose.distance_to(truth_now) < 0.1
    assert abs(math.remainder(found.pose.yaw - truth_now.yaw, math.tau)) < 0.05


def test_a_background_search_left_pending_does_not_hold_up_the_degraded_check() -> None:
    """A standing check's search still running when the localiser turns degraded is dropped
    (it compared for the ``ok`` state); the degraded check runs its own at once."""
    executor = DeferredExecutor()
    reloc = _relocaliser(executor)
    rng = np.random.default_rng(23)
    reloc.on_odometry(Pose2D(0.0, 0.0, 0.0))
    assert reloc.check_standing(utm_scan(ROOM, TRUTH, 0.1, rng), TRACKED, 0.0, 0.1) is None
    assert len(executor.queue) == 1  # the background search, not done yet
    assert reloc.check_degraded(utm_scan(ROOM, TRUTH, 0.2, rng), TRACKED, 0.2) is None
    assert len(executor.queue) == 2  # the degraded check's own search
    executor.run_all()
    found = reloc.check_degraded(utm_scan(ROOM, TRUTH, 0.3, rng), TRACKED, 0.3)
    assert found is not None and found.pose.distance_to(TRUTH) < 0.1


class PinnedLocaliser(Localiser):
    """A localiser whose state and pose the test sets (what it reports, not how it got there)."""

    pinned_state = LocaliserState.DEGRADED
    pinned_pose: Pose2D | None = None

    @property
    def state(self) -> LocaliserState:
        return self.pinned_state

    @property
    def pose(self) -> Pose2D | None:
        return self.pinned_pose


def _policy(tracked: Pose2D) -> tuple[Relocalisation, PinnedLocaliser]:
    grid = rasterise(ROOM, size=SIZE)
    localiser = PinnedLocaliser(grid)
    localiser.pinned_pose = tracked
    config = RelocalisationConfig(relocaliser=CONFIG, degraded_after_s=1.0)
    return Relocalisation(grid, localiser, config), localiser


def test_degraded_for_a_while_with_a_better_place_elsewhere_starts_the_search() -> None:
    policy, _ = _policy(TRACKED)
    rng = np.random.default_rng(24)
    started = None
    texts: list[str] = []
    for k in range(20):  # 10 Hz, driving at 0.3 m/s (degraded speed)
        now = 0.1 * (k + 1)
        _, events = policy.step(utm_scan(ROOM, TRUTH, now, rng), 0.3, now)
        texts += [e.text for e in events]
        if policy.active:
            started = now
            break
    # Not before degraded_after_s (the loss test decides first), soon after.
    assert started is not None and 1.1 - 1e-9 <= started <= 1.3
    assert policy.relocaliser.reason == "degraded"
    assert policy.state(LocaliserState.DEGRADED, started) is LocaliserState.SEARCHING
    assert any("finding my position" in t for t in texts)


def test_degraded_where_the_scan_fits_the_tracked_pose_starts_no_search() -> None:
    """Degraded by its covariance along a corridor, say, while the scan fits: no search, and
    the comparison is not even run (no place can fit ``kidnap_margin`` better)."""
    policy, _ = _policy(TRUTH)
    calls = 0
    engine = policy.relocaliser.search_engine
    original = engine.search

    def counted(*args: object, **kwargs: object) -> object:
        nonlocal calls
        calls += 1
        return original(*args, **kwargs)  # type: ignore[arg-type]

    engine.search = counted  # type: ignore[method-assign]
    rng = np.random.default_rng(25)
    for k in range(40):
        now = 0.1 * (k + 1)
        policy.step(utm_scan(ROOM, TRUTH, now, rng), 0.3, now)
        assert not policy.active
    assert calls == 0


def test_the_degraded_clock_restarts_when_the_localiser_recovers() -> None:
    policy, localiser = _policy(TRACKED)
    rng = np.random.default_rng(26)
    for k in range(8):  # degraded 0.8 s, then ok for a scan, then degraded again
        now = 0.1 * (k + 1)
        policy.step(utm_scan(ROOM, TRUTH, now, rng), 0.3, now)
    localiser.pinned_state = LocaliserState.OK
    policy.step(utm_scan(ROOM, TRUTH, 0.9, rng), 0.3, 0.9)  # driving: no background check
    localiser.pinned_state = LocaliserState.DEGRADED
    for k in range(10, 19):  # degraded again from 1.0 s: not yet 1 s of it by 1.8 s
        now = 0.1 * k
        policy.step(utm_scan(ROOM, TRUTH, now, rng), 0.3, now)
        assert not policy.active, now
    policy.step(utm_scan(ROOM, TRUTH, 2.0, rng), 0.3, 2.0)
    assert policy.active


def test_the_degraded_check_can_be_switched_off() -> None:
    grid = rasterise(ROOM, size=SIZE)
    localiser = PinnedLocaliser(grid)
    localiser.pinned_pose = TRACKED
    config = RelocalisationConfig(relocaliser=CONFIG, on_degraded=False)
    policy = Relocalisation(grid, localiser, config)
    rng = np.random.default_rng(27)
    for k in range(30):
        now = 0.1 * (k + 1)
        policy.step(utm_scan(ROOM, TRUTH, now, rng), 0.3, now)
    assert not policy.active
