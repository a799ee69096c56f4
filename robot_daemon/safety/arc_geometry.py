"""Polygons and circular arcs for the collision monitor and assisted teleoperation (vectorised).

A differential-drive base holding (v, omega) follows a circular arc of curvature
``kappa = omega / v``. After a signed arc length ``s`` (``s = v t``) its pose in the start frame is
(Siegwart & Nourbakhsh §5.2.4, the same arc the simulator integrates)::

    theta = kappa s,   x = sin(kappa s) / kappa,   y = (1 - cos(kappa s)) / kappa,

written here as ``x = s sinc(theta)`` and ``y = s sin(theta/2) sinc(theta/2)`` so that a straight
line (kappa = 0) needs no special case. A turn on the spot (v = 0) is the pose (0, 0, theta).

Rather than moving the footprint, each obstacle point ``p`` is expressed in the robot's frame at
every sampled pose, ``R(-theta) (p - (x, y))``, and tested against the footprint polygon with the
crossing-number rule. This is how Nav2's Collision Monitor computes the time to collision of
its ``approach`` polygons (``Polygon::getCollisionTime``), done for many arcs at once: the poses
with numpy (their trig), the points pose by pose in a compiled loop that stops at the first
contact (`first_contacts`, `robot_daemon.jit`; `point_in_polygon` and `point_to_polygon` are
`inside_polygon` and `distance_to_polygon` for one point, with their arithmetic).
"""

from __future__ import annotations

import functools
import math

import numpy as np
import numpy.typing as npt

from robot_daemon import jit

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


class PolygonError(ValueError):
    """A polygon is malformed (fewer than 3 vertices, non-finite, zero area)."""


def as_polygon(points: object, what: str = "polygon") -> FloatArray:
    """(E, 2) float vertices, validated: >= 3 finite vertices enclosing a non-zero area."""
    try:
        poly = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise PolygonError(
            f"{what}: points must be a list of [x, y] pairs, got {points!r}"
        ) from None
    if poly.ndim != 2 or poly.shape[1] != 2 or poly.shape[0] < 3:
        raise PolygonError(f"{what}: needs at least 3 [x, y] vertices, got {points!r}")
    if not np.all(np.isfinite(poly)):
        raise PolygonError(f"{what}: vertices must be finite")
    if abs(polygon_area(poly)) < 1e-6:
        raise PolygonError(f"{what}: vertices enclose no area")
    return poly


