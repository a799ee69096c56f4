"""Tasks and the initial pose (thesis §5.3 "Tasks", §4.2.2.1, §5.2.2.1).

Pick a room from the list (or click it on the map) and order: move to the room, deliver a message
or request an item between rooms, a guided tour, go home, or a goal pose clicked and dragged on
the map. Tasks queue in the `Supervisor` and run in order; the queue can be reordered and tasks
removed or cancelled (supervisory control). Tour stops and shown requests are answered here.
The initial pose is set by dragging an arrow on the map or by naming the room the robot is in.
"""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QFont
from PySide6.QtWidgets import (
    QComboBox,
    QFormLayout,
    QGridLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QListWidget,
    QListWidgetItem,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from base_station_app.station_controller import StationController
from base_station_app.tablet_session import describe_task
from interbot_core.supervisor import Delivery, GoHome, GoTo, GuidedTour, SupervisorState


class QtTaskPanel(QWidget):
    """Room list, task buttons, the task queue, tour/request answers and the initial pose.

    ``pick_requested(mode)`` asks the map view to pick a pose ("goal" or "initial").
    """

    pick_requested = Signal(str)

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._controller = controller
        layout = QVBoxLayout(self)
        rooms = [n for n in controller.topo.nodes if self._is_room(n.id)]

        order = QGroupBox("Order a task")
        grid = QGridLayout(order)
        self.room_list = QListWidget()
        for node in rooms:
            item = QListWidgetItem(f"{node.id}  {node.name}")
            item.setData(Qt.ItemDataRole.UserRole, node.id)
            self.room_list.addItem(item)
        self.room_list.setCurrentRow(0)
        grid.addWidget(self.room_list, 0, 0, 6, 1)
        self.goto_button = QPushButton("Move to room")
        self.tour_button = QPushButton("Guided tour")
        self.home_button = QPushButton("Go home")
        self.goal_pick_button = QPushButton("Goal on map (click, drag heading)")
        grid.addWidget(self.goto_button, 0, 1)
        grid.addWidget(self.tour_button, 1, 1)
        grid.addWidget(self.home_button, 2, 1)
        grid.addWidget(self.goal_pick_button, 3, 1)
        layout.addWidget(order)

        deliver = QGroupBox("Deliver a message / request an item")
        form = QFormLayout(deliver)
        self.request_text = QLineEdit()
        self.request_text.setPlaceholderText("e.g. the blue folder")
        self.from_room = QComboBox()
        self.to_room = QComboBox()
        for node in controller.topo.request_nodes():
            self.from_room.addItem(f"{node.id}  {node.name}", node.id)
        for node in rooms:
            self.to_room.addItem(f"{node.id}  {node.name}", node.id)
        form.addRow("text", self.request_text)
        form.addRow("from room", self.from_room)
        form.addRow("to room", self.to_room)
        buttons = QHBoxLayout()
        self.deliver_button = QPushButton("Deliver message")
        self.request_button = QPushButton("Request item")
        buttons.addWidget(self.deliver_button)
        buttons.addWidget(self.request_button)
        form.addRow(buttons)
        layout.addWidget(deliver)

        queue = QGroupBox("Task queue (runs in order)")
        qlay = QVBoxLayout(queue)
        self.current_label = QLabel()
        font = QFont(self.current_label.font())
        font.setBold(True)
        self.current_label.setFont(font)
        qlay.addWidget(self.current_label)
        row = QHBoxLayout()
        self.queue_list = QListWidget()
        row.addWidget(self.queue_list, 1)
        column = QVBoxLayout()
        self.up_button = QPushButton("Up")
        self.down_button = QPushButton("Down")
        self.remove_button = QPushButton("Remove")
        self.cancel_button = QPushButton("Cancel current")
        self.clear_button = QPushButton("Clear queue")
        self.resume_queue_button = QPushButton("Resume queue")
        self.resume_queue_button.setToolTip(
            "After an emergency stop, waiting tasks start only when you resume the queue"
        )
        for b in (
            self.up_button,
            self.down_button,
            self.remove_button,
            self.cancel_button,
            self.clear_button,
            self.resume_queue_button,
        ):
            column.addWidget(b)
        column.addStretch(1)
        row.addLayout(column)
        qlay.addLayout(row, 1)
        answers = QHBoxLayout()
        self.tour_resume_button = QPushButton("Resume tour")
        self.tour_end_button = QPushButton("End tour")
        self.accept_button = QPushButton("Request accepted")
        self.decline_button = QPushButton("Request declined")
        for b in (
            self.tour_resume_button,
            self.tour_end_button,
            self.accept_button,
            self.decline_button,
        ):
            answers.addWidget(b)
        qlay.addLayout(answers)
        layout.addWidget(queue, 1)

        pose = QGroupBox("Initial pose")
        plo = QHBoxLayout(pose)
        self.initial_pick_button = QPushButton("Drag an arrow on the map")
        self.initial_room = QComboBox()
        for node in rooms:
            self.initial_room.addItem(f"{node.id}  {node.name}", node.id)
        self.initial_room_button = QPushButton("Robot is at this room")
        plo.addWidget(self.initial_pick_button)
        plo.addWidget(self.initial_room, 1)
        plo.addWidget(self.initial_room_button)
        self.relocalise_button = QPushButton("Relocalise")
        self.relocalise_button.setToolTip("Let the robot find itself on the whole map")
        plo.addWidget(self.relocalise_button)
        layout.addWidget(pose)

        c = controller
        self.goto_button.clicked.connect(self._goto)
        self.tour_button.clicked.connect(lambda: c.submit(GuidedTour()))
        self.home_button.clicked.connect(lambda: c.submit(GoHome()))
        self.goal_pick_button.clicked.connect(lambda: self.pick_requested.emit("goal"))
        self.initial_pick_button.clicked.connect(lambda: self.pick_requested.emit("initial"))
        self.initial_room_button.clicked.connect(
            lambda: c.set_initial_pose_room(int(self.initial_room.currentData()))
        )
        self.relocalise_button.clicked.connect(c.relocalise)
        self.deliver_button.clicked.connect(self._deliver)
        self.request_button.clicked.connect(self._deliver)
        self.up_button.clicked.connect(lambda: self._move(-1))
        self.down_button.clicked.connect(lambda: self._move(+1))
        self.remove_button.clicked.connect(self._remove)
        self.cancel_button.clicked.connect(lambda: c.cancel_task())
        self.clear_button.clicked.connect(c.clear_queue)
        self.resume_queue_button.clicked.connect(c.resume_queue)
        self.tour_resume_button.clicked.connect(c.tour_resume)
        self.tour_end_button.clicked.connect(c.tour_end)
        self.accept_button.clicked.connect(lambda: c.answer_request(True))
        self.decline_button.clicked.connect(lambda: c.answer_request(False))
        c.tasks_changed.connect(self.refresh)
        c.clocked.connect(self._refresh_buttons)
        self.refresh()

    def _is_room(self, node_id: int) -> bool:
        return self._controller.rooms.in_a_room(node_id)

    def _room(self) -> int | None:
        item = self.room_list.currentItem()
        return None if item is None else int(item.data(Qt.ItemDataRole.UserRole))

    def select_room(self, node_id: int) -> None:
        """Select ``node_id`` in the room list (a click on the map)."""
        for row in range(self.room_list.count()):
            if self.room_list.item(row).data(Qt.ItemDataRole.UserRole) == node_id:
                self.room_list.setCurrentRow(row)
                return

    def _goto(self) -> None:
        room = self._room()
        if room is not None:
            self._controller.submit(GoTo(room))

    def _deliver(self) -> None:
        text = self.request_text.text().strip()
        if not text:
            self._controller.log("warning", "type the message or item first")
            return
        self._controller.submit(
            Delivery(text, int(self.from_room.currentData()), int(self.to_room.currentData()))
        )

    def _move(self, delta: int) -> None:
        row = self.queue_list.currentRow()
        if row >= 0 and self._controller.move_task(row, delta):
            self.queue_list.setCurrentRow(row + delta)

    def _remove(self) -> None:
        row = self.queue_list.currentRow()
        if row >= 0:
            self._controller.remove_task(row)

    def refresh(self) -> None:
        c = self._controller
        task = c.selected.supervisor.current_task
        who = " (tablet)" if c.tablet_task is not None else ""
        self.current_label.setText(
            "Now: idle" if task is None else f"Now: {describe_task(task, c.names)}{who}"
        )
        row = self.queue_list.currentRow()
        self.queue_list.clear()
        for t in c.selected.supervisor.queue:
            self.queue_list.addItem(describe_task(t, c.names))
        if 0 <= row < self.queue_list.count():
            self.queue_list.setCurrentRow(row)
        self._refresh_buttons()

    def _refresh_buttons(self) -> None:
        sup = self._controller.selected.supervisor
        at_stop = sup.state is SupervisorState.AT_TOUR_STOP
        self.tour_resume_button.setEnabled(at_stop)
        self.tour_end_button.setEnabled(isinstance(sup.current_task, GuidedTour))
        waiting = sup.state is SupervisorState.AWAITING_RESPONSE
        self.accept_button.setEnabled(waiting)
        self.decline_button.setEnabled(waiting)
        self.cancel_button.setEnabled(sup.current_task is not None)
        self.resume_queue_button.setEnabled(sup.held and not self._controller.estop_latched)
