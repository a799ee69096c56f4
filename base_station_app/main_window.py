"""The Base Station's main window: a composition root (STYLE.md; thesis §5.3, Appendix I Fig. 2).

It creates the widgets around one `StationController`, the actions (emergency stop, pause,
resume, pick modes, quit, the robot selector), wires signals, and reads/writes QSettings: window
geometry and state and the robot commanded last (``--robot`` wins over it; with neither and several
robots the station asks). Settings that change behaviour live in the station file, owned by the
controller (docs/station_config.md). It holds no protocol, planning or robot
logic. The map view with the camera under it fill the left, the control tabs the right. Teleoperation stops at once when the window loses activation.
"""

from __future__ import annotations

import logging

from PySide6.QtCore import QEvent, QSettings, Qt
from PySide6.QtGui import QAction, QCloseEvent, QKeySequence
from PySide6.QtWidgets import (
    QMainWindow,
    QSplitter,
    QTabWidget,
    QToolBar,
    QVBoxLayout,
    QWidget,
)

from base_station_app.qt_alerts_panel import QtAlertsPanel
from base_station_app.qt_camera_view import QtCameraView
from base_station_app.qt_config_panel import QtConfigPanel
from base_station_app.qt_diagnostics_panel import QtDiagnosticsPanel
from base_station_app.qt_map_view import QtMapView
from base_station_app.qt_replay_bar import QtReplayBar
from base_station_app.qt_robot_choice_dialog import QtRobotChoiceDialog
from base_station_app.qt_robot_selector import QtRobotSelector
from base_station_app.qt_robots_panel import QtRobotsPanel
from base_station_app.qt_state_panel import QtStatePanel
from base_station_app.qt_tablet_panel import QtTabletPanel
from base_station_app.qt_task_panel import QtTaskPanel
from base_station_app.qt_teleop_panel import QtTeleopPanel
from base_station_app.station_controller import StationController
from interbot_core.geometry import Pose2D
from interbot_core.supervisor import GoToPose
from interbot_core.topics import TopicError, validate_robot_id
from interbot_link.replay import ReplayControlClient

logger = logging.getLogger(__name__)

ROBOT_KEY = "fleet/robot"  # QSettings: the robot this station commanded last (one place)
TAB_NAMES = ("state", "alerts", "teleop", "tasks", "tablet", "config", "diagnostics", "robots")


ESTOP_STYLE = (
    "QToolButton#estop_button { background: #d00000; color: white; font-size: 16pt;"
    " font-weight: bold; border: 3px solid #700000; border-radius: 6px; padding: 6px 18px; }"
    "QToolButton#estop_button:pressed { background: #900000; }"
)
ESTOP_MIN_W, ESTOP_MIN_H = 220, 48  # [px] the largest control on the window
ALERT_BADGE_STYLE = (
    "QToolButton#alerts_badge { background: #ffb000; color: black; font-weight: bold;"
    " border-radius: 10px; padding: 4px 12px; }"
)


