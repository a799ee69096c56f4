"""interbot_link.command_priority: real-time scheduling for the command threads, when allowed.

Each test runs in a thread of its own, so the test runner's thread never changes class. Where
the OS grants SCHED_FIFO (root, CAP_SYS_NICE, RLIMIT_RTPRIO) the granted path is checked;
the refused path is checked everywhere by refusing in ``os.sched_setscheduler``.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from typing import Any

import pytest

from interbot_link import command_priority as cp

pytestmark = pytest.mark.skipif(
    not hasattr(os, "sched_setscheduler"), reason="no POSIX real-time scheduling here"
)


def in_thread(fn: Callable[[], Any]) -> Any:
    """Run ``fn`` in a new thread (which ends afterwards) and return its result."""
    box: list[Any] = []
    errors: list[BaseException] = []

    def run() -> None:
        try:
            box.append(fn())
        except BaseException as exc:  # raised again below
            errors.append(exc)

    thread = threading.Thread(target=run)
    thread.start()
    thread.join(10.0)
    if errors:
        raise errors[0]
    return box[0]


def granted() -> bool:
    """Whether this process may use SCHED_FIFO at COMMAND_PRIORITY (probed in a thread)."""
    return bool(in_thread(lambda: cp.raise_current_thread("probe").realtime))


def test_granted_puts_only_the_calling_thread_under_sched_fifo() -> None:
    if not granted():
        pytest.skip("real-time scheduling not permitted for this user")

    def check() -> tuple[cp.PriorityOutcome, bool, int, bool]:
        outcome = cp.raise_current_thread("the test thread")
        priority = os.sched_getparam(0).sched_priority
        return outcome, cp.is_realtime(), priority, cp.is_realtime(threading.main_thread().native_id)  # fmt: skip

    outcome, realtime, priority, main_realtime = in_thread(check)
    assert outcome.realtime and realtime
    assert priority == cp.COMMAND_PRIORITY
    assert "real-time priority 10" in outcome.text and "the test thread" in outcome.text
    assert not main_realtime  # per thread, not per process
    assert not cp.is_realtime()


def test_threads_started_by_a_raised_thread_begin_at_normal_priority() -> None:
    """SCHED_RESET_ON_FORK: a raised thread's children do not inherit the real-time class."""
    if not granted():
        pytest.skip("real-time scheduling not permitted for this user")

    def parent() -> tuple[bool, bool]:
        cp.raise_current_thread("parent")
        return cp.is_realtime(), bool(in_thread(cp.is_realtime))

    parent_rt, child_rt = in_thread(parent)
    assert parent_rt and not child_rt


def test_refused_keeps_normal_priority_and_says_why(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(pid: int, policy: int, param: object) -> None:
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(cp.os, "sched_setscheduler", refuse)
    outcome, realtime = in_thread(lambda: (cp.raise_current_thread("the tablet thread"), cp.is_realtime()))  # fmt: skip
    assert not outcome.realtime and not realtime
    assert outcome.text.startswith("the tablet thread: normal priority")
    assert "not permitted" in outcome.text and "RLIMIT_RTPRIO" in outcome.text
    assert "LimitRTPRIO" in outcome.text  # where to fix it


@pytest.mark.parametrize("priority", [0, 100, -1])
def test_priority_outside_1_to_99_is_refused(priority: int) -> None:
    with pytest.raises(ValueError, match=f"1..99, got {priority}"):
        cp.raise_current_thread("x", priority)


def test_thread_raiser_raises_each_thread_once(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[int] = []

    def record(pid: int, policy: int, param: object) -> None:
        calls.append(threading.get_native_id())

    monkeypatch.setattr(cp.os, "sched_setscheduler", record)
    raiser = cp.ThreadRaiser("the callback thread")

    def twice() -> tuple[cp.PriorityOutcome | None, cp.PriorityOutcome | None]:
        return raiser(), raiser()

    first, again = in_thread(twice)
    other, _ = in_thread(twice)
    assert first is not None and first.realtime and again is None
    assert other is not None  # another thread is raised too
    assert len(calls) == 2 and calls[0] != calls[1]
    assert raiser.outcome == first  # the first outcome is kept for the log


def test_interbot_realtime_0_keeps_normal_priority(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("INTERBOT_REALTIME", "0")
    outcome, realtime = in_thread(lambda: (cp.raise_current_thread("the tablet thread"), cp.is_realtime()))  # fmt: skip
    assert not outcome.realtime and not realtime
    assert outcome.text == "the tablet thread: normal priority (INTERBOT_REALTIME=0)"
