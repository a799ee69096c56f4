"""tools/reallog_decompose.py: a real log's RMS split between the reference and the localiser."""

from __future__ import annotations

import dataclasses
import importlib.util
import math
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from tests.robot_daemon.localisation.carmen_log import read_laser_records
from tests.robot_daemon.localisation.log_replay import map_of

REPO = Path(__file__).resolve().parents[2]
LOGS = REPO.parent / "shared" / "data" / "laser_logs"


def _load() -> ModuleType:
    spec = importlib.util.spec_from_file_location(
        "reallog_decompose", REPO / "tools" / "reallog_decompose.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks its module up
    spec.loader.exec_module(module)
    return module


tool = _load()


def _part(  # type: ignore[no-untyped-def]
    k: int,
    error: float,
    offset: float,
    to_fit: float,
    hit: float = 0.8,
    run: int = 0,
    score: float = 0.9,
):
    return tool.ScanPart(
        log_index=2 * k,
        run=run,
        index=k,
        state="ok",
        reason="",
        error_m=error,
        map_error_m=error,
        reference_offset_m=offset,
        estimate_to_fit_m=to_fit,
        score=score,
        sigma_m=0.02,
        odometry_error_m=1.0,
        dead_reckoning_m=0.1,
        hit_fit=hit,
        hit_estimate=hit,
        heading_error_deg=0.0,
        fit_heading_deg=0.0,
        predicted_error_m=error,
    )


def test_a_scan_is_classed_by_which_part_exceeds_the_tolerance() -> None:
    assert _part(0, 0.02, 0.01, 0.01).kind(0.05) == "agree"
    assert _part(0, 0.10, 0.10, 0.01).kind(0.05) == "reference"
    assert _part(0, 0.10, 0.01, 0.10).kind(0.05) == "localiser"
    assert _part(0, 0.30, 0.10, 0.25).kind(0.05) == "both"
    # Off the fit, but the scan fits the estimate as well: the map cannot tell them apart.
    assert _part(0, 0.30, 0.01, 0.30, score=0.99).kind(0.05) == "look-alike"
    assert _part(0, 0.30, 0.10, 0.25, score=1.02).kind(0.05) == "look-alike"
    # The scan fits the map nowhere near the logged pose: no fit to judge either by.
    assert _part(0, 0.30, 0.01, 0.30, hit=0.1).kind(0.05) == "unmatched"
    assert _part(0, 0.30, math.nan, math.nan, hit=math.nan).kind(0.05) == "unmatched"


def test_the_parts_of_the_rms_add_in_quadrature_to_the_rms() -> None:
    parts = [
        _part(0, 0.02, 0.01, 0.01),
        _part(1, 0.10, 0.10, 0.01),
        _part(2, 0.20, 0.01, 0.20),
        _part(3, 0.30, 0.10, 0.25),
        _part(4, 0.40, 0.01, 0.40, hit=0.1),
        _part(5, 0.25, 0.01, 0.25, score=1.0),
    ]
    table = tool.split(parts, 0.05)
    rms = math.sqrt(np.mean([p.error_m**2 for p in parts]))
    assert table["all"]["rms_part_m"] == pytest.approx(rms)
    together = sum(table[k]["rms_part_m"] ** 2 for k in tool.CLASSES)
    assert math.sqrt(together) == pytest.approx(rms)
    assert table["localiser"]["scans"] == 1.0
    assert table["localiser"]["rms_part_m"] == pytest.approx(math.sqrt(0.2**2 / 6))
    assert table["look-alike"]["scans"] == 1.0


def test_stretches_join_across_short_gaps_and_the_largest_comes_first() -> None:
    good = [_part(k, 0.01, 0.01, 0.01) for k in range(12)]
    parts = list(good)
    parts[1] = _part(1, 0.10, 0.01, 0.10)
    parts[3] = _part(3, 0.12, 0.01, 0.12)  # two agreeing scans between: one stretch
    parts[9] = _part(9, 0.50, 0.01, 0.50)  # far on: a stretch of its own, the larger
    found = tool.stretches(parts, 0.05, gap=2)
    assert [[p.index for p in s] for s in found] == [[9], [1, 2, 3]]
    # Another replayed run starts a new stretch even right after one.
    parts[4] = _part(4, 0.10, 0.01, 0.10, run=1)
    assert [[p.index for p in s] for s in tool.stretches(parts, 0.05, gap=2)][1:] == [
        [1, 2, 3],
        [4],
    ]


@pytest.mark.realdata
def test_a_reference_moved_off_the_map_is_the_references_share() -> None:
    """The Intel lab, scans 0-200 (every 2nd maps, the others localised): with the logged
    poses as they are, the error is the few centimetres both agree to; with every logged
    pose moved 0.15 m east (a reference that disagrees with the map, as the Infinite
    Corridor's second pass does), the localiser follows the map and the RMS is the
    reference's, not the localiser's."""
    path = LOGS / "intel-corrected.log.gz"
    if not path.is_file():
        pytest.skip(f"real laser log {path} is absent (see ../shared/data/README.md)")
    records = read_laser_records(path)[:200]
    grid = map_of(records[0::2])
    run = records[1::2]
    moved = [
        dataclasses.replace(r, pose=Pose2D(r.pose.x + 0.15, r.pose.y, r.pose.yaw)) for r in run
    ]
    fair = tool.split(tool.decompose(grid, [run], np.random.default_rng(0), id), 0.05)
    shifted = tool.split(tool.decompose(grid, [moved], np.random.default_rng(0), id), 0.05)
    assert fair["agree"]["scans"] > 0.8 * fair["all"]["scans"]
    assert fair["localiser"]["rms_part_m"] < 0.02
    assert 0.12 < shifted["all"]["rms_part_m"] < 0.18
    assert shifted["reference"]["rms_part_m"] > 0.9 * shifted["all"]["rms_part_m"]
    assert shifted["localiser"]["rms_part_m"] < 0.02


def test_the_drift_switch_sets_only_the_heading_drift_state() -> None:
    """``--drift on`` / ``off`` replays with the heading-drift state on or off and every other
    setting of the replay's localiser as it is; without it, the configuration is the replay's."""
    from tests.robot_daemon.localisation.log_replay import log_config

    default = log_config()
    assert tool.localiser_config(None) == default
    for drift in (True, False):
        config = tool.localiser_config(drift)
        assert config.odometry_yaw_bias.enabled is drift
        assert config.odometry_yaw_bias.sigma == default.odometry_yaw_bias.sigma
        assert config.matcher == default.matcher
        assert config.wall_model == default.wall_model
