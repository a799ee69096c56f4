"""The simulated laser's wall caster as numpy code: the reference for the compiled one.

``numpy_cast_walls`` and ``numpy_refine`` are ``RayCaster.cast_walls`` and ``RayCaster._refine``
of session 12 (before `robot_daemon/sim/sphere_tracing.py`), verbatim but for taking the world
as an argument: sphere tracing of all beams in numpy passes (positions as complex numbers, one
pass moves both coordinates), finished beams dropped every third pass, the last few grazing
beams marched in chunks of fine samples, each hit refined within its last fine step.
"""

from __future__ import annotations

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
