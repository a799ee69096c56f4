"""The learnt wall model's matcher is built off the scan path and swapped in at a scan boundary
(`matcher_swap`, issue 12): at the first well-tracked scan ``swap_after_s`` after the decision
on the localiser's clock, whatever the build's speed, so a run is the same for a seed; the
scans before it go on with the old matcher while the build runs. And the one line the operator
reads once the model is learnt.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest

import robot_daemon.localisation.matcher_swap as matcher_swap
from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import OccupancyGrid
from robot_daemon.localisation.localiser import Localiser, LocaliserConfig, LocaliserState
from robot_daemon.localisation.scan_matcher import ScanMatcher, ScanMatcherConfig
from robot_daemon.localisation.wall_model import WallModelConfig, WallModelStatus
from tests.robot_daemon.localisation.synthetic_office import OFFICE_BOXES, office_grid, utm_scan

SCAN_PERIOD_S = 0.1


def _config(swap_after_s: float) -> LocaliserConfig:
    return LocaliserConfig(
        matcher=ScanMatcherConfig(surface="cell_centre"),
        wall_model=WallModelConfig(learn=True, swap_after_s=swap_after_s),
    )


@dataclass
class Run:
    times: list[float]
    poses: list[Pose2D | None]
    surfaces: list[str]  # the matcher's after each scan (the one the next scan is matched with)
    decided_at: float  # [s] the deciding scan's time


def _drive(
    config: LocaliserConfig, after_scan: Callable[[Localiser, float], None] | None = None
) -> Run:
    """The plan-drawn office (walls on the cell faces, learnt within a few metres) along y = 4 m,
    10 cm and 0.1 s per scan, exact odometry; ``after_scan(loc, now)`` after each scan."""
    rng = np.random.default_rng(4)
    loc = Localiser(office_grid(), config)
    path = [Pose2D(1.5 + 0.1 * k, 4.0, 0.0) for k in range(111)]
    loc.on_odometry(Pose2D(0.0, 0.0, 0.0), 0.0)
    loc.set_initial_pose(path[0], 0.0)
    run = Run([], [], [], float("nan"))
    for k, pose in enumerate(path):
        now = SCAN_PERIOD_S * k
        loc.on_odometry(pose.relative_to(path[0]), now)
        est = loc.on_scan(utm_scan(OFFICE_BOXES, pose, now, rng), now)
        assert est.state is LocaliserState.OK, (k, est.reason)
        run.times.append(now)
        run.poses.append(est.pose)
        run.surfaces.append(loc.matcher.config.surface)
        if loc.wall_model.decided and run.decided_at != run.decided_at:  # the first: NaN before
            run.decided_at = now
        if after_scan is not None:
            after_scan(loc, now)
    return run


@pytest.mark.parametrize("swap_after_s", [0.0, 1.0])
def test_the_new_matcher_is_swapped_in_at_the_first_scan_the_delay_after_the_decision(
    swap_after_s: float,
) -> None:
    """Every scan until ``swap_after_s`` after the decision is matched with the old model
    (``cell_centre``), every one after with the learnt one (``cell_face``); 0 swaps at the
    deciding scan, as the rebuild on the scan path did."""
    run = _drive(_config(swap_after_s))
    due = run.decided_at + swap_after_s
    assert run.decided_at < 8.0
    expected = ["cell_centre" if t < due else "cell_face" for t in run.times]
    assert run.surfaces == expected
    assert run.surfaces[-1] == "cell_face"
    if swap_after_s > 0.0:
        swapped = expected.index("cell_face")
        assert (
            run.times[swapped] - run.decided_at
            >= swap_after_s
            > run.times[swapped - 1] - run.decided_at
        )


def test_a_slow_build_does_not_stall_the_scans_and_the_run_is_the_same(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The build is held back until the last scan before the swap: the scans in between are
    matched (with the old model) while it has not finished, the swap still comes at the same
    scan (waiting there for the build's last part), and every estimate is the one of a run
    whose build was not held back."""
    reference = _drive(_config(1.0))
    gate = threading.Event()

    def held_back_build(grid: OccupancyGrid, config: ScanMatcherConfig) -> ScanMatcher:
        assert gate.wait(30.0), "the test never released the build"
        return ScanMatcher(grid, config)

    monkeypatch.setattr(matcher_swap, "ScanMatcher", held_back_build)
    unfinished_scans: list[float] = []
    due = reference.decided_at + 1.0

    def after_scan(loc: Localiser, now: float) -> None:
        build = loc._matcher_build
        if build is None:
            return
        assert not build.finished  # the gate is shut: the scan went on without it
        unfinished_scans.append(now)
        next_scan = SCAN_PERIOD_S * (round(now / SCAN_PERIOD_S) + 1)  # as `_drive` counts
        if next_scan >= build.due:  # the next scan swaps: let the build finish
            gate.set()

    run = _drive(_config(1.0), after_scan)
    gate.set()
    # 1 s of scans at 10 Hz, the deciding one included
    assert unfinished_scans == [t for t in reference.times if reference.decided_at <= t < due]
    assert len(unfinished_scans) in (10, 11)
    assert run.decided_at == reference.decided_at
    assert run.surfaces == reference.surfaces
    assert run.poses == reference.poses


def test_the_learnt_model_is_one_line_for_the_operator() -> None:
    """What the daemon sends the station once the model is learnt (`RobotStack`'s status log;
    tests/e2e/test_e2e_wall_model.py sees it arrive); nothing while learning or fixed."""
    votes = {"cell_centre": 0, "cell_face": 8}
    face = WallModelStatus("cell_face", False, True, votes, 10, 4.62)
    assert face.notice() == (
        "Localiser: this map's walls lie on the cell faces (learnt after 4.6 m)"
    )
    centre = WallModelStatus(
        "cell_centre", False, True, {"cell_centre": 9, "cell_face": 1}, 12, 17.4
    )
    assert centre.notice() == (
        "Localiser: this map's walls lie through the cell centres (learnt after 17.4 m)"
    )
    assert WallModelStatus("cell_centre", True, False, votes, 10).notice() is None
    assert WallModelStatus("cell_face", False, False, votes, 0).notice() is None
