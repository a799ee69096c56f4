"""The widest way between two places on a map, and where it is narrowest (a bottleneck path).

When no path exists the robot must say *where* and *why* (issue 12): "separated by obstacles"
leaves the operator guessing, "the way narrows to 0.60 m at (4.05, 4.00)" does not. The same
measure tells whether a topological arc can be driven at all (``tools/topo_gaps.py``).

Free width. With ``d`` the distance from a cell centre to the nearest blocked cell centre, a
corridor of an odd number ``n`` of free cells has ``d = (n + 1) res / 2`` on its middle cell, an
even number ``d = n res / 2`` on its two middle cells; so the gap a cell sits in is
``w = 2 d - res`` wide (face to face) or, for an even count, one cell wider: ``w`` is a lower
bound, at most one cell low.

Bottleneck (maximin) path. The largest ``w*`` such that the cells with ``w >= w*`` join the two
places (8-connected) is found by bisection on ``w*``, each step one ``scipy.ndimage.label``. The
bottleneck itself is the cell, among those just below the next step up, that lies closest to both
halves the path falls into when the threshold rises past ``w*``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import ndimage

_EIGHT = np.ones((3, 3), dtype=bool)
BISECTION_STEPS = 10  # width resolution: (largest width) / 2**10, a few millimetres


@dataclass(frozen=True)
class Bottleneck:
    """The widest way's narrowest width [m] and the cell (row, col) where it is narrowest."""

    width: float  # [m] 0 when the places are not joined at all
    row: int
    col: int


def free_width(distance: npt.NDArray[np.floating], resolution: float) -> npt.NDArray[np.float64]:
    """Per cell, the width [m] of the gap it sits in, ``2 d - res`` (0 in blocked cells): at most
    one cell narrower than the true gap (see the module docstring)."""
    width: npt.NDArray[np.float64] = np.maximum(
        2.0 * np.asarray(distance, dtype=np.float64) - resolution, 0.0
    )
    return width


def widest_way(
    width: npt.NDArray[np.float64], start: tuple[int, int], goal: tuple[int, int]
) -> Bottleneck:
    """The bottleneck between cells ``start`` and ``goal`` (row, col) of a free-width grid.

    Cells outside the grid count as blocked; a start or goal in a blocked cell gives width 0.
    """
    h, w = width.shape
    for r, c in (start, goal):
        if not (0 <= r < h and 0 <= c < w) or width[r, c] <= 0.0:
            return Bottleneck(0.0, r, c)

    def labels_at(threshold: float) -> npt.NDArray[np.int32]:
        labels, _ = ndimage.label(width >= threshold, structure=_EIGHT)
        result: npt.NDArray[np.int32] = labels
        return result

    def joined(labels: npt.NDArray[np.int32]) -> bool:
        a = labels[start]
        return bool(a != 0 and a == labels[goal])

    lo, hi = 0.0, float(min(width[start], width[goal]))
    if not joined(labels_at(1e-9)):
        return Bottleneck(0.0, *start)
    if joined(labels_at(hi)):
        return Bottleneck(hi, *(start if width[start] <= width[goal] else goal))
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        if joined(labels_at(mid)):
            lo = mid
        else:
            hi = mid
    # At `hi` the way falls into two parts; the bottleneck joins them.
    below = labels_at(lo)
    region = below == below[start]
    above = labels_at(hi)
    near_start = ndimage.distance_transform_edt(above != above[start])
    near_goal = ndimage.distance_transform_edt(above != above[goal])
    score = np.where(region & (width < hi), near_start + near_goal, np.inf)
    row, col = np.unravel_index(int(np.argmin(score)), score.shape)
    value = float(width[row, col]) if math.isfinite(score[row, col]) else lo
    return Bottleneck(value, int(row), int(col))
