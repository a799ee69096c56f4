"""The scan matcher's Gauss-Newton iterations as compiled loops (`robot_daemon.jit`).

Method: Hector SLAM's map access and Gauss-Newton step (S. Kohlbrecher, O. von Stryk, J. Meyer,
U. Klingauf, "A flexible and scalable SLAM system with full 3D motion estimation", IEEE SSRR
2011, Section IV; `scan_matcher` holds the whole method). For scan end point ``s_i`` at pose
``ξ = (p_x, p_y, ψ)``:

* ``S_i = R(ψ) s_i + p`` (eq. 5), in the padded lattice of a level
  ``(u, v) = (S_i - origin) / res + PAD - lattice_offset``, clipped to the field;
* ``M(S_i)`` and ``∇M(S_i)`` by bilinear interpolation of the four lattice nodes around it
  (eq. 1-3): with ``(fx, fy)`` the fractions in the cell and ``d0 = m01 - m00``,
  ``d1 = m11 - m10``, ``a = m00 + fx d0``, ``b = m10 + fx d1``: ``M = a + fy (b - a)``,
  ``∂M/∂x = (d0 + fy (d1 - d0)) / res``, ``∂M/∂y = (b - a) / res`` (`bilinear`);
* the row ``J_i = (∂M/∂x, ∂M/∂y, ∇M · ∂S_i/∂ψ)`` of eq. 12-14 and ``J_i r_i``,
  ``r_i = 1 - M(S_i)`` (`gauss_newton_terms`);
* the step ``Δξ = H⁻¹ Σ_i J_iᵀ r_i``, ``H = Σ_i J_iᵀ J_i`` (eq. 12-13), iterated on one level
  (`gauss_newton_level`: one call per level of a match).

Every value is session 12's numpy code's bit for bit (`LikelihoodLevel.interpolate_xy`,
`value_xy`, `ScanMatcher.match`, `normal_information`;
`tests/robot_daemon/localisation/test_loc_match_kernels.py` keeps that code and compares): each
element with the same float operations in the same order, and the sums over the points
(``H``, ``Σ J r``) as numpy computes them (`row_sums_into`, `gram_into` below: its pairwise
summation, its BLAS product); the final evaluation's sums (score, H, the information) are left
to numpy.

The arrays are C-contiguous float64 (``table`` ``(h * w, 4)``: a lattice node's four corner
values, `LikelihoodLevel`'s corner table; ``tensor`` float32 ``(h * w, 3)``), so each kernel
compiles once (`warm_up` below registers those types). ``geometry`` is a level's
``(origin_x, origin_y, 1 / res, PAD - lattice_offset, w - 1.001, h - 1.001)``.
"""

from __future__ import annotations

import ctypes
import importlib
import logging
import math
from typing import Any

import numpy as np
import numpy.typing as npt

from robot_daemon import jit

logger = logging.getLogger(__name__)

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


@jit.kernel
def solve3(
    a: float, b: float, c: float, d: float, e: float, f: float, g0: float, g1: float, g2: float
) -> tuple[float, float, float]:
    """Solve the 3x3 symmetric system H Δ = g by Cramer's rule (cheaper than LAPACK here);
    ``H = [[a, b, c], [b, d, e], [c, e, f]]``; (0, 0, 0) where H is singular."""
    co0 = d * f - e * e
    co1 = c * e - b * f
    co2 = b * e - c * d
    det = a * co0 + b * co1 + c * co2
    if not abs(det) > 1e-300:
        return 0.0, 0.0, 0.0
    x0 = (g0 * co0 + g1 * co1 + g2 * co2) / det
    x1 = (g0 * co1 + g1 * (a * f - c * c) + g2 * (b * c - a * e)) / det
    x2 = (g0 * co2 + g1 * (b * c - a * e) + g2 * (a * d - b * b)) / det
    return x0, x1, x2


