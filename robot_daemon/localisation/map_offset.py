"""Where the building stands off its map, here: the robot's pose in the building, not only on
the map (issue 12: the realistic tour at <= 3 cm RMS / <= 10 cm max).

**The problem.** The localiser matches scans against the map and so estimates the robot's pose
*on the map*, ``m``: where the map's walls are, relative to the robot. A building departs from
its map (rooms drawn a few centimetres off, a SLAM map's slow warp): in a room that stands 5 cm
off its map, the scans fit the map perfectly 5 cm off the robot's true position, and every scan
there says the same. The map frame's error is *coloured*: constant within a room, changing at
its doors, and no number of scans averages it away (`map_floor` reports its size).

**What tells the two apart.** The odometry. Driving from one place to another, the true motion
is the odometry's; the map-frame pose moves by that *plus* the change in the map's offset. Once
the odometry's scale is known, its error over a few metres is small against the offset (the
realistic simulator, session 11: 1.2-1.6 cm per axis over 4 m with the heading from the scans,
against rooms moved 3.5 cm per axis), so the offset is observable from its changes.

**The model** (state augmentation for coloured measurement noise, Bryson and Henrikson,
"Estimation using sampled data containing sequentially correlated noise", J. Spacecraft and
Rockets 5(6), 1968): a Kalman filter on ``(p, b, k)`` beside the map-frame filter,

* ``p`` (x, y): the robot's position in the building; the odometry moves it,
  ``p' = p + k R(ψ) u`` (``u``: the raw odometry translation, ``ψ``: the map-frame heading
  before the step; rooms move, they do not turn), with a random walk ``odom_walk_m`` per
  sqrt(metre);
* ``b`` (x, y): the map's offset at the robot, ``m = p + b``; a first-order Gauss-Markov process
  *in distance travelled*, ``b' = φ b + w``, ``φ = exp(-d / correlation_m)``,
  ``Var w = (1 - φ²) σ_b²``: zero on average (the map is right on the whole), ``σ_b`` per axis
  (the floor learnt by `map_floor`), forgetting itself over about a room;
* ``k``: the odometry's scale (true / measured translation), learnt slowly (``scale_walk``):
  the map-frame filter's own scale (`odometry_scale`) wanders 0.3 % with the map's offsets it
  cannot tell from a scale error, and 0.3 % over 8 m is 2.4 cm, as much as the offset.

Each fused scan measures ``m = p + b`` (its scatter ``map_pose_sigma_m``). The map-frame filter
is *not* changed: the matcher needs the pose on the map (its prior), and so does navigation (the
planner plans among the map's walls, a door is where the scans put it).

**What is reported** (session 12): the map pose less the offset learnt there, ``m - b̂``
(`building_position`, `Localiser.building_pose`), with the map pose's reported covariance whose
floor (the offset's prior, `map_floor`) is replaced by the offset's posterior ``P_bb``
(`building_covariance`); the map pose stays available (`Localiser.pose`). Session 11 reported
``p`` with its covariance ``P_pp``: ``p`` smooths the map pose with the odometry a second time
(the map-frame filter has fused it already) and ``P_pp`` holds neither the map-frame filter's
uncertainty nor the floor: on the real logs its mean NEES was 3.8-18 where the map pose's was
1.6-7.8, on the ISR tours 0.87-0.96 per dof where the map pose's was 0.5. Replayed offline
on the same inputs (the map pose, fused or not, the raw odometry and the map floor of every
scan, recorded once: the map-frame filter and navigation do not depend on this filter), ``m - b̂``
is as good as ``p`` (ISR seed 1 2.73 against 2.75 cm) and its NEES is the map pose's or lower.

**The walk first** (`estimating`): the offset is told from the odometry's error only once
that error is known; until the walk (`odometry_walk_m`) is learnt from as many windows as its
prior counts (``walk_prior_windows``, 10 m of fused travel), ``b`` stays 0 and the building
pose *is* the map pose, covariance included. On the real logs the replayed odometry carries
1 cm of noise per step whatever the travel (3-4 cm per sqrt(m) on Freiburg 079's 0.1 m and
ACES's 6 cm steps), three times the prior's 1 cm: estimating from the first scan the filter
took that noise for offsets (Freiburg 079 revisit 3.08 -> 3.58 cm, ACES revisit 1.99 -> 2.39,
offline); waiting for the walk, 3.07 and 1.99.

**Safety.** The building position never strays from the map pose by more than
``max_offset_m``; a fused pose the filter cannot explain (innovation beyond ``gate_chi2`` with
room for a new offset of the floor's size: a jump, a new branch, a first match after a set
pose) starts it again at the map pose (``b = 0``); so does the first fused scan after a pose is
set (`restart`: a person's guess is no offset of the map). The map-frame filter judges ok /
degraded / lost; the building pose never adds a decision.

**On by default** (``enabled``). Measured on session 12's code (`interbot scenario tour
--seed N --json`, realistic world; ``loc_map_pose_*`` is the same run's map pose, the pose
without this filter): RMS / max in the building against on the map, ISR seeds 1-3
2.67 / 5.6, 2.24 / 5.8, 2.66 / 8.5 against 3.07 / 7.5, 2.49 / 6.8, 2.91 / 10.0 cm; NEES per dof
0.50, 0.42, 0.54 (the map pose's 0.51, 0.41, 0.52 in session 11; session 11's filter 0.87-0.96);
Willow seeds 1-3 2.69 / 7.4, 2.98 / 9.7, 3.55 / 8.5 against 3.31 / 8.9, 3.44 / 9.7,
4.02 / 11.1 (NEES per dof 1.06, 1.37, 1.40); Fetch 1.91 / 5.6, 1.97 / 5.3, 2.20 / 6.7 against
2.18 / 6.5, 2.27 / 5.3, 2.61 / 7.4; every tour all stops, no collision, loss or silent failure.
Kidnaps (`interbot scenario kidnap --seed N`, ISR and Willow seeds 1-5) as without it: ISR 8,
8, 7, 8, 6 and Willow 8 each of 8 relocalised, all detected, 0 wrong (the filter makes no
decision). The ideal world
(map = building, `--ideal-world`, ISR seed 1) pays 0.03 cm: 0.60 / 7.6 against 0.57 / 7.6.
Its cost: 15-17 µs per scan (20000 steps, load 4-5).
Real logs (`interbot bench --only reallogs`, the reported pose against the map pose,
``map_pose_rms_m``): better on 12 of 16 runs (Intel 2.81 / 2.24 -> 2.70 / 2.08 cm,
ACES whole 3.35 -> 2.88, CSAIL whole 2.34 -> 2.01, the Infinite Corridor 9.89 / 4.49 ->
9.68 / 4.11, Örebro whole 2.52 -> 2.28, Seattle 1.93 / 1.71 -> 1.89 / 1.48), the same on the
ACES and CSAIL revisits (short runs: the walk is never learnt), worse by 0.07 cm on Freiburg
079's whole log (3.29 -> 3.36) and 0.03 cm on Örebro's revisit (3.83 -> 3.86); mean NEES the
map pose's within 0.17 on every run (3 when calibrated; 0.33-4.41, the Freiburg campus's whole
log 7.68 against 7.75); no silent failure. These simulated figures echo the simulator's
settings (rooms moved 3.5 cm per axis on the ISR floor, Willow and Fetch warped 3.5 cm per
axis on a 4 m lattice, its odometry's 3 % scale error and noise); nothing here is set from
them: the floor and the walk are learnt, ``correlation_m`` (4 m, about a room) is
`map_floor`'s window.

Tried and dropped (session 12, offline on the recorded inputs of ISR seeds 1 and 3, Willow
seed 1 and the 16 real-log runs): the offset's sigma from the residual's variogram (the map
pose's move less the odometry's over windows of 0.5-16 m, fitted by non-negative weighted least
squares as nugget + walk + ``σ_b² (1 - exp(-d/L))``, Cressie 1985; ``L`` 4 m or chosen from
1-32 m): on the tours the residual's variance grows almost linearly to 8 m (the map's offset
changes along a corridor like a walk of its own), the fit put the offset at 0 and the gain
vanished (ISR seed 1 3.02 cm), while on the real logs' whole runs it found 1.2-3.5 cm, the
wrong way round; the floor less the walk's share of its window (``σ_b² = floor² - walk² W / 2``):
Freiburg 079's whole log 3.28 cm, but ISR seed 1 2.82 and Willow seed 1 3.04 (the walk learnt
over 1 m holds some of the offset's change, taken out twice); waiting for the scale's
uncertainty to fall below the walk's over a room: never binding once the walk is learnt.
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar

import numpy as np
import numpy.typing as npt
from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D

FloatArray = npt.NDArray[np.float64]


class MapOffsetConfigError(ValueError):
    """A map-offset parameter is out of range; the message names it."""


class MapOffsetConfig(schema.Declared, frozen=True):
    """The building-pose filter (see the module docstring)."""

    ROOT: ClassVar[str] = "MapOffsetConfig"
    ERROR: ClassVar[type[Exception]] = MapOffsetConfigError
    enabled: bool = True  # on by default (module docstring); off: the building pose is the map pose
    # travel over which the map's offset forgets itself: about a room (`map_floor.window_m`)
    correlation_m: Annotated[float, Meta(ge=0.1, le=1000.0, extra={"unit": "m"})] = 4.0
    # the odometry's error once its scale is learnt, per sqrt(metre) of travel: the prior of
    # the value learnt (`odometry_walk_m`), worth ``walk_prior_windows`` windows
    odom_walk_m: Annotated[float, Meta(ge=1e-4, le=1.0, extra={"unit": "m / sqrt(m)"})] = 0.01
    walk_window_m: Annotated[float, Meta(ge=0.1, le=100.0, extra={"unit": "m"})] = 1.0
    walk_prior_windows: Annotated[float, Meta(ge=0.0, le=1e4)] = 10.0
    max_walk_m: Annotated[float, Meta(ge=1e-4, le=1.0, extra={"unit": "m / sqrt(m)"})] = 0.1
    scale_sigma: Annotated[float, Meta(ge=1e-4, le=0.5)] = 0.05  # prior of the scale
    # the scale's drift per sqrt(metre) (slow: tyre wear, not the map's offsets)
    scale_walk: Annotated[float, Meta(ge=0.0, le=0.1, extra={"unit": "1 / sqrt(m)"})] = 1e-4
    # the map-frame pose's own scatter about the map's fit (noise, people)
    map_pose_sigma_m: Annotated[float, Meta(ge=1e-4, le=1.0, extra={"unit": "m"})] = 0.01
    # a fused map pose farther than this (chi-square, 2 dof; 99.9 %) starts the filter again
    gate_chi2: Annotated[float, Meta(ge=1.0, le=1e6)] = 13.8
    # the building pose stays this close to the map pose
    max_offset_m: Annotated[float, Meta(ge=0.0, le=1.0, extra={"unit": "m"})] = 0.2


class MapOffset:
    """The state ``(p, b, k)`` and its covariance (see the module docstring). Fed once per
    scan (`step`); ``None`` (`position`) until started at a map pose (`reset`)."""

    def __init__(self, config: MapOffsetConfig | None = None) -> None:
        self.config = config or MapOffsetConfig()
        # x = (p, b, k) and its covariance P, row-major lists (`_predict`)
        self._x = [0.0, 0.0, 0.0, 0.0, 1.0]
        self._p = _diag([0.0, 0.0, 0.0, 0.0, self.config.scale_sigma**2])
        self._started = False
        self._yaw = 0.0  # the map-frame heading at the last step [rad]
        self.resets = 0  # times the filter started again (a set pose, a gate, the bound)
        # The odometry's walk learnt (`odometry_walk_m`): windows, Σ samples [m²/m], and the
        # current window's map-pose move less odometry move [m], travel [m], last map position.
        self.walk_windows = 0
        self._walk_sum = 0.0
        self._win = [0.0, 0.0, 0.0]
        self._last_map: tuple[float, float] | None = None

    @property
    def odometry_walk_m(self) -> float:
        """The odometry's error per sqrt(metre) [m] the prediction uses: learnt by covariance
        matching (as `map_floor`, Mehra 1970) from windows of ``walk_window_m`` of travel where
        every scan was fused: the map pose's move less the odometry's (learnt scale, the map's
        heading), ``r``, gives a sample ``|r|² / (2 d)`` per axis. Over a short window the map's
        offset changes little (the tours: 0.5-0.8 cm per axis over 1 m), so the sample is the
        odometry's error plus a little: the cautious side. The real logs' replayed odometry
        (1 cm per scan whatever the travel: 3 cm per sqrt(m) on Freiburg 079's 0.1 m steps)
        needs it: with the prior's 1 cm the building pose was 1.5-1.9 cm worse there than the map
        pose against the logged poses."""
        cfg = self.config
        n0 = cfg.walk_prior_windows
        den = n0 + self.walk_windows
        if den <= 0.0:
            return cfg.odom_walk_m
        var = (n0 * cfg.odom_walk_m**2 + self._walk_sum) / den
        return min(max(math.sqrt(var), 1e-4), cfg.max_walk_m)

    @property
    def scale(self) -> float:
        """The odometry's scale learnt here (true / measured translation)."""
        return float(self._x[4])

    @property
    def offset(self) -> tuple[float, float] | None:
        """The map's offset at the robot ``b`` [m] (map pose - building position)."""
        if not self._started:
            return None
        return float(self._x[2]), float(self._x[3])

    def restart(self) -> None:
        """A pose was set (a person's guess, a relocalisation): start again at the first map
        pose a scan fixes (`step`); until then there is no building position."""
        self._started = False

    def reset(self, map_pose: Pose2D, sigma_b: float) -> None:
        """Start at ``map_pose``: the building position there, the offset 0 with its prior
        ``sigma_b`` per axis. The scale is the robot's and is kept (not its cross-terms)."""
        self._started = True
        self.resets += 1
        var_p = self.config.map_pose_sigma_m**2
        k, var_k = self._x[4], self._p[4][4]
        self._x = [map_pose.x, map_pose.y, 0.0, 0.0, k]
        self._p = _diag([var_p, var_p, sigma_b**2, sigma_b**2, var_k])
        self._yaw = map_pose.yaw
        self._win = [0.0, 0.0, 0.0]
        self._last_map = (map_pose.x, map_pose.y)

    @property
    def estimating(self) -> bool:
        """Whether the offset is estimated: once the odometry's walk is learnt from at least as
        many windows as its prior counts (``walk_prior_windows``: the data outweigh the
        prior). Before, the filter tells an offset from the odometry's error with an odometry
        error it does not know: on the real logs' short runs (ACES revisit, 14 scans a run,
        1 cm of noise per 6 cm step) it took that noise for offsets, 1.99 -> 2.39 cm. Until
        then ``b`` stays 0, the building pose is the map pose."""
        return self.walk_windows >= self.config.walk_prior_windows

    def step(self, raw_step: Pose2D, map_pose: Pose2D, fused: bool, sigma_b: float) -> None:
        """One scan: the raw odometry increment since the previous one (robot frame), the map
        pose after it and whether a match updated it (``fused``), the map floor now
        (`map_floor`: the offset's sigma once `estimating`, 0 before; the gate's allowance
        for a new offset always)."""
        if not self.config.enabled:
            return
        floor = sigma_b
        was_estimating = self.estimating
        sigma_b = floor if was_estimating else 0.0
        if not self._started:
            if fused:
                self.reset(map_pose, sigma_b)
            return
        moved = self._predict(raw_step, sigma_b)
        self._yaw = map_pose.yaw
        self._learn_walk(map_pose, moved, fused, math.hypot(raw_step.x, raw_step.y))
        if fused and not self._update(map_pose, floor):
            self.reset(map_pose, sigma_b)
        elif fused and self.estimating and not was_estimating:
            # the walk is learnt: start the offset at 0 with its prior (a covariance that
            # grew from 0 would claim to know an offset it has not looked for)
            self.reset(map_pose, floor)

    def _learn_walk(
        self, map_pose: Pose2D, moved: tuple[float, float], fused: bool, travel: float
    ) -> None:
        """One scan's share of the current window of `odometry_walk_m`; a scan not fused
        drops the window."""
        last, self._last_map = self._last_map, (map_pose.x, map_pose.y)
        if not fused or last is None:
            self._win = [0.0, 0.0, 0.0]
            return
        win = self._win
        win[0] += map_pose.x - last[0] - moved[0]
        win[1] += map_pose.y - last[1] - moved[1]
        win[2] += travel
        if win[2] >= self.config.walk_window_m:
            self._walk_sum += 0.5 * (win[0] * win[0] + win[1] * win[1]) / win[2]
            self.walk_windows += 1
            self._win = [0.0, 0.0, 0.0]

    def _predict(self, raw_step: Pose2D, sigma_b: float) -> tuple[float, float]:
        """The odometry's step on the state; returns the position's move [m].

        ``F P Fᵀ + Q`` with ``F = I`` but ``F[b, b] = φ`` and ``F[p, k] = (ux, uy)``: row
        operations, then the same on the columns (plain floats: a 5x5 in numpy cost more in
        call overhead than in arithmetic; the numpy form is the tests' reference)."""
        cfg = self.config
        # The increment is in the frame of the previous pose (``pose ⊕ step``), as in the
        # map-frame filter's prediction.
        c, s = math.cos(self._yaw), math.sin(self._yaw)
        ux, uy = c * raw_step.x - s * raw_step.y, s * raw_step.x + c * raw_step.y
        d = math.hypot(raw_step.x, raw_step.y)
        phi = math.exp(-d / cfg.correlation_m)
        x = self._x
        k = x[4]
        self._x = [x[0] + k * ux, x[1] + k * uy, phi * x[2], phi * x[3], k]
        p = self._p
        r4 = p[4]
        p = [
            [a + ux * b for a, b in zip(p[0], r4, strict=True)],
            [a + uy * b for a, b in zip(p[1], r4, strict=True)],
            [phi * a for a in p[2]],
            [phi * a for a in p[3]],
            list(r4),
        ]
        for row in p:
            row[0] += ux * row[4]
            row[1] += uy * row[4]
            row[2] *= phi
            row[3] *= phi
        walk, drift = self.odometry_walk_m**2 * d, (1.0 - phi * phi) * sigma_b**2
        p[0][0] += walk
        p[1][1] += walk
        p[2][2] += drift
        p[3][3] += drift
        p[4][4] += cfg.scale_walk**2 * d
        self._p = p
        return k * ux, k * uy

    def _update(self, map_pose: Pose2D, floor: float) -> bool:
        """Condition on ``m = p + b``; False when it does not fit (the gate, or an offset
        beyond the bound): the caller starts again. The gate allows a whole new offset of the
        map's size (``floor``, also while the offset is not estimated: a reset drops the walk's
        window) on top of the prediction's uncertainty: a room's offset
        changes at its door within a few centimetres of travel, a step the Gauss-Markov model
        calls unlikely, but no jump of the matcher. ``K = P Hᵀ S⁻¹``, ``x += K ν``,
        ``P -= K (P Hᵀ)ᵀ`` with ``H = [I I 0]``, in plain floats as `_predict`."""
        cfg = self.config
        p = self._p
        ph = [(r[0] + r[2], r[1] + r[3]) for r in p]  # P Hᵀ (5x2)
        var_m = cfg.map_pose_sigma_m**2
        s00 = ph[0][0] + ph[2][0] + var_m  # H P Hᵀ + R
        s01 = 0.5 * ((ph[0][1] + ph[2][1]) + (ph[1][0] + ph[3][0]))
        s11 = ph[1][1] + ph[3][1] + var_m
        x = self._x
        n0, n1 = map_pose.x - x[0] - x[2], map_pose.y - x[1] - x[3]  # the innovation
        g00, g11 = s00 + floor**2, s11 + floor**2
        det_g, det_s = g00 * g11 - s01 * s01, s00 * s11 - s01 * s01
        if not (det_g > 0.0 and det_s > 0.0):
            return False
        if (g11 * n0 * n0 - 2.0 * s01 * n0 * n1 + g00 * n1 * n1) / det_g > cfg.gate_chi2:
            return False
        i00, i01, i11 = s11 / det_s, -s01 / det_s, s00 / det_s  # S⁻¹
        gain = [(a * i00 + b * i01, a * i01 + b * i11) for a, b in ph]  # 5x2
        x = [xi + (g0 * n0 + g1 * n1) for xi, (g0, g1) in zip(x, gain, strict=True)]
        if math.hypot(map_pose.x - x[0], map_pose.y - x[1]) > cfg.max_offset_m:
            return False
        self._x = x
        q = [
            [pij - (g0 * a + g1 * b) for pij, (a, b) in zip(row, ph, strict=True)]
            for row, (g0, g1) in zip(p, gain, strict=True)
        ]
        self._p = [[0.5 * (q[i][j] + q[j][i]) for j in range(5)] for i in range(5)]
        return True

    def position(self) -> tuple[float, float] | None:
        """The filter's building position ``p`` [m] (None until started). Not what the robot
        reports (`building_position`): ``p`` smooths the map pose with the odometry a second
        time, and its covariance, without the map floor, was 3.8-18 times too confident on
        the real logs (mean NEES, session 11)."""
        if not self._started:
            return None
        return float(self._x[0]), float(self._x[1])

    def building_position(self, map_pose: Pose2D) -> tuple[float, float] | None:
        """The robot in the building [m]: the map pose less the offset learnt there,
        ``m - b̂`` (None until started). Exactly the map pose while ``b̂`` is 0 (a map the
        building was made from, not `estimating` yet)."""
        if not self._started:
            return None
        return map_pose.x - float(self._x[2]), map_pose.y - float(self._x[3])

    def building_covariance(self, map_cov: FloatArray, floor: float) -> FloatArray:
        """2x2 covariance of `building_position` [m²] from the map pose's reported one
        (``map_cov``: the map-frame filter's ``P`` plus the floor ``σ_b² I``, `map_floor`):
        the floor is the prior of the offset the map pose does not take out; ``m - b̂`` takes
        out ``b̂``, so its error holds the offset's posterior ``P_bb`` in the floor's place,
        ``P + P_bb`` (the cross-covariance of the map pose's error and ``b̂``'s is left out).
        The map pose's covariance while the offset is not estimated."""
        out: FloatArray = map_cov.copy()
        if self._started and self.estimating:
            p = self._p
            out += np.array([[p[2][2], p[2][3]], [p[3][2], p[3][3]]]) - floor**2 * np.eye(2)
        return out

    def position_covariance(self) -> FloatArray:
        """2x2 covariance of `position` [m²]: the offset's uncertainty included."""
        p = self._p
        out: FloatArray = np.array([[p[0][0], p[0][1]], [p[1][0], p[1][1]]])
        return out


def _diag(values: list[float]) -> list[list[float]]:
    """A diagonal matrix as row lists."""
    return [[v if i == j else 0.0 for j in range(len(values))] for i, v in enumerate(values)]
