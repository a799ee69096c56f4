"""The Tablet's main window: composition root of its screens (thesis §4.2.1, §5.2, Fig. 5.1).

A header (connection state, latency, what the robot is doing, the last outcome, and "Help me!"
whenever the robot is lost, on every screen), a `QStackedWidget` with the main menu, the joystick
and the map, and the motion bar while the robot takes someone somewhere. Like the thesis's
mainWidget it turns user actions into protocol messages sent through `TabletConnection`; what
the screens show comes from one Qt-free `TabletSession`, which every Base Station message
updates and which this window renders after each change. No screen keeps its own copy of the
robot's state.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

from PySide6.QtCore import Qt, QTimer
from PySide6.QtGui import QCloseEvent, QMouseEvent, QResizeEvent
from PySide6.QtWidgets import (
    QDialog,
    QFrame,
    QHBoxLayout,
    QLabel,
    QMainWindow,
    QMessageBox,
    QPushButton,
    QStackedWidget,
    QVBoxLayout,
    QWidget,
)

from interbot_core.occupancy_grid import OccupancyGrid
from interbot_core.protocol import (
    Cancel,
    Goal,
    Home,
    InitialPoseRoom,
    Malfunction,
    Message,
    Pause,
    Permissions,
    RequestAnswer,
    RequestFrom,
    StationMessage,
    StatusInfo,
    Stop,
    Tour,
    TourControl,
)
from interbot_core.rooms import RoomMap
from tablet_app.kiosk import CORNER_PX, ExitGesture
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
from tablet_app.tablet_session import Help, TabletSession
from tablet_app.texts import activity_text, notice_text, unavailable_text
from tablet_app.translations import LanguageSwitcher, Retranslated
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
QComboBox QAbstractItemView::item {{ min-height: {touch}px; }}
QRadioButton {{ min-height: {touch}px; }}
QRadioButton::indicator {{ width: {half}px; height: {half}px; }}
QProgressBar {{ min-height: {half}px; }}
"""


