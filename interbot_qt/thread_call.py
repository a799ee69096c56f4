"""Run a function in the thread a `QObject` lives in, and wait for its result (issue 14).

Qt objects that own sockets and timers may be used only from their own thread. The station's
tablet server lives in a thread of its own (so a frame being drawn never delays a speed
command); the Qt thread still calls a few of its methods (send a message, listen, close).
`ThreadCall` turns such a call into a blocking queued call: the function runs in the owner's
event loop and the caller gets its return value or its exception. Called from the owner's
own thread it simply runs the function.

The owner's thread never waits for the caller's (it only emits queued signals back), so a
blocking call cannot deadlock unless the caller holds a lock the owner needs: callers hold
none while calling.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

from PySide6.QtCore import QObject, Qt, QThread, Signal

T = TypeVar("T")


class _Box:
    """One call in flight: the function, then its result or exception."""

    __slots__ = ("error", "fn", "result")

    def __init__(self, fn: Callable[[], Any]) -> None:
        self.fn = fn
        self.result: Any = None
        self.error: BaseException | None = None


class ThreadCall(QObject):
    """A child of the owner (it moves with it); `run` executes in the owner's thread."""

    _requested = Signal(object)

    def __init__(self, owner: QObject) -> None:
        super().__init__(owner)
        self._requested.connect(self._execute, Qt.ConnectionType.BlockingQueuedConnection)

    def run(self, fn: Callable[[], T]) -> T:
        thread = self.thread()
        if QThread.currentThread() is thread or thread is None or not thread.isRunning():
            return fn()
        box = _Box(fn)
        self._requested.emit(box)
        if box.error is not None:
            raise box.error
        result: T = box.result
        return result

    def _execute(self, box: _Box) -> None:
        try:
            box.result = box.fn()
        except BaseException as exc:  # raised again in the caller's thread
            box.error = exc