@jit.kernel
def gauss_newton_level(
    table: FloatArray,
    w: int,
    geometry: FloatArray,
    points: FloatArray,
    state: FloatArray,
    settings: FloatArray,
    iterations: npt.NDArray[np.int64],
    terms: FloatArray,
) -> bool:
    """Hector's Gauss-Newton iterations of one start on one level (eq. 12-13):
    ``Δξ = H⁻¹ Σ_i J_iᵀ r_i`` with ``H = Σ_i J_iᵀ J_i`` plus a Levenberg damping
    ``λ = damping · tr(H) / 3 + 10⁻⁹`` on its diagonal, the angular step clamped to
    ``± max_angular_step``.

    ``state`` = (p_x, p_y, ψ), updated in place; ``settings`` = (damping, max_angular_step,
    converged_m, converged_rad); ``iterations`` = (n_iter, n_max, final): ``n_iter`` steps,
    or with ``final`` (the finest level) up to ``n_max`` while a step is not converged
    (|Δx| + |Δy| < converged_m and |Δψ| < converged_rad), then the terms at the solution are
    evaluated once more and it returns True (``terms[0]``: `gauss_newton_terms`'s at ``state``).
    ``H`` and ``Σ J r`` are numpy's sums (`gram_into`, `row_sums_into`), ``cos`` and ``sin``
    the C library's as Python's ``math``: `ScanMatcher.match`'s steps bit for bit."""
    damping, amax, converged_m, converged_rad = settings[0], settings[1], settings[2], settings[3]
    n_iter, n_max, final = iterations[0], iterations[1], iterations[2]
    pose = np.empty((1, 4))
    h = np.empty((3, 3))
    g = np.empty(3)
    jac = terms[0, 1:4]
    jr = terms[0, 4:7]
    px, py, yaw = state[0], state[1], state[2]
    converged = False
    stopped = False
    for it in range(n_max + final):
        pose[0, 0] = px
        pose[0, 1] = py
        pose[0, 2] = math.cos(yaw)
        pose[0, 3] = math.sin(yaw)
        gauss_newton_terms(table, w, geometry, points, pose, terms)
        if final and (it == n_max or (it >= n_iter and converged)):
            stopped = True  # the final evaluation: terms at the solution
            break
        gram_into(jac, h)  # H = J Jᵀ
        row_sums_into(jr, g)  # Σ J r
        lam = damping * (h[0, 0] + h[1, 1] + h[2, 2]) / 3.0 + 1e-9
        dx, dy, dth = solve3(
            h[0, 0] + lam, h[0, 1], h[0, 2], h[1, 1] + lam, h[1, 2], h[2, 2] + lam, g[0], g[1], g[2]
        )
        dth = dth if dth < amax else amax  # Python's min(amax, dth)
        dth = dth if dth > -amax else -amax  # max(-amax, dth)
        converged = abs(dx) + abs(dy) < converged_m and abs(dth) < converged_rad
        px += dx
        py += dy
        yaw += dth
    state[0] = px
    state[1] = py
    state[2] = yaw
    return stopped


@jit.kernel
def gauss_newton_starts(
    table: FloatArray,
    w: int,
    geometry: FloatArray,
    points: FloatArray,
    states: FloatArray,
    settings: FloatArray,
    iterations: npt.NDArray[np.int64],
    terms: FloatArray,
    stopped: npt.NDArray[np.bool_],
) -> None:
    """`gauss_newton_level` of each start in turn: row ``k`` of ``states`` (k, 3) updated in
    place, its terms in ``terms[k]`` (``terms`` (k, `TERM_ROWS`, n); or (1, ...): one scratch
    for all where the terms are not kept, a coarse level), whether it stopped with the final
    evaluation in ``stopped[k]``. The same steps as one call per start, bit for bit (speed: one
    call from Python per level instead of one per start and level, `ScanMatcher.coarse_many`,
    `finish_best`)."""
    shared = terms.shape[0] == 1
    for k in range(states.shape[0]):
        row = 0 if shared else k
        stopped[k] = gauss_newton_level(
            table, w, geometry, points, states[k], settings, iterations, terms[row : row + 1]
        )


# -- numpy's sums in compiled code ------------------------------------------------------------
# The steps above need H = J Jᵀ and Σ J r each iteration. Summed in a loop here, their rounding
# would differ from numpy's (another order of additions) and with it every pose after. So the
# compiled kernels compute them as numpy does:
#
# * `row_sums_into`: numpy's pairwise summation (`np.add.reduce` along a contiguous row:
#   numpy/_core/src/umath/loops_utils.h.src, ``pairwise_sum``: up to 128 elements with eight
#   accumulators, more halved at a multiple of 8; the reduction starts from 0.0) as a loop;
# * `gram_into`: numpy's matmul computes a matrix times its own transpose with BLAS ``syrk``
#   (numpy/_core/src/umath/matmul.c.src); compiled code calls that function of numpy's own BLAS
#   (found through numpy's extension module, checked against numpy's product at import) with
#   numpy's arguments. Where it is not found, it calls numpy itself through a C callback.
#
# Plain Python (numba absent or off) runs the numpy calls themselves.
# `tests/robot_daemon/localisation/test_loc_match_kernels.py` compares them with numpy.