class TabletWindow(Retranslated, QMainWindow):
    """Header + screens + motion bar; renders the session, sends what the user asks."""

    def __init__(
        self,
        connection: TabletConnection,
        plan: RoomMap,
        grid: OccupancyGrid | None = None,
        languages: LanguageSwitcher | None = None,
        parent: QWidget | None = None,
        clock: Callable[[], float] = time.monotonic,
        dpi: float | None = None,
    ) -> None:
        super().__init__(parent)
        self.dpi_override = dpi  # [dots per inch] the tablet's real screen, when Qt cannot tell
        self.connection = connection
        self.plan = plan
        self.clock = clock
        self.languages = languages or LanguageSwitcher(parent=self)
        self.shown_plan = plan.in_language(self.languages.language)
        self.session = TabletSession(room_xy=plan.node_xy, home_room=plan.topo.home_id)
        self._connection_detail = ""
        self._touch = 0
        self.kiosk = False  # set by `tablet_app.main.show_kiosk`: closing needs the gesture
        self._exit_gesture = ExitGesture()
        self._may_close = False
        self.dialog: QDialog | None = None  # the open dialog, if any
        self._create_widgets(grid)
        self._connect_signals()
        self.session.subscribe(self.render)
        self._tick = QTimer(self)
        self._tick.setInterval(250)
        self._tick.timeout.connect(lambda: self.session.tick(self.clock()))
        self._tick.start()
        self.render()
        self.retranslate()

    # ---------------------------------------------------------------- construction
    def _create_widgets(self, grid: OccupancyGrid | None) -> None:
        self.header = QFrame()
        self.header.setObjectName("header")
        self.connection_label = QLabel()
        self.activity_label = QLabel()
        self.activity_label.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.status_label = QLabel()  # the last outcome ("Arrived at ...", a refusal)
        self.status_label.setWordWrap(True)
        self.status_label.setAlignment(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
        self.help_button = QPushButton()
        self.help_button.setObjectName("helpButton")
        self.unavailable_label = QLabel()  # why some buttons are greyed out
        self.unavailable_label.setObjectName("unavailable")
        self.unavailable_label.setWordWrap(True)
        header = QHBoxLayout(self.header)
        header.addWidget(self.connection_label, 1)
        header.addWidget(self.activity_label, 1)
        header.addWidget(self.status_label, 1)
        header.addWidget(self.unavailable_label, 1)
        header.addWidget(self.help_button)
        self.menu = QtMainMenu()
        self.joystick_screen = QtJoystickScreen(self.connection)
        self.map_view = QtMapView(self.shown_plan, grid)
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
        c, s = self.connection, self.session
        c.state_changed.connect(lambda _state: self._update_connection_text())
        c.connected.connect(s.on_connected)
        c.disconnected.connect(s.on_disconnected)
        c.reconnect_scheduled.connect(self._on_reconnect_scheduled)
        c.latency_changed.connect(self._on_latency)
        c.refused.connect(s.on_refused)
        c.message_received.connect(self._on_message)
        c.robot_name_changed.connect(s.on_robot_name)
        c.robot_name_changed.connect(lambda _name: self._update_connection_text())

        self.menu.joystick_requested.connect(self.show_joystick)
        self.menu.map_requested.connect(self.show_map)
        self.menu.home_requested.connect(self.go_home)
        self.menu.malfunction_requested.connect(self.open_malfunction_dialog)
        self.menu.language_requested.connect(self.languages.set_language)
        self.help_button.clicked.connect(self._start_helping)
        self.joystick_screen.back_requested.connect(self._joystick_back)
        self.map_screen.back_requested.connect(self.show_menu)
        self.map_screen.tour_requested.connect(self._start_tour)
        self.map_screen.home_requested.connect(self.go_home)
        self.map_screen.help_requested.connect(self._start_helping)
        self.map_screen.joystick_requested.connect(self.show_joystick)
        self.map_view.room_clicked.connect(self.on_room_clicked)
        self.motion_bar.pause_requested.connect(lambda: self._pause(True))
        self.motion_bar.resume_requested.connect(lambda: self._pause(False))
        self.motion_bar.cancel_requested.connect(self._cancel_motion)
        self.motion_bar.manual_requested.connect(self.show_joystick)

    def room_name(self, room_id: int) -> str:
        """The room's name in the UI language (``name_pt`` in the topological map)."""
        return self.shown_plan.name(room_id)

    # ---------------------------------------------------------------- navigation between screens
    def show_menu(self) -> None:
        self.stack.setCurrentWidget(self.menu)

    def show_map(self) -> None:
        self.stack.setCurrentWidget(self.map_screen)

    def show_joystick(self) -> None:
        self.stack.setCurrentWidget(self.joystick_screen)

    def _joystick_back(self) -> None:
        # While helping or moving, the map is where the user came from.
        if self.session.help is Help.CHOOSING or self.session.goal is not None:
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

    def _close_dialog(self, kind: type[QDialog]) -> None:
        if isinstance(self.dialog, kind):
            self.dialog.close()

    def _dialog_closed(self, dialog: QDialog) -> None:
        if self.dialog is dialog:
            self.dialog = None
        if isinstance(dialog, QtShowRequestDialog):
            self.session.request_closed()

    def _size_dialog(self, dialog: QDialog) -> None:
        if getattr(dialog, "HAS_KEYBOARD", False):
            dialog.resize(int(self.width() * 0.85), int(self.height() * 0.95))
        else:
            dialog.resize(max(320, int(self.width() * 0.6)), max(240, int(self.height() * 0.5)))

    # ---------------------------------------------------------------- user actions
    def _send(self, msg: Message) -> bool:
        sent = self.connection.send(msg)
        if not sent:
            self.session.not_sent()
        return sent

    def on_room_clicked(self, room_id: int) -> None:
        room = self.shown_plan.room(room_id)
        if self.session.lost and self.session.help is Help.CHOOSING:
            dialog = QtHelpConfirmDialog(room, self)
            dialog.confirmed.connect(self._set_initial_room)
            self._open(dialog)
            return
        perms = self.session.permissions
        room_dialog = QtRoomDialog(
            room, perms.goals and not self.session.lost, perms.requests, self
        )
        room_dialog.go_requested.connect(self.go_to)
        room_dialog.request_requested.connect(self._open_request_dialog)
        self._open(room_dialog)

    def go_to(self, room_id: int) -> None:
        if self._send(Goal(room_id)):
            self.session.goal_sent(room_id)

    def go_home(self) -> None:
        if self._send(Home()):
            self.session.home_sent()

    def _start_tour(self) -> None:
        if self._send(Tour(True)):
            self.session.tour_sent()

    def _open_request_dialog(self, room_id: int) -> None:
        dialog = QtRequestDialog(self.shown_plan.room(room_id), self.shown_plan, self)
        dialog.request_submitted.connect(self._send_request)
        self._open(dialog)

    def _send_request(self, text: str, room_id: int, deliver_to: int) -> None:
        if self._send(RequestFrom(text, room_id, deliver_to, True)):
            self.session.request_sent(text, room_id, deliver_to)

    def _pause(self, paused: bool) -> None:
        if self._send(Pause(paused)):
            self.session.pause_sent(paused)

    def _cancel_motion(self) -> None:
        if self._send(Stop(True)):
            self.session.cancel_sent(self.clock())

    def _start_helping(self) -> None:
        self.session.help_started()
        self.show_map()

    def _set_initial_room(self, room_id: int) -> None:
        if self._send(InitialPoseRoom(room_id)):
            self.session.help_room_sent(room_id, self.clock())

    def _tour_control(self, action: str) -> None:
        if self._send(TourControl(action)):
            self.session.tour_control_sent(action, self.clock())

    def _answer_request(self, request_id: int, accepted: bool) -> None:
        if self._send(RequestAnswer(request_id, accepted)):
            self.session.request_answered(accepted)

    def open_malfunction_dialog(self) -> None:
        dialog = QtMalfunctionDialog(self)
        dialog.submitted.connect(self._report)
        self._open(dialog)

    def _report(self, kind: str, text: str) -> None:
        if self._send(Malfunction(kind, text)):
            self.session.report_sent(kind)

    # ---------------------------------------------------------------- Base Station messages
    def _on_message(self, msg: StationMessage) -> None:
        """Into the session; a cancel by the operator closes what the user had open about it,
        and the station's progress on an accepted request shows in the request's dialog."""
        self.session.on_message(msg, self.clock())
        if isinstance(msg, Cancel) and self.dialog is not None:
            self.dialog.close()
        elif isinstance(msg, StatusInfo) and isinstance(self.dialog, QtShowRequestDialog):
            self.dialog.set_status(activity_text(self.room_name, self.session))

    # ---------------------------------------------------------------- rendering the session
    def render(self) -> None:
        """Make every screen show the session (idempotent; called after each change)."""
        s = self.session
        if s.pose is None:
            self.map_view.clear_robot()
        else:
            self.map_view.set_robot_pose(*s.pose)
        self.map_view.set_tour(s.tour.visited, s.tour.next)
        help_room = self.room_name(s.help_room) if s.help_room is not None else ""
        self.map_screen.set_help_state(s.help, help_room)
        self.help_button.setVisible(s.help is Help.OFFERED)
        self._render_goal()
        self._render_dialogs()
        self._render_permissions(s.permissions)
        self._render_texts()

    def _render_goal(self) -> None:
        goal = self.session.goal
        if goal is None:
            self.motion_bar.setVisible(False)
            return
        self.motion_bar.set_destination(self.room_name(goal.room))
        self.motion_bar.set_progress(goal.progress)
        self.motion_bar.set_paused(goal.paused)
        self.motion_bar.setVisible(True)

    def _render_dialogs(self) -> None:
        """Dialogs that show station state open and close with it (no leftovers)."""
        s = self.session
        if s.tour_stop is None:
            self._close_dialog(QtTourStopDialog)
        elif not (
            isinstance(self.dialog, QtTourStopDialog) and self.dialog.room.covers(s.tour_stop)
        ):
            try:
                room = self.shown_plan.room(s.tour_stop)
            except KeyError:
                logger.warning("tour stop %s is not a room of the floor plan", s.tour_stop)
            else:
                dialog = QtTourStopDialog(room, self)
                dialog.resume_requested.connect(lambda: self._tour_control("resume"))
                dialog.end_requested.connect(lambda: self._tour_control("end"))
                self._open(dialog)
        request = s.shown_request
        if request is None:
            self._close_dialog(QtShowRequestDialog)
        elif not (isinstance(self.dialog, QtShowRequestDialog) and self.dialog.request == request):
            show = QtShowRequestDialog(request, self.shown_plan, self)
            show.answered.connect(self._answer_request)
            self._open(show)

    def _render_permissions(self, perms: Permissions) -> None:
        text = unavailable_text(perms.teleop, perms.goals, perms.tours, perms.requests)
        self.unavailable_label.setText(text)
        self.unavailable_label.setVisible(bool(text) and self.session.connected)
        why = self.tr("The operator does not allow this now.")
        for widget, allowed in (
            (self.menu.joystick_button, perms.teleop),
            (self.map_screen.drive_button, perms.teleop),
            (self.motion_bar.manual_button, perms.teleop),
            (self.joystick_screen.joystick, perms.teleop),
            (self.map_screen.tour_button, perms.tours),
            (self.menu.home_button, perms.goals),
            (self.map_screen.home_button, perms.goals),
        ):
            widget.setEnabled(allowed)
            widget.setToolTip("" if allowed else why)

    def _render_texts(self) -> None:
        s = self.session
        self.activity_label.setText(activity_text(self.room_name, s))
        notice = s.notice
        self.status_label.setText("" if notice is None else notice_text(self.room_name, notice))
        self.status_label.setStyleSheet("color: #b00000;" if notice and notice.error else "")

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
            robot = self.session.robot  # the robot driven, which the operator may switch
            shown = f"{robot} ({target})" if robot else target
            text = self.tr("Connected to %1").replace("%1", shown)
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
    def screen_dpi(self) -> float:
        """Dots per inch of the screen as a finger meets it: the override, else the larger of
        Qt's logical and physical figures (a desktop platform often reports 96 logical)."""
        if self.dpi_override is not None:
            return self.dpi_override
        screen = self.screen()
        physical = screen.physicalDotsPerInch() if screen is not None else 0.0
        return max(float(self.logicalDpiX()), physical)

    def apply_metrics(self) -> None:
        """Touch targets of at least 9 mm, growing with the window (ui_metrics)."""
        touch = touch_target_px(self.screen_dpi(), self.width(), self.height())
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
        self.shown_plan = self.plan.in_language(self.languages.language)
        self.map_view.set_plan(self.shown_plan)
        self.setWindowTitle(self.tr("Interbot Tablet"))
        self.help_button.setText(self.tr("Help me!"))
        self._update_connection_text()
        self.render()

    def mousePressEvent(self, event: QMouseEvent) -> None:
        """Kiosk: taps in the top-left corner count towards the operator's exit gesture."""
        pos = event.position()
        corner = pos.x() <= CORNER_PX and pos.y() <= CORNER_PX
        if self.kiosk and corner and self._exit_gesture.tap(self.clock()):
            self.ask_to_leave_kiosk()
        super().mousePressEvent(event)

    def ask_to_leave_kiosk(self) -> None:
        box = QMessageBox(
            QMessageBox.Icon.Question,
            self.tr("Operator"),
            self.tr("Leave the kiosk and close the tablet application?"),
            QMessageBox.StandardButton.Yes | QMessageBox.StandardButton.No,
            self,
        )
        box.setDefaultButton(QMessageBox.StandardButton.No)
        self.exit_box = box
        box.finished.connect(self._on_leave_answer)
        box.open()

    def _on_leave_answer(self, result: int) -> None:
        if result == QMessageBox.StandardButton.Yes:
            self._may_close = True
            self.close()

    def closeEvent(self, event: QCloseEvent) -> None:
        if self.kiosk and not self._may_close:
            event.ignore()  # the kiosk stays: only the operator's gesture closes it
            return
        self.connection.stop()
        super().closeEvent(event)
