"""When the robot looks for itself: start-up, loss, request, "Help me!" and the background check.

The policy around `relocaliser.Relocaliser`, kept out of the stack so the stack only calls
`Relocalisation.step` once per localised scan and asks `state` what to report:

* **Start-up.** With the pose unset the search starts by itself (``on_unset``).
* **Lost.** When the localiser reports ``lost`` the search starts (``on_lost``).
* **Request.** The station's "Relocalise" starts a search even while localised (`request`).
* **"Help me!".** A pose picked by a person (a room on the tablet) is not trusted as it is: the
  same search runs restricted to ``help_radius_m`` around it (`verify_help`) and only a pose it
  accepts is applied; if it finds none within ``help_verify_s`` the pose is rejected and the
  whole-map search resumes.
* **Background check.** While localised and standing, every ``background_every_s`` the whole
  map is searched; a clearly better place elsewhere means a kidnap the loss test missed.
* **Degraded.** Once the localiser has reported ``degraded`` for ``degraded_after_s``, the same
  comparison runs every ``RelocaliserConfig.degraded_every_s``, standing or driving
  (`Relocaliser.check_degraded`); a clearly better place elsewhere starts the search. A robot
  carried off whose new scan still fits the old pose a little (hit fraction above the loss
  test's, below the degraded threshold) was otherwise neither lost nor checked: it drove on at
  the degraded speed, 32 m off, for 14 s (Willow kidnap seed 3 #7, the station handing it its
  next leg).

State reported while a search runs: ``searching``; once it has been undecided for
``help_after_s`` (failed, or look-alike places and no motion to tell them apart): ``lost``
(``unset`` at start-up), which is when the station and tablet offer "Help me!".
"""

from __future__ import annotations

import logging
from concurrent.futures import Executor
from dataclasses import dataclass
from typing import Annotated, ClassVar

import msgspec
from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid
from robot_daemon.localisation.global_search import SearchRegion
from robot_daemon.localisation.localiser import Localiser, LocaliserState
from robot_daemon.localisation.relocaliser import Relocaliser, RelocaliserConfig

logger = logging.getLogger(__name__)


class RelocalisationConfig(schema.Declared, frozen=True):
    """When to search (SI units); the search and the decision are in ``relocaliser``."""

    ROOT: ClassVar[str] = "RelocalisationConfig"
    ERROR: ClassVar[type[Exception]] = ValueError
    relocaliser: RelocaliserConfig = msgspec.field(default_factory=RelocaliserConfig)
    on_unset: bool = True  # search at start-up with the pose unset
    on_lost: bool = True  # search when the localiser reports lost
    background: bool = True  # standing-kidnap check while localised
    on_degraded: bool = True  # the same check while degraded (standing or driving) ...
    # ... once degraded this long (the loss test decides first: lost_after_s is 1 s)
    degraded_after_s: Annotated[float, Meta(ge=0.0, le=600.0, extra={"unit": "s"})] = 1.0
    # a "Help me!" pose is verified within this box half-width
    help_radius_m: Annotated[float, Meta(ge=0.5, le=100.0, extra={"unit": "m"})] = 5.0
    # ... and rejected if not confirmed within this long
    help_verify_s: Annotated[float, Meta(ge=0.5, le=600.0, extra={"unit": "s"})] = 5.0


@dataclass(frozen=True)
class RelocalisationEvent:
    level: str  # info | warning | error
    text: str