def row_sums_into(a: FloatArray, out: FloatArray) -> None:
    """``out[r] = np.add.reduce(a[r])`` for each row of the C-contiguous 2-D ``a``."""
    np.add.reduce(a, axis=1, out=out)


def gram_into(a: FloatArray, out: FloatArray) -> None:
    """``out = a @ a.T`` for a C-contiguous ``a`` (k, n): numpy's BLAS ``syrk`` product."""
    out[...] = a @ a.T


_ROW_MAJOR, _UPPER, _NO_TRANS = 101, 121, 111  # CBLAS enumerations
# cblas_dsyrk(order, uplo, trans, n, k, alpha, A, lda, beta, C, ldc), 64-bit integers
_SYRK_ARGS: tuple[Any, ...] = (ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_int64)
_SYRK_ARGS += (ctypes.c_int64, ctypes.c_double, ctypes.c_void_p, ctypes.c_int64, ctypes.c_double)
_SYRK_ARGS += (ctypes.c_void_p, ctypes.c_int64)


def _numpy_blas_syrk() -> Any | None:
    """numpy's own ``cblas_dsyrk`` with 64-bit integers (numpy's wheels: scipy-openblas64),
    if it gives numpy's product bit for bit on a few random matrices; else None."""
    try:
        umath = importlib.import_module("numpy._core._multiarray_umath")
    except ImportError:  # numpy 1.x
        umath = importlib.import_module("numpy.core._multiarray_umath")
    lib = ctypes.CDLL(umath.__file__)  # its symbols and those of the BLAS it links
    for name in ("scipy_cblas_dsyrk64_", "cblas_dsyrk64_"):
        syrk = getattr(lib, name, None)
        if syrk is None:
            continue
        syrk.restype, syrk.argtypes = None, _SYRK_ARGS
        rng = np.random.default_rng(0)
        for k in (1, 9, 130, 401):
            a = rng.normal(0.0, 1.0, (3, k))
            c = np.zeros((3, 3))
            syrk(_ROW_MAJOR, _UPPER, _NO_TRANS, 3, k, 1.0, a.ctypes.data, k, 0.0, c.ctypes.data, 3)
            want = a @ a.T
            if not np.array_equal(np.triu(c), np.triu(want)):
                logger.info("numpy's BLAS %s differs from numpy's product: not used", name)
                return None
        return syrk
    return None


def _syrk_by_numpy_python(
    order: int,
    uplo: int,
    trans: int,
    n: int,
    k: int,
    alpha: float,
    a: int,
    lda: int,
    beta: float,
    c: int,
    ldc: int,
) -> None:
    """``cblas_dsyrk`` as `gram_into` calls it (row-major, C = A Aᵀ), by numpy's product."""
    pa = ctypes.cast(a, ctypes.POINTER(ctypes.c_double))
    pc = ctypes.cast(c, ctypes.POINTER(ctypes.c_double))
    rows = np.ctypeslib.as_array(pa, shape=(n, lda))[:, :k]
    np.ctypeslib.as_array(pc, shape=(n, ldc))[:, :n] = rows @ rows.T


_syrk_by_numpy = ctypes.CFUNCTYPE(None, *_SYRK_ARGS)(_syrk_by_numpy_python)  # a C callback


