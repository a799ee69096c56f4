"""The localiser learns where its map's walls lie in their cells (`wall_model`, issue 12).

On a map drawn from a plan (walls on cell faces) it switches from ``cell_centre`` to
``cell_face``; on a map binned from scan end points it keeps ``cell_centre``; it decides once
and says so; the daemon's ``map_surface: learn`` is the default.
"""

from __future__ import annotations

import functools
import logging
import math
from pathlib import Path

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import OccupancyGrid
from robot_daemon.config import DaemonConfig
from robot_daemon.localisation.localiser import Localiser, LocaliserConfig, LocaliserState
from robot_daemon.localisation.scan_matcher import ScanMatcherConfig
from robot_daemon.localisation.wall_model import (
    WallModelConfig,
    WallModelConfigError,
    WallModelLearner,
    beam_depths,
    wall_model_setting,
)
from robot_daemon.scenarios.runner import daemon_localiser_config
from tests.robot_daemon.localisation.carmen_log import read_laser_records
from tests.robot_daemon.localisation.log_replay import grid_from_scans, localise_interleaved
from tests.robot_daemon.localisation.synthetic_office import (
    OFFICE_BOXES,
    office_grid,
    utm_scan,
)

LOGS = Path(__file__).resolve().parents[3].parent / "shared" / "data" / "laser_logs"
LEARN = LocaliserConfig(
    matcher=ScanMatcherConfig(surface="cell_centre"), wall_model=WallModelConfig(learn=True)
)
# The office's walls and furniture moved off the 0.05 m lattice (by 1.7 cm in x, 3.1 cm in y):
# a map binned from scans of it has its walls inside the cells, not on their faces.
OFF_LATTICE = OFFICE_BOXES + np.array([0.017, 0.031, 0.017, 0.031])


def _path() -> list[Pose2D]:
    """Along the office at y = 4 m, x from 1.5 to 12.5 m, 10 cm per scan."""
    return [Pose2D(1.5 + 0.1 * k, 4.0, 0.0) for k in range(111)]


def _drive(grid: OccupancyGrid, boxes: np.ndarray, config: LocaliserConfig) -> Localiser:
    """Localise `_path` in ``grid`` with scans of ``boxes`` and exact odometry."""
    rng = np.random.default_rng(4)
    loc = Localiser(grid, config)
    path = _path()
    loc.on_odometry(Pose2D(0.0, 0.0, 0.0), 0.0)
    loc.set_initial_pose(path[0], 0.0)
    for k, pose in enumerate(path):
        now = 0.1 * k
        loc.on_odometry(pose.relative_to(path[0]), now)  # exact odometry
        est = loc.on_scan(utm_scan(boxes, pose, now, rng), now)
        assert est.state is not LocaliserState.LOST
    return loc


@functools.cache
def _binned_map() -> OccupancyGrid:
    """The off-lattice office binned from noisy scans along the path (as SLAM builds a map)."""
    rng = np.random.default_rng(7)
    poses = [Pose2D(1.5 + 0.25 * k, y, 0.3 * k) for k in range(45) for y in (2.5, 6.5, 10.5)]
    poses = [p for p in poses if p.x < 19.0]
    scans = [utm_scan(OFF_LATTICE, p, 0.0, rng) for p in poses]
    return grid_from_scans(scans, poses, 0.05, margin=0.0)


def test_beam_depths_are_zero_on_faces_and_half_a_cell_on_a_binned_map() -> None:
    """The evidence itself: the beams of a scan of the plan-drawn office end at the faces of
    its occupied cells (median depth ~0), those of the off-lattice office inside the cells of
    a map binned from its scans (median about half a cell or more)."""
    pose = Pose2D(6.0, 4.0, 0.3)
    rng = np.random.default_rng(1)
    scan = utm_scan(OFFICE_BOXES, pose, 0.0, rng)
    depths = beam_depths(office_grid(), scan.points(30.0), pose) / 0.05
    assert depths.size > 500
    assert abs(float(np.median(depths))) < 0.15
    binned = _binned_map()
    scan = utm_scan(OFF_LATTICE, pose, 0.0, rng)
    depths = beam_depths(binned, scan.points(30.0), pose) / 0.05
    assert depths.size > 500
    assert float(np.median(depths)) > 0.45


