"""Real-time scheduling for the threads that carry commands (issue 14: the teleop latency tail).

Why. Per-hop time stamps of the teleop bench (``bench/_hop_trace.py``) beside the kernel's
scheduler trace (``perf sched``) showed where the slowest samples lost their milliseconds: a
thread on the command path (the station's tablet thread, the daemon's zenoh callback thread
or its command thread) had been woken and was ready to run, but both cores were busy: with the
simulator's ray casting, the localiser, the station's drawing, or other programs. Under the
normal scheduler such a thread may wait for the running one's slice to end, a scheduler tick
at a time (4 ms at HZ=250): 2-4 ms per hop, several hops per command. The threads do little per
command (0.1-0.3 ms), so under ``SCHED_FIFO`` they preempt that bulk work at once and give the
CPU back within a fraction of a millisecond. This is the usual split on robots (ros2_control's
real-time control thread, the rest at normal priority).

Why it is safe. Each of these threads blocks on a socket or a queue and does bounded work per
message (the tablet's input policy, the link's bounded queues); the kernel's real-time
throttling (``sched_rt_runtime_us``, 95 % by default) keeps the rest of the machine running
even if one spun. ``SCHED_RESET_ON_FORK``: threads they start begin at normal priority. The
priority is low (`COMMAND_PRIORITY`): above every normal thread, below the kernel's own.

Only where the OS allows it: root, ``CAP_SYS_NICE``, or ``RLIMIT_RTPRIO`` >= the priority
(systemd ``LimitRTPRIO=``, ``/etc/security/limits.conf`` ``rtprio``; docs/deploy.md). Otherwise
the thread stays at normal priority, which works as before, and the caller says so once.
``INTERBOT_REALTIME=0`` in the environment keeps every thread at normal priority (to compare,
or on a machine where a real-time thread is not wanted).
Python's GIL still serialises the threads of one process: a command thread waits for the GIL
as before (at most ``sys.getswitchinterval()`` while another thread runs Python code).

zenoh's own network threads carry every command too (`NamedThreadRaiser`, issue 14, fifth
session): the kernel's scheduler trace (``perf sched``) of the slowest teleop samples showed
the station's zenoh transmit thread (``tx-0``) woken by the tablet thread's put and then waiting
2-7 ms for a core behind the station's Qt thread or another program; likewise the threads that
read a link (``acc-`` for a link the process accepted, ``net-`` for one it connected) and hand
the message on (``rx-``), and the daemon's ``tx-0`` sending the mux output. They run zenoh's
Rust code only (Python callbacks run on threads of their own), do bounded work per message and sleep in the kernel
between messages, so they get the command threads' priority too (zenoh's ``app-`` threads,
never seen on the path, keep normal priority). zenoh starts them lazily (a link's first
message), so their owner scans for them now and then. The Base Station raises only its
transmit threads (`ZENOH_SEND_THREADS`): what it receives is display data, which at real-time
priority ran ahead of its tablet thread (measured: the tablet → mux p99 was lower without).
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass
from pathlib import Path

COMMAND_PRIORITY = 10
"""SCHED_FIFO priority (1-99) of the command threads: the kernel's own threads use 50 and 99."""
DISABLE_VARIABLE = "INTERBOT_REALTIME"
"""``INTERBOT_REALTIME=0``: no real-time priority for any thread."""
ZENOH_THREADS = ("tx-", "rx-", "acc-", "net-")
"""Name prefixes of zenoh's network threads (its transmit, receive, accept and link runtimes)."""
ZENOH_SEND_THREADS = ("tx-",)
"""zenoh's transmit threads only: for a program whose commands go out but whose incoming
traffic is display data (the Base Station)."""
SCAN_PERIOD_S = 1.0
"""[s] wall time between two `NamedThreadRaiser.scan` calls by their owners (zenoh starts its
network threads as links come up, so they are looked for now and then)."""
TASK_DIR = Path("/proc/self/task")
"""Linux: one directory per thread of this process, its name in ``comm``."""


@dataclass(frozen=True)
class PriorityOutcome:
    """What `raise_current_thread` got: ``realtime`` True under SCHED_FIFO; ``text`` says it."""

    realtime: bool
    text: str


def _rtprio_limit() -> str:
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_RTPRIO)
    except (ImportError, AttributeError, OSError):
        return "unknown"
    return "unlimited" if soft == resource.RLIM_INFINITY else str(soft)


def raise_current_thread(what: str, priority: int = COMMAND_PRIORITY) -> PriorityOutcome:
    """Put the calling thread under SCHED_FIFO at ``priority``, if the OS allows it.

    ``what`` names the thread in the outcome's text (e.g. "the tablet thread"). Never raises
    for lack of permission: the thread then keeps its normal priority and the outcome says why.
    """
    return raise_thread(0, what, priority)


