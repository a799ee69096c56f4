"""The simulated UTM-30LX's range errors applied beam by beam, compiled (`laser_sim`'s model).

The error model (``LaserConfig.realistic``; Pomerleau et al. 2012, Okubo et al. 2009; see
`laser_sim`) on a scan's noise-free ranges ``r``, in this order:

1. mixed pixels: each neighbour pair ``(i, i + 1)`` of finite ranges differing by more than
   ``mixed_pixel_jump`` is a candidate (`jump_pairs`); the candidates the caller draws (with
   ``mixed_pixel_probability``) get, at the farther beam of the pair, ``near + u (far -
   near)`` with ``u`` uniform, every pair's values taken before any is written (`mix_pairs`);
2. noise and bias on every finite range, ``r + n_k`` then ``+ b`` (`apply_errors`);
3. dropouts: a finite beam with ``u_i < p_0 + p_m r`` returns ``+inf``;
4. REP-117: a finite range above ``range_max`` is ``+inf``, below ``range_min`` ``-inf``;

then float32, the ``LaserScan`` message's type. The random numbers (``numpy.random.Generator``
draws, in the order and sizes the numpy version drew them) come from the caller: the kernels
replace only numpy's passes over the beams, with the same float64 operations in the same order,
so a seed gives the same scans bit for bit (``tests/robot_daemon/sim/test_sim_range_errors.py``
keeps the numpy version).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from robot_daemon import jit

FloatArray = npt.NDArray[np.float64]
IndexArray = npt.NDArray[np.intp]


@jit.kernel
def jump_pairs(ranges: FloatArray, jump: float, pairs: IndexArray) -> int:
    """Indices ``i`` with ``ranges[i]`` and ``ranges[i + 1]`` finite and more than ``jump``
    apart, ascending, into ``pairs`` (size ``ranges.size - 1`` or more); how many."""
    count = 0
    for i in range(ranges.size - 1):
        a, b = ranges[i], ranges[i + 1]
        if math.isfinite(a) and math.isfinite(b) and abs(a - b) > jump:
            pairs[count] = i
            count += 1
    return count


@jit.kernel
def mix_pairs(ranges: FloatArray, chosen: IndexArray, uniform: FloatArray) -> None:
    """The farther beam of each pair ``(chosen[k], chosen[k] + 1)`` gets ``near + uniform[k] *
    (far - near)``; all values from ``ranges`` as they were (a later pair wins a shared beam)."""
    values = np.empty(chosen.size)
    farther = np.empty(chosen.size, dtype=np.intp)
    for k in range(chosen.size):
        i = chosen[k]
        a, b = ranges[i], ranges[i + 1]
        near, far = (b, a) if a > b else (a, b)
        farther[k] = i if a > b else i + 1
        values[k] = near + uniform[k] * (far - near)
    for k in range(chosen.size):
        ranges[farther[k]] = values[k]


@jit.kernel
def apply_errors(
    ranges: FloatArray,
    noise: FloatArray,
    bias: float,
    dropout: bool,
    dropout_probability: float,
    far_dropout_per_m: float,
    uniform: FloatArray,
    range_min: float,
    range_max: float,
    out: npt.NDArray[np.float32],
) -> None:
    """Steps 2-4 of the module docstring into ``out`` (float32): ``noise`` holds one draw per
    finite range in order (empty: no noise), ``bias`` is added where not 0, and with
    ``dropout`` a beam drops where ``uniform[i] < dropout_probability + far_dropout_per_m r``."""
    k = 0
    for i in range(ranges.size):
        r = ranges[i]
        if math.isfinite(r):
            if noise.size:
                r += noise[k]
                k += 1
            if bias != 0.0:
                r += bias
            if dropout and uniform[i] < dropout_probability + far_dropout_per_m * r:
                r = np.inf
            if r > range_max:
                r = np.inf
            elif r < range_min:
                r = -np.inf
        out[i] = r


@jit.on_warm_up("robot_daemon.sim.range_errors")
def _warm_up() -> None:
    """The kernels with the argument types `LaserSim.scan` passes."""
    ranges = np.array([1.0, 2.0, np.inf, 2.5, 0.05])
    pairs = np.empty(ranges.size, dtype=np.intp)
    count = jump_pairs(ranges, 0.3, pairs)
    mix_pairs(ranges, pairs[:count], np.full(count, 0.5))
    out = np.empty(ranges.size, dtype=np.float32)
    apply_errors(ranges, np.zeros(4), 0.01, True, 0.01, 0.002, np.ones(5), 0.1, 30.0, out)
