"""A seeded Wi-Fi link for TCP-like streams: in order, never lost, sometimes late (thesis §6.4).

Thesis §6.4 found zones of ISR floor 0 where speed commands arrived late: access-point (AP)
hand-overs and walls that attenuate the signal, worst near the Library (Fig. 6.7). The commands
travel over TCP, so a radio loss is not a lost message but a retransmission: that message is late
and every later one waits behind it (head-of-line blocking). The model:

* **Base delay.** ``base_delay + Exp(jitter)`` one way (a few ms).
* **Gilbert-Elliott channel** (Gilbert 1960, Elliott 1963): a two-state Markov chain advanced once
  per message, good -> bad with probability ``p_good_to_bad`` (raised to the zone's value inside a
  lossy zone), bad -> good with ``p_bad_to_good``. A message sent in the bad state is
  retransmitted: delay ``U(bad_delay_min, bad_delay_max)`` (0.2-1.5 s) on top of the base delay.
* **AP hand-over.** Crossing a zone boundary (the sender's position entering or leaving a
  `LossyZone`) stalls the link for ``U(handover_min, handover_max)``: nothing is delivered before
  the stall ends.
* **In order.** A message is delivered no earlier than the one before it:
  ``t_recv[k] = max(t_send[k] + delay[k], stall_end, t_recv[k-1])``.

Positions are where the robot (and the tablet it carries) physically is: the simulator's
ground truth, which is the environment's business, never the robot software's. Everything random
comes from one ``numpy.random.Generator``: a seed gives the same delays every run.
"""

from __future__ import annotations

import heapq
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar

import numpy as np
from msgspec import Meta

from interbot_core import schema

logger = logging.getLogger(__name__)


class WifiConfigError(ValueError):
    """A Wi-Fi link parameter is out of range; the message names the field."""


Seconds = Annotated[float, Meta(ge=0.0, le=60.0, extra={"unit": "s"})]
Probability = Annotated[float, Meta(ge=0.0, le=1.0)]


class LossyZone(schema.Declared, frozen=True):
    """A circle [m] of poor reception; ``p_good_to_bad`` applies to messages sent inside it."""

    ROOT: ClassVar[str] = "LossyZone"
    ERROR: ClassVar[type[Exception]] = WifiConfigError
    x: Annotated[float, Meta(ge=-1e6, le=1e6, extra={"unit": "m"})]
    y: Annotated[float, Meta(ge=-1e6, le=1e6, extra={"unit": "m"})]
    radius: Annotated[float, Meta(ge=1e-3, le=1e4, extra={"unit": "m"})]
    p_good_to_bad: Probability = 0.02
    name: str = ""

    def contains(self, x: float, y: float) -> bool:
        return math.hypot(x - self.x, y - self.y) <= self.radius


class WifiConfig(schema.Declared, frozen=True):
    """The link's parameters (defaults: an office Wi-Fi with one bad spot, thesis §6.4)."""

    ROOT: ClassVar[str] = "WifiConfig"
    ERROR: ClassVar[type[Exception]] = WifiConfigError
    base_delay: Annotated[float, Meta(ge=0.0, le=10.0, extra={"unit": "s"})] = 0.004  # one way
    # mean of the exponential extra delay
    jitter: Annotated[float, Meta(ge=0.0, le=10.0, extra={"unit": "s"})] = 0.002
    p_good_to_bad: Probability = 0.001  # per message, outside the zones
    p_bad_to_good: Annotated[float, Meta(ge=1e-6, le=1.0)] = 0.6  # per message
    bad_delay_min: Seconds = 0.2  # retransmission delay in the bad state
    bad_delay_max: Seconds = 1.5
    handover_min: Seconds = 0.3  # AP hand-over stall when crossing a zone boundary
    handover_max: Seconds = 1.2
    zones: tuple[LossyZone, ...] = ()

    def check(self) -> None:
        for low, high in (("bad_delay_min", "bad_delay_max"), ("handover_min", "handover_max")):
            if getattr(self, high) < getattr(self, low):
                raise WifiConfigError(
                    f"WifiConfig.{high} = {getattr(self, high)} s is below "
                    f"{low} = {getattr(self, low)} s"
                )


@dataclass(frozen=True)
class Delivery:
    """One message: sent at ``sent`` [s], received at ``received`` [s]."""

    seq: int
    sent: float
    received: float
    payload: Any
    bad: bool  # sent in the bad state (retransmitted)
    position: tuple[float, float]  # [m] where the sender was


class WifiLink:
    """One direction of a TCP-like connection over the modelled Wi-Fi."""

    def __init__(self, config: WifiConfig, rng: np.random.Generator) -> None:
        self.config = config
        self._rng = rng
        self._bad = False
        self._zone: int | None = None  # index of the zone the sender is in (first match)
        self._zone_known = False
        self._stall_until = -math.inf
        self._last_received = -math.inf
        self._last_sent = -math.inf
        self._seq = 0
        self._queue: list[tuple[float, int, Delivery]] = []
        self.sent_count = 0
        self.handovers = 0

    def send(self, now: float, payload: Any, position: Sequence[float] = (0.0, 0.0)) -> Delivery:
        """Queue ``payload`` sent at ``now`` [s] from ``position`` [m]; returns its fate."""
        if not math.isfinite(now) or now < self._last_sent:
            raise ValueError(f"send times must be finite and non-decreasing, got {now!r}")
        self._last_sent = now
        cfg, rng = self.config, self._rng
        x, y = float(position[0]), float(position[1])
        zone = next((i for i, z in enumerate(cfg.zones) if z.contains(x, y)), None)
        if self._zone_known and zone != self._zone:
            stall = float(rng.uniform(cfg.handover_min, cfg.handover_max))
            self._stall_until = max(self._stall_until, now + stall)
            self.handovers += 1
            logger.debug("AP hand-over at (%.2f, %.2f), %.2f s: stall %.2f s", x, y, now, stall)
        self._zone, self._zone_known = zone, True
        p_gb = cfg.p_good_to_bad if zone is None else cfg.zones[zone].p_good_to_bad
        u = float(rng.random())
        self._bad = (u >= cfg.p_bad_to_good) if self._bad else (u < p_gb)
        delay = cfg.base_delay + (float(rng.exponential(cfg.jitter)) if cfg.jitter > 0 else 0.0)
        if self._bad:
            delay += float(rng.uniform(cfg.bad_delay_min, cfg.bad_delay_max))
        received = max(now + delay, self._stall_until, self._last_received)
        self._last_received = received
        delivery = Delivery(self._seq, now, received, payload, self._bad, (x, y))
        heapq.heappush(self._queue, (received, self._seq, delivery))
        self._seq += 1
        self.sent_count += 1
        return delivery

    def receive(self, now: float) -> list[Delivery]:
        """Every message whose arrival time is <= ``now``, in sending order."""
        out: list[Delivery] = []
        while self._queue and self._queue[0][0] <= now + 1e-12:
            out.append(heapq.heappop(self._queue)[2])
        return out
