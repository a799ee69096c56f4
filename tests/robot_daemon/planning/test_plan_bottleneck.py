"""The widest way between two cells (bottleneck path) against a readable reference."""

from __future__ import annotations

import heapq

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from robot_daemon.planning.bottleneck import free_width, widest_way

RES = 0.05


def reference_widest(width: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> float:
    """Dijkstra's algorithm on max-min: the widest way's narrowest cell (0 if none)."""
    h, w = width.shape
    best = np.full(width.shape, -1.0)
    best[start] = width[start]
    heap = [(-best[start], start)]
    while heap:
        neg, (r, c) = heapq.heappop(heap)
        if (r, c) == goal:
            return float(-neg)
        if -neg < best[r, c]:
            continue
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                rr, cc = r + dr, c + dc
                if (dr or dc) and 0 <= rr < h and 0 <= cc < w and width[rr, cc] > 0.0:
                    value = min(-neg, width[rr, cc])
                    if value > best[rr, cc]:
                        best[rr, cc] = value
                        heapq.heappush(heap, (-value, (rr, cc)))
    return 0.0


def wall_with_door(door_cells: int) -> np.ndarray:
    """A 4 x 3 m room split by a 2-cell wall at x = 2 m with a door centred at y = 1.5 m."""
    free = np.ones((60, 80), dtype=bool)
    free[:1, :] = free[-1:, :] = free[:, :1] = free[:, -1:] = False
    free[:, 40:42] = False
    lo = 30 - door_cells // 2
    free[lo : lo + door_cells, 40:42] = True
    return free


@pytest.mark.parametrize("door_cells", [11, 12, 18])
def test_the_door_is_the_bottleneck_and_its_width_is_measured(door_cells: int) -> None:
    free = wall_with_door(door_cells)
    width = free_width(ndimage.distance_transform_edt(free, sampling=RES), RES)
    found = widest_way(width, (30, 20), (30, 60))
    door = door_cells * RES
    assert door - RES - 1e-6 <= found.width <= door + 1e-6  # at most one cell low
    assert 40 <= found.col <= 41 and abs(found.row - 30) <= door_cells // 2


def test_separated_places_and_blocked_ends_have_no_way() -> None:
    free = wall_with_door(12)
    free[:, 40:42] = False  # the door is shut
    width = free_width(ndimage.distance_transform_edt(free, sampling=RES), RES)
    assert widest_way(width, (30, 10), (30, 70)).width == 0.0
    assert widest_way(width, (30, 10), (30, 40)).width == 0.0  # goal in the wall
    assert widest_way(width, (30, 10), (99, 10)).width == 0.0  # goal off the grid


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_matches_the_reference_on_random_clutter(seed: int) -> None:
    rng = np.random.default_rng(seed)
    free = rng.random((24, 30)) > 0.12
    free = ndimage.binary_opening(free, iterations=1) | (rng.random((24, 30)) > 0.97)
    width = free_width(ndimage.distance_transform_edt(free, sampling=RES), RES)
    cells = np.argwhere(width > 0)
    if len(cells) < 2:
        return
    a, b = (tuple(int(v) for v in cells[i]) for i in rng.choice(len(cells), 2, replace=False))
    found = widest_way(width, a, b)  # type: ignore[arg-type]
    expected = reference_widest(width, a, b)  # type: ignore[arg-type]
    step = max(float(width.max()), 1e-9) / 2**10  # the bisection's resolution
    assert expected - step <= found.width <= expected + 1e-9
    if expected > 0.0:  # the reported bottleneck lies on a way that narrow
        assert abs(width[found.row, found.col] - expected) <= step + 1e-9
