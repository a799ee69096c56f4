"""The simulated laser's wall ranges: sphere tracing on the world's safe-step field, compiled.

Sphere tracing (Hart, "Sphere tracing", The Visual Computer 12(10), 1996) on the grid of
``World.ray_step_flat`` (padded cells, row-major; each free cell holds a safe step [cells], the
distance to the nearest blocked cell minus sqrt(2) or half a cell when that is smaller, and a
blocked cell holds exactly 0). A beam from ``(u0, v0)`` [cells] along ``(c, s)`` advances

    t_{k+1} = t_k + step(cell(u_k, v_k)),   u_{k+1} = u_k + step c,   v_{k+1} = v_k + step s,

until its cell is blocked (its step is 0, so it stays put) or ``t > max_t``. Cells are
``(int(v), int(u))``: truncation, as ``ndarray.astype(np.intp)``.

The schedule is the one the simulator's numpy caster had (session 12), kept exactly because the
two phases round differently (phase 1 accumulates ``u_k``; phase 2 recomputes ``u0 + t c``), so
*which* beams reach phase 2, and at which ``t``, decides the last bits of their ranges:

1. All beams step in lockstep. Every ``_COMPACT_EVERY``-th step, beams whose cell is blocked
   (a hit at ``t`` if ``t <= max_t``) or that are past ``max_t`` leave; phase 1 runs while more
   than ``max(_TAIL_BEAMS, n // 8)`` beams are left, a test made after each such removal.
2. The beams left (grazing a wall, or far from any) march in chunks of ``_TAIL_CHUNK`` samples
   ``t + j * RAY_FINE_STEP`` (cells clipped to the grid, as ``ndarray.take(mode="clip")``): the
   first blocked sample is the hit (if ``<= max_t``); with none, the beam goes on from the
   chunk's last sample plus its safe step while that sample is ``<= max_t``.

A hit at ``t_hit`` is refined by sampling ``t0 + (t_hit - t0) k / _REFINE_SAMPLES``, ``k = 1 ..
_REFINE_SAMPLES``, ``t0 = max(t_hit - RAY_FINE_STEP, 0)``: the first blocked sample is the range
(the first sample when, by rounding, none is). Range [m] = refined ``t`` times the resolution,
``+inf`` beyond ``max_range``.

Every operation is the numpy caster's, in its order, on float64 (the float32 steps widen
exactly), so the ranges are the same bit for bit (``tests/robot_daemon/sim/
test_sim_sphere_tracing.py`` keeps the numpy caster as the reference).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from robot_daemon import jit
from robot_daemon.sim.world import RAY_FINE_STEP

FloatArray = npt.NDArray[np.float64]
StepArray = npt.NDArray[np.float32]

_REFINE_SAMPLES = 5  # samples of the last fine step when refining a hit
_TAIL_BEAMS = 64  # below this many active beams (or n // 8), phase 2
_COMPACT_EVERY = 3  # phase-1 steps between removals of finished beams
_TAIL_CHUNK = 96  # fine samples per beam per chunk in phase 2
_NO_HIT = -1.0  # t_hit of a beam that met nothing within max_t (t is never negative)


@jit.kernel
def wall_ranges(
    field: StepArray,
    width: int,
    u0: float,
    v0: float,
    cos: FloatArray,
    sin: FloatArray,
    max_t: float,
    resolution: float,
    max_range: float,
    ranges: FloatArray,
) -> None:
    """Range [m] to the first blocked cell along each beam ``(cos[i], sin[i])`` from ``(u0,
    v0)`` [padded cells] into ``ranges`` (``+inf`` if none within ``max_range``).

    ``field``: ``World.ray_step_flat`` (float32, C order), rows of ``width`` cells; ``max_t``:
    ``max_range / resolution`` [cells]. The origin must lie inside the grid.
    """
    n = cos.size
    last_cell = field.size - 1
    t_hit = np.full(n, _NO_HIT)
    # Phase 1: the working set, compacted every _COMPACT_EVERY steps (beam, t, u, v, c, s).
    beam = np.arange(n)
    t = np.zeros(n)
    u = np.full(n, u0)
    v = np.full(n, v0)
    c = cos.copy()
    s = sin.copy()
    step = np.zeros(n)
    active = n
    tail = max(_TAIL_BEAMS, n // 8)
    iteration = 0
    while active > tail:
        for k in range(active):
            cell = min(max(int(v[k]) * width + int(u[k]), 0), last_cell)
            step[k] = float(field[cell])
            t[k] += step[k]
            u[k] += step[k] * c[k]
            v[k] += step[k] * s[k]
        iteration += 1
        if iteration % _COMPACT_EVERY == 0:
            kept = 0
            for k in range(active):
                blocked = step[k] == 0.0
                if blocked or t[k] > max_t:
                    if blocked and t[k] <= max_t:
                        t_hit[beam[k]] = t[k]
                    continue
                beam[kept], t[kept], u[kept], v[kept] = beam[k], t[k], u[k], v[k]
                c[kept], s[kept] = c[k], s[k]
                kept += 1
            active = kept
    # Phase 2: each beam left marches in chunks of fine samples from u0 + t c, v0 + t s.
    for k in range(active):
        t_start = t[k]
        while True:
            last_t = t_start
            last_step = 0.0
            blocked = False
            for j in range(_TAIL_CHUNK):
                sample = t_start + float(j) * RAY_FINE_STEP
                cell = int(v0 + sample * s[k]) * width + int(u0 + sample * c[k])
                last_step = float(field[min(max(cell, 0), last_cell)])
                last_t = sample
                if last_step == 0.0:
                    blocked = True
                    if sample <= max_t:
                        t_hit[beam[k]] = sample
                    break
            if blocked or not last_t <= max_t:
                break
            t_start = last_t + last_step
    # Refinement of each hit within its last fine step, then metres.
    for i in range(n):
        ranges[i] = np.inf
        if t_hit[i] == _NO_HIT:
            continue
        t0 = max(t_hit[i] - RAY_FINE_STEP, 0.0)
        span = t_hit[i] - t0
        refined = t0 + span * (1.0 / _REFINE_SAMPLES)  # argmax of no blocked sample: the first
        for k in range(1, _REFINE_SAMPLES + 1):
            sample = t0 + span * (float(k) / _REFINE_SAMPLES)
            cell = int(v0 + sample * sin[i]) * width + int(u0 + sample * cos[i])
            if field[min(max(cell, 0), last_cell)] == 0.0:
                refined = sample
                break
        metres = refined * resolution
        if not metres > max_range:
            ranges[i] = metres


@jit.on_warm_up("robot_daemon.sim.sphere_tracing")
def _warm_up() -> None:
    """`wall_ranges` with the argument types `RayCaster.cast_walls` passes: a 3 x 3 room."""
    field = np.zeros(9, dtype=np.float32)
    field[4] = RAY_FINE_STEP
    angles = np.linspace(-1.0, 1.0, 200)
    ranges = np.empty(angles.size)
    wall_ranges(field, 3, 1.5, 1.5, np.cos(angles), np.sin(angles), 10.0, 0.05, 0.5, ranges)
