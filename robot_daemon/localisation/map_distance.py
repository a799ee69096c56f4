"""A scan's end points in the map frame and their distance to the map's surfaces, compiled.

The localiser's confidence is the fraction of a scan's end points within ``hit_tolerance_m`` of
an occupied map cell, and its map update looks at the end points farther than
``unexplained_m`` (`Localiser._hit_fraction`, `Localiser._update_map`): both read the distance
transform of the map (Felzenszwalb and Huttenlocher, "Distance transforms of sampled
functions", Theory of Computing 8, 2012, as `scipy.ndimage.distance_transform_edt` computes
it) at the cell of each end point::

    x = p_x + cos ψ · s_x - sin ψ · s_y,   y = p_y + sin ψ · s_x + cos ψ · s_y
    d = D[⌊(y - y0) / res⌋, ⌊(x - x0) / res⌋]   (inf off the map)

One loop over the points (`robot_daemon.jit`) with the operations of the numpy code it replaced
(`Localiser._to_map` and `Localiser._distance_to_map`), in their order: every coordinate and
distance equals it bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from robot_daemon import jit

FloatArray = npt.NDArray[np.float64]


@jit.kernel
def end_points_on_map(
    points: FloatArray,
    pose: tuple[float, float],
    cos_sin: tuple[float, float],
    distance: FloatArray,
    grid: tuple[float, float, float],
    size: tuple[int, int],
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The map-frame ``x``, ``y`` of the sensor-frame end points ``points`` ((N, 2),
    C-contiguous) of a laser at ``pose`` (x, y) with heading ``cos_sin``, and their distance
    [m] to the map (inf off it).

    ``distance``: the distance field with a border of inf cells, flat row-major
    (`localiser._padded_distance`); ``grid``: the map's origin x, y and resolution [m];
    ``size``: its width and height in cells (without the border). A point off the map reads
    the border: its column and row are clipped to -1 .. width and -1 .. height."""
    c, s = cos_sin
    ox, oy, resolution = grid
    width, height = size
    n = points.shape[0]
    xs, ys, out = np.empty(n), np.empty(n), np.empty(n)
    for k in range(n):
        sx, sy = points[k, 0], points[k, 1]
        x = pose[0] + c * sx - s * sy
        y = pose[1] + s * sx + c * sy
        col = min(max(math.floor((x - ox) / resolution), -1), width)
        row = min(max(math.floor((y - oy) / resolution), -1), height)
        xs[k], ys[k] = x, y
        out[k] = distance[(row + 1) * (width + 2) + col + 1]
    return xs, ys, out


@jit.on_warm_up("localiser's map distance")
def _warm_up() -> None:
    """`end_points_on_map` with the types `Localiser` passes."""
    distance = np.full(5 * 5, np.inf)
    end_points_on_map(np.zeros((2, 2)), (0.0, 0.0), (1.0, 0.0), distance, (0.0, 0.0, 0.05), (3, 3))
