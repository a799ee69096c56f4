"""The simulated laser's caster as numpy code: the reference for the compiled one.

``numpy_cast_walls`` and ``numpy_refine`` are ``RayCaster.cast_walls`` and ``RayCaster._refine``
of session 12 (before `robot_daemon/sim/sphere_tracing.py`), verbatim but for taking the world
as an argument: sphere tracing of all beams in numpy passes (positions as complex numbers, one
pass moves both coordinates), finished beams dropped every third pass, the last few grazing
beams marched in chunks of fine samples, each hit refined within its last fine step.
``numpy_cast_circles`` and ``numpy_cast_glass`` are ``RayCaster.cast_circles`` and
``RayCaster.cast_glass`` of session 12 (before `robot_daemon/sim/analytic_rays.py`), with the
windows of beams they tested for increasing beams (``increasing=None`` checks) or every beam.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from robot_daemon.sim.world import RAY_FINE_STEP, World

FloatArray = npt.NDArray[np.float64]

_REFINE_SAMPLES = 5
_TAIL_BEAMS = 64
_COMPACT_EVERY = 3
_TAIL_CHUNK = 96


def numpy_cast_walls(
    w: World,
    origin_x: float,
    origin_y: float,
    angles: FloatArray,
    max_range: float,
    trig: tuple[FloatArray, FloatArray] | None = None,
) -> FloatArray:
    res = w.resolution
    field = w.ray_step_flat
    width = w.padded_width
    n = angles.size
    cos, sin = trig if trig is not None else (np.cos(angles), np.sin(angles))
    u0, v0 = w.to_padded_cells(origin_x, origin_y)
    u0f, v0f = float(u0), float(v0)
    max_t = max_range / res
    result = np.full(n, np.inf)
    if not (0 <= u0f < w.padded_width and 0 <= v0f < w.padded_height):
        result[:] = 0.0
        return result
    idx = np.arange(n)
    t = np.zeros(n)
    cs, sn = cos, sin
    hit_idx: list[npt.NDArray[np.intp]] = []
    hit_t: list[FloatArray] = []
    tail = max(_TAIL_BEAMS, n // 8)
    uv = np.full(n, complex(u0f, v0f))
    direction = cs + 1j * sn
    flat = np.empty(n, dtype=np.intp)
    s = np.empty(n, dtype=field.dtype)
    iteration = 0
    while idx.size > tail:
        np.add(uv.imag.astype(np.intp) * width, uv.real.astype(np.intp), out=flat)
        field.take(flat, out=s)
        t += s
        uv += s * direction
        iteration += 1
        if iteration % _COMPACT_EVERY == 0:
            hit = s == 0.0
            done = hit | (t > max_t)
            if np.count_nonzero(done):
                hits = hit & (t <= max_t)
                if np.count_nonzero(hits):
                    hit_idx.append(idx[hits])
                    hit_t.append(t[hits])
                keep = ~done
                idx, t, uv, direction = idx[keep], t[keep], uv[keep], direction[keep]
                flat = np.empty(idx.size, dtype=np.intp)
                s = np.empty(idx.size, dtype=field.dtype)
    cs, sn = direction.real, direction.imag
    offsets = np.arange(_TAIL_CHUNK, dtype=np.float64) * RAY_FINE_STEP
    while idx.size:
        ts = t[:, None] + offsets[None, :]
        flat = (v0f + ts * sn[:, None]).astype(np.intp) * width + (u0f + ts * cs[:, None]).astype(
            np.intp
        )
        s = field.take(flat, mode="clip")
        blocked = s == 0.0
        first = blocked.argmax(axis=1)
        any_blocked = blocked[np.arange(idx.size), first]
        t_hit = ts[np.arange(idx.size), first]
        hits = any_blocked & (t_hit <= max_t)
        if np.count_nonzero(hits):
            hit_idx.append(idx[hits])
            hit_t.append(t_hit[hits])
        t_next = ts[:, -1] + s[:, -1]
        keep = ~any_blocked & (ts[:, -1] <= max_t)
        idx, t, cs, sn = idx[keep], t_next[keep], cs[keep], sn[keep]
    if hit_idx:
        hi = np.concatenate(hit_idx)
        ht = np.concatenate(hit_t)
        result[hi] = numpy_refine(w, u0f, v0f, cos[hi], sin[hi], ht) * res
        result[result > max_range] = np.inf
    return result


def numpy_refine(
    w: World, u0: float, v0: float, cs: FloatArray, sn: FloatArray, t_hit: FloatArray
) -> FloatArray:
    frac = np.arange(1, _REFINE_SAMPLES + 1, dtype=np.float64) / _REFINE_SAMPLES
    t0 = np.maximum(t_hit - RAY_FINE_STEP, 0.0)
    ts = t0[:, None] + (t_hit - t0)[:, None] * frac[None, :]
    u = (u0 + ts * cs[:, None]).astype(np.intp)
    v = (v0 + ts * sn[:, None]).astype(np.intp)
    v *= w.padded_width
    v += u
    blocked = w.ray_step_flat.take(v) == 0.0
    first = blocked.argmax(axis=1)
    refined: FloatArray = ts[np.arange(ts.shape[0]), first]
    return refined


def numpy_cast_circles(
    origin_x: float,
    origin_y: float,
    angles: FloatArray,
    circles: FloatArray,
    increasing: bool | None = None,
    trig: tuple[FloatArray, FloatArray] | None = None,
) -> tuple[FloatArray, npt.NDArray[np.intp]]:
    """Range [m] to the nearest circle along each angle (inf if none) and its index (-1).

    With increasing ``angles`` (a scan's; ``increasing=None`` checks) each circle is
    intersected only with the beams of its angular window (`_angle_window`), with the
    same arithmetic per beam; otherwise with every beam. ``trig``: ``(cos(angles),
    sin(angles))`` if the caller has them.
    """
    n = angles.size
    if circles.size == 0:
        return np.full(n, np.inf), np.full(n, -1, dtype=np.intp)
    dx = circles[:, 0] - origin_x
    dy = circles[:, 1] - origin_y
    c = dx * dx + dy * dy - circles[:, 2] ** 2
    if not (_increasing(angles) if increasing is None else increasing):
        b = np.cos(angles)[:, None] * dx[None, :] + np.sin(angles)[:, None] * dy[None, :]
        disc = b * b - c[None, :]
        with np.errstate(invalid="ignore"):
            t = b - np.sqrt(disc)
        t = np.where((disc >= 0) & (b > 0), np.where(c[None, :] < 0, 0.0, t), np.inf)
        which = t.argmin(axis=1)
        best = t[np.arange(n), which]
        return best, np.where(np.isfinite(best), which, -1)
    cos, sin = trig if trig is not None else (np.cos(angles), np.sin(angles))
    best = np.full(n, np.inf)
    nearest = np.full(n, -1, dtype=np.intp)
    for j in range(circles.shape[0]):
        distance = math.hypot(dx[j], dy[j])
        # Inside the circle every beam ahead hits it at 0; outside, a beam meets it only
        # within asin(r / distance) of the bearing to its centre.
        half = math.pi if c[j] < 0 else math.asin(min(1.0, circles[j, 2] / distance))
        for lo, hi in _angle_window(angles, math.atan2(dy[j], dx[j]), half):
            b = cos[lo:hi] * dx[j] + sin[lo:hi] * dy[j]
            disc = b * b - c[j]
            with np.errstate(invalid="ignore"):
                t = b - np.sqrt(disc)
            t = np.where((disc >= 0) & (b > 0), 0.0 if c[j] < 0 else t, np.inf)
            closer = t < best[lo:hi]  # strict: the first circle wins a tie, as argmin
            best[lo:hi][closer] = t[closer]
            nearest[lo:hi][closer] = j
    return best, nearest


def numpy_cast_glass(
    glass: tuple[tuple[float, float, float, float], ...],
    origin_x: float,
    origin_y: float,
    angles: FloatArray,
    return_angle: float,
    increasing: bool | None = None,
    trig: tuple[FloatArray, FloatArray] | None = None,
) -> FloatArray:
    """Range [m] to the first glass pane that reflects each beam back (inf if none).

    Slab test per axis-aligned pane: entry at ``t = max(t_x, t_y)`` over the near faces;
    the face entered is the one of the larger; it reflects when the beam is within
    ``return_angle`` of that face's normal (``|cos| >= cos(return_angle)``). With
    increasing ``angles`` (``increasing=None`` checks) only the beams within the pane's
    angular extent are tested.
    """
    n = angles.size
    best = np.full(n, np.inf)
    if not glass:
        return best
    cx, cy = trig if trig is not None else (np.cos(angles), np.sin(angles))
    threshold = math.cos(return_angle)
    windowed = _increasing(angles) if increasing is None else increasing
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_x, inv_y = 1.0 / cx, 1.0 / cy
        for x0, y0, x1, y1 in glass:
            windows = [(0, n)]
            if windowed and not (x0 <= origin_x <= x1 and y0 <= origin_y <= y1):
                windows = _box_windows(angles, origin_x, origin_y, (x0, y0, x1, y1))
            for lo, hi in windows:
                ix, iy = inv_x[lo:hi], inv_y[lo:hi]
                tx0, tx1 = (x0 - origin_x) * ix, (x1 - origin_x) * ix
                ty0, ty1 = (y0 - origin_y) * iy, (y1 - origin_y) * iy
                tx_near, tx_far = np.minimum(tx0, tx1), np.maximum(tx0, tx1)
                ty_near, ty_far = np.minimum(ty0, ty1), np.maximum(ty0, ty1)
                t_in = np.fmax(tx_near, ty_near)
                t_out = np.fmin(tx_far, ty_far)
                hit = (t_in <= t_out) & (t_in > 0)
                # Normal of the entered face: x-face if tx_near is the later entry.
                cos_incidence = np.where(tx_near >= ty_near, np.abs(cx[lo:hi]), np.abs(cy[lo:hi]))
                reflect = hit & (cos_incidence >= threshold)
                part = best[lo:hi]
                part[...] = np.where(reflect & (t_in < part), t_in, part)
    return best


# Beam windows: a margin [rad] beyond a target's exact angular extent, far above rounding.
_WINDOW_MARGIN = 1e-6


def _increasing(angles: FloatArray) -> bool:
    """Whether ``angles`` increase strictly (a scan's beams do), so windows can be searched."""
    return angles.size > 1 and bool(np.all(angles[1:] > angles[:-1]))


def _angle_window(angles: FloatArray, bearing: float, half: float) -> list[tuple[int, int]]:
    """Index ranges ``[lo, hi)`` of the increasing ``angles`` within ``half`` (+ a margin) of
    ``bearing``, modulo a full turn."""
    half += _WINDOW_MARGIN
    if half >= math.pi:
        return [(0, angles.size)]
    first = float(angles[0]) - half
    centre = first + (bearing - first) % (2.0 * math.pi)  # the first turn at or after `first`
    windows = []
    while centre - half <= angles[-1]:
        lo = int(angles.searchsorted(centre - half, side="left"))
        hi = int(angles.searchsorted(centre + half, side="right"))
        if hi > lo:
            windows.append((lo, hi))
        centre += 2.0 * math.pi
    return windows


def _box_windows(
    angles: FloatArray, x: float, y: float, box: tuple[float, float, float, float]
) -> list[tuple[int, int]]:
    """`_angle_window` of the beams from (x, y), outside the box, that can meet the box: its
    corners span less than half a turn, around the bearing of its centre."""
    x0, y0, x1, y1 = box
    mid = math.atan2((y0 + y1) / 2 - y, (x0 + x1) / 2 - x)
    half = max(
        abs(math.remainder(math.atan2(cy - y, cx - x) - mid, 2.0 * math.pi))
        for cx in (x0, x1)
        for cy in (y0, y1)
    )
    return _angle_window(angles, mid, half)


def numpy_cast(
    world: World,
    origin_x: float,
    origin_y: float,
    angles: FloatArray,
    max_range: float,
    circles: FloatArray | None = None,
    glass_return_angle: float = 0.0,
) -> FloatArray:
    """``RayCaster.cast`` of session 12 (without its cache of the last walls)."""
    trig = (np.cos(angles), np.sin(angles))
    ranges = numpy_cast_walls(world, origin_x, origin_y, angles, max_range, trig)
    if world.glass:
        pane = numpy_cast_glass(
            world.glass, origin_x, origin_y, angles, glass_return_angle, True, trig
        )
        ranges = np.minimum(ranges, np.where(pane <= max_range, pane, np.inf))
    if circles is not None and circles.size:
        people, _ = numpy_cast_circles(origin_x, origin_y, angles, circles, True, trig)
        ranges = np.minimum(ranges, np.where(people <= max_range, people, np.inf))
    return ranges
