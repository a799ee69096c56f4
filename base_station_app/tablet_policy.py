"""The station's rules for the one controlling tablet: what it may do, and what it owns.

Thesis §5.3.1: the operator decides "if the requests from the Tablet should be accepted or not,
and which type of requests are allowed" (the protocol's `Permissions`, sent as they are). Issue
14 adds ownership: the tablet cancels only the tasks it ordered (identity of the task object,
whatever robot runs it), its stop pauses an operator's task instead, and nothing it orders is
accepted while it could not work (robot offline, emergency stop). The tablet is bound to the robot the operator
commands (the selected one): its tasks go to that robot's supervisor. Plain Python, no Qt.
"""

from __future__ import annotations

from typing import Final

import msgspec

from interbot_core.protocol import Permissions
from interbot_core.supervisor import Task

PERMISSION_KINDS: Final = Permissions.__struct_fields__  # teleop, goals, tours, requests
EVERYTHING: Final = Permissions(True, True, True, True)  # the default, as in the thesis's tests
NOTHING: Final = Permissions(False, False, False, False)


def allows(permissions: Permissions, kind: str | None) -> bool:
    """Whether ``permissions`` allow a message needing ``kind`` (None: needs none)."""
    if kind is None:
        return True
    if kind not in PERMISSION_KINDS:
        raise ValueError(f"unknown permission {kind!r}; known: {list(PERMISSION_KINDS)}")
    return bool(getattr(permissions, kind))


def with_kind(permissions: Permissions, kind: str, allowed: bool) -> Permissions:
    """``permissions`` with ``kind`` allowed or not (the name is checked)."""
    allows(permissions, kind)
    return msgspec.structs.replace(permissions, **{kind: allowed})


class TabletPolicy:
    """Permissions chosen by the operator and the tasks the tablet ordered."""

    def __init__(self) -> None:
        self.permissions = EVERYTHING
        self.tasks: list[Task] = []  # tasks the tablet ordered (identity matters)

    def effective(self, robot_online: bool, estop_latched: bool) -> Permissions:
        """What the tablet may do now: the operator's choice, and only what can work.

        During a stop nothing the tablet orders could start: refused, with the reason, rather
        than queued to start the moment the stop is released.
        """
        if not robot_online or estop_latched:
            return NOTHING
        return self.permissions

    def refusal(self, kind: str | None, robot_online: bool, estop_latched: bool) -> str | None:
        """Why a message needing ``kind`` is refused now, or None when it is allowed."""
        if allows(self.effective(robot_online, estop_latched), kind):
            return None
        if not robot_online:
            return f"the robot is offline: {kind} cannot work"
        if allows(self.permissions, kind):
            return f"emergency stop engaged: {kind} ignored"
        return f"the operator does not allow {kind} from the tablet"

    def owns(self, task: Task | None) -> bool:
        return task is not None and any(t is task for t in self.tasks)

    def adopt(self, task: Task) -> None:
        self.tasks.append(task)

    def forget(self, task: Task) -> None:
        self.tasks = [t for t in self.tasks if t is not task]
