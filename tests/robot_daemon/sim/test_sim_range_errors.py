"""The compiled UTM-30LX error model (`robot_daemon/sim/range_errors.py`) gives the numpy
version's scans bit for bit and draws the same random numbers.

``NumpyLaserSim`` is ``LaserSim`` with session 12's ``_mix_pixels`` and ``scan`` (verbatim): the
reference. Both simulators get the same noise-free ranges (crafted: spikes whose two pairs share
a beam, runs of jumps, infinities, ranges beyond the limits; or cast in the office) and the same
seed; their scans and their generators' states afterwards must be equal.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from robot_daemon import jit
from robot_daemon.sim import range_errors
from robot_daemon.sim.laser_sim import LaserConfig, LaserSim, RayCaster
from tests.robot_daemon.sim.test_sim_speed_equivalence import WORLD, _poses

FloatArray = npt.NDArray[np.float64]


class NumpyLaserSim(LaserSim):
    """``LaserSim`` with the error model as numpy passes (session 12)."""

    def _mix_pixels(self, ranges: FloatArray) -> None:
        c = self.config
        a, b = ranges[:-1], ranges[1:]
        finite = np.isfinite(a) & np.isfinite(b)
        with np.errstate(invalid="ignore"):
            jump = finite & (np.abs(a - b) > c.mixed_pixel_jump)
        pairs = np.flatnonzero(jump)
        if pairs.size == 0:
            return
        chosen = pairs[self._rng.random(pairs.size) < c.mixed_pixel_probability]
        if chosen.size == 0:
            return
        near = np.minimum(ranges[chosen], ranges[chosen + 1])
        far = np.maximum(ranges[chosen], ranges[chosen + 1])
        farther = np.where(ranges[chosen] > ranges[chosen + 1], chosen, chosen + 1)
        ranges[farther] = near + self._rng.random(chosen.size) * (far - near)

    def scan(
        self, robot_pose: Pose2D, stamp: float, circles: FloatArray | None = None
    ) -> LaserScan:
        c = self.config
        sensor = robot_pose.compose(c.mount)
        true = self.caster.cast(
            sensor.x,
            sensor.y,
            self._beam_angles + sensor.yaw,
            c.range_max,
            circles,
            c.glass_return_angle,
        )
        ranges = true.copy()
        if c.mixed_pixel_probability > 0:
            self._mix_pixels(ranges)
        finite = np.isfinite(ranges)
        if c.noise_sigma > 0:
            ranges[finite] += self._rng.normal(0.0, c.noise_sigma, int(finite.sum()))
        if c.bias_sigma > 0:
            ranges[finite] += self._advance_bias(stamp)
        if c.dropout_probability > 0 or c.far_dropout_per_m > 0:
            p = c.dropout_probability + c.far_dropout_per_m * np.where(finite, ranges, 0.0)
            ranges[finite & (self._rng.random(ranges.size) < p)] = np.inf
        ranges[finite & (ranges > c.range_max)] = np.inf
        ranges[finite & (ranges < c.range_min)] = -np.inf
        return LaserScan(
            stamp=stamp,
            angle_min=c.angle_min,
            angle_increment=c.angle_increment,
            range_min=c.range_min,
            range_max=c.range_max,
            ranges=ranges.astype(np.float32),
        )


class GivenRanges(RayCaster):
    """A caster that returns the given noise-free ranges, one array per cast."""

    def __init__(self, ranges: list[FloatArray]) -> None:
        super().__init__(WORLD)
        self._ranges = iter(ranges)

    def cast(self, *args: object, **kwargs: object) -> FloatArray:
        return next(self._ranges).copy()


def _crafted(rng: np.random.Generator, beams: int) -> FloatArray:
    """Noise-free ranges with everything the error model treats apart."""
    ranges = rng.uniform(0.0, 32.0, beams)
    steps = rng.random(beams) < 0.2  # runs of discontinuities
    ranges[steps] = rng.uniform(0.0, 32.0, int(steps.sum()))
    spikes = rng.integers(1, beams - 1, beams // 20)  # a beam farther than both neighbours
    ranges[spikes] = ranges[spikes - 1] + rng.uniform(0.5, 5.0, spikes.size)
    ranges[spikes + 1] = ranges[spikes - 1]
    ranges[rng.random(beams) < 0.05] = np.inf
    ranges[rng.random(beams) < 0.01] = 0.0  # a cast from outside the map
    ranges[rng.random(beams) < 0.02] = rng.uniform(0.0, 0.1)  # below range_min
    return ranges


def _configs(rng: np.random.Generator) -> list[LaserConfig]:
    return [
        LaserConfig.realistic(),
        LaserConfig(),
        LaserConfig(noise_sigma=0.0),
        LaserConfig(
            noise_sigma=float(rng.uniform(0.0, 0.1)),
            bias_sigma=float(rng.uniform(0.0, 0.05)),
            dropout_probability=float(rng.uniform(0.0, 0.3)),
            far_dropout_per_m=float(rng.uniform(0.0, 0.05)),
            mixed_pixel_probability=float(rng.uniform(0.0, 1.0)),
            mixed_pixel_jump=float(rng.uniform(0.05, 2.0)),
        ),
        LaserConfig(mixed_pixel_probability=1.0, mixed_pixel_jump=0.1, far_dropout_per_m=0.01),
    ]


def _assert_same_scans(config: LaserConfig, truths: list[FloatArray], seed: int) -> None:
    fast = LaserSim(WORLD, config, np.random.default_rng(seed))
    ref = NumpyLaserSim(WORLD, config, np.random.default_rng(seed))
    fast.caster, ref.caster = GivenRanges(truths), GivenRanges(truths)
    for k in range(len(truths)):
        a = fast.scan(Pose2D(0.0, 0.0, 0.0), 0.025 * k)
        b = ref.scan(Pose2D(0.0, 0.0, 0.0), 0.025 * k)
        assert a.ranges.dtype == b.ranges.dtype == np.float32
        assert np.array_equal(a.ranges, b.ranges), (config, k)
    assert fast._rng.bit_generator.state == ref._rng.bit_generator.state


def test_crafted_ranges_give_the_numpy_scans() -> None:
    rng = np.random.default_rng(31)
    for seed in range(12):
        truths = [_crafted(rng, int(rng.choice([1081, 40, 3]))) for _ in range(25)]
        for config in _configs(rng):
            _assert_same_scans(config, truths, seed)


def test_cast_ranges_give_the_numpy_scans() -> None:
    rng = np.random.default_rng(32)
    caster = RayCaster(WORLD)
    beams = LaserConfig().beam_angles()
    truths = [caster.cast(x, y, beams + yaw, 30.0, None, 0.17) for x, y, yaw in _poses(rng, 80)]
    for seed, config in enumerate(_configs(rng)):
        _assert_same_scans(config, truths, seed)


def test_compiled_equals_its_plain_python_functions() -> None:
    rng = np.random.default_rng(33)
    for _ in range(20):
        ranges = _crafted(rng, 1081)
        results = []
        for kernels in (
            (range_errors.jump_pairs, range_errors.mix_pairs, range_errors.apply_errors),
            tuple(
                jit.python_function(k)
                for k in (
                    range_errors.jump_pairs,
                    range_errors.mix_pairs,
                    range_errors.apply_errors,
                )
            ),
        ):
            jump_pairs, mix_pairs, apply_errors = kernels
            mixed = ranges.copy()
            pairs = np.empty(mixed.size, dtype=np.intp)
            count = jump_pairs(mixed, 0.3, pairs)
            mix_pairs(mixed, pairs[:count], np.linspace(0.0, 1.0, count))
            finite = int(np.count_nonzero(np.isfinite(mixed)))
            out = np.empty(mixed.size, dtype=np.float32)
            noise = np.linspace(-0.05, 0.05, finite)
            uniform = np.linspace(0.0, 0.2, mixed.size)
            apply_errors(mixed, noise, 0.01, True, 0.01, 0.002, uniform, 0.1, 30.0, out)
            results.append((count, pairs[:count], mixed, out))
        (c1, p1, m1, o1), (c2, p2, m2, o2) = results
        assert c1 == c2 and np.array_equal(p1, p2)
        assert np.array_equal(m1, m2) and np.array_equal(o1, o2)
