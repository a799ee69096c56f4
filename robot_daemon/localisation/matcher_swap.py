"""A scan matcher built off the scan path and swapped in at a scan boundary (issue 12).

Once the localiser has learnt its map's wall model (`wall_model`) and it differs from the one
its matcher uses, the matcher is rebuilt: its likelihood levels are distance transforms of the
whole map, 0.2-0.4 s of CPU on the ISR, Willow and Fetch maps (1.2 s under load 5). Built on
the scan path, that was a stall of the localiser, and of the daemon's control loop around it,
once per map. Here a worker thread builds it while the scans go on with the old matcher; the
new one is taken at a scan at least ``WallModelConfig.swap_after_s`` after the decision on the
localiser's clock, waiting for the build only if it has not finished by then.

Why a delay on the clock and not "when the build is done": the swap point then depends on the
clock alone, so a run on simulated time (scenarios, benches, tests) gives the same figures for
a seed however loaded the machine is; on the robot's real clock the build has long finished.
The build reads only the map (immutable); the worker releases the GIL in numpy and scipy for
most of it (measured with a probe loop on another thread, not shipped: during an ISR build
that took 1.2 s inline, the probe waited at most 35 ms for the GIL, load 5).
"""

from __future__ import annotations

import threading

from interbot_core.occupancy_grid import OccupancyGrid
from robot_daemon.localisation.scan_matcher import ScanMatcher, ScanMatcherConfig


class MatcherBuild:
    """A `ScanMatcher` of ``grid`` with ``config``, built on a worker thread, due at ``due``
    [s] on the localiser's clock."""

    def __init__(self, grid: OccupancyGrid, config: ScanMatcherConfig, due: float) -> None:
        self.due = due
        self._matcher: ScanMatcher | None = None
        self._error: BaseException | None = None
        self._thread = threading.Thread(
            target=self._run, args=(grid, config), name="matcher-build", daemon=True
        )
        self._thread.start()

    def _run(self, grid: OccupancyGrid, config: ScanMatcherConfig) -> None:
        try:
            self._matcher = ScanMatcher(grid, config)
        except BaseException as exc:  # raised again on the scan path, where it is reported
            self._error = exc

    @property
    def finished(self) -> bool:
        return not self._thread.is_alive()

    def take(self) -> ScanMatcher:
        """The new matcher, once built (waits for the worker if it has not finished)."""
        self._thread.join()
        if self._error is not None:
            raise self._error
        assert self._matcher is not None
        return self._matcher
