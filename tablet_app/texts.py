"""The sentences the tablet says about the robot, in plain words and in the UI language.

`TabletSession` keeps outcomes as keys (`Notice`) and the station's supervisor state as it was
sent; this module turns them into what a visitor reads ("On my way to the Library, 12 m to
go", not "navigating, 12.3 m to the next goal"). Every sentence goes through
``QCoreApplication.translate("TabletTexts", ...)`` so ``pyside6-lupdate`` finds it and the
Portuguese catalogue covers it.
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6.QtCore import QCoreApplication

from tablet_app.tablet_session import Notice, TabletSession


def _fill(template: str, *args: str) -> str:
    for i, arg in enumerate(args, start=1):
        template = template.replace(f"%{i}", arg)
    return template


def malfunction_kind_text(kind: str) -> str:
    return {
        "collision": QCoreApplication.translate("TabletTexts", "a collision"),
        "wrong_position": QCoreApplication.translate("TabletTexts", "a wrong position"),
        "wrong_orientation": QCoreApplication.translate("TabletTexts", "a wrong orientation"),
        "other": QCoreApplication.translate("TabletTexts", "a problem"),
    }.get(kind, kind)


def notice_text(room_name: Callable[[int], str], notice: Notice) -> str:
    """The outcome sentence for ``notice`` (unknown keys are shown as they are)."""
    a = tuple(room_name(v) if isinstance(v, int) else v for v in notice.args)
    templates = {
        "arrived": QCoreApplication.translate("TabletTexts", "Arrived at %1."),
        "cancelled": QCoreApplication.translate("TabletTexts", "Cancelled. I have stopped."),
        "cancelled_by_operator": QCoreApplication.translate(
            "TabletTexts", "The operator cancelled the task: %1"
        ),
        "still_going": QCoreApplication.translate(
            "TabletTexts", "The Base Station is still taking me to %1: ask the operator."
        ),
        "help_checking": QCoreApplication.translate("TabletTexts", "Checking that I am at %1…"),
        "help_thanks": QCoreApplication.translate("TabletTexts", "Thank you! I am at %1."),
        "help_failed": QCoreApplication.translate(
            "TabletTexts", "I could not confirm that I am at %1. Please try another room."
        ),
        "report_sent": QCoreApplication.translate(
            "TabletTexts", "Thank you: the operator has your report of %1."
        ),
        "request_sent": QCoreApplication.translate(
            "TabletTexts", "Request sent: I will bring “%1” from %2 to %3."
        ),
        "request_accepted": QCoreApplication.translate("TabletTexts", "Thank you! I am on my way."),
        "request_declined": QCoreApplication.translate(
            "TabletTexts", "Declined. I will tell the person who asked."
        ),
        "tour_requested": QCoreApplication.translate("TabletTexts", "Guided tour requested."),
        "tour_ended": QCoreApplication.translate("TabletTexts", "The guided tour has ended."),
        "refused": QCoreApplication.translate("TabletTexts", "Refused by the Base Station: %1"),
        "station_error": QCoreApplication.translate("TabletTexts", "The Base Station says: %1"),
        "not_sent": QCoreApplication.translate("TabletTexts", "Not connected: nothing was sent."),
    }
    if notice.key == "report_sent":
        return _fill(templates["report_sent"], malfunction_kind_text(a[0] if a else ""))
    if notice.key == "help_failed" and len(a) > 1 and a[1]:
        return _fill(templates["help_failed"], a[0]) + " (" + a[1] + ")"
    template = templates.get(notice.key)
    return " ".join(a) if template is None else _fill(template, *a)


def activity_text(room_name: Callable[[int], str], session: TabletSession) -> str:
    """What the robot is doing, for anyone passing by."""
    s = session
    if not s.connected:
        return QCoreApplication.translate("TabletTexts", "Not connected to the Base Station")
    if s.estop:
        return QCoreApplication.translate("TabletTexts", "Stopped by the operator")
    if s.lost:
        return QCoreApplication.translate("TabletTexts", "I do not know where I am")
    if s.localisation == "searching":
        return QCoreApplication.translate("TabletTexts", "Finding my position…")
    if s.localisation == "turning":
        return QCoreApplication.translate("TabletTexts", "Turning to find my position…")
    goal = room_name(s.goal.room) if s.goal is not None else None
    state = s.activity
    if state == "navigating":
        text = (
            _fill(QCoreApplication.translate("TabletTexts", "On my way to %1"), goal)
            if goal
            else QCoreApplication.translate("TabletTexts", "On my way")
        )
        if s.activity_distance is not None:
            metres = f"{s.activity_distance:.0f}"
            text += ", " + _fill(QCoreApplication.translate("TabletTexts", "%1 m to go"), metres)
        return text
    plain = {
        "idle": QCoreApplication.translate("TabletTexts", "Ready"),
        "waiting for pose": QCoreApplication.translate("TabletTexts", "Waiting to know where I am"),
        "paused": QCoreApplication.translate("TabletTexts", "Paused"),
        "at tour stop": QCoreApplication.translate(
            "TabletTexts", "At a tour stop: waiting for you"
        ),
        "awaiting response": QCoreApplication.translate(
            "TabletTexts", "Waiting for an answer at the room"
        ),
        "emergency stop engaged": QCoreApplication.translate(
            "TabletTexts", "Stopped by the operator"
        ),
    }
    return plain.get(state, state)


def unavailable_text(teleop: bool, goals: bool, tours: bool, requests: bool) -> str:
    """What the station does not allow now, said plainly (empty when everything is allowed)."""
    names = [
        name
        for allowed, name in (
            (teleop, QCoreApplication.translate("TabletTexts", "driving with the joystick")),
            (goals, QCoreApplication.translate("TabletTexts", "trips to rooms")),
            (tours, QCoreApplication.translate("TabletTexts", "guided tours")),
            (requests, QCoreApplication.translate("TabletTexts", "requests")),
        )
        if not allowed
    ]
    if not names:
        return ""
    return _fill(
        QCoreApplication.translate("TabletTexts", "Not available now: %1"), ", ".join(names)
    )