class Relocalisation:
    """Runs the relocaliser when it helps; built lazily (the search precomputes its grids)."""

    def __init__(
        self,
        grid: OccupancyGrid,
        localiser: Localiser,
        config: RelocalisationConfig | None = None,
    ) -> None:
        self.config = config or RelocalisationConfig()
        self._grid = grid
        self._localiser = localiser
        self._reloc: Relocaliser | None = None
        self._help_until: float | None = None  # verifying a "Help me!" pose until then
        self.help_requests = 0  # times the search asked for a person (for figures)
        self._help_flagged = False
        self._degraded_since: float | None = None  # the localiser reports degraded since
        self.executor: Executor | None = None  # where searches run (None: in the caller)

    @property
    def relocaliser(self) -> Relocaliser:
        if self._reloc is None:
            self._reloc = Relocaliser(self._grid, self._localiser, self.config.relocaliser)
            self._reloc.executor = self.executor
        return self._reloc

    def run_searches_in(self, executor: Executor) -> None:
        """Run global searches on ``executor`` (the daemon's worker thread), not in the loop;
        builds the search's grids now rather than at the first scan."""
        self.executor = executor
        self.relocaliser.executor = executor

    @property
    def active(self) -> bool:
        return self._reloc is not None and self._reloc.active

    def state(self, localiser_state: LocaliserState, now: float) -> LocaliserState:
        """The localisation state to report: ``searching`` while a search runs."""
        if not self.active:
            return localiser_state
        if self.relocaliser.status(now).help_needed and self._help_until is None:
            if localiser_state is LocaliserState.UNSET:
                return LocaliserState.UNSET
            return LocaliserState.LOST
        return LocaliserState.SEARCHING

    def _check_degraded(self, scan: LaserScan, now: float) -> bool:
        """Degraded for ``degraded_after_s``: compare the places (`Relocaliser.check_degraded`)
        and start the search when another one fits clearly better."""
        pose = self._localiser.pose
        since = self._degraded_since
        if pose is None or since is None or now - since < self.config.degraded_after_s - 1e-9:
            return False
        if self.relocaliser.check_degraded(scan, pose, now) is None:
            return False
        self.relocaliser.start(now, "degraded")
        return True

    # ------------------------------------------------------------------ requests

    def request(self, now: float) -> RelocalisationEvent:
        """The station's "Relocalise": search the whole map now."""
        self.relocaliser.start(now, "request")
        self._help_until = None
        return RelocalisationEvent("info", "relocalisation requested: finding my position…")

    def verify_help(self, laser_pose: Pose2D, now: float) -> RelocalisationEvent:
        """A person's pose ("Help me!"): searched around before it is trusted."""
        r = self.config.help_radius_m
        self.relocaliser.start(now, "help-me", SearchRegion.around(laser_pose.x, laser_pose.y, r))
        self._help_until = now + self.config.help_verify_s
        return RelocalisationEvent(
            "info", f"checking the pose given around ({laser_pose.x:.1f}, {laser_pose.y:.1f})…"
        )

    def cancel(self) -> None:
        """A trusted initial pose arrived: stop searching."""
        if self._reloc is not None:
            self._reloc.stop()
        self._help_until = None

    # ------------------------------------------------------------------ the loop

    def on_odometry(self, odom_laser: Pose2D) -> None:
        if self._reloc is not None:
            self._reloc.on_odometry(odom_laser)

    def step(
        self, scan: LaserScan | None, speed: float, now: float
    ) -> tuple[Pose2D | None, list[RelocalisationEvent]]:
        """After each localised scan: (laser pose to apply, events for the status log)."""
        cfg = self.config
        events: list[RelocalisationEvent] = []
        if scan is None:
            return None, events
        loc_state = self._localiser.state
        if loc_state is not LocaliserState.DEGRADED:
            self._degraded_since = None
        elif self._degraded_since is None:
            self._degraded_since = now
        if not self.active:
            if loc_state is LocaliserState.UNSET and cfg.on_unset:
                self.relocaliser.start(now, "start-up")
                events.append(RelocalisationEvent("info", "pose unset: finding my position…"))
            elif loc_state is LocaliserState.LOST and cfg.on_lost:
                self.relocaliser.start(now, "lost")
                events.append(RelocalisationEvent("error", "lost: finding my position…"))
            elif loc_state is LocaliserState.OK and cfg.background:
                pose = self._localiser.pose
                if pose is not None:
                    better = self.relocaliser.check_standing(scan, pose, speed, now)
                    if better is not None:
                        self.relocaliser.start(now, "kidnap")
                        events.append(
                            RelocalisationEvent(
                                "error",
                                "the scan fits another place better: finding my position…",
                            )
                        )
                return None, events
            elif loc_state is LocaliserState.DEGRADED and cfg.on_degraded:
                if self._check_degraded(scan, now):
                    events.append(
                        RelocalisationEvent(
                            "error",
                            "localisation degraded and the scan fits another place better: "
                            "finding my position…",
                        )
                    )
                else:
                    return None, events
            else:
                return None, events
            self._help_flagged = False
        reloc = self.relocaliser
        pose = reloc.on_scan(scan, now)
        if pose is not None:
            what = "the pose given" if self._help_until is not None else "my position"
            self._help_until = None
            self._help_flagged = False
            events.append(
                RelocalisationEvent(
                    "info", f"found {what}: ({pose.x:.2f}, {pose.y:.2f}, {pose.yaw:.2f})"
                )
            )
            return pose, events
        if self._help_until is not None and now >= self._help_until:
            self._help_until = None
            why = reloc.last_failure or "not confirmed"
            reloc.stop()
            events.append(
                RelocalisationEvent(
                    "error", f"the pose given does not match what the laser sees ({why})"
                )
            )
        elif reloc.active and reloc.status(now).help_needed and not self._help_flagged:
            self._help_flagged = True
            self.help_requests += 1
            why = reloc.last_failure or "no match"
            events.append(
                RelocalisationEvent("error", f"cannot find my position ({why}): help me!")
            )
        return None, events
