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
    QLabel,
    QLineEdit,
    QListWidget,
    QListWidgetItem,
    QWidget,
)

from base_station_app.station_controller import StationController
from base_station_app.tablet_session import describe_task
from interbot_core.supervisor import Delivery, GoHome, GoTo, GuidedTour, SupervisorState
from interbot_qt.layout import button, column, row


class QtTaskPanel(QWidget):
    """Room list, task buttons, the task queue, tour/request answers and the initial pose.

    ``pick_requested(mode)`` asks the map view to pick a pose ("goal" or "initial").
    """

    pick_requested = Signal(str)

    def __init__(self, controller: StationController, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._controller = c = controller
        rooms = [n for n in controller.topo.nodes if controller.rooms.in_a_room(n.id)]

        order = QGroupBox("Order a task")
        grid = QGridLayout(order)
        self.room_list = QListWidget()
        for node in rooms:
            item = QListWidgetItem(f"{node.id}  {node.name}")
            item.setData(Qt.ItemDataRole.UserRole, node.id)
            self.room_list.addItem(item)
        self.room_list.setCurrentRow(0)
        grid.addWidget(self.room_list, 0, 0, 6, 1)
        self.goto_button = button("Move to room", self._goto)
        self.tour_button = button("Guided tour", lambda: c.submit(GuidedTour()))
        self.home_button = button("Go home", lambda: c.submit(GoHome()))
        self.goal_pick_button = button(
            "Goal on map (click, drag heading)", lambda: self.pick_requested.emit("goal")
        )
        for i, b in enumerate((self.goto_button, self.tour_button, self.home_button)):
            grid.addWidget(b, i, 1)
        grid.addWidget(self.goal_pick_button, 3, 1)

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
        self.deliver_button = button("Deliver message", self._deliver)
        self.request_button = button("Request item", self._deliver)
        form.addRow(row(self.deliver_button, self.request_button))

        queue = QGroupBox("Task queue (runs in order)")
        self.current_label = QLabel()
        font = QFont(self.current_label.font())
        font.setBold(True)
        self.current_label.setFont(font)
        self.queue_list = QListWidget()
        self.up_button = button("Up", lambda: self._move(-1))
        self.down_button = button("Down", lambda: self._move(+1))
        self.remove_button = button("Remove", self._remove)
        self.cancel_button = button("Cancel current", c.commands.cancel_task)
        self.clear_button = button("Clear queue", c.commands.clear_queue)
        self.resume_queue_button = button(
            "Resume queue",
            c.commands.resume_queue,
            tip="After an emergency stop, waiting tasks start only when you resume the queue",
        )
        edits = column(
            self.up_button,
            self.down_button,
            self.remove_button,
            self.cancel_button,
            self.clear_button,
            self.resume_queue_button,
        )
        edits.addStretch(1)
        self.tour_resume_button = button("Resume tour", c.commands.tour_resume)
        self.tour_end_button = button("End tour", c.commands.tour_end)
        self.accept_button = button("Request accepted", lambda: c.commands.answer_request(True))
        self.decline_button = button("Request declined", lambda: c.commands.answer_request(False))
        answers = row(
            self.tour_resume_button, self.tour_end_button, self.accept_button, self.decline_button
        )
        column(self.current_label, (row((self.queue_list, 1), edits), 1), answers, parent=queue)

        pose = QGroupBox("Initial pose")
        self.initial_pick_button = button(
            "Drag an arrow on the map", lambda: self.pick_requested.emit("initial")
        )
        self.initial_room = QComboBox()
        for node in rooms:
            self.initial_room.addItem(f"{node.id}  {node.name}", node.id)
        self.initial_room_button = button(
            "Robot is at this room",
            lambda: c.commands.set_initial_pose_room(int(self.initial_room.currentData())),
        )
        self.relocalise_button = button(
            "Relocalise", c.commands.relocalise, tip="Let the robot find itself on the whole map"
        )
        row(
            self.initial_pick_button,
            (self.initial_room, 1),
            self.initial_room_button,
            self.relocalise_button,
            parent=pose,
        )
        column(order, deliver, (queue, 1), pose, parent=self)
        c.tasks_changed.connect(self.refresh)
        c.clocked.connect(self._refresh_buttons)
        self.refresh()

    def _room(self) -> int | None:
        item = self.room_list.currentItem()
        return None if item is None else int(item.data(Qt.ItemDataRole.UserRole))

    def select_room(self, node_id: int) -> None:
        """Select ``node_id`` in the room list (a click on the map)."""
        for i in range(self.room_list.count()):
            if self.room_list.item(i).data(Qt.ItemDataRole.UserRole) == node_id:
                self.room_list.setCurrentRow(i)
                return

    def _goto(self) -> None:
        room = self._room()
        if room is not None:
            self._controller.commands.submit(GoTo(room))

    def _deliver(self) -> None:
        text = self.request_text.text().strip()
        if not text:
            self._controller.log("warning", "type the message or item first")
            return
        self._controller.commands.submit(
            Delivery(text, int(self.from_room.currentData()), int(self.to_room.currentData()))
        )

    def _move(self, delta: int) -> None:
        index = self.queue_list.currentRow()
        if index >= 0 and self._controller.commands.move_task(index, delta):
            self.queue_list.setCurrentRow(index + delta)

    def _remove(self) -> None:
        index = self.queue_list.currentRow()
        if index >= 0:
            self._controller.commands.remove_task(index)

    def refresh(self) -> None:
        c = self._controller
        task = c.selected.supervisor.current_task
        who = " (tablet)" if c.tablet_requests.task is not None else ""
        self.current_label.setText(
            "Now: idle" if task is None else f"Now: {describe_task(task, c.names)}{who}"
        )
        index = self.queue_list.currentRow()
        self.queue_list.clear()
        for t in c.selected.supervisor.queue:
            self.queue_list.addItem(describe_task(t, c.names))
        if 0 <= index < self.queue_list.count():
            self.queue_list.setCurrentRow(index)
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
