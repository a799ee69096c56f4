"""The localiser's see-through test as one compiled loop over rays: sphere tracing on a step field.

Sphere tracing (Hart, "Sphere tracing: a geometric method for the antialiased ray tracing of
implicit surfaces", The Visual Computer 12, 1996) marches a ray by the distance to the nearest
surface, which it cannot overshoot. `Localiser.impossible_beams` traces each beam from the laser
this way on the map's distance field to its occupied cells: a point whose cell is at distance
``d`` from the nearest occupied cell centre is at least ``d - √2·res`` from any occupied cell,
so the ray advances by ``max(d - √2·res, res)`` (the step field, `localiser._sphere_steps`: NaN
in an occupied cell, inf on the field's border). A beam is impossible when its ray reaches an
occupied cell, and stays in occupied cells for ``depth`` (probed at half and the whole of it),
before its measured range less the margin; a lone occupied cell not that deep is stepped over
by one cell. A ray that reaches that range, leaves the map or runs out of steps is possible.

Each ray in scalar float64 arithmetic, compiled (`robot_daemon.jit`; a few rays side by side,
`LANES`): the same operations in the same order as the plain numpy loop that
`tests/robot_daemon/localisation/test_loc_speed_equivalence.py` keeps as the reference (``int``
truncates as ``astype(np.intp)`` does, then the cell is clipped to the field; the beams'
lengths are numpy's ``hypot``), so every flag and every crossing range equals it bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from robot_daemon import jit

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

LANES = 8  # rays traced side by side (`trace_rays`)


@jit.kernel
def _step_at(
    steps: FloatArray,
    t: float,
    dcol: float,
    drow: float,
    laser: tuple[float, float],
    field: tuple[int, int],
) -> float:
    """The step field at parameter ``t`` [m] of the ray ``laser + t · (dcol, drow)`` (cells of
    the ``field = (width, height)`` field, border included), the sample clipped to the field."""
    width, height = field
    col = min(max(int(laser[0] + t * dcol), 0), width - 1)
    row = min(max(int(laser[1] + t * drow), 0), height - 1)
    value: float = steps[row * width + col]
    return value


@jit.kernel
def _advance(
    steps: FloatArray,
    t: float,
    direction: tuple[float, float],
    laser: tuple[float, float],
    field: tuple[int, int],
    resolution: float,
    depth: float,
) -> tuple[float, bool]:
    """One step of the ray ``laser + t · direction`` (cells per metre): ``(t + step, False)``,
    or ``(t, True)`` where it passes into the map's occupied cells (the step field is NaN at
    ``t``, and at ``t + depth / 2`` and ``t + depth`` too: else it is not deep, one cell on)."""
    dcol, drow = direction
    d = _step_at(steps, t, dcol, drow, laser, field)
    if math.isnan(d):  # an occupied cell
        if depth <= 0.0 or (
            math.isnan(_step_at(steps, t + 0.5 * depth, dcol, drow, laser, field))
            and math.isnan(_step_at(steps, t + 1.0 * depth, dcol, drow, laser, field))
        ):
            return t, True
        d = resolution  # not deep: one cell on
    return t + d, False


@jit.kernel
def trace_rays(
    points: FloatArray,
    ranges: FloatArray,
    cos_sin: tuple[float, float],
    laser: tuple[float, float],
    steps: FloatArray,
    field: tuple[int, int],
    resolution: float,
    trace: tuple[float, int, float],
) -> tuple[BoolArray, FloatArray]:
    """Which of the beams ``points`` (sensor-frame end points, (N, 2), C-contiguous) pass
    through the map, and the range [m] at which each of those enters its occupied cells (NaN
    for the others).

    ``ranges``: the beams' lengths, ``np.hypot`` of the points (numpy's, the reference's:
    CPython's ``math.hypot``, the plain-Python fallback's, rounds apart from the C library's
    in a few end points in a thousand); ``cos_sin``: the laser's heading; ``laser``: its position in continuous cells of the step
    field (column, row: the map's cells plus its border of one); ``steps``: the step field,
    flat row-major, ``field = (width, height)`` cells; ``resolution`` [m]; ``trace = (margin
    [m], max_steps, depth [m])`` (`LocaliserConfig.impossible_margin_m`,
    ``impossible_max_steps``, ``impossible_depth_m``).

    A beam of range ``r`` and unit direction ``u`` (map frame) is the ray ``x(t) = laser +
    t · u / res``: ``t ← t + step(x(t))`` from 0 until ``t ≥ r - margin`` (possible),
    ``max_steps`` steps (possible) or `_advance` finds it passing through (impossible).

    Speed: `LANES` rays step side by side, one step of each in turn, so the reads of the step
    field of different rays (cache misses on a large map) overlap instead of each waiting for
    the one before; every ray's arithmetic is its own, in the plain loop's order.
    """
    c, s = cos_sin
    margin, max_steps, depth = trace
    inv = 1.0 / resolution
    n = points.shape[0]
    crossing = np.full(n, np.nan)
    t = np.zeros(LANES)
    limit = np.zeros(LANES)
    dcol = np.zeros(LANES)
    drow = np.zeros(LANES)
    ray = np.zeros(LANES, dtype=np.intp)
    left = np.zeros(LANES, dtype=np.intp)  # steps left; 0: the lane's ray has ended
    for first in range(0, n, LANES):
        lanes = 0
        for i in range(first, min(first + LANES, n)):
            sx, sy, r = points[i, 0], points[i, 1], ranges[i]
            if not r - margin > 0.0:
                continue  # a beam shorter than the margin cannot pass through anything
            t[lanes], limit[lanes], ray[lanes], left[lanes] = 0.0, r - margin, i, max_steps
            dcol[lanes] = (c * sx - s * sy) / r * inv
            drow[lanes] = (s * sx + c * sy) / r * inv
            lanes += 1
        busy = lanes > 0
        while busy:
            busy = False
            for k in range(lanes):
                if left[k] == 0:
                    continue
                left[k] -= 1
                direction = (dcol[k], drow[k])
                t_next, through = _advance(steps, t[k], direction, laser, field, resolution, depth)
                if through:
                    crossing[ray[k]] = t[k]
                    left[k] = 0
                elif not t_next < limit[k]:
                    left[k] = 0
                else:
                    t[k] = t_next
                    busy = True
    return ~np.isnan(crossing), crossing


@jit.on_warm_up("localiser's see-through trace")
def _warm_up() -> None:
    """The kernels with the types `Localiser` passes."""
    field = np.full(4 * 4, np.inf)
    field[5] = np.nan
    points = np.array([[1.0, 0.0], [0.0, 1.0]])
    ranges = np.hypot(points[:, 0], points[:, 1])
    trace_rays(points, ranges, (1.0, 0.0), (1.5, 1.5), field, (4, 4), 0.05, (0.3, 30, 0.1))
