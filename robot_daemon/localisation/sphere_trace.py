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

One ray at a time in scalar float64 arithmetic (`robot_daemon.jit`): the same operations in the
same order as the plain numpy loop `tests/robot_daemon/localisation/test_loc_speed_equivalence.py`
keeps as the reference (``int`` truncates as ``astype(np.intp)`` does, then the cell is clipped
to the field), so every flag and every crossing range equals it bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from robot_daemon import jit

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


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
def _trace_ray(
    point: FloatArray,
    cos_sin: tuple[float, float],
    laser: tuple[float, float],
    steps: FloatArray,
    field: tuple[int, int],
    resolution: float,
    trace: tuple[float, int, float],
) -> float:
    """The range [m] at which the beam to ``point`` (sensor frame) enters the map's occupied
    cells, NaN if it does not pass through them (`trace_rays` has the arguments).

    ``x(t) = laser + t · u / res`` with ``u`` the beam's unit direction in the map frame:
    ``t ← t + step(x(t))`` until ``t ≥ r - margin`` (possible) or ``step(x(t))`` is NaN (an
    occupied cell: the beam is impossible when it is NaN again at ``t + depth / 2`` and
    ``t + depth``; else one cell on)."""
    c, s = cos_sin
    margin, max_steps, depth = trace
    sx, sy = point[0], point[1]
    r = math.hypot(sx, sy)
    limit = r - margin
    if not limit > 0.0:
        return math.nan  # a beam shorter than the margin cannot pass through anything
    inv = 1.0 / resolution
    dcol = (c * sx - s * sy) / r * inv
    drow = (s * sx + c * sy) / r * inv
    t = 0.0
    for _ in range(max_steps):
        d = _step_at(steps, t, dcol, drow, laser, field)
        if math.isnan(d):  # an occupied cell
            if depth <= 0.0 or (
                math.isnan(_step_at(steps, t + 0.5 * depth, dcol, drow, laser, field))
                and math.isnan(_step_at(steps, t + 1.0 * depth, dcol, drow, laser, field))
            ):
                return t
            d = resolution  # not deep: one cell on
        t += d
        if not t < limit:
            break
    return math.nan


@jit.kernel
def trace_rays(
    points: FloatArray,
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

    ``cos_sin``: the laser's heading; ``laser``: its position in continuous cells of the step
    field (column, row: the map's cells plus its border of one); ``steps``: the step field,
    flat row-major, ``field = (width, height)`` cells; ``resolution`` [m]; ``trace = (margin
    [m], max_steps, depth [m])`` (`LocaliserConfig.impossible_margin_m`,
    ``impossible_max_steps``, ``impossible_depth_m``).
    """
    n = points.shape[0]
    crossing = np.empty(n)
    for i in range(n):
        crossing[i] = _trace_ray(points[i], cos_sin, laser, steps, field, resolution, trace)
    return ~np.isnan(crossing), crossing


@jit.kernel
def trace_runs_of_two(
    points: FloatArray,
    cos_sin: tuple[float, float],
    laser: tuple[float, float],
    steps: FloatArray,
    field: tuple[int, int],
    resolution: float,
    trace: tuple[float, int, float],
) -> tuple[bool, BoolArray, FloatArray]:
    """`trace_rays` where only runs of two or more neighbouring impossible beams count:
    ``(False, ...)`` when there is certainly no such run, else ``(True, through, crossing)``,
    every beam traced.

    Of two neighbours one has an even index, so the even beams are traced first; if none is
    impossible, or none of the odd beams next to an impossible one is, no run exists (most
    scans: about half the rays traced). Otherwise the other odd beams are traced too. Each
    ray's trace depends on that ray alone, so the result equals `trace_rays`' bit for bit."""
    n = points.shape[0]
    crossing = np.full(n, np.nan)
    any_even = False
    for i in range(0, n, 2):
        crossing[i] = _trace_ray(points[i], cos_sin, laser, steps, field, resolution, trace)
        any_even = any_even or not math.isnan(crossing[i])
    paired = False
    if any_even:
        for i in range(1, n, 2):
            if not (math.isnan(crossing[i - 1]) and (i + 1 >= n or math.isnan(crossing[i + 1]))):
                crossing[i] = _trace_ray(points[i], cos_sin, laser, steps, field, resolution, trace)
                paired = paired or not math.isnan(crossing[i])
    if paired:
        for i in range(1, n, 2):
            if math.isnan(crossing[i - 1]) and (i + 1 >= n or math.isnan(crossing[i + 1])):
                crossing[i] = _trace_ray(points[i], cos_sin, laser, steps, field, resolution, trace)
    return paired, ~np.isnan(crossing), crossing


@jit.on_warm_up("localiser's see-through trace")
def _warm_up() -> None:
    """The kernels with the types `Localiser` passes."""
    field = np.full(4 * 4, np.inf)
    field[5] = np.nan
    points = np.array([[1.0, 0.0], [0.0, 1.0]])
    args = ((1.0, 0.0), (1.5, 1.5), field, (4, 4), 0.05, (0.3, 30, 0.1))
    trace_rays(points, *args)
    trace_runs_of_two(points, *args)
