"""Hector SLAM's scan matcher against an a-priori map (thesis §3.2, §4.2.3.1).

Method: S. Kohlbrecher, O. von Stryk, J. Meyer, U. Klingauf, "A flexible and scalable SLAM
system with full 3D motion estimation", IEEE SSRR 2011, Section IV:

* The map is a continuous function ``M(P_m)`` in [0, 1] obtained by bilinear interpolation of
  grid values, with the gradient ``∇M = (∂M/∂x, ∂M/∂y)`` from the same four cells (eq. 1-3).
* The pose ``ξ = (p_x, p_y, ψ)`` minimises ``Σ_i [1 - M(S_i(ξ))]²`` (eq. 4), where
  ``S_i(ξ) = R(ψ) s_i + (p_x, p_y)`` is scan end point ``s_i`` in the map frame (eq. 5).
* Gauss-Newton: ``Δξ = H⁻¹ Σ_i [∇M(S_i) ∂S_i/∂ξ]ᵀ [1 - M(S_i(ξ))]`` with
  ``H = Σ_i [∇M ∂S_i/∂ξ]ᵀ [∇M ∂S_i/∂ξ]`` (eq. 12-13) and
  ``∂S_i/∂ξ = [[1, 0, -sinψ s_ix - cosψ s_iy], [0, 1, cosψ s_ix - sinψ s_iy]]`` (eq. 14).
* Multi-resolution: several maps, each with half the resolution of the previous, matched coarse
  to fine, each level starting from the estimate of the coarser one (Section IV-C).

Departures from Hector (documented choices):

* Hector stores occupancy probabilities of a map it builds itself. Here the map is given, so each
  level holds a smooth *likelihood field* ``M = exp(-d² / (2σ²))`` of the distance ``d`` to the
  nearest obstacle surface, with ``σ`` growing with the level's cell size. This keeps the bilinear
  model of the paper while widening the basin of convergence (the coarse level pulls in offsets of
  a few decimetres, the fine level pins the pose to a couple of centimetres).
* Where the surface lies in a cell is a property of the map (``ScanMatcherConfig.surface``):
  ``cell_face`` (default) for maps whose cells are solid squares (a rasterised floor plan, and
  the simulator, which casts rays against cell faces): the field is sampled at cell corners and
  peaks on the faces between occupied and free cells. ``cell_centre`` for maps built by binning
  scan end points (Hector, GMapping, `mapping.grid_from_scans`): a wall lies anywhere in its
  cell, so on average through the centre. The wrong choice biases every wall by half a cell
  (2.5 cm at 0.05 m); the laser sees 270 degrees, so the walls ahead outweigh those behind and
  the bias does not cancel along the direction of travel (measured on the simulated tour:
  1.6 cm RMS standing still, and a false minimum 15 cm down a corridor that held the estimate).
* The angular step is clamped to ±0.2 rad per iteration (FIELD_NOTES, as in hector_mapping) and
  a small Levenberg-style damping keeps ``H`` invertible along featureless corridors.
* At most ``max_points`` end points (default 400) are used, taken with a fixed stride over the
  valid beams so the same beams are used scan after scan; the coarse levels use fewer (a quarter
  and a half). 400 of the UTM-30LX's 1081 beams still give ~0.7 degree spacing, well below the
  angular detail the 5 cm map resolves at office distances, and keep one match well under 2 ms.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Annotated, ClassVar, TypeVar

import numpy as np
import numpy.typing as npt
from msgspec import Meta
from scipy import ndimage

from interbot_core import schema
from interbot_core.geometry import Pose2D
from interbot_core.occupancy_grid import OccupancyGrid
from robot_daemon.localisation import match_kernels

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

MAX_ANGULAR_STEP = 0.2  # [rad] per Gauss-Newton iteration (hector_mapping)
PAD = 2  # cells of M = 0 around each level: clipped points outside read M = 0, ∇M = 0
INLIER_M = math.exp(-2.0)  # M above this (within 2 sigma of a surface): an inlier end point


class ScanMatcherConfigError(ValueError):
    """A scan matcher parameter is outside its allowed range."""


class ScanMatcherConfig(schema.Declared, frozen=True):
    """Parameters of the multi-resolution matcher."""

    ROOT: ClassVar[str] = "ScanMatcherConfig"
    ERROR: ClassVar[type[Exception]] = ScanMatcherConfigError
    levels: Annotated[int, Meta(ge=1, le=5)] = 3  # map levels (each halves the resolution)
    # likelihood-field width sigma, in cells of each level
    sigma_cells: Annotated[float, Meta(ge=0.5, le=10.0)] = 1.0
    # Gauss-Newton iterations, coarse .. fine: one entry per level
    iterations: tuple[Annotated[int, Meta(ge=1, le=50)], ...] = (3, 3, 4)
    max_points: Annotated[int, Meta(ge=20, le=5000)] = 400  # end points used on the finest level
    max_angular_step: Annotated[float, Meta(ge=0.01, le=1.0, extra={"unit": "rad"})] = (
        MAX_ANGULAR_STEP
    )
    damping: Annotated[float, Meta(ge=0.0, le=1.0)] = 1e-3  # Levenberg damping, / trace(H)/3
    # where a map's surface lies: "cell_face" or "cell_centre"
    surface: Annotated[str, schema.one_of("cell_face", "cell_centre")] = "cell_face"
    # finest level: iterate until converged, at most this
    fine_max_iterations: Annotated[int, Meta(ge=1, le=100)] = 10
    # a step below converged_m and converged_rad is converged
    converged_m: Annotated[float, Meta(gt=0.0, le=1.0, extra={"unit": "m"})] = 0.002
    converged_rad: Annotated[float, Meta(gt=0.0, le=1.0, extra={"unit": "rad"})] = 0.001
    # Scale [m] of the surface orientation (`surface_tensor`) that gives each inlier's normal
    # for the match information: the Gaussian-weighted scatter of the finest level's surface
    # nodes within about 3 times this. 0.15 m over-smoothed the realistic world's door jambs and
    # furniture (ISR tour seeds 1 and 3 lost); 0.05 m (one cell) no longer sees a dotted wall's
    # direction (`test_match_information_along_a_dotted_corridor_is_small`).
    tensor_sigma_m: Annotated[float, Meta(ge=0.01, le=2.0, extra={"unit": "m"})] = 0.10

    def check(self) -> None:
        if len(self.iterations) != self.levels:
            raise ScanMatcherConfigError(
                f"ScanMatcherConfig.iterations needs one entry per level ({self.levels}), "
                f"got {self.iterations}"
            )


@dataclass(frozen=True)
class MatchResult:
    """Outcome of one match: the pose, Hector's Hessian (information) and a score in [0, 1]."""

    pose: Pose2D
    hessian: FloatArray  # 3x3 Σ JᵀJ at the solution (x, y, yaw); its inverse ~ covariance
    score: float  # mean M(S_i(ξ)) over the end points on the finest level
    n_points: int
    # Σ J_nᵀ J_n over the inliers (M > INLIER_M) with J_n = (n_x, n_y, n · ∂S_i/∂ψ), n the unit
    # surface normal (∇M / |∇M|): the point-to-surface information of the scan per 1 m² of
    # per-point variance (`Localiser` scales it; see `normal_information`).
    normal_info: FloatArray = field(default_factory=lambda: np.zeros((3, 3)))
    n_inliers: int = 0