def raise_thread(tid: int, what: str, priority: int = COMMAND_PRIORITY) -> PriorityOutcome:
    """`raise_current_thread` for thread ``tid`` of this process (0: the calling thread).

    Raises ProcessLookupError if thread ``tid`` has ended (not a refusal)."""
    if not 1 <= priority <= 99:
        raise ValueError(f"real-time priority must be in 1..99, got {priority!r}")
    if os.environ.get(DISABLE_VARIABLE, "1") == "0":
        return PriorityOutcome(False, f"{what}: normal priority ({DISABLE_VARIABLE}=0)")
    if not hasattr(os, "sched_setscheduler") or not hasattr(os, "SCHED_FIFO"):
        return PriorityOutcome(False, f"{what}: normal priority (no real-time scheduling here)")
    policy = os.SCHED_FIFO | getattr(os, "SCHED_RESET_ON_FORK", 0)
    try:
        # Linux: a thread id names that thread only; 0 is the calling thread.
        os.sched_setscheduler(tid, policy, os.sched_param(priority))
    except ProcessLookupError:
        raise  # thread ``tid`` has ended: not a refusal (NamedThreadRaiser skips it)
    except OSError as exc:
        return PriorityOutcome(
            False,
            f"{what}: normal priority, real-time scheduling not permitted ({exc.strerror}; "
            f"RLIMIT_RTPRIO {_rtprio_limit()}): commands may wait for a busy CPU "
            "(docs/deploy.md, LimitRTPRIO)",
        )
    return PriorityOutcome(True, f"{what}: real-time priority {priority} (SCHED_FIFO)")


def is_realtime(tid: int = 0) -> bool:
    """True if thread ``tid`` (0: the calling thread) runs under SCHED_FIFO or SCHED_RR."""
    if not hasattr(os, "sched_getscheduler"):
        return False
    policy = os.sched_getscheduler(tid) & ~getattr(os, "SCHED_RESET_ON_FORK", 0)
    return policy in (os.SCHED_FIFO, os.SCHED_RR)


class ThreadRaiser:
    """Raises each thread that calls it once (for callbacks on threads we do not create, such
    as zenoh's callback threads); remembers the outcome of the first."""

    def __init__(self, what: str, priority: int = COMMAND_PRIORITY) -> None:
        self._what = what
        self._priority = priority
        self._done: set[int] = set()
        self._lock = threading.Lock()
        self.outcome: PriorityOutcome | None = None

    def __call__(self) -> PriorityOutcome | None:
        """Raise the calling thread if not yet done; its outcome the first time, else None."""
        tid = threading.get_native_id()
        if tid in self._done:  # the common case: one set lookup, no lock
            return None
        with self._lock:
            if tid in self._done:
                return None
            self._done.add(tid)
        outcome = raise_current_thread(self._what, self._priority)
        if self.outcome is None:
            self.outcome = outcome
        return outcome


class NamedThreadRaiser:
    """Raises this process's threads whose names start with one of ``prefixes``, each once.

    For threads a library starts and names itself, such as zenoh's network threads
    (`ZENOH_THREADS`): they exist only once a link carries data, and a runtime may add one
    later, so the owner calls `scan` now and then (it reads a few small files). Linux only:
    elsewhere (no ``task_dir``) `scan` finds nothing and `outcome` says so.
    """

    def __init__(
        self,
        what: str,
        prefixes: tuple[str, ...] = ZENOH_THREADS,
        priority: int = COMMAND_PRIORITY,
        task_dir: Path = TASK_DIR,
    ) -> None:
        if not prefixes or not all(isinstance(p, str) and p for p in prefixes):
            raise ValueError(f"thread name prefixes must be non-empty strings, got {prefixes!r}")
        self._what = what
        self._prefixes = prefixes
        self._priority = priority
        self._task_dir = task_dir
        self._done: dict[int, str] = {}  # thread id -> its name, once raised (or refused)
        self._lock = threading.Lock()
        self.outcome: PriorityOutcome | None = None
        """The first thread's outcome (None until a thread matched)."""

    @property
    def raised(self) -> dict[int, str]:
        """Thread id -> name of every matching thread seen so far (raised or refused)."""
        with self._lock:
            return dict(self._done)

    def scan(self) -> PriorityOutcome | None:
        """Raise the matching threads not seen before; the first outcome ever, once, else None.

        A thread is tried once: refused (no permission), it keeps normal priority and is not
        tried again. A thread whose name is not set yet is seen again at the next scan.
        """
        try:
            tids = [int(entry.name) for entry in self._task_dir.iterdir() if entry.name.isdigit()]
        except OSError:
            return self._first(
                PriorityOutcome(False, f"{self._what}: not found (no {self._task_dir})")
            )
        first: PriorityOutcome | None = None
        for tid in tids:
            with self._lock:
                if tid in self._done:
                    continue
            try:
                name = (self._task_dir / str(tid) / "comm").read_text(encoding="utf-8").strip()
            except OSError:  # the thread ended meanwhile
                continue
            if not name.startswith(self._prefixes):
                continue
            try:
                outcome = raise_thread(tid, f"{self._what} ({name})", self._priority)
            except ProcessLookupError:  # it ended between the two reads
                continue
            with self._lock:
                self._done[tid] = name
            first = first or self._first(outcome)
        return first

    def _first(self, outcome: PriorityOutcome) -> PriorityOutcome | None:
        with self._lock:
            if self.outcome is not None:
                return None
            self.outcome = outcome
        return outcome
