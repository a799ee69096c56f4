"""What the station knows about the selected robot: the newest value of each state topic.

Thesis §5.3.6: the station's ``clock()`` "obtains Interbot's current position and orientation"
and speeds and shows them. Here the 25 ms frame timer polls the zenoh link and stores the newest
message of each topic in a `RobotState`; ``version`` increases on every change so views redraw
only when something is new, and the status log keeps the last ``log_capacity`` lines
(messages and errors, thesis §4.2.2.1).
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import dataclass

from interbot_core.geometry import Pose2D
from interbot_core.laser_scan import LaserScan
from interbot_core.occupancy_grid import OccupancyGrid
from interbot_core.pose_history import PoseHistory
from interbot_core.topics import (
    Battery,
    ImageMsg,
    MuxMsg,
    Odom,
    PlanMsg,
    PoseMsg,
    RouteProgress,
    SafetyMsg,
    StandingNotices,
    Status,
    Topic,
    Twist,
)

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class LogEntry:
    stamp: float  # [s] station clock
    level: str  # info, warning, error
    text: str


# The attribute that keeps the newest message of each state topic, and the message's type.
_SLOTS: dict[Topic, tuple[str, type]] = {
    Topic.POSE: ("pose", PoseMsg),
    Topic.ODOM: ("odom", Odom),
    Topic.CMD_VEL: ("cmd_vel", Twist),
    Topic.SCAN: ("scan", LaserScan),
    Topic.MAP: ("grid", OccupancyGrid),
    Topic.IMAGE: ("image", ImageMsg),
    Topic.BATTERY: ("battery", Battery),
    Topic.MUX: ("mux", MuxMsg),
    Topic.ROUTE_PROGRESS: ("progress", RouteProgress),
    Topic.STATUS: ("status", Status),
    Topic.SAFETY: ("safety", SafetyMsg),
    Topic.PLAN: ("plan", PlanMsg),
    Topic.NOTICES: ("notices", StandingNotices),
}


class RobotState:
    """Newest state of the selected robot (None until first received)."""

    def __init__(self, log_capacity: int = 500) -> None:
        self.log: deque[LogEntry] = deque(maxlen=log_capacity)
        self.poses = PoseHistory()  # localised poses by robot time, to place each scan
        self.clear()

    def clear(self) -> None:
        self.pose: PoseMsg | None = None
        self.odom: Odom | None = None
        self.cmd_vel: Twist | None = None
        self.scan: LaserScan | None = None
        self.grid: OccupancyGrid | None = None
        self.image: ImageMsg | None = None
        self.battery: Battery | None = None
        self.mux: MuxMsg | None = None
        self.progress: RouteProgress | None = None
        self.status: Status | None = None
        self.safety: SafetyMsg | None = None  # collision monitor (issue 17)
        self.plan: PlanMsg | None = None
        self.notices: StandingNotices | None = None  # the robot's standing status lines
        self.poses.clear()
        self.version = 0
        self.map_version = 0  # map updates applied (bench_replay counts them)
        self.image_version = 0

    @property
    def localised_pose(self) -> Pose2D | None:
        """The pose when the localiser reports ``ok`` or ``degraded`` (tracking, uncertain);
        None when unset, lost or searching."""
        p = self.pose
        return None if p is None or p.state not in ("ok", "degraded") else Pose2D(p.x, p.y, p.yaw)

    def scan_pose(self) -> Pose2D | None:
        """Where the robot was when the newest scan was taken (None: no scan or not localised)."""
        return None if self.scan is None else self.poses.at(self.scan.stamp)

    @property
    def localisation(self) -> str:
        return "unset" if self.pose is None else self.pose.state

    @property
    def estop_engaged(self) -> bool | None:
        """The robot's report: True when its mux has the stop lock active (None: no report)."""
        if self.mux is None:
            return None
        # Lock *names* are reported ("Emergency Stop" in interbot_mux.yaml, "stop" elsewhere).
        return any("stop" in name.lower() for name in self.mux.active_locks)

    def apply(self, topic: Topic, message: object) -> None:
        """Store one decoded message of ``topic``."""
        slot = _SLOTS.get(topic)
        if slot is None or not isinstance(message, slot[1]):
            logger.debug("ignored %s message %r", topic, type(message).__name__)
            return
        setattr(self, slot[0], message)
        if isinstance(message, PoseMsg):
            if message.state == "ok":
                self.poses.add(message.stamp, Pose2D(message.x, message.y, message.yaw))
            else:
                self.poses.clear()
        elif isinstance(message, OccupancyGrid):
            self.map_version += 1
        elif isinstance(message, ImageMsg):
            self.image_version += 1
        self.version += 1

    def add_log(self, now: float, level: str, text: str) -> None:
        self.log.append(LogEntry(now, level, text))
        log = logger.warning if level in ("warning", "error") else logger.info
        log("status: %s", text)
