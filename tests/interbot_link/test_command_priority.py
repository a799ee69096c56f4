"""interbot_link.command_priority: real-time scheduling for the command threads, when allowed.

Each test runs in a thread of its own, so the test runner's thread never changes class. Where
the OS grants SCHED_FIFO (root, CAP_SYS_NICE, RLIMIT_RTPRIO) the granted path is checked;
the refused path is checked everywhere by refusing in ``os.sched_setscheduler``.
"""

from __future__ import annotations

import contextlib
import os
import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path
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


# ---------------------------------------------------------------- NamedThreadRaiser


def fake_tasks(root: Path, threads: dict[int, str]) -> Path:
    """A stand-in for /proc/self/task: one directory per thread id, its name in ``comm``."""
    for tid, name in threads.items():
        (root / str(tid)).mkdir(exist_ok=True)
        (root / str(tid) / "comm").write_text(name + "\n", encoding="utf-8")
    return root


def recording(monkeypatch: pytest.MonkeyPatch, refuse: type[OSError] | None = None) -> list[int]:
    """Replace ``os.sched_setscheduler``: record the thread ids (or refuse with ``refuse``)."""
    calls: list[int] = []

    def record(tid: int, policy: int, param: object) -> None:
        calls.append(tid)
        if refuse is not None:
            raise refuse(1, "refused")

    monkeypatch.setattr(cp.os, "sched_setscheduler", record)
    return calls


def test_named_thread_raiser_raises_only_the_named_threads_each_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = recording(monkeypatch)
    tasks = fake_tasks(
        tmp_path, {101: "tx-0", 102: "python", 103: "rx-1", 104: "app-0", 107: "net-1"}
    )
    raiser = cp.NamedThreadRaiser("the daemon's zenoh threads", task_dir=tasks)
    first = raiser.scan()
    assert sorted(calls) == [101, 103, 107]
    assert first is not None and first.realtime
    assert first.text.startswith("the daemon's zenoh threads (")
    assert "real-time priority 10" in first.text
    assert raiser.outcome == first
    assert raiser.raised == {101: "tx-0", 103: "rx-1", 107: "net-1"}
    assert raiser.scan() is None and sorted(calls) == [101, 103, 107]  # nothing new: no call
    fake_tasks(tmp_path, {105: "acc-0", 106: "rx-2"})  # zenoh started two more
    assert raiser.scan() is None  # the first outcome was said already
    assert sorted(calls) == [101, 103, 105, 106, 107]


def test_named_thread_raiser_looks_again_at_a_thread_not_named_yet(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A new thread carries its parent's name until it names itself: seen again later."""
    calls = recording(monkeypatch)
    tasks = fake_tasks(tmp_path, {201: "python"})
    raiser = cp.NamedThreadRaiser("zenoh", task_dir=tasks)
    assert raiser.scan() is None and calls == []
    fake_tasks(tmp_path, {201: "tx-0"})
    outcome = raiser.scan()
    assert outcome is not None and outcome.realtime and calls == [201]


def test_named_thread_raiser_refused_says_why_and_does_not_retry(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = recording(monkeypatch, refuse=PermissionError)
    raiser = cp.NamedThreadRaiser("the station's zenoh threads", task_dir=fake_tasks(tmp_path, {7: "tx-0"}))  # fmt: skip
    outcome = raiser.scan()
    assert outcome is not None and not outcome.realtime
    assert outcome.text.startswith("the station's zenoh threads (tx-0): normal priority")
    assert "not permitted" in outcome.text and "LimitRTPRIO" in outcome.text
    assert raiser.scan() is None and calls == [7]  # tried once


def test_named_thread_raiser_skips_a_thread_that_ended(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A thread gone between reading its name and raising it is no refusal, and not kept."""
    calls = recording(monkeypatch, refuse=ProcessLookupError)
    raiser = cp.NamedThreadRaiser("zenoh", task_dir=fake_tasks(tmp_path, {9: "rx-0"}))
    assert raiser.scan() is None and raiser.outcome is None and raiser.raised == {}
    assert raiser.scan() is None and calls == [9, 9]  # still listed: tried again


def test_named_thread_raiser_without_a_task_list_says_so(tmp_path: Path) -> None:
    raiser = cp.NamedThreadRaiser("zenoh", task_dir=tmp_path / "missing")
    outcome = raiser.scan()
    assert outcome is not None and not outcome.realtime and "not found" in outcome.text
    assert raiser.scan() is None  # said once


def test_named_thread_raiser_keeps_normal_priority_with_interbot_realtime_0(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = recording(monkeypatch)
    monkeypatch.setenv("INTERBOT_REALTIME", "0")
    outcome = cp.NamedThreadRaiser("zenoh", task_dir=fake_tasks(tmp_path, {3: "tx-0"})).scan()
    assert outcome is not None and not outcome.realtime and calls == []
    assert outcome.text == "zenoh (tx-0): normal priority (INTERBOT_REALTIME=0)"


@pytest.mark.parametrize("prefixes", [(), ("",), ("tx-", "")])
def test_named_thread_raiser_refuses_empty_prefixes(prefixes: tuple[str, ...]) -> None:
    with pytest.raises(ValueError, match="non-empty strings"):
        cp.NamedThreadRaiser("zenoh", prefixes)


@pytest.mark.skipif(not cp.TASK_DIR.is_dir(), reason="no /proc/self/task (not Linux)")
def test_zenohs_network_threads_are_found_and_raised_where_allowed() -> None:
    """Two loopback sessions exchange a sample, so zenoh's network threads exist; a scan puts
    every one of them (and nothing else) under SCHED_FIFO. They are set back afterwards."""
    import zenoh

    from interbot_link import session_config

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    endpoint = f"tcp/127.0.0.1:{port}"
    got = threading.Event()
    listener = zenoh.open(session_config([endpoint], []))
    raiser = cp.NamedThreadRaiser("the test's zenoh threads")
    try:
        sub = listener.declare_subscriber("interbot/test/priority", lambda s: got.set())
        talker = zenoh.open(session_config([], [endpoint]))
        try:
            deadline = time.monotonic() + 10.0
            while not got.is_set() and time.monotonic() < deadline:
                talker.put("interbot/test/priority", b"x")
                got.wait(0.05)
            assert got.is_set(), "no sample over the loopback link"
            outcome = raiser.scan()
        finally:
            talker.close()
        sub.undeclare()
    finally:
        listener.close()
        for tid in raiser.raised:  # the runtime outlives the sessions: back to normal
            with contextlib.suppress(OSError):
                os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))
    names = set(raiser.raised.values())
    assert any(n.startswith("tx-") for n in names) and any(n.startswith("rx-") for n in names)
    assert all(n.startswith(cp.ZENOH_THREADS) for n in names)
    assert outcome is not None
    if not granted():
        assert not outcome.realtime and "not permitted" in outcome.text
    else:
        assert outcome.realtime
    assert not cp.is_realtime(threading.main_thread().native_id or 0)