@dataclass(frozen=True)
class CoarseStarts:
    """Several starts matched down to a coarse ``level`` (`ScanMatcher.coarse_many`): their
    poses there (x, y, yaw as iterated, yaw not wrapped) and their scores on that level."""

    level: int
    x: FloatArray
    y: FloatArray
    yaw: FloatArray
    scores: list[float]

    def pose(self, k: int) -> Pose2D:
        return Pose2D(float(self.x[k]), float(self.y[k]), float(self.yaw[k]))


@dataclass(frozen=True)
class _Finished:
    """A start matched to the finest level: its pose and score, and what its `MatchResult`'s
    Hessian and point-to-surface information are computed from (`result`: the same values
    whenever computed)."""

    pose: Pose2D
    score: float
    n_points: int
    terms: FloatArray  # the final evaluation's terms (`TERM_ROWS`, n)
    level: LikelihoodLevel

    def result(self) -> MatchResult:
        m, jac, rxy, mxy = (self.terms[rows] for rows in (_M, _J, _R, _S))
        normal_info, n_inliers = normal_information(
            m, jac[0], jac[1], rxy[0], rxy[1], mxy, self.level
        )
        hessian: FloatArray = jac @ jac.T  # H = Σ JᵀJ
        return MatchResult(self.pose, hessian, self.score, self.n_points, normal_info, n_inliers)