def test_a_plan_drawn_map_is_learnt_to_have_its_walls_on_the_faces(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Started with ``cell_centre`` on the plan-drawn office, the localiser learns faces within
    a few metres, switches its matcher once and says so (one log line); it then samples no
    more."""
    with caplog.at_level(logging.WARNING):
        loc = _drive(office_grid(), OFFICE_BOXES, LEARN)
    status = loc.wall_model
    assert status.decided and not status.learning
    assert status.surface == "cell_face" == loc.matcher.config.surface
    assert loc.config.matcher.surface == "cell_face"
    assert status.votes["cell_face"] >= 6 and status.votes["cell_centre"] == 0
    assert status.decided_at_m < 8.0
    learnt = [r for r in caplog.records if "wall model learnt" in r.getMessage()]
    assert len(learnt) == 1 and "on the cell faces" in learnt[0].getMessage()
    assert "switches from cell_centre" in learnt[0].getMessage()
    assert status.samples <= 2 * (status.votes["cell_face"] + 2)  # stopped once decided
    assert "learnt" in status.describe()


def test_a_binned_map_keeps_its_walls_through_the_cell_centres(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """On a map binned from scans of a building whose walls are not on the lattice, the
    localiser learns ``cell_centre`` (the model it started with: no switch) and says so."""
    with caplog.at_level(logging.WARNING):
        loc = _drive(_binned_map(), OFF_LATTICE, LEARN)
    status = loc.wall_model
    assert status.decided and status.surface == "cell_centre" == loc.matcher.config.surface
    assert status.votes["cell_face"] == 0
    learnt = [r for r in caplog.records if "wall model learnt" in r.getMessage()]
    assert len(learnt) == 1 and "through the cell centres" in learnt[0].getMessage()
    assert "switches" not in learnt[0].getMessage()


def test_a_fixed_wall_model_is_never_sampled_or_switched() -> None:
    """``learn`` off (the default of `LocaliserConfig`, and ``map_surface: cell_centre`` or
    ``cell_face``): the matcher's model stays, even on a map that would vote against it."""
    fixed = LocaliserConfig(matcher=ScanMatcherConfig(surface="cell_centre"))
    loc = _drive(office_grid(), OFFICE_BOXES, fixed)
    status = loc.wall_model
    assert not status.decided and not status.learning and status.samples == 0
    assert status.surface == "cell_centre" == loc.matcher.config.surface
    assert status.describe() == "cell_centre (fixed)"


def test_the_learner_decides_once_by_a_margin_of_votes() -> None:
    """The sequential sign test: no decision before ``min_votes`` votes and a lead of
    ``decide_margin``; scans in between the two models abstain; after the decision nothing
    more is sampled, whatever the scans say."""
    cfg = WallModelConfig(learn=True, decide_margin=3, min_votes=4, min_beams=5)
    learner = WallModelLearner(cfg, "cell_centre")
    faces, centres, between = np.zeros(50), np.full(50, 0.6), np.full(50, 0.3)
    assert learner.wants_sample(0.0, 0.01, 0.9)
    assert not learner.wants_sample(0.0, 0.2, 0.9)  # not tracking well: no sample
    assert not learner.wants_sample(0.0, 0.01, 0.5)
    assert learner.add(faces, 0.0) is None
    assert not learner.wants_sample(0.3, 0.01, 0.9)  # within sample_every_m of the last
    assert learner.add(centres, 0.5) is None
    assert learner.add(between, 1.0) is None  # abstains
    assert learner.add(faces[:3], 1.5) is None  # too few beams: abstains
    assert learner.votes == {"cell_centre": 1, "cell_face": 1} and learner.samples == 4
    assert learner.add(faces, 2.0) is None
    assert learner.add(faces, 2.5) is None  # lead 2 < 3
    assert learner.add(faces, 3.0) == "cell_face"
    assert learner.decided and learner.surface == "cell_face" and learner.decided_at_m == 3.0
    assert not learner.learning and not learner.wants_sample(10.0, 0.01, 0.9)


def test_wall_model_settings_and_their_validation() -> None:
    """``learn`` starts from cell centres and learns; the fixed models do not; the thresholds
    are checked with messages naming the field."""
    matcher, wall = wall_model_setting("learn")
    assert matcher.surface == "cell_centre" and wall.learn
    for fixed in ("cell_centre", "cell_face"):
        matcher, wall = wall_model_setting(fixed)
        assert matcher.surface == fixed and not wall.learn
    with pytest.raises(WallModelConfigError, match="face_below_cells"):
        WallModelConfig(face_below_cells=0.5, centre_above_cells=0.4)
    with pytest.raises(WallModelConfigError, match="sample_every_m"):
        WallModelConfig(sample_every_m=-1.0)
    with pytest.raises(WallModelConfigError, match="decide_margin"):
        WallModelConfig(decide_margin=0)


@pytest.mark.realdata
def test_the_intel_labs_binned_map_is_learnt_to_have_walls_through_the_centres(
    record_property,
) -> None:
    """A real log's map binned from its scans (`log_replay`, the interleaved method on 600
    scans of the Intel lab, the daemon's ``learn``): the localiser learns ``cell_centre`` and
    never matches a scan with faces."""
    path = LOGS / "intel-corrected.log.gz"
    if not path.is_file():
        pytest.skip(f"real laser log {path} is absent (see ../shared/data/README.md)")
    stats = localise_interleaved(path, 2, count=600, records=read_laser_records(path))
    for key, value in stats.items():
        record_property(key, value)
    assert stats["wall_face_scans"] == 0.0
    assert stats["wall_learnt_scans"] > 0.5
    assert stats["silent_failures"] == 0
    assert math.isfinite(stats["rms_m"]) and stats["rms_m"] < 0.05


def test_the_daemon_and_the_scenarios_learn_the_wall_model_by_default() -> None:
    """One way for every backend: the daemon's default ``map_surface`` is ``learn``, and the
    scenarios build their localiser from it (never `LocaliserConfig`'s fixed default)."""
    matcher, wall = wall_model_setting(DaemonConfig().localiser.map_surface)
    assert wall.learn and matcher.surface == "cell_centre"
    config = daemon_localiser_config()
    assert config.wall_model.learn and config.matcher.surface == "cell_centre"
