"""The slide test's profile as one compiled loop: a scan's map likelihood at many poses.

`Localiser.slide_profile` scores the scan at poses moved along the weakest direction of its
match (degeneracy-aware fusion, Zhang, Kaess and Singh, ICRA 2016). Each pose's score is the
mean of Hector SLAM's map likelihood ``M`` at the scan's end points (Kohlbrecher et al., "A
flexible and scalable SLAM system with full 3D motion estimation", SSRR 2011, eq. 1-3: the
bilinear interpolation of the four lattice nodes around a point)::

    x = p_x + cos ψ · s_x - sin ψ · s_y,   y = p_y + sin ψ · s_x + cos ψ · s_y
    (u, v) = clip((x, y) - origin) / res + PAD - offset,   (j, i) = ⌊(u, v)⌋, (f_x, f_y) the rest
    a = M00 + f_x (M01 - M00),   b = M10 + f_x (M11 - M10),   M = a + f_y (b - a)

Here the end points at every pose and their ``M`` are one compiled loop (`robot_daemon.jit`),
with the operations in the order of the numpy code they replace (the stacked end points of
`Localiser.slide_profile` until session 13 and `scan_matcher.LikelihoodLevel.value_xy`), so
each ``M`` equals it bit for bit; the means stay numpy's (its pairwise sum, in its order).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from robot_daemon import jit

FloatArray = npt.NDArray[np.float64]


@jit.kernel
def likelihood_at_poses(
    points: FloatArray,
    pose: tuple[float, float],
    direction: tuple[float, float],
    along: FloatArray,
    cos_sin: tuple[FloatArray, FloatArray],
    corners: FloatArray,
    lattice: tuple[float, float, float, float, float, float],
    width: int,
) -> FloatArray:
    """``M`` (rows: poses, columns: end points) of the sensor-frame end points ``points``
    ((N, 2), C-contiguous) at the poses ``(p_x, p_y) = pose + along · direction`` with
    headings of cosine and sine ``cos_sin`` (one per pose, numpy's: its ``cos`` and ``sin``
    may round apart from the C library's).

    ``corners``: the level's corner table (`LikelihoodLevel.corners`, (4, nodes): M00, M01,
    M10, M11 of each lattice node); ``lattice``: its origin x and y [m], 1 / resolution, the
    offset ``PAD - lattice_offset`` and the clip bounds of u and v; ``width``: its nodes per
    row."""
    ox, oy, inv, offset, high_u, high_v = lattice
    cos, sin = cos_sin
    n = points.shape[0]
    out = np.empty((along.shape[0], n))
    for k in range(along.shape[0]):
        px = pose[0] + along[k] * direction[0]
        py = pose[1] + along[k] * direction[1]
        c, s = cos[k], sin[k]
        for p in range(n):
            sx, sy = points[p, 0], points[p, 1]
            u = max(min((px + c * sx - s * sy - ox) * inv + offset, high_u), 0.0)
            v = max(min((py + s * sx + c * sy - oy) * inv + offset, high_v), 0.0)
            j, i = int(u), int(v)
            fx, fy = u - j, v - i
            node = i * width + j
            m00, m01 = corners[0, node], corners[1, node]
            m10, m11 = corners[2, node], corners[3, node]
            a = (m01 - m00) * fx + m00
            b = (m11 - m10) * fx + m10
            out[k, p] = (b - a) * fy + a
    return out


@jit.on_warm_up("localiser's slide profile")
def _warm_up() -> None:
    """`likelihood_at_poses` with the types `Localiser.slide_profile` passes (the corner table
    is a transposed view: Fortran order)."""
    corners = np.zeros((16, 4)).T
    along = np.array([0.0, 0.1, -0.1])
    cos_sin = (np.cos(along), np.sin(along))
    lattice = (0.0, 0.0, 10.0, 2.0, 2.999, 2.999)
    likelihood_at_poses(
        np.zeros((3, 2)), (0.0, 0.0), (1.0, 0.0), along, cos_sin, corners, lattice, 4
    )
