"""The sentences the tablet says about the robot, in plain words and in the UI language.

`TabletSession` keeps outcomes as keys (`Notice`) and the station's supervisor state as it was
sent; this module turns them into what a visitor reads ("On my way to the Library, 12 m to
go", not "navigating, 12.3 m to the next goal"). Every sentence goes through
``QCoreApplication.translate("TabletTexts", ...)`` so ``pyside6-lupdate`` finds it and the
Portuguese catalogue covers it.
"""

from __future__ import annotations

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


def notice_text(_widget: object, notice: Notice) -> str:
    """The outcome sentence for ``notice`` (unknown keys are shown as they are)."""
    a = notice.args
    tr = QCoreApplication.translate
    templates = {
        "arrived": tr("TabletTexts", "Arrived at %1."),
        "cancelled": tr("TabletTexts", "Cancelled. I have stopped."),
        "cancelled_by_operator": tr("TabletTexts", "The operator cancelled the task: %1"),
        "still_going": tr(
            "TabletTexts", "The Base Station is still taking me to %1: ask the operator."
        ),
        "help_checking": tr("TabletTexts", "Checking that I am at %1…"),
        "help_thanks": tr("TabletTexts", "Thank you! I am at %1."),
        "help_failed": tr(
            "TabletTexts", "I could not confirm that I am at %1. Please try another room."
        ),
        "report_sent": tr("TabletTexts", "Thank you: the operator has your report of %1."),
        "request_sent": tr("TabletTexts", "Request sent: I will bring “%1” from %2 to %3."),
        "request_accepted": tr("TabletTexts", "Thank you! I am on my way."),
        "request_declined": tr("TabletTexts", "Declined. I will tell the person who asked."),
        "tour_requested": tr("TabletTexts", "Guided tour requested."),
        "tour_ended": tr("TabletTexts", "The guided tour has ended."),
        "refused": tr("TabletTexts", "Refused by the Base Station: %1"),
        "station_error": tr("TabletTexts", "The Base Station says: %1"),
        "not_sent": tr("TabletTexts", "Not connected: nothing was sent."),
    }
    if notice.key == "report_sent":
        return _fill(templates["report_sent"], malfunction_kind_text(a[0] if a else ""))
    if notice.key == "help_failed" and len(a) > 1 and a[1]:
        return _fill(templates["help_failed"], a[0]) + " (" + a[1] + ")"
    template = templates.get(notice.key)
    return " ".join(a) if template is None else _fill(template, *a)


def activity_text(_widget: object, session: TabletSession) -> str:
    """What the robot is doing, for anyone passing by."""
    tr = QCoreApplication.translate
    s = session
    if not s.connected:
        return tr("TabletTexts", "Not connected to the Base Station")
    if s.estop:
        return tr("TabletTexts", "Stopped by the operator")
    if s.lost:
        return tr("TabletTexts", "I do not know where I am")
    if s.localisation == "searching":
        return tr("TabletTexts", "Finding my position…")
    goal = s.room_names(s.goal.room) if s.goal is not None else None
    state = s.activity
    if state == "navigating":
        text = (
            _fill(tr("TabletTexts", "On my way to %1"), goal)
            if goal
            else tr("TabletTexts", "On my way")
        )
        if s.activity_distance is not None:
            metres = f"{s.activity_distance:.0f}"
            text += ", " + _fill(tr("TabletTexts", "%1 m to go"), metres)
        return text
    plain = {
        "idle": tr("TabletTexts", "Ready"),
        "waiting for pose": tr("TabletTexts", "Waiting to know where I am"),
        "paused": tr("TabletTexts", "Paused"),
        "at tour stop": tr("TabletTexts", "At a tour stop: waiting for you"),
        "awaiting response": tr("TabletTexts", "Waiting for an answer at the room"),
        "emergency stop engaged": tr("TabletTexts", "Stopped by the operator"),
    }
    return plain.get(state, state)
