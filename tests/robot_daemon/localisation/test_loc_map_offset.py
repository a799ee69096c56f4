"""The robot's position in the building beside its pose on the map (`map_offset`, issue 12: a
room that stands off its map fits the scans perfectly off the robot's true position; the
odometry, tied across its door, tells the two apart)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from interbot_core.geometry import Pose2D
from robot_daemon.localisation import Localiser, LocaliserConfig, LocaliserState
from robot_daemon.localisation.map_offset import MapOffset, MapOffsetConfig, MapOffsetConfigError
from tests.robot_daemon.localisation.synthetic_office import OFFICE_BOXES, rasterise, utm_scan

ON = MapOffsetConfig(enabled=True)  # the default (`map_offset`'s docstring)
SIGMA_B = 0.035  # [m] the map's offset per axis (the realistic world's rooms)
STEP = 0.05  # [m] travel between scans
ROOM = (6.0, 10.0)  # [m] x range of the stretch whose walls stand off the map (of 16 m)
ROOM_OFFSET = np.array([0.05, -0.04])  # [m] map pose - true position there


def _offset_at(x: float) -> np.ndarray:
    return ROOM_OFFSET if ROOM[0] <= x < ROOM[1] else np.zeros(2)


def _drive(
    offset_at: object, laps: int = 3, seed: int = 2, scale: float = 1.03, odom_noise: float = 0.003
) -> tuple[np.ndarray, np.ndarray, np.ndarray, MapOffset]:
    """Back and forth along x from 0 to 16 m, ``laps`` times; the odometry measures ``scale``
    times the true travel (3 %, the simulator's wheels) with 3 mm per sqrt(m) of noise; each scan
    fixes the map pose at the truth plus the map's offset there plus 3 mm of noise. Returns the
    true x, the map pose's and the reported building position's errors (last lap only) and the
    filter."""
    rng = np.random.default_rng(seed)
    xs = np.arange(0.0, 16.0 + 1e-9, STEP)
    there = [Pose2D(float(x), 0.0, 0.0) for x in xs]
    back = [Pose2D(float(x), 0.0, math.pi) for x in xs[::-1]]  # a turn in place at the end
    path = (there + back) * laps
    offset = MapOffset(ON)
    true_x, map_err, building_err = [], [], []
    last = len(path) - 2 * len(xs)
    for i, truth in enumerate(path):
        x = truth.x
        b = offset_at(x)  # type: ignore[operator]
        noise = rng.normal(0.0, 0.003, 2)
        map_pose = Pose2D(x + b[0] + noise[0], b[1] + noise[1], truth.yaw)
        if i == 0:
            offset.step(Pose2D(0.0, 0.0, 0.0), map_pose, True, SIGMA_B)
            continue
        step = truth.relative_to(path[i - 1])
        moved = math.hypot(step.x, step.y)
        along = scale * step.x + rng.normal(0.0, odom_noise * math.sqrt(moved))
        offset.step(Pose2D(along, scale * step.y, step.yaw), map_pose, True, SIGMA_B)
        if i >= last:
            position = offset.building_position(map_pose)
            assert position is not None
            true_x.append(x)
            map_err.append(math.hypot(map_pose.x - x, map_pose.y))
            building_err.append(math.hypot(position[0] - x, position[1]))
    return np.array(true_x), np.array(map_err), np.array(building_err), offset


def _rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(a**2)))


def test_a_room_off_its_map_is_told_apart_by_the_odometry() -> None:
    """A drawn map: the map pose is 6.4 cm off throughout a 4 m room on a 16 m stretch; the
    building position follows the odometry in from the corridor and is off by less there. The
    filter believes the map right on average, so it pays a little in the corridor."""
    x, map_err, building_err, offset = _drive(_offset_at)
    room = (x >= ROOM[0]) & (x < ROOM[1])
    assert _rms(map_err[room]) > 0.06
    assert _rms(building_err[room]) < 0.8 * _rms(map_err[room])
    assert _rms(building_err[~room]) < 0.02
    assert offset.scale == pytest.approx(1.0 / 1.03, abs=0.003)  # learnt the wheels' scale
    assert offset.estimating
    # started once, and once more when the walk was learnt (`MapOffset.estimating`)
    assert offset.resets == 2


def test_where_the_building_is_its_map_the_building_position_is_the_map_pose() -> None:
    _, map_err, building_err, _ = _drive(lambda _: np.zeros(2))
    assert _rms(building_err) < 0.01
    assert _rms(building_err) < 2.0 * _rms(map_err) + 0.002


def test_the_odometry_walk_is_learnt_from_short_windows() -> None:
    """3 mm per sqrt(m) of odometry noise against 3 cm (the real logs' replay on Freiburg 079):
    the walk the prediction uses follows, from the 1 cm prior (measured: 0.5 and 1.9 cm)."""
    *_, quiet = _drive(lambda _: np.zeros(2))
    *_, noisy = _drive(lambda _: np.zeros(2), odom_noise=0.03)
    assert quiet.walk_windows > 40 and noisy.walk_windows > 40
    assert quiet.odometry_walk_m < 0.008
    assert noisy.odometry_walk_m > 0.015


def test_no_position_until_a_scan_fixes_the_pose_after_a_set_pose() -> None:
    offset = MapOffset(ON)
    guess = Pose2D(1.0, 2.0, 0.3)
    assert offset.position() is None and offset.offset is None
    offset.step(Pose2D(0.1, 0.0, 0.0), guess, False, SIGMA_B)  # not fused: nothing yet
    assert offset.position() is None
    offset.step(Pose2D(0.1, 0.0, 0.0), guess, True, SIGMA_B)
    assert offset.position() == pytest.approx((1.0, 2.0))
    assert offset.offset == (0.0, 0.0)
    offset.restart()  # a person sets the pose again: their guess is no offset of the map
    assert offset.position() is None
    offset.step(Pose2D(0.0, 0.0, 0.0), Pose2D(5.0, 5.0, 0.0), True, SIGMA_B)
    assert offset.position() == pytest.approx((5.0, 5.0))


def test_a_jump_of_the_map_pose_starts_again_there() -> None:
    """A map pose the filter cannot explain (a 0.3 m jump: a look-alike, a new branch) is not
    an offset of the map: the building position starts again at the new map pose."""
    offset = MapOffset(ON)
    for i in range(40):
        offset.step(Pose2D(STEP, 0.0, 0.0), Pose2D(i * STEP, 0.0, 0.0), True, SIGMA_B)
    resets = offset.resets
    offset.step(Pose2D(STEP, 0.0, 0.0), Pose2D(40 * STEP, 0.3, 0.0), True, SIGMA_B)
    assert offset.resets == resets + 1
    assert offset.position() == pytest.approx((40 * STEP, 0.3))
    assert offset.offset == (0.0, 0.0)


def test_the_building_position_stays_within_its_bound_of_the_map_pose() -> None:
    """However the map pose wanders (here a slow 1 cm per scan walk, which the gate lets
    through), the building position is never farther from it than ``max_offset_m``."""
    cfg = MapOffsetConfig(enabled=True, max_offset_m=0.05)
    offset = MapOffset(cfg)
    rng = np.random.default_rng(7)
    y = 0.0
    for i in range(400):
        y += float(rng.choice([-1.0, 1.0])) * 0.01
        map_pose = Pose2D(i * STEP, y, 0.0)
        offset.step(Pose2D(STEP, 0.0, 0.0), map_pose, True, SIGMA_B)
        position = offset.position()
        assert position is not None
        assert math.hypot(position[0] - map_pose.x, position[1] - map_pose.y) <= 0.05 + 1e-12


def test_no_offset_until_the_odometry_walk_is_learnt() -> None:
    """For the first ``walk_prior_windows`` metres of fused travel the filter does not know
    its odometry's error, so it estimates no offset: the building position is the map pose
    itself, and so is its covariance; from there it estimates, its offset's prior the floor."""
    offset = MapOffset(ON)
    map_cov = np.diag([0.02**2 + SIGMA_B**2, 0.02**2 + SIGMA_B**2])
    rng = np.random.default_rng(4)
    for i in range(400):  # 20 m
        map_pose = Pose2D(i * STEP + float(rng.normal(0.0, 0.01)), 0.03, 0.0)
        offset.step(Pose2D(STEP, 0.0, 0.0), map_pose, True, SIGMA_B)
        position = offset.building_position(map_pose)
        assert position is not None
        if offset.walk_windows < ON.walk_prior_windows:
            assert not offset.estimating
            assert position == (map_pose.x, map_pose.y)
            assert np.array_equal(offset.building_covariance(map_cov, SIGMA_B), map_cov)
    assert offset.estimating
    cov = offset.building_covariance(map_cov, SIGMA_B)
    # the offset's posterior in the floor's place: between the map filter's own and the map's
    assert np.all(np.linalg.eigvalsh(map_cov - cov) >= 0.0)
    assert np.all(np.linalg.eigvalsh(cov - (map_cov - SIGMA_B**2 * np.eye(2))) > 0.0)


def test_on_by_default_and_when_off_it_never_starts() -> None:
    assert MapOffsetConfig().enabled
    offset = MapOffset(MapOffsetConfig(enabled=False))
    offset.step(Pose2D(0.1, 0.0, 0.0), Pose2D(1.0, 0.0, 0.0), True, SIGMA_B)
    assert offset.position() is None
    assert offset.building_position(Pose2D(1.0, 0.0, 0.0)) is None


@pytest.mark.parametrize(
    ("field", "value"),
    [("correlation_m", 0.0), ("odom_walk_m", -0.01), ("max_offset_m", 2.0), ("gate_chi2", 0.5)],
)
def test_bad_settings_are_refused_by_name(field: str, value: float) -> None:
    with pytest.raises(MapOffsetConfigError, match=field):
        MapOffsetConfig(**{field: value})  # type: ignore[arg-type]


# ------------------------------------------------------------------ in the localiser


def _localise(config: LocaliserConfig, scans: int = 60) -> Localiser:
    """Along the synthetic office's hall at 1 m/s, 5 scans a second, exact odometry."""
    rng = np.random.default_rng(3)
    loc = Localiser(rasterise(OFFICE_BOXES), config)
    odom = Pose2D(0.0, 0.0, 0.0)
    loc.on_odometry(odom, 0.0)
    start = Pose2D(2.0, 4.0, 0.0)
    assert loc.building_pose is None  # unset
    loc.set_initial_pose(start, 0.0)
    assert loc.building_pose == loc.pose  # a person's guess: no building position yet
    truth = start
    for k in range(1, scans):
        now = k / 5.0
        truth = Pose2D(2.0 + 0.2 * k, 4.0, 0.0)
        odom = odom.compose(Pose2D(0.2, 0.0, 0.0))
        loc.on_odometry(odom, now)
        est = loc.on_scan(utm_scan(OFFICE_BOXES, truth, now, rng), now)
        assert est.state is LocaliserState.OK
    return loc


def test_the_localiser_reports_a_building_pose_near_its_map_pose() -> None:
    """Estimating from the first scan (no walk to learn first, so 12 m show it)."""
    eager = MapOffsetConfig(walk_prior_windows=0.0)
    loc = _localise(LocaliserConfig(map_update=False, map_offset=eager), scans=60)
    pose, building = loc.pose, loc.building_pose
    assert pose is not None and building is not None
    assert building != pose  # the offset learnt taken out
    assert building.yaw == pose.yaw  # rooms move, they do not turn
    assert building.distance_to(pose) < loc.config.map_offset.max_offset_m
    cov = loc.building_covariance
    assert cov.shape == (3, 3) and np.allclose(cov, cov.T)
    assert np.all(np.linalg.eigvalsh(cov) > 0.0)
    assert cov[2, 2] == pytest.approx(loc.covariance[2, 2])
    # the offset's posterior in the map floor's place: no more confident than the map-frame
    # filter's own covariance, no less than the map pose's reported one
    floor = loc.map_floor.sigma_m**2 * np.eye(2)
    assert np.all(np.linalg.eigvalsh(cov[:2, :2] - (loc.covariance[:2, :2] - floor)) >= 0.0)
    assert np.all(np.linalg.eigvalsh(loc.covariance[:2, :2] - cov[:2, :2]) >= -1e-15)
    current = loc.current_building_pose
    assert current is not None and current.distance_to(building) < 1e-9  # no odometry since


def test_by_default_the_building_pose_is_the_map_pose_until_the_walk_is_learnt() -> None:
    loc = _localise(LocaliserConfig(map_update=False), scans=20)  # 4 m
    assert loc.config.map_offset.enabled
    assert loc.building_pose == loc.pose
    assert np.array_equal(loc.building_covariance, loc.covariance)


def test_off_the_building_pose_is_the_map_pose() -> None:
    off = LocaliserConfig(map_update=False, map_offset=MapOffsetConfig(enabled=False))
    loc = _localise(off, scans=60)
    assert loc.building_pose == loc.pose
    assert np.array_equal(loc.building_covariance, loc.covariance)


class _NumpyReference(MapOffset):
    """`_predict` and `_update` in numpy matrix form (session 11's code): the readable
    reference of the plain-float ones."""

    def _predict(self, raw_step: Pose2D, sigma_b: float) -> tuple[float, float]:
        cfg = self.config
        c, s = math.cos(self._yaw), math.sin(self._yaw)
        ux, uy = c * raw_step.x - s * raw_step.y, s * raw_step.x + c * raw_step.y
        d = math.hypot(raw_step.x, raw_step.y)
        phi = math.exp(-d / cfg.correlation_m)
        f = np.eye(5)
        f[2, 2] = f[3, 3] = phi
        f[0, 4], f[1, 4] = ux, uy
        q = np.diag(
            [
                self.odometry_walk_m**2 * d,
                self.odometry_walk_m**2 * d,
                (1.0 - phi * phi) * sigma_b**2,
                (1.0 - phi * phi) * sigma_b**2,
                cfg.scale_walk**2 * d,
            ]
        )
        x = f @ np.array(self._x)
        self._x = [float(v) for v in x]
        self._p = (f @ np.array(self._p) @ f.T + q).tolist()
        k = self._x[4]
        return k * ux, k * uy

    def _update(self, map_pose: Pose2D, floor: float) -> bool:
        cfg = self.config
        h = np.hstack([np.eye(2), np.eye(2), np.zeros((2, 1))])
        p, x = np.array(self._p), np.array(self._x)
        s = h @ p @ h.T + cfg.map_pose_sigma_m**2 * np.eye(2)
        nu = np.array([map_pose.x, map_pose.y]) - h @ x
        if nu @ np.linalg.solve(s + floor**2 * np.eye(2), nu) > cfg.gate_chi2:
            return False
        gain = p @ h.T @ np.linalg.inv(s)
        x = x + gain @ nu
        if math.hypot(map_pose.x - x[0], map_pose.y - x[1]) > cfg.max_offset_m:
            return False
        self._x = [float(v) for v in x]
        p = (np.eye(5) - gain @ h) @ p
        self._p = (0.5 * (p + p.T)).tolist()
        return True


def test_the_plain_float_filter_is_the_matrix_form() -> None:
    """The same drive (rooms off their map, turns, a jump, a scan not fused) through the
    plain-float filter and its numpy reference: the same states, covariances and restarts."""
    fast, slow = MapOffset(ON), _NumpyReference(ON)
    rng = np.random.default_rng(11)
    x = y = yaw = 0.0
    for i in range(1500):
        turn = float(rng.normal(0.0, 0.05))
        step = Pose2D(STEP * 1.03, 0.0, turn)
        yaw += turn
        x, y = x + STEP * math.cos(yaw), y + STEP * math.sin(yaw)
        b = _offset_at(abs(x) % 16.0)
        jump = 0.3 if i == 700 else 0.0
        noise = rng.normal(0.0, 0.003, 2)
        map_pose = Pose2D(x + b[0] + noise[0] + jump, y + b[1] + noise[1], yaw)
        fused = i % 97 != 0
        for f in (fast, slow):
            f.step(step, map_pose, fused, SIGMA_B)
        assert fast.resets == slow.resets
        assert fast.position() == pytest.approx(slow.position(), abs=1e-12)
        assert fast.offset == pytest.approx(slow.offset, abs=1e-12)
        assert fast.building_position(map_pose) == pytest.approx(
            slow.building_position(map_pose), abs=1e-12
        )
        assert np.allclose(fast._p, slow._p, rtol=1e-9, atol=1e-18)
    assert fast.estimating and fast.resets >= 3  # the start, the walk learnt, the jump