def polygon_area(poly: FloatArray) -> float:
    """Signed area [m^2] (positive counter-clockwise), the shoelace formula."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def polygon_radius(poly: FloatArray) -> float:
    """Distance [m] from the origin (base_link) to the farthest vertex."""
    return float(np.hypot(poly[:, 0], poly[:, 1]).max())


def inside_polygon(px: FloatArray, py: FloatArray, poly: FloatArray) -> BoolArray:
    """Crossing-number point-in-polygon for arrays of any (equal) shape (a closed form for
    axis-aligned rectangles, the usual footprint and zones)."""
    box = axis_aligned_box(poly)
    if box is not None:
        cx, cy, hl, hw = box
        result: BoolArray = (np.abs(px - cx) <= hl) & (np.abs(py - cy) <= hw)
        return result
    inside = np.zeros(np.shape(px), dtype=bool)
    n = len(poly)
    for i in range(n):  # loop over the few edges; points stay vectorised
        ax, ay = poly[i]
        bx, by = poly[(i + 1) % n]
        if ay == by:
            continue
        straddles = (ay > py) != (by > py)
        x_cross = ax + (py - ay) * ((bx - ax) / (by - ay))
        inside ^= straddles & (px < x_cross)
    return inside


def axis_aligned_box(poly: FloatArray) -> tuple[float, float, float, float] | None:
    """(centre x, centre y, half length, half width) if ``poly`` is an axis-aligned rectangle."""
    return _box_cached(poly.tobytes(), poly.shape[0])


@functools.lru_cache(maxsize=64)
def _box_cached(data: bytes, n: int) -> tuple[float, float, float, float] | None:
    poly = np.frombuffer(data, dtype=np.float64).reshape(n, 2)
    if len(poly) != 4:
        return None
    xs, ys = np.unique(poly[:, 0]), np.unique(poly[:, 1])
    if len(xs) != 2 or len(ys) != 2:
        return None
    edges = np.diff(np.vstack((poly, poly[:1])), axis=0)
    if not np.all((edges[:, 0] == 0) | (edges[:, 1] == 0)):
        return None
    return (
        float(xs.mean()),
        float(ys.mean()),
        float(xs[1] - xs[0]) / 2,
        float(ys[1] - ys[0]) / 2,
    )


def distance_to_polygon(px: FloatArray, py: FloatArray, poly: FloatArray) -> FloatArray:
    """Euclidean distance [m] from each point to the polygon (0 inside it)."""
    box = axis_aligned_box(poly)
    if box is not None:  # the usual footprint: a closed form
        cx, cy, hl, hw = box
        ex = np.maximum(np.abs(px - cx) - hl, 0.0)
        ey = np.maximum(np.abs(py - cy) - hw, 0.0)
        dist: FloatArray = np.hypot(ex, ey)
        return dist
    best = np.full(np.shape(px), np.inf)
    n = len(poly)
    for i in range(n):
        ax, ay = poly[i]
        bx, by = poly[(i + 1) % n]
        ex, ey = bx - ax, by - ay
        t = np.clip(((px - ax) * ex + (py - ay) * ey) / (ex * ex + ey * ey), 0.0, 1.0)
        best = np.minimum(best, np.hypot(px - ax - t * ex, py - ay - t * ey))
    result: FloatArray = np.where(inside_polygon(px, py, poly), 0.0, best)
    return result


def arc_poses(curvature: FloatArray, s: FloatArray) -> tuple[FloatArray, ...]:
    """(x, y, cos theta, sin theta) after signed arc lengths ``s`` on arcs of ``curvature``.

    Shapes broadcast: ``curvature`` (C, 1) and ``s`` (1, K) give (C, K) arrays.
    """
    theta = curvature * s
    x = s * np.sinc(theta / math.pi)
    y = s * np.sin(theta / 2) * np.sinc(theta / (2 * math.pi))
    return x, y, np.cos(theta), np.sin(theta)


def first_contact(
    px: FloatArray,
    py: FloatArray,
    x: FloatArray,
    y: FloatArray,
    cos_t: FloatArray,
    sin_t: FloatArray,
    poly: FloatArray,
    min_points: int = 1,
) -> npt.NDArray[np.intp]:
    """Index of the first pose (per row of the (C, K) pose arrays) at which at least
    ``min_points`` of the (N,) points lie inside ``poly``; K where none does (`first_contacts`)."""
    poses = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (x, y, cos_t, sin_t)))
    shape = poses[0].shape
    x2, y2, c2, s2 = (np.ascontiguousarray(a.reshape(-1, shape[-1])) for a in poses)
    first = first_contacts(
        np.ascontiguousarray(px, dtype=np.float64).ravel(),
        np.ascontiguousarray(py, dtype=np.float64).ravel(),
        x2,
        y2,
        c2,
        s2,
        np.ascontiguousarray(poly, dtype=np.float64),
        polygon_box(poly),
        int(min_points),
    )
    result: npt.NDArray[np.intp] = first.reshape(shape[:-1])
    return result


def polygon_box(poly: FloatArray) -> FloatArray:
    """``axis_aligned_box(poly)`` as an array for the kernels: (centre x, centre y, half length,
    half width), or all -1 for a polygon that is not such a box."""
    box = axis_aligned_box(poly)
    return np.array(box if box is not None else (-1.0, -1.0, -1.0, -1.0))


@jit.kernel
def point_in_polygon(x: float, y: float, poly: FloatArray, box: FloatArray) -> bool:
    """`inside_polygon` of one point (``box`` from `polygon_box`): the closed form of a box,
    else the crossing number, with `inside_polygon`'s arithmetic."""
    if box[2] >= 0.0:
        return bool(abs(x - box[0]) <= box[2] and abs(y - box[1]) <= box[3])
    inside = False
    n = poly.shape[0]
    for i in range(n):
        ax, ay = poly[i, 0], poly[i, 1]
        bx, by = poly[(i + 1) % n, 0], poly[(i + 1) % n, 1]
        if ay == by:
            continue
        if (ay > y) != (by > y) and x < ax + (y - ay) * ((bx - ax) / (by - ay)):
            inside = not inside
    return inside