if jit.ENABLED:  # compiled: numpy's sums for the kernels (plain Python calls numpy)
    import llvmlite.binding as llvm  # type: ignore[import-untyped] # numba's dependency
    from numba.extending import overload

    types: Any = importlib.import_module("numba.types")

    _blas_syrk = _numpy_blas_syrk()
    if _blas_syrk is None:
        logger.info("numpy's BLAS not found: compiled matches call numpy for H (slower)")
    _syrk_target = _syrk_by_numpy if _blas_syrk is None else _blas_syrk
    llvm.add_symbol("interbot_numpy_dsyrk", ctypes.cast(_syrk_target, ctypes.c_void_p).value)
    _i32, _i64, _f64, _ptr = types.int32, types.int64, types.float64, types.CPointer(types.float64)
    _dsyrk: Any = types.ExternalFunction(
        "interbot_numpy_dsyrk",
        types.void(_i32, _i32, _i32, _i64, _i64, _f64, _ptr, _i64, _f64, _ptr, _i64),
    )

    @jit.kernel
    def _pairwise_block(a: FloatArray, lo: int, n: int) -> float:
        """numpy's ``pairwise_sum`` of ``a[lo : lo + n]`` for ``n <= 128``: eight accumulators."""
        res: float = -0.0
        if n < 8:
            for i in range(lo, lo + n):
                res += a[i]
            return res
        r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
        r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
        i = 8
        while i < n - n % 8:
            j = lo + i
            r0 += a[j]
            r1 += a[j + 1]
            r2 += a[j + 2]
            r3 += a[j + 3]
            r4 += a[j + 4]
            r5 += a[j + 5]
            r6 += a[j + 6]
            r7 += a[j + 7]
            i += 8
        res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        while i < n:
            res += a[lo + i]
            i += 1
        return res

    @jit.kernel
    def _pairwise_sum(a: FloatArray) -> float:
        """numpy's ``pairwise_sum`` of ``a``: blocks of at most 128, a longer run split in two
        at a multiple of 8 below its half and the halves' sums added. numpy recurses; here the
        recursion runs on an explicit stack (a cached recursive kernel crashed numba 0.68)."""
        lo = np.empty(64, dtype=np.int64)  # frames: a run [lo, lo + n) and how far it got
        n = np.empty(64, dtype=np.int64)
        stage = np.empty(64, dtype=np.int64)
        sums = np.empty(64)  # the sums of finished runs, innermost last
        top, done = 0, 0
        lo[0], n[0], stage[0] = 0, a.size, 0
        while top >= 0:
            half = n[top] // 2
            half -= half % 8
            if n[top] <= 128:
                sums[done] = _pairwise_block(a, lo[top], n[top])
                done += 1
                top -= 1
            elif stage[top] < 2:  # the first half, then the second
                stage[top] += 1
                first = stage[top] == 1
                lo[top + 1] = lo[top] if first else lo[top] + half
                n[top + 1] = half if first else n[top] - half
                stage[top + 1] = 0
                top += 1
            else:  # both halves summed
                done -= 1
                sums[done - 1] = sums[done - 1] + sums[done]
                top -= 1
        return float(sums[0])

    @overload(row_sums_into, jit_options={"error_model": "numpy"})
    def _row_sums_compiled(a: Any, out: Any) -> Any:
        def impl(a: Any, out: Any) -> None:  # (the annotations must be the overload's)
            for r in range(a.shape[0]):
                out[r] = 0.0 + _pairwise_sum(a[r])

        return impl

    @overload(gram_into, jit_options={"error_model": "numpy"})
    def _gram_compiled(a: Any, out: Any) -> Any:
        def impl(a: Any, out: Any) -> None:  # (the annotations must be the overload's)
            n, k = a.shape
            if k == 0:  # numpy: an empty sum (BLAS refuses a leading dimension 0)
                out[:, :] = 0.0
                return
            ldc = out.shape[1]
            _dsyrk(_ROW_MAJOR, _UPPER, _NO_TRANS, n, k, 1.0, a.ctypes, k, 0.0, out.ctypes, ldc)
            for i in range(n):  # syrk writes the upper triangle; numpy copies it down
                for j in range(i + 1, n):
                    out[j, i] = out[i, j]

        return impl


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
    gauss_newton_level(
        table,
        4,
        geometry,
        points,
        np.zeros(3),
        np.array([1e-3, 0.2, 0.002, 0.001]),
        np.array([2, 3, 1]),
        np.empty((1, TERM_ROWS, 3)),
    )
    gauss_newton_starts(
        table,
        4,
        geometry,
        points,
        np.zeros((2, 3)),
        np.array([1e-3, 0.2, 0.002, 0.001]),
        np.array([2, 3, 1]),
        np.empty((2, TERM_ROWS, 3)),
        np.zeros(2, dtype=np.bool_),
    )
