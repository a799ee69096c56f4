"""How the station words what it shows: unset values as "—", ages in seconds, the stop's state.

Qt-free so the wording is tested without a screen. The e-stop line puts the two owners of the
stop side by side (the operator's intent at the station and the robot's latch) and says plainly
when they disagree, because that is the moment an operator must act.
"""

from __future__ import annotations

import math

from interbot_core.topics import PoseMsg

UNSET = "—"


def position_text(pose: PoseMsg | None) -> str:
    if pose is None or not pose.known:
        return UNSET
    return f"x {pose.x:.2f} m, y {pose.y:.2f} m"


def orientation_text(pose: PoseMsg | None) -> str:
    if pose is None or not pose.known:
        return UNSET
    return f"{math.degrees(pose.yaw):.1f}° ({pose.yaw:.3f} rad)"


#: What the station shows for each localisation state (interbot_core.topics.POSE_STATES).
LOCALISATION_TEXT = {
    "ok": "localised",
    "degraded": "DEGRADED (uncertain: driving slowly)",
    "lost": "LOST",
    "searching": "searching (global localisation)",
    "turning": "searching (global localisation): turning to find my position…",
    "unset": "initial pose not set",
}


def localisation_text(state: str, pose: PoseMsg | None) -> str:
    """The localisation line: the state, the confidence and the pose's sigmas when reported
    (the largest position sigma in cm, the heading's in degrees)."""
    text = LOCALISATION_TEXT.get(state, state)
    if pose is None:
        return text
    text += f" (confidence {pose.confidence:.2f})"
    sigmas = pose.sigmas
    if sigmas is not None:
        text += f", ±{max(sigmas[0], sigmas[1]) * 100:.0f} cm, ±{math.degrees(sigmas[2]):.1f}°"
    return text


def age_text(seconds: float) -> str:
    """A duration for a person: "0.35 s", "12 s", "3 min 24 s", "2 h 5 min"; inf is "never"."""
    if not math.isfinite(seconds):
        return "never"
    seconds = max(0.0, seconds)
    if seconds < 10.0:
        return f"{seconds:.2f} s"
    if seconds < 60.0:
        return f"{seconds:.0f} s"
    minutes, secs = divmod(int(seconds), 60)
    if minutes < 60:
        return f"{minutes} min {secs} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes} min"


def estop_text(station_latched: bool, robot_engaged: bool | None) -> tuple[str, bool]:
    """The emergency-stop line and whether it is an alarm (drawn red).

    ``robot_engaged`` is the robot's own report (None: no report from the robot).
    """
    if station_latched:
        if robot_engaged is None:
            return "ENGAGED at the station; no answer from the robot yet", True
        if robot_engaged:
            return "ENGAGED: robot stopped (release at the station)", True
        return "ENGAGED at the station, but the robot has not stopped yet: re-sending", True
    if robot_engaged:
        return "released at the station, but the robot is still stopped", True
    return "released", False