@jit.kernel
def point_to_polygon(x: float, y: float, poly: FloatArray, box: FloatArray) -> float:
    """`distance_to_polygon` of one point [m] (0 inside), with its arithmetic (numpy's
    ``minimum``: a NaN, from a zero-length edge, wins)."""
    if box[2] >= 0.0:
        ex = max(abs(x - box[0]) - box[2], 0.0)
        ey = max(abs(y - box[1]) - box[3], 0.0)
        return math.hypot(ex, ey)
    best = math.inf
    n = poly.shape[0]
    for i in range(n):
        ax, ay = poly[i, 0], poly[i, 1]
        ex, ey = poly[(i + 1) % n, 0] - ax, poly[(i + 1) % n, 1] - ay
        t = ((x - ax) * ex + (y - ay) * ey) / (ex * ex + ey * ey)
        t = min(max(t, 0.0), 1.0) if t == t else t
        d = math.hypot(x - ax - t * ex, y - ay - t * ey)
        if best == best and not best <= d:
            best = d
    return 0.0 if point_in_polygon(x, y, poly, box) else best


@jit.kernel
def first_contacts(
    px: FloatArray,
    py: FloatArray,
    x: FloatArray,
    y: FloatArray,
    cos_t: FloatArray,
    sin_t: FloatArray,
    poly: FloatArray,
    box: FloatArray,
    min_points: int,
) -> npt.NDArray[np.intp]:
    """For each row of poses (x, y, cos, sin) (C, K), the first pose k at which ``min_points``
    of the points, in that pose's frame ``(c dx + s dy, c dy - s dx)``, lie inside ``poly``;
    K where none does. Pose by pose, stopping at the first contact, where numpy tested every
    point at every pose of every row at once."""
    rows, steps = x.shape
    first = np.full(rows, steps, dtype=np.intp)
    for r in range(rows):
        for k in range(steps):
            c, s = cos_t[r, k], sin_t[r, k]
            count = 0
            for p in range(px.size):
                dx, dy = px[p] - x[r, k], py[p] - y[r, k]
                if point_in_polygon(c * dx + s * dy, c * dy - s * dx, poly, box):
                    count += 1
            if count >= min_points:
                first[r] = k
                break
    return first


def free_arc_length(
    px: FloatArray,
    py: FloatArray,
    poly: FloatArray,
    curvatures: FloatArray,
    length: float,
    steps: int,
    min_points: int = 1,
) -> FloatArray:
    """Signed arc length [m] each arc of ``curvatures`` can travel before ``poly`` (the footprint)
    touches ``min_points`` points, sampled in ``steps`` equal steps up to ``length`` (signed:
    negative reverses). The last collision-free sample counts: 0 if the first step collides,
    ``length`` if none does. Points already inside ``poly`` at the start are the caller's."""
    curv = np.asarray(curvatures, dtype=np.float64).reshape(-1, 1)
    s = (length / steps) * np.arange(1, steps + 1, dtype=np.float64)[None, :]
    x, y, c, sn = arc_poses(curv, s)
    first = first_contact(px, py, x, y, c, sn, poly, min_points)
    result: FloatArray = first.astype(np.float64) * (length / steps)
    return result


def free_rotation(
    px: FloatArray, py: FloatArray, poly: FloatArray, angle: float, steps: int, min_points: int = 1
) -> float:
    """Signed angle [rad] a turn on the spot can sweep (up to ``angle``) before contact."""
    theta = (angle / steps) * np.arange(1, steps + 1, dtype=np.float64)[None, :]
    zero = np.zeros_like(theta)
    first = first_contact(px, py, zero, zero, np.cos(theta), np.sin(theta), poly, min_points)
    return float(first[0]) * (angle / steps)


def grow_polygon(poly: FloatArray, margin: float) -> FloatArray:
    """A polygon grown outward by about ``margin`` [m] (each vertex pushed along the bisector;
    exact for rectangles centred anywhere, a fair approximation for other convex shapes)."""
    if margin == 0:
        return poly.copy()
    ccw = poly if polygon_area(poly) > 0 else poly[::-1]
    prev = np.roll(ccw, 1, axis=0)
    nxt = np.roll(ccw, -1, axis=0)

    def normals(d: FloatArray) -> FloatArray:
        n = np.column_stack((d[:, 1], -d[:, 0]))  # right-hand normal: outward for CCW
        out: FloatArray = n / np.hypot(n[:, 0], n[:, 1])[:, None]
        return out

    n1 = normals(ccw - prev)
    n2 = normals(nxt - ccw)
    bis = n1 + n2
    bis_unit = bis / np.maximum(np.hypot(bis[:, 0], bis[:, 1]), 1e-12)[:, None]
    cos_half = np.maximum(np.einsum("ij,ij->i", bis_unit, n1), 0.2)
    grown: FloatArray = ccw + bis_unit * (margin / cos_half)[:, None]
    return grown


