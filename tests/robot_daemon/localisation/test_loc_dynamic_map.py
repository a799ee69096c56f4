"""Dynamic evidence grid: streaks, promotion rules, decay of short-lived hits."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from interbot_core.occupancy_grid import FREE, OccupancyGrid
from robot_daemon.localisation.dynamic_map import (
    DynamicEvidenceGrid,
    DynamicMapConfig,
    DynamicMapConfigError,
)

GRID = OccupancyGrid(np.full((40, 60), FREE, dtype=np.int8), 0.05, -1.0, -1.0)
CFG = DynamicMapConfig(promote_after_s=10.0, max_gap_s=1.0, min_hits=5, min_travel_m=0.5)
X, Y = np.array([0.31]), np.array([0.21])


def test_steady_hits_with_travel_promote_after_the_delay() -> None:
    ev = DynamicEvidenceGrid(GRID, CFG)
    promoted_at = None
    for k in range(0, 121):
        t = k * 0.1
        px, py = ev.update(X, Y, t, travel_m=0.05 * t)
        if px.size:
            promoted_at = t
            assert px[0] == pytest.approx(0.325) and py[0] == pytest.approx(0.225)
            break
    assert promoted_at == pytest.approx(10.0)
    assert ev.promoted.sum() == 1


def test_no_promotion_without_travel() -> None:
    ev = DynamicEvidenceGrid(GRID, CFG)
    for k in range(0, 300):
        px, _ = ev.update(X, Y, k * 0.1, travel_m=0.2)
        assert px.size == 0


def test_a_gap_restarts_the_streak() -> None:
    ev = DynamicEvidenceGrid(GRID, CFG)
    for k in range(0, 90):  # 0 .. 8.9 s
        ev.update(X, Y, k * 0.1, travel_m=0.1 * k)
    # 1.5 s without hits (> max_gap_s): the streak restarts at 10.4 s.
    for k in range(104, 250):
        t = k * 0.1
        px, _ = ev.update(X, Y, t, travel_m=0.1 * k)
        if px.size:
            assert t == pytest.approx(20.4)
            return
    pytest.fail("never promoted after the restart")


def test_points_outside_the_grid_are_ignored() -> None:
    ev = DynamicEvidenceGrid(GRID, CFG)
    px, _ = ev.update(np.array([-5.0, 50.0]), np.array([0.0, 0.0]), 0.0, 0.0)
    assert px.size == 0 and ev.active_cells(0.0) == 0


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(1.01, 5.0), min_size=1, max_size=60))
def test_hits_separated_by_long_gaps_never_promote(gaps: list[float]) -> None:
    """A passer-by: however many times a cell is hit, gaps > max_gap_s keep it dynamic."""
    ev = DynamicEvidenceGrid(GRID, CFG)
    t = 0.0
    for i, gap in enumerate(gaps):
        t += gap
        px, _ = ev.update(X, Y, t, travel_m=float(i))
        assert px.size == 0
    assert not ev.promoted.any()


def test_reset_streaks_keeps_promoted_cells() -> None:
    ev = DynamicEvidenceGrid(GRID, CFG)
    for k in range(0, 101):
        ev.update(X, Y, k * 0.1, travel_m=0.1 * k)
    assert ev.promoted.sum() == 1
    ev.reset_streaks()
    assert ev.promoted.sum() == 1 and ev.active_cells(10.0) == 0


@pytest.mark.parametrize(
    "kwargs",
    [{"promote_after_s": 0.5}, {"max_gap_s": 0.0}, {"min_hits": 0}, {"min_travel_m": -1.0}],
)
def test_config_rejects_out_of_range(kwargs: dict[str, float]) -> None:
    with pytest.raises(DynamicMapConfigError, match=next(iter(kwargs))):
        DynamicMapConfig(**kwargs)  # type: ignore[arg-type]
