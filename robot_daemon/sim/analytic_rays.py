"""The simulated laser's analytic targets: people (circles) and glass panes (boxes), compiled.

Every beam is tested against every target, in the targets' order (what the numpy caster did
for beams in any order; for a scan's increasing beams it tested only each target's angular
window, which gave the same ranges, tested, and cost more Python than arithmetic).

People, ray-circle intersection: for a beam ``d = (cos, sin)`` from ``o`` and a circle ``(c, r)``
with ``b = d . (c - o)`` and ``k = |c - o|^2 - r^2``, the nearest crossing ahead is

    t = b - sqrt(b^2 - k)   if b^2 - k >= 0 and b > 0   (0 if k < 0: the origin is inside),

else none; the nearest circle wins, the first one on a tie.

Glass, the slab test (Kay and Kajiya, "Ray tracing complex scenes", SIGGRAPH 1986) per
axis-aligned pane ``[x0, x1] x [y0, y1]``: with ``t_x = (x - o_x) / cos`` at the two x faces
(near = the smaller), likewise ``t_y``, the beam enters at ``t_in = max(t_x_near, t_y_near)``
and leaves at ``t_out = min(t_x_far, t_y_far)``; it meets the pane if ``t_in <= t_out`` and
``t_in > 0``. The face entered is the x face if ``t_x_near >= t_y_near``; the pane returns the
beam when it is within ``return_angle`` of that face's normal (``|cos| >= cos(return_angle)``
for an x face, ``|sin|`` for a y face). A beam along an axis gives ``x / 0 = +-inf`` and
``0 * inf = nan``; ``min`` and ``max`` of the faces propagate nan and ``t_in``, ``t_out`` skip
it, as numpy's ``minimum`` / ``maximum`` and ``fmax`` / ``fmin`` do.

The arithmetic is the numpy caster's, element by element in its order, so the ranges are the
same bit for bit (``tests/robot_daemon/sim/test_sim_analytic_rays.py`` keeps the numpy code).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from robot_daemon import jit

FloatArray = npt.NDArray[np.float64]
IndexArray = npt.NDArray[np.intp]


@jit.kernel
def circle_ranges(
    origin_x: float,
    origin_y: float,
    cos: FloatArray,
    sin: FloatArray,
    circles: FloatArray,
    ranges: FloatArray,
    nearest: IndexArray,
) -> None:
    """Range [m] along each beam to the nearest circle (rows x, y, r of ``circles``) into
    ``ranges`` (``+inf`` if none) and that circle's row into ``nearest`` (-1 if none)."""
    for i in range(cos.size):
        ranges[i] = np.inf
        nearest[i] = -1
    for j in range(circles.shape[0]):
        dx = circles[j, 0] - origin_x
        dy = circles[j, 1] - origin_y
        r = circles[j, 2]
        k = dx * dx + dy * dy - r * r
        for i in range(cos.size):
            b = cos[i] * dx + sin[i] * dy
            disc = b * b - k
            if not (disc >= 0.0 and b > 0.0):
                continue
            t = 0.0 if k < 0.0 else b - math.sqrt(disc)
            if t < ranges[i]:  # strict: the first circle wins a tie
                ranges[i] = t
                nearest[i] = j


@jit.kernel
def pane_ranges(
    origin_x: float,
    origin_y: float,
    cos: FloatArray,
    sin: FloatArray,
    panes: FloatArray,
    threshold: float,
    ranges: FloatArray,
) -> None:
    """Range [m] along each beam to the first pane (rows x0, y0, x1, y1 of ``panes``) that
    returns it (``threshold``: the cosine of the return angle) into ``ranges`` (``+inf`` if
    none)."""
    for i in range(cos.size):
        ranges[i] = np.inf
    for j in range(panes.shape[0]):
        ax0 = float(panes[j, 0] - origin_x)
        ay0 = float(panes[j, 1] - origin_y)
        ax1 = float(panes[j, 2] - origin_x)
        ay1 = float(panes[j, 3] - origin_y)
        for i in range(cos.size):
            c, s = float(cos[i]), float(sin[i])  # Python floats in plain Python: no warnings
            inv_x = 1.0 / c if c != 0.0 else math.copysign(math.inf, c)  # 1 / +-0 = +-inf
            inv_y = 1.0 / s if s != 0.0 else math.copysign(math.inf, s)
            tx0, tx1 = ax0 * inv_x, ax1 * inv_x  # 0 * inf = nan
            ty0, ty1 = ay0 * inv_y, ay1 * inv_y
            # numpy.minimum / maximum: a nan wins
            tx_near = tx0 if tx0 != tx0 or tx0 < tx1 else tx1
            tx_far = tx0 if tx0 != tx0 or tx0 > tx1 else tx1
            ty_near = ty0 if ty0 != ty0 or ty0 < ty1 else ty1
            ty_far = ty0 if ty0 != ty0 or ty0 > ty1 else ty1
            # numpy.fmax / fmin: a nan loses
            t_in = ty_near if tx_near != tx_near or ty_near > tx_near else tx_near
            t_out = ty_far if tx_far != tx_far or ty_far < tx_far else tx_far
            if not (t_in <= t_out and t_in > 0.0):
                continue
            cos_incidence = abs(c) if tx_near >= ty_near else abs(s)
            if cos_incidence >= threshold and t_in < ranges[i]:
                ranges[i] = t_in


@jit.on_warm_up("robot_daemon.sim.analytic_rays")
def _warm_up() -> None:
    """Both kernels with the argument types `RayCaster` passes."""
    angles = np.linspace(-2.0, 2.0, 200)
    cos, sin = np.cos(angles), np.sin(angles)
    ranges = np.empty(angles.size)
    nearest = np.empty(angles.size, dtype=np.intp)
    circles = np.array([[1.0, 0.5, 0.25], [0.1, 0.0, 0.3]])
    circle_ranges(0.0, 0.0, cos, sin, circles, ranges, nearest)
    panes = np.array([[1.0, -1.0, 1.1, 1.0]])
    pane_ranges(0.0, 0.0, cos, sin, panes, 0.98, ranges)
