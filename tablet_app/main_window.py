"""The Tablet's main window: composition root of its screens (thesis §4.2.1, §5.2, Fig. 5.1).

A header (connection state, latency, status text), a `QStackedWidget` with the main menu, the
joystick and the map, and the motion bar while the robot moves. Like the thesis's mainWidget it
turns user actions into protocol messages sent through `TabletConnection` and Base Station
messages into what the screens show; it holds no protocol framing or robot logic.
"""

from __future__ import annotations

import logging
import math

from PySide6.QtCore import QEvent, Qt
from PySide6.QtGui import QCloseEvent, QResizeEvent
from PySide6.QtWidgets import (
    QDialog,
    QFrame,
    QHBoxLayout,
    QLabel,
    QMainWindow,
    QStackedWidget,
    QVBoxLayout,
    QWidget,
)

from interbot_core.occupancy_grid import OccupancyGrid
from interbot_core.protocol import (
    Cancel,
    ErrorReport,
    Goal,
    GoalStatus,
    Home,
    InitialPose,
    InitialPoseRoom,
    Localisation,
    Malfunction,
    Message,
    Pause,
    Permissions,
    Pose,
    RequestAnswer,
    RequestFrom,
    ShowRequest,
    StatusInfo,
    Stop,
    Tour,
    TourControl,
    TourState,
)
from tablet_app.floor_plan import FloorPlan
from tablet_app.qt_dialogs import (
    QtHelpConfirmDialog,
    QtMalfunctionDialog,
    QtRequestDialog,
    QtRoomDialog,
    QtShowRequestDialog,
    QtTourStopDialog,
)
from tablet_app.qt_joystick_screen import QtJoystickScreen
from tablet_app.qt_main_menu import QtMainMenu
from tablet_app.qt_map_screen import QtMapScreen
from tablet_app.qt_map_view import QtMapView
from tablet_app.qt_motion_bar import QtMotionBar
from tablet_app.tablet_connection import ConnectionState, TabletConnection
from tablet_app.translations import LanguageSwitcher
from tablet_app.ui_metrics import font_px, touch_target_px

logger = logging.getLogger(__name__)

STYLE = """
QWidget {{ font-size: {font}px; }}
QMainWindow, QDialog {{ background: #f4f5f7; }}
QPushButton {{ min-height: {touch}px; min-width: {touch}px; padding: 2px {pad}px;
  border-radius: {radius}px; background: #2d6cdf; color: white; }}
QPushButton:disabled {{ background: #9aa3b0; }}
QPushButton#big {{ min-height: {big}px; font-size: {font_big}px; font-weight: bold; }}
QPushButton#helpButton {{ background: #d00000; font-weight: bold; }}
QLabel#title {{ font-size: {font_big}px; font-weight: bold; }}
QLabel#warning {{ color: white; background: #c00000; padding: {pad}px; font-weight: bold; }}
QFrame#helpBanner {{ background: #ffd24a; border-radius: {radius}px; }}
QFrame#motionBar, QFrame#header {{ background: #dde6f5; }}
QLineEdit, QComboBox {{ min-height: {touch}px; }}
QRadioButton {{ min-height: {touch}px; }}
QRadioButton::indicator {{ width: {font}px; height: {font}px; }}
QProgressBar {{ min-height: {half}px; }}
"""


