"""The compiled people and glass casters (`robot_daemon/sim/analytic_rays.py`) give the numpy
casters' ranges bit for bit, windowed (a scan's increasing beams) or not, and so does the whole
``RayCaster.cast`` against the numpy one (``numpy_caster.py``: session 12's code, verbatim).

Edge cases the numpy code met through numpy's own rules: a beam along an axis (``1 / 0``), the
laser on a pane's face (``0 * inf = nan`` in the slab test), inside a pane or a person, ties
between people (the first wins), beams past +-pi.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from robot_daemon import jit
from robot_daemon.sim import analytic_rays
from robot_daemon.sim.laser_sim import LaserConfig, RayCaster
from tests.robot_daemon.sim.numpy_caster import numpy_cast, numpy_cast_circles, numpy_cast_glass
from tests.robot_daemon.sim.test_sim_speed_equivalence import WORLD, _office, _poses

FloatArray = npt.NDArray[np.float64]


def _angles(rng: np.random.Generator, k: int, yaw: float) -> FloatArray:
    """A scan's beams (past +-pi every third time), else random beams in any order, always
    with beams exactly along the axes."""
    if k % 2 == 0:
        return LaserConfig().beam_angles() + yaw + (2 * math.pi if k % 3 == 0 else 0.0)
    axes = np.array([0.0, -0.0, math.pi / 2, math.pi, -math.pi / 2, -math.pi])
    return np.concatenate((rng.uniform(-7.0, 7.0, int(rng.integers(1, 1200))), axes))


def _circles(rng: np.random.Generator, k: int, x: float, y: float) -> FloatArray:
    n = int(rng.integers(1, 7))
    circles = np.column_stack(
        (x + rng.uniform(-3, 3, n), y + rng.uniform(-3, 3, n), rng.uniform(0.05, 0.4, n))
    )
    if k % 5 == 0:
        circles[0, :2] = (x + 0.05, y)  # the laser inside a person
    if k % 7 == 0:
        circles[-1] = circles[0]  # a tie: the first circle wins
    if k % 11 == 0:
        circles[0] = (x + 0.25, y, 0.25)  # the laser on a person's edge
    return circles


def test_people_equal_the_numpy_caster() -> None:
    rng = np.random.default_rng(12)
    seen = 0
    for k, (x, y, yaw) in enumerate(_poses(rng, 200)):
        angles = _angles(rng, k, yaw)
        circles = _circles(rng, k, x, y)
        ranges, which = RayCaster.cast_circles(x, y, angles, circles)
        for increasing in (None, False):  # windows where the beams increase, every beam
            ref_ranges, ref_which = numpy_cast_circles(x, y, angles, circles, increasing)
            assert np.array_equal(ranges, ref_ranges) and np.array_equal(which, ref_which)
        seen += int(np.count_nonzero(which >= 0))
    assert seen > 10_000


def _panes(rng: np.random.Generator, k: int, x: float, y: float) -> FloatArray:
    n = int(rng.integers(1, 5))
    x0, y0 = x + rng.uniform(-4, 4, n), y + rng.uniform(-4, 4, n)
    panes = np.column_stack((x0, y0, x0 + rng.uniform(0.02, 2, n), y0 + rng.uniform(0.02, 2, n)))
    if k % 4 == 1:
        panes[0] = (x, y - 1.0, x + 0.04, y + 1.0)  # the laser on a pane's x face
    if k % 9 == 0:
        panes[-1] = (x - 0.1, y - 0.1, x + 0.1, y + 0.1)  # inside a pane
    if k % 6 == 3:  # on a y face, along a beam at +-0 (odd k: `_angles` has it): 0 * inf
        panes[0] = (x - 2.0, y, x + 2.0, y + 0.04)
    return panes


def test_glass_equals_the_numpy_caster() -> None:
    rng = np.random.default_rng(13)
    seen = 0
    caster = RayCaster(_office())
    for k, (x, y, yaw) in enumerate(_poses(rng, 300)):
        angles = _angles(rng, k, yaw)
        panes = _panes(rng, k, x, y)
        glass = tuple((float(a), float(b), float(c), float(d)) for a, b, c, d in panes)
        caster.world.glass = glass
        return_angle = float(rng.choice([0.0, 0.17, 0.5, math.pi / 2, rng.uniform(0, 1.5)]))
        ranges = caster.cast_glass(x, y, angles, return_angle)
        for increasing in (None, False):
            ref = numpy_cast_glass(glass, x, y, angles, return_angle, increasing)
            assert np.array_equal(ranges, ref), (k, x, y, return_angle)
        seen += int(np.count_nonzero(np.isfinite(ranges)))
    assert seen > 10_000


def test_compiled_equals_its_plain_python_function() -> None:
    rng = np.random.default_rng(14)
    circles_plain = jit.python_function(analytic_rays.circle_ranges)
    panes_plain = jit.python_function(analytic_rays.pane_ranges)
    for k, (x, y, yaw) in enumerate(_poses(rng, 12)):
        angles = _angles(rng, k, yaw)
        cos, sin = np.cos(angles), np.sin(angles)
        n = angles.size
        circles = _circles(rng, k, x, y)
        out = [np.empty(n), np.empty(n, dtype=np.intp), np.empty(n), np.empty(n, dtype=np.intp)]
        analytic_rays.circle_ranges(x, y, cos, sin, circles, out[0], out[1])
        circles_plain(x, y, cos, sin, circles, out[2], out[3])
        assert np.array_equal(out[0], out[2]) and np.array_equal(out[1], out[3])
        panes = _panes(rng, k, x, y)
        compiled, python = np.empty(n), np.empty(n)
        analytic_rays.pane_ranges(x, y, cos, sin, panes, 0.9, compiled)
        panes_plain(x, y, cos, sin, panes, 0.9, python)
        assert np.array_equal(compiled, python)


def test_cast_equals_the_numpy_cast_with_walls_glass_and_people() -> None:
    rng = np.random.default_rng(15)
    caster = RayCaster(WORLD)
    for k, (x, y, yaw) in enumerate(_poses(rng, 100)):
        angles = LaserConfig().beam_angles() + yaw
        circles = _circles(rng, k, x, y) if k % 4 else None
        new = caster.cast(x, y, angles, 30.0, circles, 0.17)
        assert np.array_equal(new, numpy_cast(WORLD, x, y, angles, 30.0, circles, 0.17))