class LikelihoodLevel:
    """One map level: a smooth field M in [0, 1] and its bilinear-interpolation corner table.

    ``M = exp(-d² / (2σ²))`` where ``d`` [m] is the distance from a lattice node to the nearest
    obstacle surface node of this level (`surface_distance`: cell centres of rim cells, or cell
    corners on the faces of occupied cells). The field is padded by `PAD` nodes of zeros so
    points outside the map read M = 0 and ∇M = 0. A coarse level snaps surfaces by up to half
    its cell, so its optimum can be off by that much: the localiser starts at the finest level
    whose cell covers the prior's uncertainty (`ScanMatcher.match`'s ``start_level``).
    """

    def __init__(
        self,
        distance: FloatArray,
        resolution: float,
        origin: tuple[float, float],
        sigma: float,
        lattice_offset: float = 0.5,
        obstacle_half_size: float = 0.0,
    ) -> None:
        self.resolution = resolution
        self.sigma = sigma
        self.origin_x, self.origin_y = origin
        # Lattice node (i, j) sits at origin + ((j, i) + lattice_offset) * resolution: 0.5 for
        # cell centres, 0 for cell corners (vertices).
        self.lattice_offset = lattice_offset
        # New obstacles are squares of this half size [m] around their points (0: points).
        self.obstacle_half_size = obstacle_half_size
        # M is cut to 0 beyond `cutoff` (about 3 sigma; never exactly a grid distance).
        self._radius = math.ceil(3.0 * sigma / resolution - 1e-9)
        self.cutoff = (self._radius + 0.5) * resolution  # [m]
        h, w = distance.shape
        p = PAD
        field = np.zeros((h + 2 * p, w + 2 * p), dtype=np.float64)
        # The cut-off also makes incremental additions exact.
        inner = np.exp(-(distance * distance) / (2.0 * sigma * sigma))
        inner[distance > self.cutoff] = 0.0
        field[p:-p, p:-p] = inner
        self.field = field
        self._rebuild_corners(0, h + 2 * p, 0, w + 2 * p)
        # What the compiled loops need of this level (`match_kernels`: origin, 1 / res, the
        # padded-lattice offset and the clip bounds of (u, v)).
        u_max, v_max = w + 2 * p - 1.001, h + 2 * p - 1.001
        self.geometry = np.array(
            (self.origin_x, self.origin_y, 1.0 / resolution, PAD - lattice_offset, u_max, v_max)
        )
        # Per padded lattice node: the surface orientation (txx, txy, tyy) of `surface_tensor`,
        # NaN where no surface is near (set by `ScanMatcher` on the finest level only).
        self.tensor: npt.NDArray[np.float32] | None = None

    def set_surface_tensor(self, tensor: npt.NDArray[np.float32]) -> None:
        """Attach `surface_tensor`'s (h, w, 3) field (unpadded lattice) to this level."""
        h, w = self.field.shape
        p = PAD
        padded = np.full((h, w, 3), np.nan, dtype=np.float32)
        padded[p:-p, p:-p] = tensor
        self.tensor = padded.reshape(-1, 3)

    def tensor_at(self, px: FloatArray, py: FloatArray) -> npt.NDArray[np.float32]:
        """(txx, txy, tyy) at the lattice node nearest each map-frame point (NaN rows: none)."""
        if self.tensor is None:
            return np.full((px.size, 3), np.nan, dtype=np.float32)
        inv = 1.0 / self.resolution
        h, w = self.field.shape
        u = np.rint((px - self.origin_x) * inv + (PAD - self.lattice_offset)).astype(np.intp)
        v = np.rint((py - self.origin_y) * inv + (PAD - self.lattice_offset)).astype(np.intp)
        _clip_into(u, 0, w - 1)
        _clip_into(v, 0, h - 1)
        out: npt.NDArray[np.float32] = self.tensor[v * w + u]
        return out

    @property
    def corners(self) -> FloatArray:
        """The corner table as four planes (4, h * w): ``corners[c, k]``, a view of the
        interleaved table."""
        out: FloatArray = self._table.T
        return out

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of the padded field."""
        return int(self.field.shape[0]), int(self.field.shape[1])

    def _rebuild_corners(self, r0: int, r1: int, c0: int, c1: int) -> None:
        """Corner table, one row of four per lattice node: ``_table[k]`` = (M[i,j], M[i,j+1],
        M[i+1,j], M[i+1,j+1]) for flat k = i * w + j (`corners` shows it as four planes).
        Rows rather than planes (speed, issue 12): a point's four corners are one 32-byte read,
        where planes cost four cache misses on a map that does not fit in the cache (the
        Freiburg campus log's finest table is 650 MB: its 25-start first match 7.7 -> 5.4 ms,
        one match 0.48 -> 0.43 ms CPU; the same on the Intel lab's 15 MB table within noise).

        Only the block ``[r0, r1) x [c0, c1)`` and the row and column after it are copied
        (speed: `add_obstacles` rebuilds a few cells around each new obstacle, and a copy of
        the whole field per obstacle made one map update of a campus log take 0.1 s)."""
        f = self.field
        h, w = f.shape
        if not hasattr(self, "_table"):
            self._table = np.zeros((h * w, 4), dtype=np.float64)
        r0, c0 = max(r0, 0), max(c0, 0)
        r1, c1 = min(r1, h), min(c1, w)
        if r0 >= r1 or c0 >= c1:
            return
        # The field's block with one more row and column, zero beyond the field's edge.
        nxt = np.zeros((r1 - r0 + 1, c1 - c0 + 1), dtype=np.float64)
        nxt[: min(r1 + 1, h) - r0, : min(c1 + 1, w) - c0] = f[r0 : r1 + 1, c0 : c1 + 1]
        view = self._table.T.reshape(4, h, w)
        view[0, r0:r1, c0:c1] = nxt[:-1, :-1]
        view[1, r0:r1, c0:c1] = nxt[:-1, 1:]
        view[2, r0:r1, c0:c1] = nxt[1:, :-1]
        view[3, r0:r1, c0:c1] = nxt[1:, 1:]

    def add_obstacles(self, xs: FloatArray, ys: FloatArray) -> None:
        """Raise M around new obstacle points [m] (exact: M is a max over obstacles)."""
        h, w = self.field.shape
        k = self._radius + 1
        res = self.resolution
        for x, y in zip(xs.tolist(), ys.tolist(), strict=True):
            # Padded index of the lattice node just below (x, y).
            off = self.lattice_offset
            col = math.floor((x - self.origin_x) / res - off) + PAD
            row = math.floor((y - self.origin_y) / res - off) + PAD
            if not (PAD <= row < h - PAD and PAD <= col < w - PAD):
                continue
            r0, r1 = max(row - k, PAD), min(row + k + 1, h - PAD)
            c0, c1 = max(col - k, PAD), min(col + k + 1, w - PAD)
            half = self.obstacle_half_size
            cx = np.abs(self.origin_x + (np.arange(c0, c1) - PAD + off) * res - x)
            cy = np.abs(self.origin_y + (np.arange(r0, r1) - PAD + off) * res - y)
            cx = np.maximum(cx - half, 0.0)
            cy = np.maximum(cy - half, 0.0)
            d2 = cx[None, :] ** 2 + cy[:, None] ** 2
            patch = np.exp(-d2 / (2.0 * self.sigma**2))
            patch[d2 > self.cutoff**2] = 0.0
            np.maximum(self.field[r0:r1, c0:c1], patch, out=self.field[r0:r1, c0:c1])
            self._rebuild_corners(r0 - 1, r1, c0 - 1, c1)

    def value(self, px: FloatArray, py: FloatArray) -> FloatArray:
        """Bilinear M alone at map-frame points (`value_xy` of the points stacked)."""
        return self.value_xy(np.stack((px, py)))

    def value_xy(self, pxy: FloatArray) -> FloatArray:
        """Bilinear M alone at map-frame points stacked as (2, ...) x and y: `interpolate`'s
        first output (the localiser's slide profile scores ~2000 points)."""
        flat = _stacked_points(pxy)
        m = np.empty(flat.shape[1])
        match_kernels.bilinear(
            self._table, self.field.shape[1], self.geometry, flat, m, np.empty(flat.shape)
        )
        return m.reshape(pxy.shape[1:])

    def interpolate(
        self, px: FloatArray, py: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Bilinear M, ∂M/∂x, ∂M/∂y at map-frame points (Hector eq. 1-3)."""
        grad = np.empty((2, *np.shape(px)))
        m = self.interpolate_xy(np.stack((px, py)), grad)
        return m, grad[0], grad[1]

    def interpolate_xy(self, pxy: FloatArray, grad: FloatArray) -> FloatArray:
        """`interpolate` of points stacked as (2, ...) x and y: returns M and writes ∂M/∂x,
        ∂M/∂y into ``grad`` (2, ...) (compiled: `match_kernels.bilinear`)."""
        flat = _stacked_points(pxy)
        m = np.empty(flat.shape[1])
        out = np.empty(flat.shape)
        match_kernels.bilinear(self._table, self.field.shape[1], self.geometry, flat, m, out)
        grad[...] = out.reshape(grad.shape)
        return m.reshape(pxy.shape[1:])

    def gauss_newton(
        self,
        points: FloatArray,
        state: FloatArray,
        steps: FloatArray,
        iterations: npt.NDArray[np.int64],
        terms: FloatArray,
    ) -> bool:
        """Gauss-Newton iterations of one start on this level
        (`match_kernels.gauss_newton_level`): end points ``points`` (2, n) in the sensor frame,
        ``state`` (p_x, p_y, ψ) updated in place; True when it ended with the final evaluation
        (``terms`` (1, `TERM_ROWS`, n) then hold the terms at the solution)."""
        stopped: bool = match_kernels.gauss_newton_level(
            self._table, self.field.shape[1], self.geometry, points, state, steps, iterations, terms
        )
        return stopped

    def gauss_newton_starts(
        self,
        points: FloatArray,
        states: FloatArray,
        steps: FloatArray,
        iterations: npt.NDArray[np.int64],
        terms: FloatArray,
    ) -> npt.NDArray[np.bool_]:
        """`gauss_newton` of each row of ``states`` (k, 3) in one compiled call
        (`match_kernels.gauss_newton_starts`): ``terms`` (k, `TERM_ROWS`, n), or (1, ...) as
        a scratch where they are not kept; whether each ended with the final evaluation."""
        stopped = np.zeros(states.shape[0], dtype=np.bool_)
        match_kernels.gauss_newton_starts(
            self._table,
            self.field.shape[1],
            self.geometry,
            points,
            states,
            steps,
            iterations,
            terms,
            stopped,
        )
        return stopped


# The rows of `LikelihoodLevel.gauss_newton_terms`'s terms: M, J (the Jacobian
# J_i = (∂M/∂x, ∂M/∂y, ∇M · ∂S_i/∂ψ) one row per component: `_hessian`'s layout, H = J Jᵀ),
# J r, R(ψ) s_i and the end points in the map frame S_i.
TERM_ROWS = match_kernels.TERM_ROWS
_M, _J, _R, _S = 0, slice(1, 4), slice(7, 9), slice(9, 11)


def _stacked_points(pxy: FloatArray) -> FloatArray:
    """Points stacked as (2, ...) as one C-contiguous float64 (2, N) array (a view when they
    are one already): the one layout the compiled loops take."""
    flat: FloatArray = np.ascontiguousarray(pxy, dtype=np.float64).reshape(2, -1)
    return flat


def obstacle_surface(occupied: npt.NDArray[np.bool_]) -> npt.NDArray[np.bool_]:
    """Occupied cells with a non-occupied 4-neighbour: the surfaces a laser can hit.

    Using only surfaces (not the filled interior of thick walls) makes M fall off on *both*
    sides of a surface, so range noise that puts end points inside an obstacle is pulled back
    as much as noise that leaves them short; with a filled interior (M = 1 inside) the match is
    biased away from one-sided surfaces by about the range noise.
    """
    interior = ndimage.binary_erosion(occupied, border_value=1)
    out: npt.NDArray[np.bool_] = occupied & ~interior
    return out


def face_vertices(occupied: npt.NDArray[np.bool_]) -> npt.NDArray[np.bool_]:
    """Cell corners (shape ``(h + 1, w + 1)``) where an occupied and a non-occupied cell meet.

    Corner ``(i, j)`` touches cells ``(i - 1 .. i, j - 1 .. j)``; cells outside the grid count
    as not occupied. These corners lie on the faces of the occupied region: where a ray that
    treats cells as solid squares stops.
    """
    h, w = occupied.shape
    padded = np.zeros((h + 2, w + 2), dtype=bool)
    padded[1:-1, 1:-1] = occupied
    quads = (padded[:-1, :-1], padded[:-1, 1:], padded[1:, :-1], padded[1:, 1:])
    any_occ = quads[0] | quads[1] | quads[2] | quads[3]
    all_occ = quads[0] & quads[1] & quads[2] & quads[3]
    out: npt.NDArray[np.bool_] = any_occ & ~all_occ
    return out


def surface_nodes(
    occupied: npt.NDArray[np.bool_], surface: str
) -> tuple[npt.NDArray[np.bool_], float]:
    """The lattice nodes on the map's surfaces and the lattice offset (see `surface_distance`)."""
    if surface == "cell_centre":
        return obstacle_surface(occupied), 0.5
    return face_vertices(occupied), 0.0


def surface_tensor(nodes: npt.NDArray[np.bool_], sigma_nodes: float) -> npt.NDArray[np.float32]:
    """Local orientation of the surfaces: at every lattice node, ``I - C / tr(C)`` with ``C``
    the Gaussian-weighted (``sigma_nodes``) scatter matrix of the surface nodes around it.

    Returns (h, w, 3) = (txx, txy, tyy), NaN where the nodes within reach weigh less than one
    node. Along a straight wall ``C`` is elongated along it and the tensor is ``n nᵀ`` with
    ``n`` the wall's normal; at a corner or a small blob it tends to ``I / 2`` (both directions
    constrained). It is the position information of one end point on that surface per unit
    variance (trace 1), robust where ``∇M`` is not: a wall binned from scan end points is a
    dotted, jagged line whose gradient turns along the wall between the dots and would claim
    information along a featureless corridor that the map does not have (the MIT Infinite
    Corridor log: half the inliers' gradients along it). Separable Gaussian moment filters.
    """
    f = nodes.astype(np.float64)
    radius = max(1, math.ceil(3.0 * sigma_nodes))
    k = np.arange(-radius, radius + 1, dtype=np.float64)
    g = np.exp(-0.5 * (k / sigma_nodes) ** 2)
    g0, g1, g2 = g, g * k, g * k * k

    # Moments of the node offsets (x: columns, y: rows) about each node, then about their
    # mean: rows filtered once per kernel, then columns.
    r0, r1, r2 = (ndimage.correlate1d(f, kr, axis=0, mode="constant") for kr in (g0, g1, g2))

    def cols(a: FloatArray, kc: FloatArray) -> FloatArray:
        out: FloatArray = ndimage.correlate1d(a, kc, axis=1, mode="constant")
        return out

    m0, mx, mxx = cols(r0, g0), cols(r0, g1), cols(r0, g2)
    my, mxy, myy = cols(r1, g0), cols(r1, g1), cols(r2, g0)
    with np.errstate(invalid="ignore", divide="ignore"):
        ex, ey = mx / m0, my / m0
        cxx = mxx / m0 - ex * ex
        cxy = mxy / m0 - ex * ey
        cyy = myy / m0 - ey * ey
        tr = cxx + cyy
        out = np.stack((1.0 - cxx / tr, -cxy / tr, 1.0 - cyy / tr), axis=-1)
    out[~((m0 >= 1.0) & (tr > 1e-9))] = np.nan
    return out.astype(np.float32)


def surface_distance(
    occupied: npt.NDArray[np.bool_], resolution: float, surface: str
) -> tuple[FloatArray, float]:
    """Distance [m] from each lattice node to the nearest surface node, and the lattice offset.

    ``cell_centre``: nodes at cell centres, surfaces through the centres of the rim cells (a map
    built by binning scan end points: a wall lies anywhere in its cell, on average mid-cell).
    ``cell_face``: nodes at cell corners, surfaces on the faces between occupied and free cells
    (a map whose cells are solid squares: a rasterised floor plan, or a ray-casting simulator).
    """
    nodes, offset = surface_nodes(occupied, surface)
    if nodes.any():
        distance = np.asarray(ndimage.distance_transform_edt(~nodes), dtype=np.float64)
        return distance * resolution, offset
    return np.full(nodes.shape, np.inf), offset


def downsample_occupied(occ: npt.NDArray[np.bool_], factor: int) -> npt.NDArray[np.bool_]:
    """A coarse cell is occupied if any of its ``factor x factor`` fine cells is (Hector's
    coarser maps hold the same end points in larger cells)."""
    if factor == 1:
        return occ
    h, w = occ.shape
    hp, wp = -(-h // factor) * factor, -(-w // factor) * factor
    padded = np.zeros((hp, wp), dtype=bool)
    padded[:h, :w] = occ
    blocks = padded.reshape(hp // factor, factor, wp // factor, factor)
    out: npt.NDArray[np.bool_] = np.any(blocks, axis=(1, 3))
    return out


def subsample_points(points: FloatArray, max_points: int) -> FloatArray:
    """At most ``max_points`` rows of ``points`` taken with a fixed stride (deterministic)."""
    n = points.shape[0]
    if n <= max_points:
        return points
    stride = -(-n // max_points)
    return points[::stride]


class ScanMatcher:
    """Multi-resolution Gauss-Newton matcher of scan end points against a static map."""

    def __init__(self, grid: OccupancyGrid, config: ScanMatcherConfig | None = None) -> None:
        self.config = config or ScanMatcherConfig()
        self.levels: list[LikelihoodLevel] = []  # finest first
        for level in range(self.config.levels):
            factor = 2**level
            res = grid.resolution * factor
            occupied = downsample_occupied(grid.occupied(), factor)
            distance, offset = surface_distance(occupied, res, self.config.surface)
            self.levels.append(
                LikelihoodLevel(
                    distance,
                    res,
                    (grid.origin_x, grid.origin_y),
                    self.config.sigma_cells * res,
                    offset,
                    0.5 * grid.resolution if self.config.surface == "cell_face" else 0.0,
                )
            )
            if level == 0:
                nodes, _ = surface_nodes(occupied, self.config.surface)
                self.levels[0].set_surface_tensor(
                    surface_tensor(nodes, self.config.tensor_sigma_m / res)
                )
        logger.debug(
            "scan matcher: %d levels %s m", len(self.levels), [lv.resolution for lv in self.levels]
        )
        cfg = self.config
        # `match_kernels.gauss_newton_level`'s settings, and its iterations on each level: the
        # finest goes on past its iterations while the steps are not converged (a few degrees
        # of yaw take more than 4 steps at 5 cm), up to fine_max_iterations, then evaluates
        # the solution.
        self._steps = np.array(
            (cfg.damping, cfg.max_angular_step, cfg.converged_m, cfg.converged_rad)
        )
        self._iterations = []
        for li in range(len(self.levels)):
            n_iter = cfg.iterations[len(self.levels) - 1 - li]
            n_max = max(n_iter, cfg.fine_max_iterations) if li == 0 else n_iter
            self._iterations.append(np.array((n_iter, n_max, li == 0), dtype=np.int64))

    def add_obstacles(self, xs: FloatArray, ys: FloatArray) -> None:
        """Add new static obstacle points [m] to every level."""
        for level in self.levels:
            level.add_obstacles(xs, ys)

    def start_level(self, sigma_xy: float, sigma_yaw: float) -> int:
        """Coarsest level needed for a prior with these standard deviations [m], [rad].

        The finest level whose cell is at least ``sigma_xy`` (and at least level 1 when
        ``sigma_yaw`` > 0.05 rad); the coarsest level when none is large enough.
        """
        for li, level in enumerate(self.levels):
            if level.resolution >= sigma_xy and (li >= 1 or sigma_yaw <= 0.05):
                return li
        return len(self.levels) - 1

    def match(
        self, points: FloatArray, initial: Pose2D, start_level: int | None = None
    ) -> MatchResult:
        """Align sensor-frame end points (N, 2) [m] to the map starting at ``initial``.

        Levels are matched coarse to fine from ``start_level`` (default: the coarsest); level
        ``l`` uses ``max_points >> l`` points. Returns the finest level's pose, H and mean M.
        """
        fine = subsample_points(points, self.config.max_points)
        return self._descend(fine, initial, start_level).result()

    def match_many(
        self, points: FloatArray, initials: Sequence[Pose2D], start_level: int | None = None
    ) -> list[MatchResult]:
        """`match` from each of ``initials``.

        (Session 12 iterated the starts stacked, one numpy call per step for all of them; with
        each level's iterations one compiled call, start by start is faster.)"""
        fine = subsample_points(points, self.config.max_points)
        stacked = self._level_points(fine, self._first_level(start_level), 0)
        return [self._descend(fine, p, start_level, stacked).result() for p in initials]

    def match_best(
        self,
        points: FloatArray,
        initials: Sequence[Pose2D],
        start_level: int | None = None,
        keep: int = 0,
    ) -> list[MatchResult]:
        """`match_many`'s results of the first ``keep`` starts and of the best-scoring one of
        the rest (the first of equals), bit for bit; the others' Hessians and information,
        which a caller keeping only the best never reads, are not computed.

        Speed (issue 12): that final evaluation (`normal_information`, the Hessian) was a sixth
        of the 25-start first match after a set pose (`Localiser._match_from_starts`, the
        Freiburg campus, CSAIL and Örebro whole-log runs' 14 such matches: 5.5 -> 4.6 ms of
        CPU; their 28 wide-heading matches, `Localiser._wide_heading_match`: 2.0 -> 1.8 ms;
        medians of three interleaved runs, load 8-9)."""
        if not 0 <= keep < len(initials):
            raise ValueError(f"match_best: keep must be 0..{len(initials) - 1}, got {keep}")
        fine = subsample_points(points, self.config.max_points)
        stacked = self._level_points(fine, self._first_level(start_level), 0)
        finished = [self._descend(fine, p, start_level, stacked) for p in initials]
        return [f.result() for f in finished[:keep]] + [_best(finished[keep:]).result()]

    def coarse_many(
        self,
        points: FloatArray,
        initials: Sequence[Pose2D],
        stop_level: int,
        start_level: int | None = None,
    ) -> CoarseStarts:
        """`match_many` stopped after level ``stop_level`` (> 0, a coarse one): each start's
        pose there and its score on that level (`level_score`); `finish` one of them for
        `match_many`'s result for that start, bit for bit (`test_loc_speed_equivalence.py`).

        Speed (issue 12): the finest level holds most of a match's cost (400 points, up to
        ``fine_max_iterations``); a caller that keeps only the best of several starts
        (`Localiser._wide_heading_match`) can rank them here and finish one."""
        n_levels = len(self.levels)
        if not 0 < stop_level < n_levels:
            raise ValueError(f"coarse_many: stop_level must be 1..{n_levels - 1}, got {stop_level}")
        if start_level is not None and start_level < stop_level:
            raise ValueError(
                f"coarse_many: start_level {start_level} is finer than stop_level {stop_level}"
            )
        fine = subsample_points(points, self.config.max_points)
        states = np.array([(p.x, p.y, p.yaw) for p in initials]).reshape(-1, 3)
        if fine.shape[0] > 0:
            first = max(self._first_level(start_level), stop_level)
            stacked = self._level_points(fine, first, stop_level)  # once for every start
            for li in range(first, stop_level - 1, -1):  # every start a level at a time
                scratch = np.empty((1, TERM_ROWS, stacked[li].shape[1]))
                self.levels[li].gauss_newton_starts(
                    stacked[li], states, self._steps, self._iterations[li], scratch
                )
        px, py, yaw = (np.ascontiguousarray(states[:, k]) for k in range(3))
        scores = self._level_scores(fine, px, py, yaw, stop_level)
        return CoarseStarts(stop_level, px, py, yaw, scores)

    def finish(
        self, points: FloatArray, starts: CoarseStarts, ks: Sequence[int]
    ) -> list[MatchResult]:
        """Starts ``ks`` of `coarse_many` matched on down to the finest level: `match_many`'s
        results for them (the poses carried on unwrapped, as there)."""
        fine = subsample_points(points, self.config.max_points)
        if fine.shape[0] == 0:
            return [self.match(points, starts.pose(k), 0) for k in ks]
        out = []
        for k in ks:
            state = np.array((starts.x[k], starts.y[k], starts.yaw[k]))
            out.append(self._finish(fine, state, starts.level - 1).result())
        return out

    def finish_best(
        self, points: FloatArray, starts: CoarseStarts, ks: Sequence[int]
    ) -> MatchResult:
        """`finish`'s result of the best-scoring of starts ``ks`` (the first of equals), bit for
        bit; the others' Hessians and information are not computed (as `match_best`)."""
        if not ks:
            raise ValueError("finish_best: no start to finish")
        fine = subsample_points(points, self.config.max_points)
        if fine.shape[0] == 0:
            return _best(self.finish(points, starts, ks))
        first = starts.level - 1
        stacked = self._level_points(fine, first, 0)
        states = np.array([(starts.x[k], starts.y[k], starts.yaw[k]) for k in ks])
        for li in range(first, 0, -1):  # every start a level at a time, as `coarse_many`
            scratch = np.empty((1, TERM_ROWS, stacked[li].shape[1]))
            self.levels[li].gauss_newton_starts(
                stacked[li], states, self._steps, self._iterations[li], scratch
            )
        terms = np.empty((len(ks), TERM_ROWS, fine.shape[0]))
        stopped = self.levels[0].gauss_newton_starts(
            stacked[0], states, self._steps, self._iterations[0], terms
        )
        if not stopped.all():  # the finest level always ends with its final evaluation
            raise RuntimeError("scan matcher: the finest level did not finish")
        finished = []
        for k in range(len(ks)):
            m = terms[k, _M]
            score = float(np.add.reduce(m)) / m.size if m.size else 0.0  # as `_finish`
            px, py, yaw = states[k].tolist()
            pose = Pose2D(px, py, yaw)
            finished.append(_Finished(pose, score, int(fine.shape[0]), terms[k], self.levels[0]))
        return _best(finished).result()

    def _first_level(self, start_level: int | None) -> int:
        """The level a match starts on: ``start_level`` clipped to the levels, else the
        coarsest."""
        coarsest = len(self.levels) - 1
        return coarsest if start_level is None else min(max(start_level, 0), coarsest)

    def _descend(
        self,
        fine: FloatArray,
        initial: Pose2D,
        start_level: int | None,
        stacked: dict[int, FloatArray] | None = None,
    ) -> _Finished:
        """One start matched from ``start_level`` (`_first_level`) to the finest level
        (``stacked``: `_level_points` of ``fine`` from there, when the caller has them)."""
        state = np.array((initial.x, initial.y, initial.yaw))  # ξ, iterated in place
        return self._finish(fine, state, self._first_level(start_level), stacked)

    def _finish(
        self,
        fine: FloatArray,
        state: FloatArray,
        first: int,
        stacked: dict[int, FloatArray] | None = None,
    ) -> _Finished:
        """``state`` (p_x, p_y, ψ) iterated from level ``first`` down to the finest level, and
        what its result is computed from (the terms of the final evaluation); ``stacked``:
        `_level_points` of ``fine``, when the caller has them."""
        terms = self._iterate(fine, state, first, 0, stacked)
        if terms is None:  # the finest level always ends with its final evaluation
            raise RuntimeError("scan matcher: the finest level did not finish")
        m = terms[_M]
        score = float(np.add.reduce(m)) / m.size if m.size else 0.0  # m.mean()
        px, py, yaw = state.tolist()
        return _Finished(Pose2D(px, py, yaw), score, int(fine.shape[0]), terms, self.levels[0])

    def _iterate(
        self,
        fine: FloatArray,
        state: FloatArray,
        first: int,
        last: int,
        stacked: dict[int, FloatArray] | None = None,
    ) -> FloatArray | None:
        """Levels ``first`` down to ``last`` (coarse to fine; level ``l`` uses
        ``max_points >> l`` of the points ``fine``, at least 30: `_level_points`, or
        ``stacked`` when given) iterated from ``state`` (updated in place), one compiled call a
        level (`LikelihoodLevel.gauss_newton`). Returns the finest level's terms at the
        solution (`TERM_ROWS`, n) when ``last`` is 0, else None."""
        if stacked is None:
            stacked = self._level_points(fine, first, last)
        for li in range(first, last - 1, -1):
            sxy = stacked[li]  # the end points s_i, x and y stacked
            terms = np.empty((1, TERM_ROWS, sxy.shape[1]))
            if self.levels[li].gauss_newton(sxy, state, self._steps, self._iterations[li], terms):
                solution: FloatArray = terms[0]
                return solution
        return None

    def _level_points(self, fine: FloatArray, first: int, last: int) -> dict[int, FloatArray]:
        """The end points each of levels ``first`` down to ``last`` iterates on, x and y
        stacked (2, n): ``fine`` on the finest level, ``max_points >> l`` of them (at least 30)
        on level ``l`` (speed: computed once for all the starts of a call)."""
        cfg = self.config
        out = {}
        for li in range(first, last - 1, -1):
            pts = fine if li == 0 else subsample_points(fine, max(cfg.max_points >> li, 30))
            out[li] = np.ascontiguousarray(pts.T)
        return out

    def level_score(self, points: FloatArray, pose: Pose2D, level: int) -> float:
        """Mean M of the end points at ``pose`` on ``level``, over the points `match` uses
        there (``max_points >> level`` of them, at least 30)."""
        fine = subsample_points(points, self.config.max_points)
        return self._level_score(fine, pose.x, pose.y, pose.yaw, level)

    def _level_scores(
        self, fine: FloatArray, x: FloatArray, y: FloatArray, yaw: FloatArray, level: int
    ) -> list[float]:
        """`_level_score` at each pose (``x``, ``y``, ``yaw``), the same values: every pose's
        end points in one interpolation (speed: 25 starts, `Localiser._match_from_starts`)."""
        cfg = self.config
        pts = fine if level == 0 else subsample_points(fine, max(cfg.max_points >> level, 30))
        if pts.shape[0] == 0 or x.size == 0:
            return [0.0] * x.size
        # (math's cos and sin, as `_level_score`: numpy's may round differently)
        c = np.array([math.cos(t) for t in yaw.tolist()])[:, None]
        s = np.array([math.sin(t) for t in yaw.tolist()])[:, None]
        pxy = np.empty((2, x.size, pts.shape[0]))
        np.add(c * pts[:, 0] - s * pts[:, 1], x[:, None], out=pxy[0])
        np.add(s * pts[:, 0] + c * pts[:, 1], y[:, None], out=pxy[1])
        m = self.levels[level].value_xy(pxy)
        out: list[float] = (np.add.reduce(m, axis=1) / pts.shape[0]).tolist()
        return out

    def _level_score(self, fine: FloatArray, x: float, y: float, yaw: float, level: int) -> float:
        cfg = self.config
        pts = fine if level == 0 else subsample_points(fine, max(cfg.max_points >> level, 30))
        if pts.shape[0] == 0:
            return 0.0
        c, s = math.cos(yaw), math.sin(yaw)
        pxy = np.empty((2, pts.shape[0]))
        np.add(c * pts[:, 0] - s * pts[:, 1], x, out=pxy[0])
        np.add(s * pts[:, 0] + c * pts[:, 1], y, out=pxy[1])
        m = self.levels[level].value_xy(pxy)
        return float(np.add.reduce(m)) / m.size


_T = TypeVar("_T", MatchResult, _Finished)


def _best(results: Sequence[_T]) -> _T:
    """The highest-scoring of ``results`` (the first of equals)."""
    best = results[0]
    for result in results[1:]:
        if result.score > best.score:
            best = result
    return best


def normal_information(
    m: FloatArray,
    gx: FloatArray,
    gy: FloatArray,
    rx: FloatArray,
    ry: FloatArray,
    mxy: FloatArray,
    level: LikelihoodLevel,
) -> tuple[FloatArray, int]:
    """Point-to-surface information ``Σ Aᵢᵀ Tᵢ Aᵢ`` of the inliers, and their number.

    Hector's ``H`` is built from ``∇M``, which vanishes where an end point sits exactly on a
    surface (the peak of M): at the solution it measures the residual noise as much as the
    geometry. The covariance needs the geometry: for an end point at distance ``d`` from a
    surface with unit normal ``n``, ``∂d/∂ξ = nᵀ Aᵢ`` with ``Aᵢ = [I₂ | R'(ψ) sᵢ]``, the
    Jacobian of point-to-line ICP (Censi, "An accurate closed-form estimate of ICP's
    covariance", ICRA 2007), whose information is ``Aᵢᵀ n nᵀ Aᵢ``. ``Tᵢ`` is the surface's
    orientation tensor at the end point (`surface_tensor`: ``n nᵀ`` on a straight wall, about
    ``I / 2`` at a corner), or ``n nᵀ`` with ``n = ∇M / |∇M|`` where the map has none (new
    obstacles). Only inliers (``M > INLIER_M``: within 2 sigma of a surface) count, so beams
    into open space or onto people add nothing. Along a featureless corridor every ``Tᵢ`` is
    across it, so the information along it is (near) zero.

    ``m``, ``gx``, ``gy``: M and ∇M at the end points; ``rx``, ``ry``: ``R(ψ) sᵢ``; ``mxy``:
    the end points in the map frame, x and y stacked, where ``Tᵢ`` is looked up in ``level``'s
    tensor (its nearest lattice node; none without a tensor). The summands are computed in a
    compiled loop (`match_kernels.inlier_terms`), their sums by numpy (its pairwise order).
    """
    c = np.ascontiguousarray
    out = np.empty((6, m.size))
    tensor, (h, w) = (_NO_TENSOR, (1, 1)) if level.tensor is None else (level.tensor, level.shape)
    n = match_kernels.inlier_terms(
        c(m), c(gx), c(gy), c(rx), c(ry), c(mxy), tensor, w, h, level.geometry, INLIER_M, out
    )
    if n == 0:
        return np.zeros((3, 3)), 0
    # Σ T_xx, Σ T_xy, Σ T_yy, Σ a_x, Σ a_y, Σ jᵀ a: each row reduces as a lone array does.
    a, b, d, e, f, q = np.add.reduce(out[:, :n], axis=1).tolist()
    return np.array([[a, b, e], [b, d, f], [e, f, q]]), n


# A tensor with no surface anywhere: every inlier's T is n nᵀ (`normal_information`).
_NO_TENSOR = np.full((1, 3), np.nan, dtype=np.float32)


def _clip_into(
    a: npt.NDArray[np.generic], low: float | FloatArray, high: float | FloatArray
) -> None:
    """``np.clip(a, low, high, out=a)`` with the ufuncs directly: the same values, without
    np.clip's wrapper, which costs more than the clipping on a scan's few hundred points."""
    np.minimum(a, high, out=a)
    np.maximum(a, low, out=a)