class TabletWindow(QMainWindow):
    """Header + screens + motion bar; translates between the user and the connection."""

    def __init__(
        self,
        connection: TabletConnection,
        plan: FloorPlan,
        grid: OccupancyGrid | None = None,
        languages: LanguageSwitcher | None = None,
        parent: QWidget | None = None,
    ) -> None:
        super().__init__(parent)
        self.connection = connection
        self.plan = plan
        self.languages = languages or LanguageSwitcher(parent=self)
        self._goal: int | None = None
        self._goal_start_distance: float | None = None
        self._last_goal_status: GoalStatus | None = None
        self._pose: tuple[float, float, float] | None = None
        self._initial_pose_unset = False
        self._localisation = "ok"
        self._helping = False
        self._permissions = Permissions(True, True, True, True)
        self._status_text = ""
        self._connection_detail = ""
        self._touch = 0
        self.dialog: QDialog | None = None  # the open dialog, if any
        self._create_widgets(grid)
        self._connect_signals()
        self._update_connection_text()
        self._update_help()
        self.retranslate()

    # ---------------------------------------------------------------- construction
    def _create_widgets(self, grid: OccupancyGrid | None) -> None:
        self.header = QFrame()
        self.header.setObjectName("header")
        self.connection_label = QLabel()
        self.status_label = QLabel()
        self.status_label.setAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
        header = QHBoxLayout(self.header)
        header.addWidget(self.connection_label, 1)
        header.addWidget(self.status_label, 1)
        self.menu = QtMainMenu()
        self.joystick_screen = QtJoystickScreen(self.connection)
        self.map_view = QtMapView(self.plan, grid)
        self.map_screen = QtMapScreen(self.map_view)
        self.stack = QStackedWidget()
        for screen in (self.menu, self.joystick_screen, self.map_screen):
            self.stack.addWidget(screen)
        self.motion_bar = QtMotionBar()
        self.motion_bar.setVisible(False)
        central = QWidget()
        layout = QVBoxLayout(central)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(0)
        layout.addWidget(self.header)
        layout.addWidget(self.stack, 1)
        layout.addWidget(self.motion_bar)
        self.setCentralWidget(central)

    def _connect_signals(self) -> None:
        c = self.connection
        c.state_changed.connect(lambda _state: self._update_connection_text())
        c.reconnect_scheduled.connect(self._on_reconnect_scheduled)
        c.latency_changed.connect(self._on_latency)
        c.refused.connect(self._on_refused)
        c.pose_received.connect(self._on_pose)
        c.initial_pose_received.connect(self._on_initial_pose)
        c.localisation_received.connect(self._on_localisation)
        c.goal_status_received.connect(self._on_goal_status)
        c.tour_state_received.connect(self._on_tour_state)
        c.request_shown.connect(self._on_show_request)
        c.cancel_received.connect(self._on_cancel)
        c.permissions_received.connect(self._on_permissions)
        c.status_received.connect(self._on_status)
        c.error_received.connect(self._on_error)

        self.menu.joystick_requested.connect(self.show_joystick)
        self.menu.map_requested.connect(self.show_map)
        self.menu.home_requested.connect(self.go_home)
        self.menu.malfunction_requested.connect(self.open_malfunction_dialog)
        self.menu.language_requested.connect(self.languages.set_language)
        self.joystick_screen.back_requested.connect(self._joystick_back)
        self.map_screen.back_requested.connect(self.show_menu)
        self.map_screen.tour_requested.connect(lambda: self._send(Tour(True)))
        self.map_screen.home_requested.connect(self.go_home)
        self.map_screen.help_requested.connect(self._start_helping)
        self.map_screen.joystick_requested.connect(self.show_joystick)
        self.map_view.room_clicked.connect(self.on_room_clicked)
        self.motion_bar.pause_requested.connect(lambda: self._pause(True))
        self.motion_bar.resume_requested.connect(lambda: self._pause(False))
        self.motion_bar.cancel_requested.connect(self._cancel_motion)
        self.motion_bar.manual_requested.connect(self.show_joystick)

    # ---------------------------------------------------------------- navigation between screens
    def show_menu(self) -> None:
        self.stack.setCurrentWidget(self.menu)

    def show_map(self) -> None:
        self.stack.setCurrentWidget(self.map_screen)

    def show_joystick(self) -> None:
        self.stack.setCurrentWidget(self.joystick_screen)

    def _joystick_back(self) -> None:
        # While helping or moving, the map is where the user came from.
        if self._helping or self._goal is not None:
            self.show_map()
        else:
            self.show_menu()

    def _open(self, dialog: QDialog) -> None:
        if self.dialog is not None:
            self.dialog.close()
        self.dialog = dialog
        dialog.setAttribute(Qt.WidgetAttribute.WA_DeleteOnClose)
        dialog.finished.connect(lambda _r, d=dialog: self._dialog_closed(d))
        self._size_dialog(dialog)
        dialog.open()

    def _dialog_closed(self, dialog: QDialog) -> None:
        if self.dialog is dialog:
            self.dialog = None

    def _size_dialog(self, dialog: QDialog) -> None:
        dialog.resize(max(320, int(self.width() * 0.6)), max(240, int(self.height() * 0.5)))

    # ---------------------------------------------------------------- user actions
    def _send(self, msg: Message) -> bool:
        sent = self.connection.send(msg)
        if not sent:
            self._set_status(self.tr("Not connected: the command was not sent."))
        return sent

    def on_room_clicked(self, room_id: int) -> None:
        room = self.plan.room(room_id)
        if self._lost and self._helping:
            dialog = QtHelpConfirmDialog(room, self)
            dialog.confirmed.connect(self._set_initial_room)
            self._open(dialog)
            return
        perms = self._permissions
        room_dialog = QtRoomDialog(room, perms.goals and not self._lost, perms.requests, self)
        room_dialog.go_requested.connect(self.go_to)
        room_dialog.request_requested.connect(self._open_request_dialog)
        self._open(room_dialog)

    def go_to(self, room_id: int) -> None:
        if self._send(Goal(room_id)):
            self._start_goal(room_id)

    def go_home(self) -> None:
        if self._send(Home()):
            home = next((r.id for r in self.plan.rooms if r.home), None)
            if home is None and self.plan.rooms:
                home = self.plan.rooms[0].id
            if home is not None:
                self._start_goal(home)

    def _open_request_dialog(self, room_id: int) -> None:
        dialog = QtRequestDialog(self.plan.room(room_id), self.plan, self)
        dialog.request_submitted.connect(self._send_request)
        self._open(dialog)

    def _send_request(self, text: str, room_id: int, deliver_to: int) -> None:
        if self._send(RequestFrom(text, room_id, deliver_to, True)):
            self._start_goal(room_id)

    def _pause(self, paused: bool) -> None:
        if self._send(Pause(paused)):
            self.motion_bar.set_paused(paused)

    def _cancel_motion(self) -> None:
        if self._send(Stop(True)):
            self._end_goal()

    def _start_helping(self) -> None:
        self._helping = True
        self._update_help()

    def _set_initial_room(self, room_id: int) -> None:
        if self._send(InitialPoseRoom(room_id)):
            self._helping = False
            self._initial_pose_unset = False
            self._localisation = "ok"
            self._update_help()
            self._set_status(
                self.tr("Thank you! I am at %1.").replace("%1", self.plan.name(room_id))
            )

    def open_malfunction_dialog(self) -> None:
        dialog = QtMalfunctionDialog(self)
        dialog.submitted.connect(lambda kind, text: self._send(Malfunction(kind, text)))
        self._open(dialog)

    # ---------------------------------------------------------------- goal progress
    def _start_goal(self, room_id: int) -> None:
        self._goal = room_id
        self._goal_start_distance = self._distance_to_goal()
        self.motion_bar.set_destination(self.plan.name(room_id))
        self.motion_bar.set_progress(0)
        self.motion_bar.set_paused(False)
        self.motion_bar.setVisible(True)

    def _end_goal(self) -> None:
        self._goal = None
        self._goal_start_distance = None
        self.motion_bar.setVisible(False)

    def _distance_to_goal(self) -> float | None:
        if self._goal is None or self._pose is None:
            return None
        try:
            room = self.plan.room(self._goal)
        except KeyError:
            return None
        return math.hypot(room.x - self._pose[0], room.y - self._pose[1])

    def _update_progress(self) -> None:
        distance = self._distance_to_goal()
        if distance is None:
            return
        if self._goal_start_distance is None or distance > self._goal_start_distance:
            self._goal_start_distance = distance
        start = self._goal_start_distance
        percent = 100 if start < 1e-6 else round(100.0 * (1.0 - distance / start))
        self.motion_bar.set_progress(percent)

    # ---------------------------------------------------------------- Base Station messages
    def _on_pose(self, pose: Pose) -> None:
        self._pose = (pose.x, pose.y, pose.angle)
        self.map_view.set_robot_pose(pose.x, pose.y, pose.angle)
        if self._initial_pose_unset:
            self._initial_pose_unset = False
            self._update_help()
        self._update_progress()

    def _on_initial_pose(self, msg: InitialPose) -> None:
        self._initial_pose_unset = not msg.is_set
        if not msg.is_set:
            self.map_view.clear_robot()
        self._update_help()

    def _on_localisation(self, msg: Localisation) -> None:
        self._localisation = msg.state
        self._update_help()

    @property
    def _lost(self) -> bool:
        return self._initial_pose_unset or self._localisation in ("unset", "lost")

    def _update_help(self) -> None:
        if not self._lost:
            self._helping = False
        self.map_screen.set_help_state(
            self._lost, self._helping, searching=self._localisation == "searching"
        )

    def _on_goal_status(self, msg: GoalStatus) -> None:
        repeated = msg == self._last_goal_status
        self._last_goal_status = msg
        name = self.plan.name(msg.goal)
        if msg.tour_reached:
            if repeated:
                # The station repeats its goal state every clock(): one dialog per stop, and
                # none re-opened by a repeat still in flight after Resume / End tour.
                return
            self._end_goal()
            try:
                room = self.plan.room(msg.goal)
            except KeyError:
                return
            dialog = QtTourStopDialog(room, self)
            dialog.resume_requested.connect(lambda: self._send(TourControl("resume")))
            dialog.end_requested.connect(lambda: self._send(TourControl("end")))
            self._open(dialog)
        elif msg.reached:
            self._end_goal()
            self._set_status(self.tr("Arrived at %1.").replace("%1", name))
        elif self._goal != msg.goal or not self.motion_bar.isVisible():
            self._start_goal(msg.goal)

    def _on_tour_state(self, msg: TourState) -> None:
        self.map_view.set_tour(set(msg.visited), msg.next)

    def _on_show_request(self, msg: ShowRequest) -> None:
        dialog = QtShowRequestDialog(msg, self.plan, self)
        dialog.answered.connect(lambda rid, ok: self._send(RequestAnswer(rid, ok)))
        self._open(dialog)

    def _on_cancel(self, msg: Cancel) -> None:
        if self.dialog is not None:
            self.dialog.close()
        self._end_goal()
        self._set_status(self.tr("Cancelled by the operator: %1").replace("%1", msg.reason))

    def _on_permissions(self, perms: Permissions) -> None:
        self._permissions = perms
        self.menu.joystick_button.setEnabled(perms.teleop)
        self.map_screen.drive_button.setEnabled(perms.teleop)
        self.motion_bar.manual_button.setEnabled(perms.teleop)
        self.joystick_screen.joystick.setEnabled(perms.teleop)
        self.map_screen.tour_button.setEnabled(perms.tours)
        self.menu.home_button.setEnabled(perms.goals)
        self.map_screen.home_button.setEnabled(perms.goals)

    def _on_status(self, msg: StatusInfo) -> None:
        self._set_status(msg.message)
        if isinstance(self.dialog, QtShowRequestDialog):
            self.dialog.set_status(msg.message)

    def _on_error(self, msg: ErrorReport) -> None:
        self._set_status(self.tr("Base Station: %1").replace("%1", msg.message))

    def _on_refused(self, reason: str) -> None:
        self._set_status(self.tr("Refused by the Base Station: %1").replace("%1", reason))

    def _set_status(self, text: str) -> None:
        self._status_text = text
        self.status_label.setText(text)

    # ---------------------------------------------------------------- connection display
    def _on_reconnect_scheduled(self, delay: float) -> None:
        self._connection_detail = f"{delay:.1f}"
        self._update_connection_text()

    def _on_latency(self, latency_ms: float) -> None:
        self.menu.set_latency(latency_ms)
        self._update_connection_text()

    def _update_connection_text(self) -> None:
        state = self.connection.state
        target = f"{self.connection.host}:{self.connection.port}"
        if state == ConnectionState.CONNECTED:
            text = self.tr("Connected to %1").replace("%1", target)
            latency = self.connection.average_latency_ms
            if latency is not None:
                text += " · " + self.tr("%1 ms").replace("%1", f"{latency:.0f}")
        elif state == ConnectionState.CONNECTING:
            text = self.tr("Connecting to %1…").replace("%1", target)
        elif state == ConnectionState.WAITING:
            text = self.tr("Disconnected: reconnecting in %1 s").replace(
                "%1", self._connection_detail
            )
        else:
            text = self.tr("Disconnected")
        self.connection_label.setText(text)
        self.menu.set_connection_text(text)

    # ---------------------------------------------------------------- look and language
    def apply_metrics(self) -> None:
        """Touch targets of at least 9 mm, growing with the window (ui_metrics)."""
        touch = touch_target_px(self.logicalDpiX(), self.width(), self.height())
        if touch == self._touch:
            return
        self._touch = touch
        font = font_px(touch)
        self.setStyleSheet(
            STYLE.format(
                font=font,
                font_big=round(font * 1.35),
                touch=touch,
                big=touch * 2,
                half=touch // 2,
                pad=max(4, touch // 6),
                radius=max(4, touch // 8),
            )
        )
        self.map_view.set_min_touch(touch)

    def resizeEvent(self, event: QResizeEvent) -> None:
        self.apply_metrics()
        if self.dialog is not None:
            self._size_dialog(self.dialog)
        super().resizeEvent(event)

    def retranslate(self) -> None:
        self.setWindowTitle(self.tr("Interbot Tablet"))
        self._update_connection_text()

    def changeEvent(self, event: QEvent) -> None:
        if event.type() == QEvent.Type.LanguageChange:
            self.retranslate()
        super().changeEvent(event)

    def closeEvent(self, event: QCloseEvent) -> None:
        self.connection.stop()
        super().closeEvent(event)