class MainWindow(QMainWindow):
    """Map + camera + control tabs around a `StationController`."""

    def __init__(
        self,
        controller: StationController,
        settings: QSettings | None = None,
        parent: QWidget | None = None,
    ) -> None:
        super().__init__(parent)
        self.controller = controller
        self.settings = settings if settings is not None else QSettings("Interbot", "BaseStation")
        self.setWindowTitle("Interbot Base Station")
        self._reading = False
        self.robot_choice: QtRobotChoiceDialog | None = None
        self._create_widgets()
        self._create_actions()
        self._connect_signals()
        self._read_settings()

    # ------------------------------------------------------------------ composition
    def _create_widgets(self) -> None:
        c = self.controller
        self.map_view = QtMapView(c)
        self.camera_view = QtCameraView(c)
        self.state_panel = QtStatePanel(c)
        self.alerts_panel = QtAlertsPanel(c)
        self.teleop_panel = QtTeleopPanel(c)
        self.task_panel = QtTaskPanel(c)
        self.tablet_panel = QtTabletPanel(c)
        self.config_panel = QtConfigPanel(c)
        self.diagnostics_panel = QtDiagnosticsPanel(c)
        self.robots_panel = QtRobotsPanel(c)
        self.tabs = QTabWidget()
        for name, widget in zip(
            TAB_NAMES,
            (
                self.state_panel,
                self.alerts_panel,
                self.teleop_panel,
                self.task_panel,
                self.tablet_panel,
                self.config_panel,
                self.diagnostics_panel,
                self.robots_panel,
            ),
            strict=True,
        ):
            self.tabs.addTab(widget, name.capitalize())
        # The floor plan is wide (70 m x 28 m): the camera goes under the map, beside it on
        # screen, and the control tabs get the full height on the right.
        left = QSplitter(Qt.Orientation.Vertical)
        left.addWidget(self._with_replay_bar(self.map_view))
        left.addWidget(self.camera_view)
        left.setStretchFactor(0, 3)
        left.setStretchFactor(1, 2)
        left.setSizes([520, 400])
        self._left = left
        self.camera_view.aspect_changed.connect(self.fit_camera)
        self.splitter = QSplitter(Qt.Orientation.Horizontal)
        self.splitter.addWidget(left)
        self.splitter.addWidget(self.tabs)
        self.splitter.setStretchFactor(0, 3)
        self.splitter.setStretchFactor(1, 2)
        self.splitter.setSizes([900, 700])
        self.setCentralWidget(self.splitter)
        self.statusBar().showMessage("ready")

    def _with_replay_bar(self, map_view: QWidget) -> QWidget:
        """The map view with the replay bar under it (shown only for a replayed robot)."""
        c = self.controller
        client = ReplayControlClient(c.link.session) if c.link is not None else None
        self.replay_bar = QtReplayBar(c, client)
        box = QWidget()
        layout = QVBoxLayout(box)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(0)
        layout.addWidget(map_view, 1)
        layout.addWidget(self.replay_bar)
        return box

    def _create_actions(self) -> None:
        c = self.controller
        bar = QToolBar("Main")
        bar.setObjectName("main_toolbar")
        # Always there: the bar cannot be hidden, moved or floated away (the stop lives on it).
        bar.setMovable(False)
        bar.setFloatable(False)
        bar.toggleViewAction().setEnabled(False)
        bar.toggleViewAction().setVisible(False)
        self.addToolBar(bar)
        self.estop_action = QAction("EMERGENCY STOP", self)
        self.estop_action.setShortcut(QKeySequence(Qt.Key.Key_F12))
        self.estop_action.setShortcutContext(Qt.ShortcutContext.ApplicationShortcut)
        self.estop_action.triggered.connect(c.emergency_stop)
        self.release_action = QAction("Release stop", self)
        self.release_action.triggered.connect(c.release_stop)
        self.pause_action = QAction("Pause", self)
        self.pause_action.setShortcut(QKeySequence("Ctrl+P"))
        self.pause_action.triggered.connect(c.commands.pause)
        self.resume_action = QAction("Resume", self)
        self.resume_action.setShortcut(QKeySequence("Ctrl+R"))
        self.resume_action.triggered.connect(c.commands.resume)
        self.goal_action = QAction("Goal on map", self)
        self.goal_action.triggered.connect(lambda: self.map_view.set_pick_mode("goal"))
        self.initial_action = QAction("Initial pose on map", self)
        self.initial_action.triggered.connect(lambda: self.map_view.set_pick_mode("initial"))
        self.fit_action = QAction("Fit map", self)
        self.fit_action.triggered.connect(self.map_view.fit_map)
        self.quit_action = QAction("Quit", self)
        self.quit_action.setShortcut(QKeySequence.StandardKey.Quit)
        self.quit_action.triggered.connect(self.close)
        self.alerts_action = QAction("No alerts", self)
        self.alerts_action.triggered.connect(lambda: self.tabs.setCurrentWidget(self.alerts_panel))
        for action in (
            self.estop_action,
            self.alerts_action,
            self.release_action,
            self.pause_action,
            self.resume_action,
            self.goal_action,
            self.initial_action,
            self.fit_action,
            self.quit_action,
        ):
            bar.addAction(action)
            self.addAction(action)
        self.estop_button = bar.widgetForAction(self.estop_action)
        self.estop_button.setObjectName("estop_button")
        self.estop_button.setToolTip("Emergency stop (F12): latches until released here")
        self.estop_button.setStyleSheet(ESTOP_STYLE)
        self.estop_button.setMinimumSize(ESTOP_MIN_W, ESTOP_MIN_H)
        bar.addSeparator()  # the robot commanded, always in sight (issue 14)
        self.robot_selector = QtRobotSelector(c)
        bar.addWidget(self.robot_selector)
        self.alerts_badge = bar.widgetForAction(self.alerts_action)
        self.alerts_badge.setObjectName("alerts_badge")
        c.alert_raised.connect(lambda _alert: self.update_alert_badge())
        c.clocked.connect(self.update_alert_badge)

    def update_alert_badge(self) -> None:
        """ "3 alerts" in red while any is unacknowledged; a click shows the list."""
        count = len(self.controller.alerts.unacknowledged)
        text = "No alerts" if count == 0 else f"{count} alert{'s' if count > 1 else ''}"
        if self.alerts_action.text() != text:
            self.alerts_action.setText(text)
            self.alerts_badge.setStyleSheet(ALERT_BADGE_STYLE if count else "")

    def fit_camera(self, aspect: float | None = None) -> None:
        """Give the camera pane the image's shape (at most 45 % of the height), map the rest."""
        aspect = aspect or self.camera_view.aspect
        total = sum(self._left.sizes())
        if total <= 0 or aspect <= 0:
            return
        camera = min(int(self._left.width() / aspect), int(0.45 * total))
        self._left.setSizes([total - camera, camera])

    def _connect_signals(self) -> None:
        c = self.controller
        self.map_view.room_clicked.connect(self.task_panel.select_room)
        self.map_view.pose_picked.connect(self._on_pose_picked)
        self.map_view.pick_mode_changed.connect(self._on_pick_mode)
        self.task_panel.pick_requested.connect(self.map_view.set_pick_mode)
        c.log_added.connect(lambda level, text: self.statusBar().showMessage(text, 5000))
        c.estop_changed.connect(self.release_action.setEnabled)
        self.release_action.setEnabled(c.estop_latched)
        c.robot_choice_needed.connect(self.ask_robot)
        c.robot_selected.connect(self._save_robot)

    # ------------------------------------------------------------------ settings
    def _read_settings(self) -> None:
        self._reading = True  # applying what was saved must not write it back half-read
        try:
            self._apply_settings()
        finally:
            self._reading = False

    def _apply_settings(self) -> None:
        """Window state and the robot commanded last (docs/station_config.md: everything that
        changes behaviour is in the station file, which the controller owns)."""
        s = self.settings
        geometry = s.value("window/geometry")
        if geometry is not None:
            self.restoreGeometry(geometry)
        state = s.value("window/state")
        if state is not None:
            self.restoreState(state)
        self._restore_robot()

    def _write_settings(self) -> None:
        if self._reading:
            return
        s = self.settings
        s.setValue("window/geometry", self.saveGeometry())
        s.setValue("window/state", self.saveState())
        s.sync()

    def _restore_robot(self) -> None:
        """The saved choice decides which robot a restarted station commands, unless --robot."""
        saved = self.settings.value(ROBOT_KEY)
        if self.controller.fleet.preferred is not None or not saved:
            return
        try:
            self.controller.fleet.preferred = validate_robot_id(str(saved))
        except TopicError as exc:
            logger.warning("ignored the saved robot choice: %s", exc)
            return
        self.controller.log("info", f"commanding robot {saved} when it appears (saved choice)")

    def _save_robot(self, robot_id: str) -> None:
        """A robot was chosen (dialog, list, selector or map): save it; the question is over."""
        if robot_id and self.robot_choice is not None:
            self.robot_choice.close()
        if robot_id and not self._reading:
            self.settings.setValue(ROBOT_KEY, robot_id)

    def ask_robot(self, robot_ids: tuple[str, ...]) -> None:
        """Several robots and no choice: ask (non-modal to the timers: the station keeps running)."""
        if self.robot_choice is not None:
            self.robot_choice.close()
        self.robot_choice = QtRobotChoiceDialog(self.controller, robot_ids, self)
        self.robot_choice.open()

    # ------------------------------------------------------------------ slots and events
    def _on_pose_picked(self, mode: str, pose: Pose2D) -> None:
        if mode == "goal":
            self.controller.commands.submit(GoToPose(pose))
        else:
            self.controller.commands.set_initial_pose(pose)

    def _on_pick_mode(self, mode: str) -> None:
        if mode:
            what = "goal" if mode == "goal" else "initial pose"
            self.statusBar().showMessage(f"click the {what} on the map and drag its heading")

    def changeEvent(self, event: QEvent) -> None:
        if event.type() == QEvent.Type.ActivationChange and not self.isActiveWindow():
            self.controller.release_all()  # never keep driving with a key held elsewhere
        super().changeEvent(event)

    def closeEvent(self, event: QCloseEvent) -> None:
        self._write_settings()
        self.controller.shutdown()
        super().closeEvent(event)

    def shutdown(self) -> None:
        """Called from QApplication.aboutToQuit as well as on close (idempotent)."""
        self.controller.shutdown()
