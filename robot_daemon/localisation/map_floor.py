"""How far the building stands off its map, learnt from the localiser's own corrections
(issue 12: "report a calibrated confidence and covariance").

The filter's covariance ``P`` says how well the scans and the odometry pin the pose *on the
map*. A building departs from its map (rooms drawn a few centimetres off, a SLAM map's slow
warp): where it does, every beam of every scan there fits the map best at the same offset, an
error that no number of beams or scans averages away. The localiser reports ``P`` plus a
*floor* ``σ_b²`` per axis (`Localiser.reported_covariance`). A fixed ``σ_b`` suits one kind of
map only: 2 cm is calibrated on the real logs' SLAM maps (walls through the cell centres) but
twice too cautious on the realistic ISR tours once the walls are learnt on the cell faces (NEES
per degree of freedom 0.34-0.53), and too confident on the simulated Willow building (1.31).

**What the robot can see of it.** From one place, nothing: a room that stands 5 cm off its map
fits the scan perfectly 5 cm off. Across places, the odometry ties them together: driving from
one place to another, the scans move the pose by the change in the map's offset on top of what
the odometry says (plus the odometry's own error). The *net correction* over a stretch of
``window_m`` of travel, ``c = Σ (x_post - x_pred)`` (x, y), is therefore an increment of the
map's offset field ``b``: ``E[c cᵀ] = 2 (1 - ρ(W)) σ_b² I + Q_odo(W)``, its semivariogram at lag
``W`` (plus the odometry's true error, which errs on the cautious side). With ``W`` about a
room (4 m: rooms and a warp's lattice decorrelate by then, ``ρ ≈ 0``) each clean window gives a
sample ``|c|² / 4`` of ``σ_b²`` per axis: covariance matching on the innovations
(innovation-based adaptive estimation, Mehra, "On the identification of variances and adaptive
Kalman filtering", IEEE TAC 1970; Mohamed and Schwarz, J. Geodesy 1999), on their sums over a
travel window because the map's error is correlated along the path, not white per scan.

**The estimate.** ``σ̂_b² = (n0 σ0² + Σ samples) / (n0 + n)``: the prior ``σ0``
(`LocaliserConfig.map_sigma_m`) counts as ``prior_windows`` windows, so a robot on an unknown
map reports the prior until it has driven some tens of metres, and learns from there. Only
windows where every scan was ok and fused count (a jump, a bad scan or a switch to the trusted
branch is not the map's offset). The floor is a property of the map: a new initial pose keeps
it.

Measured (session 10, realistic world, `interbot scenario tour --seed 1 --json`, the
diagnostic's own replay of each run's corrections): the per-axis square root of the samples'
mean at W = 1 / 2 / 4 / 8 m is 0.71 / 1.14 / 1.70 / 2.75 cm on ISR seed 1, 0.61 / 0.93 / 1.55 /
2.34 on Fetch and 0.98 / 1.44 / 2.45 / 3.42 on Willow. Learnt at the end of the tour: ISR 1.78 cm
(46 windows), Fetch 1.32 (59), Willow 2.00 (19, a tour blocked after 5 of 14 stops). NEES per
degree of freedom with the fixed 2 cm -> learnt: ISR seeds 1-3 0.52 / 0.34 / 0.53 -> 0.49 /
0.41 / 0.53, Fetch 0.60 -> 0.77, Willow 1.31 -> 1.26. Nearer 1 on Fetch and Willow, not on ISR:
there the floor that makes NEES 1 is about 1.3 cm, because the filter's own ``P`` (median
1.7 cm per axis) is already cautious (its odometry model); the floor measures the map, not ``P``.
On the eight real logs (`interbot bench --only reallogs`, 1 Hz scans, odometry with 5 % scale
error) every RMS and silent-failure count is unchanged and the mean NEES (3 when calibrated)
moves by at most 0.1 but on Freiburg 079's whole log, 3.13 -> 2.42 (inside the 95 % region
0.915 -> 0.947). The simulated figures echo the simulator's own settings (rooms moved 3.5 cm per axis on the ISR floor,
grids warped 3.5 cm per axis on a 4 m lattice for Willow and Fetch).
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar

from msgspec import Meta

from interbot_core import schema


class MapFloorConfigError(ValueError):
    """A map-floor parameter is out of range; the message names it."""


class MapFloorConfig(schema.Declared, frozen=True):
    """How the floor under the reported covariance is learnt (see the module docstring)."""

    ROOT: ClassVar[str] = "MapFloorConfig"
    ERROR: ClassVar[type[Exception]] = MapFloorConfigError
    learn: bool = True  # False: the prior (`LocaliserConfig.map_sigma_m`) throughout
    # travel per sample: about a room, where the map's offsets decorrelate
    window_m: Annotated[float, Meta(ge=0.5, le=100.0, extra={"unit": "m"})] = 4.0
    # the prior counts as this many windows (20 m of travel at 4 m)
    prior_windows: Annotated[float, Meta(ge=0.0, le=1e4)] = 5.0
    # the learnt sigma stays within these
    min_sigma_m: Annotated[float, Meta(ge=0.0, le=1.0, extra={"unit": "m"})] = 0.005
    max_sigma_m: Annotated[float, Meta(ge=0.0, le=1.0, extra={"unit": "m"})] = 0.1


class MapFloor:
    """The map's own error per axis, ``sigma_m``: the prior ``prior_sigma_m`` until windows of
    travel with clean corrections teach it (`add`)."""

    def __init__(self, config: MapFloorConfig, prior_sigma_m: float) -> None:
        self.config = config
        self.prior_sigma_m = prior_sigma_m
        self.windows = 0  # clean windows learnt from
        self._sum_var = 0.0  # Σ |c|² / 4 over them [m²]
        self._cx = self._cy = 0.0  # net correction of the current window [m]
        self._travel = 0.0  # [m] travelled in it
        self._clean = True  # every scan in it ok and fused

    @property
    def sigma_m(self) -> float:
        """The floor's sigma per axis [m] (``σ̂_b``)."""
        cfg = self.config
        if not cfg.learn:
            return self.prior_sigma_m
        n0 = cfg.prior_windows
        den = n0 + self.windows
        if den <= 0.0:
            return self.prior_sigma_m
        var = (n0 * self.prior_sigma_m**2 + self._sum_var) / den
        return min(max(math.sqrt(var), cfg.min_sigma_m), cfg.max_sigma_m)

    def add(self, dx: float, dy: float, travel_m: float, clean: bool) -> None:
        """One scan: its correction (posterior - prediction, map frame) [m], the travel since the
        previous scan [m], and whether it was ok and fused (``clean``)."""
        if not self.config.learn:
            return
        self._cx += dx
        self._cy += dy
        self._travel += travel_m
        self._clean = self._clean and clean
        if self._travel < self.config.window_m:
            return
        if self._clean:
            self._sum_var += 0.25 * (self._cx * self._cx + self._cy * self._cy)
            self.windows += 1
        self.restart()

    def restart(self, clean: bool = True) -> None:
        """Start a new window; ``clean=False`` drops it when it ends (after a new initial pose:
        its corrections converge from a person's guess, they are no increment of the map's
        offset)."""
        self._cx = self._cy = 0.0
        self._travel = 0.0
        self._clean = clean
