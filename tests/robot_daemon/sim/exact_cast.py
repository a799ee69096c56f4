"""A plain, readable reference for the simulated laser: one beam, one cell at a time.

Amanatides & Woo's grid traversal ("A fast voxel traversal algorithm", 1987): from the origin,
step into whichever neighbouring cell the beam reaches first, until a blocked one. The range is
the distance at which the beam enters that cell, so a beam that clips a corner by a hair hits it
(a march in fixed steps, however fine, can step over such a corner: the simulator's caster, which
steps half a cell near walls, may pass a corner it clips by less than that; `exact_hit` gives
the chord so a test can tell that documented case from a real miss).
"""

from __future__ import annotations

import math

from robot_daemon.sim.world import World


def exact_cast(world: World, x: float, y: float, angle: float, max_range: float) -> float:
    """Distance [m] from (x, y) along ``angle`` to the first blocked cell; inf beyond range."""
    return exact_hit(world, x, y, angle, max_range)[0]


def exact_hit(
    world: World, x: float, y: float, angle: float, max_range: float
) -> tuple[float, float]:
    """(range, chord) [m]: where the beam enters the first blocked cell, and the length of its
    path through that cell (small where it only clips a corner); (inf, 0) beyond range."""
    res = world.resolution
    u0, v0 = (float(c) for c in world.to_padded_cells(x, y))
    cu, cv = math.floor(u0), math.floor(v0)
    dx, dy = math.cos(angle), math.sin(angle)
    step_u, step_v = (1 if dx > 0 else -1), (1 if dy > 0 else -1)
    t_u = ((cu + (dx > 0)) - u0) / dx if dx != 0 else math.inf  # [cells] to the next x boundary
    t_v = ((cv + (dy > 0)) - v0) / dy if dy != 0 else math.inf
    per_u = abs(1 / dx) if dx != 0 else math.inf
    per_v = abs(1 / dy) if dy != 0 else math.inf
    t = 0.0
    while t * res <= max_range:
        if world.blocked_padded[cv, cu]:
            return t * res, (min(t_u, t_v) - t) * res
        if t_u < t_v:
            t, cu, t_u = t_u, cu + step_u, t_u + per_u
        else:
            t, cv, t_v = t_v, cv + step_v, t_v + per_v
    return math.inf, 0.0
