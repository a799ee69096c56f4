"""The scan matcher's per-point work as compiled loops (`robot_daemon.jit`).

Method: Hector SLAM's map access and Gauss-Newton terms (S. Kohlbrecher, O. von Stryk, J. Meyer,
U. Klingauf, "A flexible and scalable SLAM system with full 3D motion estimation", IEEE SSRR
2011, Section IV; `scan_matcher` holds the whole method). For scan end point ``s_i`` at pose
``ξ = (p_x, p_y, ψ)``:

* ``S_i = R(ψ) s_i + p`` (eq. 5), in the padded lattice of a level
  ``(u, v) = (S_i - origin) / res + PAD - lattice_offset``, clipped to the field;
* ``M(S_i)`` and ``∇M(S_i)`` by bilinear interpolation of the four lattice nodes around it
  (eq. 1-3): with ``(fx, fy)`` the fractions in the cell and ``d0 = m01 - m00``,
  ``d1 = m11 - m10``, ``a = m00 + fx d0``, ``b = m10 + fx d1``: ``M = a + fy (b - a)``,
  ``∂M/∂x = (d0 + fy (d1 - d0)) / res``, ``∂M/∂y = (b - a) / res``;
* the row ``J_i = (∂M/∂x, ∂M/∂y, ∇M · ∂S_i/∂ψ)`` of eq. 12-14 and ``J_i r_i``,
  ``r_i = 1 - M(S_i)``.

Each output element is computed with the float operations of the numpy code these loops
replaced (session 12's `LikelihoodLevel.interpolate_xy`, `value_xy`, `ScanMatcher.match`,
`normal_information`), in the same order, so bit for bit the same
(`tests/robot_daemon/localisation/test_loc_match_kernels.py` compares them). The sums over the
points (``H = Σ J_iᵀ J_i``, ``Σ J_i r_i``, scores, the information) stay in numpy on these
outputs: numpy's pairwise summation and the BLAS product fix their rounding, which a loop here
would change.

The arrays are C-contiguous float64 (``table`` ``(h * w, 4)``: a lattice node's four corner
values, `LikelihoodLevel`'s corner table; ``tensor`` float32 ``(h * w, 3)``), so each kernel
compiles once (`warm_up` below registers those types). ``geometry`` is a level's
``(origin_x, origin_y, 1 / res, PAD - lattice_offset, w - 1.001, h - 1.001)``.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from robot_daemon import jit

FloatArray = npt.NDArray[np.float64]


@jit.kernel
def bilinear(
    table: FloatArray,
    w: int,
    geometry: FloatArray,
    pxy: FloatArray,
    m: FloatArray,
    grad: FloatArray,
) -> None:
    """``m[k]``, ``grad[:2, k]``: M, ∂M/∂x and ∂M/∂y at map point ``pxy[:, k]`` [m] (Hector
    eq. 1-3; `LikelihoodLevel.interpolate_xy`, `value_xy`).

    A point off the field reads the padding's zeros (clipped to its border); a NaN coordinate
    reads lattice node 0 (padding: M = 0), never memory outside the table."""
    ox, oy, inv, offset, u_max, v_max = (
        geometry[0],
        geometry[1],
        geometry[2],
        geometry[3],
        geometry[4],
        geometry[5],
    )
    for k in range(m.size):
        u = (pxy[0, k] - ox) * inv
        u = u + offset
        v = (pxy[1, k] - oy) * inv
        v = v + offset
        if u > u_max:  # np.minimum, then np.maximum(., 0)
            u = u_max
        if not u >= 0.0:  # (NaN too)
            u = 0.0
        if v > v_max:
            v = v_max
        if not v >= 0.0:
            v = 0.0
        j = int(u)  # u >= 0: truncation is the floor (ndarray.astype(np.intp))
        i = int(v)
        fx = u - j
        fy = v - i
        node = i * w + j
        m00 = table[node, 0]
        m01 = table[node, 1]
        m10 = table[node, 2]
        m11 = table[node, 3]
        d0 = m01 - m00
        d1 = m11 - m10
        a = fx * d0 + m00
        b = fx * d1 + m10
        ba = b - a
        m[k] = fy * ba + a
        dmx = (d1 - d0) * fy + d0
        grad[0, k] = dmx * inv
        grad[1, k] = ba * inv


#: Rows of `gauss_newton_terms`'s output per start: M, J (3 rows), J r (3), R(ψ) s (2), S (2).
TERM_ROWS = 11


@jit.kernel
def gauss_newton_terms(
    table: FloatArray,
    w: int,
    geometry: FloatArray,
    points: FloatArray,
    poses: FloatArray,
    terms: FloatArray,
) -> None:
    """One Gauss-Newton iteration's per-point terms for each start ``b`` of a stack.

    ``points`` (2, n): the end points ``s`` in the sensor frame, x and y stacked;
    ``poses[b] = (p_x, p_y, cos ψ, sin ψ)``. Writes ``terms[b]`` (`TERM_ROWS`, n): row 0
    ``M(S)``, rows 1-3 ``J = (∂M/∂x, ∂M/∂y, ∇M · ∂S/∂ψ)`` with ``∂S/∂ψ = (-ry, rx)`` (eq. 14),
    rows 4-6 ``J (1 - M)``, rows 7-8 ``(rx, ry) = R(ψ) s``, rows 9-10 ``S = R(ψ) s + p``."""
    for b in range(poses.shape[0]):
        px = poses[b, 0]
        py = poses[b, 1]
        c = poses[b, 2]
        s = poses[b, 3]
        t = terms[b]
        for i in range(points.shape[1]):
            rx = c * points[0, i] - s * points[1, i]
            ry = s * points[0, i] + c * points[1, i]
            t[7, i] = rx
            t[8, i] = ry
            t[9, i] = rx + px
            t[10, i] = ry + py
        bilinear(table, w, geometry, t[9:11], t[0], t[1:3])  # M and ∇M at S
        for i in range(points.shape[1]):
            gx = t[1, i]
            gy = t[2, i]
            jt = gy * t[7, i] - gx * t[8, i]
            r = 1.0 - t[0, i]
            t[3, i] = jt
            t[4, i] = gx * r
            t[5, i] = gy * r
            t[6, i] = jt * r


@jit.kernel
def inlier_terms(
    m: FloatArray,
    gx: FloatArray,
    gy: FloatArray,
    rx: FloatArray,
    ry: FloatArray,
    mxy: FloatArray,
    tensor: npt.NDArray[np.float32],
    w: int,
    h: int,
    geometry: FloatArray,
    inlier_m: float,
    out: FloatArray,
) -> int:
    """The summands of the point-to-surface information (`scan_matcher.normal_information`).

    For each inlier ``i`` (``M > inlier_m`` and ``|∇M| > 1e-9``), in order, the next column of
    ``out`` is ``(T_xx, T_xy, T_yy, a_x, a_y, jᵀ a)`` with ``T`` the surface tensor at the
    lattice node nearest ``S_i = mxy[:, i]`` (``tensor`` (h * w, 3), row NaN: none there), else
    ``n nᵀ``, ``n = ∇M / |∇M|``; ``j = ∂S/∂ψ = (-ry, rx)`` and ``a = T j``. Returns how many."""
    ox, oy, inv, offset = geometry[0], geometry[1], geometry[2], geometry[3]
    n = 0
    for i in range(m.size):
        g = np.hypot(gx[i], gy[i])
        if not (m[i] > inlier_m and g > 1e-9):
            continue
        u = np.rint((mxy[0, i] - ox) * inv + offset)  # the nearest node, clipped to the field
        v = np.rint((mxy[1, i] - oy) * inv + offset)
        col = int(min(u, w - 1.0)) if u >= 0.0 else 0  # (NaN: node 0)
        row = int(min(v, h - 1.0)) if v >= 0.0 else 0
        node = row * w + col
        if math.isnan(tensor[node, 0]):
            norm = 1.0 / g
            nx = gx[i] * norm
            ny = gy[i] * norm
            txx = nx * nx
            txy = nx * ny
            tyy = ny * ny
        else:
            txx = float(tensor[node, 0])
            txy = float(tensor[node, 1])
            tyy = float(tensor[node, 2])
        jx = -ry[i]
        jy = rx[i]
        ax = txx * jx + txy * jy
        ay = txy * jx + tyy * jy
        out[0, n] = txx
        out[1, n] = txy
        out[2, n] = tyy
        out[3, n] = ax
        out[4, n] = ay
        out[5, n] = jx * ax + jy * ay
        n += 1
    return n


@jit.on_warm_up("match_kernels")
def _warm_up() -> None:
    """Each kernel once with the types `LikelihoodLevel` and `ScanMatcher` pass."""
    table = np.zeros((16, 4))
    geometry = np.array([0.0, 0.0, 10.0, 2.0, 2.999, 2.999])
    points = np.zeros((2, 3))
    m = np.empty(3)
    bilinear(table, 4, geometry, points, m, np.empty((2, 3)))
    poses = np.array([[0.0, 0.0, math.cos(0.1), math.sin(0.1)]])
    gauss_newton_terms(table, 4, geometry, points, poses, np.empty((1, TERM_ROWS, 3)))
    tensor = np.full((16, 3), np.nan, dtype=np.float32)
    inlier_terms(m, m, m, m, m, points, tensor, 4, 4, geometry, 0.1, np.empty((6, 3)))