def near_arcs(
    px: FloatArray, py: FloatArray, curvatures: FloatArray, radius: float, length: float
) -> npt.NDArray[np.bool_]:
    """Points that a footprint of circumscribed ``radius`` [m] could touch while base_link moves
    up to ``|length|`` along any of the arcs: within ``radius`` of the arc's circle (of the
    x axis for a straight line) and of the origin plus ``|length|``. A cheap superset that keeps
    the per-step tests small (walls beside a straight run drop out) (`near_arc_points`)."""
    keep: npt.NDArray[np.bool_] = near_arc_points(
        np.ascontiguousarray(px, dtype=np.float64).ravel(),
        np.ascontiguousarray(py, dtype=np.float64).ravel(),
        np.ascontiguousarray(curvatures, dtype=np.float64).ravel(),
        float(radius),
        float(length),
    )
    return keep.reshape(np.shape(px))


@jit.kernel
def near_arc_points(
    px: FloatArray, py: FloatArray, curvatures: FloatArray, radius: float, length: float
) -> npt.NDArray[np.bool_]:
    """`near_arcs` point by point: ``|py| <= radius`` for a straight line (``|kappa| <
    1e-6``), else ``| |p - (0, 1/kappa)| - |1/kappa| | <= radius``; and ``|p| <= radius +
    |length|``."""
    keep = np.zeros(px.size, dtype=np.bool_)
    reach = radius + abs(length)
    for p in range(px.size):
        if not math.hypot(px[p], py[p]) <= reach:
            continue
        for kappa in curvatures:
            if abs(kappa) < 1e-6:
                near = abs(py[p]) <= radius
            else:
                rho = 1.0 / kappa
                near = abs(math.hypot(px[p], py[p] - rho) - abs(rho)) <= radius
            if near:
                keep[p] = True
                break
    return keep


def two_arc_poses(
    k1: FloatArray, k2: FloatArray, split: float, s: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Poses (x, y, cos, sin) after signed arc lengths ``s`` (1, K) along paths of curvature
    ``k1`` (C, 1) up to ``split`` and ``k2`` (C, 1) after it (a lane change when k2 mirrors k1
    about the intent): the second arc composed onto the end pose of the first."""
    first = np.minimum(np.abs(s), abs(split)) * np.sign(s)
    x1, y1, c1, s1 = arc_poses(k1, first)
    rest = s - first
    x2, y2, c2, s2 = arc_poses(k2, rest)
    x = x1 + c1 * x2 - s1 * y2
    y = y1 + s1 * x2 + c1 * y2
    return x, y, c1 * c2 - s1 * s2, s1 * c2 + c1 * s2


def free_path_length(
    px: FloatArray,
    py: FloatArray,
    poly: FloatArray,
    k1: FloatArray,
    k2: FloatArray,
    split: float,
    length: float,
    steps: int,
) -> FloatArray:
    """`free_arc_length` for two-arc paths (see `two_arc_poses`); |length| per path when free."""
    s = (length / steps) * np.arange(1, steps + 1, dtype=np.float64)[None, :]
    x, y, c, sn = two_arc_poses(k1.reshape(-1, 1), k2.reshape(-1, 1), split, s)
    first = first_contact(px, py, x, y, c, sn, poly, 1)
    result: FloatArray = first.astype(np.float64) * abs(length / steps)
    return result


def closes_in(
    px: FloatArray,
    py: FloatArray,
    footprint: FloatArray,
    x: FloatArray,
    y: FloatArray,
    c: FloatArray,
    s: FloatArray,
    tolerance: float,
) -> npt.NDArray[np.bool_]:
    """For each probe pose (x, y, cos, sin) (C,), whether the footprint there is closer than at
    the start to any of the points (by more than ``tolerance`` [m])."""
    before = distance_to_polygon(px, py, footprint)[None, :]
    dx = px[None, :] - x[:, None]
    dy = py[None, :] - y[:, None]
    lx = c[:, None] * dx + s[:, None] * dy
    ly = c[:, None] * dy - s[:, None] * dx
    after = distance_to_polygon(lx, ly, footprint)
    result: npt.NDArray[np.bool_] = np.any(after < before - tolerance, axis=1)
    return result
