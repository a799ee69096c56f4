"""Recent poses by time, so a scan is drawn from where the robot was when it was taken.

The station receives the pose at 20 Hz and the scan at 10 Hz on separate topics; drawing a scan
from the newest pose smears it through the walls while the robot turns (0.1 s at 1 rad/s is
6 degrees, 1 m of arc at 10 m). `PoseHistory.at(stamp)` interpolates linearly between the two
poses around ``stamp`` (yaw along the shorter arc), holds the newest pose for stamps up to
``max_hold`` [s] past it, and answers None for stamps it cannot vouch for, so the caller can skip
the scan rather than draw it in the wrong place.
"""

from __future__ import annotations

import bisect
from collections import deque

from interbot_core.geometry import Pose2D, wrap_angle


class PoseHistory:
    """A bounded, time-ordered list of ``(stamp, pose)``; stamps on one clock (the robot's)."""

    def __init__(self, capacity: int = 64, max_hold: float = 0.25) -> None:
        if capacity < 2 or max_hold < 0.0:
            raise ValueError(f"capacity must be >= 2 and max_hold >= 0, got {capacity}, {max_hold}")
        self._stamps: deque[float] = deque(maxlen=capacity)
        self._poses: deque[Pose2D] = deque(maxlen=capacity)
        self.max_hold = max_hold  # [s]

    def __len__(self) -> int:
        return len(self._stamps)

    def clear(self) -> None:
        self._stamps.clear()
        self._poses.clear()

    def add(self, stamp: float, pose: Pose2D) -> None:
        """Append a pose; one older than the newest (a reordered or restarted clock) resets."""
        if self._stamps and stamp < self._stamps[-1]:
            self.clear()
        if self._stamps and stamp == self._stamps[-1]:
            self._poses[-1] = pose
            return
        self._stamps.append(stamp)
        self._poses.append(pose)

    def at(self, stamp: float) -> Pose2D | None:
        """The pose at ``stamp``: interpolated, held briefly past the newest, else None."""
        if not self._stamps or stamp < self._stamps[0]:
            return None
        newest = self._stamps[-1]
        if stamp >= newest:
            return self._poses[-1] if stamp - newest <= self.max_hold else None
        stamps = list(self._stamps)
        i = bisect.bisect_right(stamps, stamp)
        t0, t1 = stamps[i - 1], stamps[i]
        p0, p1 = self._poses[i - 1], self._poses[i]
        f = (stamp - t0) / (t1 - t0)
        return Pose2D(
            p0.x + f * (p1.x - p0.x),
            p0.y + f * (p1.y - p0.y),
            wrap_angle(p0.yaw + f * wrap_angle(p1.yaw - p0.yaw)),
        )
