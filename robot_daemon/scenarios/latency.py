"""Latency analysis (thesis §6.4, Table 6.8, Figs. 6.6/6.7): speed commands over a lossy Wi-Fi.

The thesis repeated the Test Scenario 1 circuit (Fig. 6.1) with the Base Station, then the
Tablet, sending speed commands every 100 ms, and logged the period of the commands the robot
received (Table 6.8: mean and std per section), the moments when the multiplexer's timeout
fired and cmd_vel went to zero (Fig. 6.6a, timeout 0.2 s there), and the places where the delay
exceeded 1 s (Fig. 6.7: clustered near the Library).

Here, per controller and per seed (``runs``, default 3, seeds ``seed .. seed+2``):

* the robot starts at node 0, localised, and the supervisor drives it to the start of a straight
  corridor stretch (the straight node-to-node segment nearest the lossy zone), laid so that the
  section-2 rotations happen nearest the zone (the thesis's most critical section);
* a lossy zone (`robot_daemon.sim.wifi.LossyZone`) is centred on the topological node named
  "Library" (``LatencyConfig.zone_point`` overrides; without either, the stretch's far end);
* the controller runs its 100 ms loop: section 1 straight for D at ``linear_speed``, section 2 a
  2 pi rotation counter-clockwise and on until it faces back, section 3 straight back, section 4
  clockwise likewise, 1 s of zero commands between sections. It closes the loop on the pose the
  robot publishes (what the station shows), not on the truth;
* Base Station: each command goes over one `WifiLink` (station -> robot, ``station_vel``).
  Tablet: tablet -> station over a first link; the station's `LatencyWatchdog` (ceiling
  ``watchdog_ceiling``, thesis §5.3.4) restarts on every chunk (the messages that arrive
  together); a chunk arriving after a silence longer than the ceiling is stale and discarded; the
  rest is forwarded at once over a second link (station -> robot, ``tablet_vel``);
* the robot hands each message to the stack's multiplexer with its arrival time; the mux's
  ``station_vel``/``tablet_vel`` timeouts are ``mux_timeout``.

Reported: the received-period mean/std per section [ms] (Table 6.8), mux timeouts (transitions
of the controller's input from valid to expired while the controller was sending), watchdog
discards, and the true positions where a command's end-to-end delay exceeded 1 s (Fig. 6.7).
No people walk (``people`` is ignored): the commands are scripted for an empty corridor.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar

import msgspec
import numpy as np
from msgspec import Meta

from interbot_core import schema
from interbot_core.geometry import Pose2D, angle_diff
from interbot_core.watchdog import LatencyWatchdog, PeriodStats
from robot_daemon.scenarios.runner import (
    ScenarioOptions,
    ScenarioResult,
    SimulatedSystem,
    StraightSegment,
    daemon_localiser_config,
    drive_to_pose,
    run_ticks,
    straight_segments,
)
from robot_daemon.sim.wifi import LossyZone, WifiConfig, WifiLink
from robot_daemon.stack import StackConfig

CONTROLLERS = ("Base Station", "Tablet")
TOPIC = {"Base Station": "station_vel", "Tablet": "tablet_vel"}
SEND_PERIOD = 0.1  # [s] the controllers' loop (thesis §6.4)
END_MARGIN = 1.0  # [m]
PAUSE_S = 1.0  # [s] zero commands between sections
DELAY_POINT_S = 1.0  # [s] Fig. 6.7 threshold


class LatencyScenarioError(RuntimeError):
    """The map has no usable stretch or the robot could not reach it."""


Rate = Annotated[float, Meta(gt=0.0, le=10.0)]


class LatencyConfig(schema.Declared, frozen=True):
    """The experiment's knobs; defaults follow the thesis (mux timeout 0.5 s as configured)."""

    ROOT: ClassVar[str] = "LatencyConfig"
    ERROR: ClassVar[type[Exception]] = ValueError
    mux_timeout: Rate = 0.5  # [s] station_vel/tablet_vel (thesis Fig. 6.6a used 0.2 s)
    watchdog_ceiling: Rate = 0.5  # [s] station's tablet watchdog (thesis §5.3.4)
    linear_speed: Rate = 0.6  # [m/s]
    angular_speed: Rate = 0.6  # [rad/s]
    distance: Annotated[float, Meta(ge=1.0, le=schema.FINITE, extra={"unit": "m"})] = 26.0
    zone_radius: float = 5.0  # [m]
    zone_p_good_to_bad: float = 0.02  # per message inside the zone
    zone_point: tuple[float, float] | None = None  # None: the node named "Library"
    runs: Annotated[int, Meta(ge=1, le=20)] = 3
    wifi: WifiConfig = msgspec.field(default_factory=WifiConfig)  # zones are added


@dataclass
class TrialResult:
    """One run of one controller."""

    controller: str
    seed: int
    periods: dict[int, PeriodStats]
    mux_timeouts: dict[int, int]
    watchdog_discards: int
    sent: int
    received: int
    max_delay: float
    points_over_1s: list[tuple[float, float]]
    zone: LossyZone
    collisions: int

    def row(self, test: int) -> dict[str, Any]:
        sections = {}
        for section, stats in sorted(self.periods.items()):
            sections[str(section)] = {
                "mean_ms": _ms(stats.mean()),
                "std_ms": _ms(stats.std()),
                "count": stats.count,
            }
        return {
            "test": test,
            "controller": self.controller,
            "seed": self.seed,
            "sections": sections,
            "mux_timeouts": sum(self.mux_timeouts.values()),
            "mux_timeouts_per_section": {str(k): v for k, v in sorted(self.mux_timeouts.items())},
            "watchdog_discards": self.watchdog_discards,
            "sent": self.sent,
            "received": self.received,
            "max_delay_s": round(self.max_delay, 3),
            "points_over_1s": len(self.points_over_1s),
            "collisions": self.collisions,
        }


def _ms(value: float) -> float | None:
    return None if not math.isfinite(value) else round(1000.0 * value, 1)


def find_zone_point(system: SimulatedSystem, config: LatencyConfig) -> tuple[float, float] | None:
    if config.zone_point is not None:
        return config.zone_point
    for node in system.topo.nodes:
        if "library" in node.name.lower():
            return (node.pose.x, node.pose.y)
    return None


def lay_out_run(
    segments: list[StraightSegment], point: tuple[float, float] | None, distance: float
) -> tuple[Pose2D, float, tuple[float, float]]:
    """Start pose, length D and the zone point: the run's far end as near the point as fits."""
    if not segments:
        raise LatencyScenarioError("no straight collision-free segment between topological nodes")
    if point is None:
        seg = segments[0]
        point = seg.end
    else:
        seg = min(segments, key=lambda s: (round(s.distance_to(*point), 3), -s.length))
    length = min(distance, seg.length - 2 * END_MARGIN)
    if length < 1.0:
        raise LatencyScenarioError(f"the stretch between nodes {seg.nodes} is too short")
    ux, uy = math.cos(seg.heading), math.sin(seg.heading)
    t_c = (point[0] - seg.start[0]) * ux + (point[1] - seg.start[1]) * uy
    lo, hi = END_MARGIN, seg.length - END_MARGIN
    fwd_start = min(max(t_c - length, lo), hi - length)
    back_start = min(max(t_c + length, lo + length), hi)
    if abs(fwd_start + length - t_c) <= abs(back_start - length - t_c):
        s, heading = fwd_start, seg.heading
    else:
        s, heading = back_start, seg.heading + math.pi
    start = Pose2D(seg.start[0] + s * ux, seg.start[1] + s * uy, heading)
    return start, length, point


class CircuitSender:
    """The controller's 100 ms loop: the Fig. 6.1 circuit on the pose the robot publishes."""

    def __init__(
        self, system: SimulatedSystem, start: Pose2D, distance: float, config: LatencyConfig
    ) -> None:
        self.system = system
        self.config = config
        back = Pose2D(
            start.x + distance * math.cos(start.yaw),
            start.y + distance * math.sin(start.yaw),
            start.yaw + math.pi,
        )
        self.plan: list[tuple[int, str, Pose2D]] = [
            (1, "line", start),
            (1, "pause", start),
            (2, "turn+", back),
            (2, "pause", back),
            (3, "line", back),
            (3, "pause", back),
            (4, "turn-", start),
            (4, "pause", start),
        ]
        self.distance = distance
        self.index = 0
        self._phase_start: float | None = None
        self._turned = 0.0
        self._last_yaw: float | None = None
        self._aligning = False

    @property
    def section(self) -> int:
        return self.plan[min(self.index, len(self.plan) - 1)][0]

    @property
    def done(self) -> bool:
        return self.index >= len(self.plan)

    def _advance(self) -> None:
        self.index += 1
        self._phase_start = None
        self._turned, self._last_yaw, self._aligning = 0.0, None, False

    def command(self, now: float) -> tuple[float, float]:
        """The (linear, angular) to send now; advances through the plan."""
        if self.done:
            return 0.0, 0.0
        _, kind, ref = self.plan[self.index]
        pose = self.system.stack.pose
        if self._phase_start is None:
            self._phase_start = now
        cfg = self.config
        if kind == "pause":
            if now - self._phase_start >= PAUSE_S - 1e-9:
                self._advance()
                return self.command(now)
            return 0.0, 0.0
        if pose is None:
            return 0.0, 0.0
        if kind == "line":
            rel = pose.relative_to(ref)
            if (
                rel.x >= self.distance
                or now - self._phase_start > 3 * self.distance / cfg.linear_speed
            ):
                self._advance()
                return self.command(now)
            heading_err = angle_diff(pose.yaw, ref.yaw)
            if abs(heading_err) > 0.25:  # late commands overshot the turn: face the line first
                return 0.0, max(-0.4, min(0.4, -1.5 * heading_err))
            w = -0.6 * rel.y - 1.5 * heading_err
            return cfg.linear_speed, max(-0.2, min(0.2, w))
        sign = 1.0 if kind == "turn+" else -1.0
        if self._last_yaw is not None:
            self._turned += sign * angle_diff(pose.yaw, self._last_yaw)
        self._last_yaw = pose.yaw
        err = angle_diff(ref.yaw, pose.yaw)
        timeout = now - self._phase_start > 4 * 3 * math.pi / cfg.angular_speed
        if self._turned >= 2 * math.pi and abs(err) < 0.3:
            self._aligning = True
        if self._aligning:
            if abs(err) < 0.03 or timeout:
                self._advance()
                return self.command(now)
            return 0.0, max(-0.4, min(0.4, 1.5 * err))
        if timeout:
            self._advance()
            return self.command(now)
        return 0.0, sign * cfg.angular_speed


def run_trial(
    options: ScenarioOptions, controller: str, seed: int, config: LatencyConfig
) -> TrialResult:
    """One circuit driven by ``controller`` ("Base Station" or "Tablet") with links seeded ``seed``."""
    if controller not in CONTROLLERS:
        raise ValueError(f"controller must be one of {CONTROLLERS}, got {controller!r}")
    opts = dataclasses.replace(options, seed=seed, people=0)
    mux = StackConfig().mux
    inputs = tuple(  # the commands' inputs time out after config.mux_timeout
        msgspec.structs.replace(i, timeout=config.mux_timeout) if i.topic in TOPIC.values() else i
        for i in mux.inputs
    )
    stack_config = StackConfig(
        mux=dataclasses.replace(mux, inputs=inputs), localiser=daemon_localiser_config()
    )
    system = SimulatedSystem(opts, start_node=0, stack_config=stack_config)
    system.localise()
    segments = straight_segments(system.grid, system.topo)
    start, distance, point = lay_out_run(segments, find_zone_point(system, config), config.distance)
    zone = LossyZone(point[0], point[1], config.zone_radius, config.zone_p_good_to_bad, "lossy")
    wifi = msgspec.structs.replace(config.wifi, zones=(*config.wifi.zones, zone))
    if not drive_to_pose(system, start):
        raise LatencyScenarioError(
            f"the robot could not drive from node 0 to ({start.x:.2f}, {start.y:.2f})"
        )
    rng_station, rng_tablet = (
        np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(2)
    )
    station_link = WifiLink(wifi, rng_station)
    tablet_link = WifiLink(wifi, rng_tablet) if controller == "Tablet" else None
    watchdog = LatencyWatchdog(config.watchdog_ceiling)
    topic = TOPIC[controller]
    sender = CircuitSender(system, start, distance, config)
    periods = {s: PeriodStats() for s in (1, 2, 3, 4)}
    timeouts = {s: 0 for s in (1, 2, 3, 4)}
    state: dict[str, Any] = {
        "discards": 0,
        "received": 0,
        "max_delay": 0.0,
        "expired": False,
        "got_any": False,
        "last_section": 1,
    }
    points: list[tuple[float, float]] = []
    mux_input = stack_config.mux.input_by_topic(topic)

    def position() -> tuple[float, float]:
        truth = system.sim.true_pose()  # the radio sees where the robot physically is
        return (truth.x, truth.y)

    def tick(now: float) -> bool:
        linear, angular = sender.command(now)
        if sender.done:
            return True
        payload = (sender.section, linear, angular, now, position())
        (tablet_link or station_link).send(now, payload, payload[4])  # the controller's link
        return False

    def on_step(now: float) -> None:
        if tablet_link is not None:
            chunk_time: float | None = None
            discard = False
            for d in tablet_link.receive(now):
                if d.received != chunk_time:  # a new chunk (messages read together)
                    chunk_time = d.received
                    discard = watchdog.last_feed is not None and watchdog.expired(d.received)
                    watchdog.feed(d.received)
                if discard:
                    state["discards"] += 1
                    continue
                station_link.send(d.received, d.payload, position())
        for d in station_link.receive(now):
            section, linear, angular, sent, where = d.payload
            system.stack.on_twist(topic, linear, angular, d.received)
            periods[section].add_arrival(d.received)
            state["received"] += 1
            state["got_any"] = True
            state["last_section"] = section
            delay = d.received - sent
            state["max_delay"] = max(state["max_delay"], delay)
            if delay > DELAY_POINT_S:
                points.append((round(where[0], 2), round(where[1], 2)))
        expired = state["got_any"] and mux_input not in system.stack.mux.valid_inputs(now)
        if expired and not state["expired"]:
            timeouts[state["last_section"]] += 1
        state["expired"] = expired

    limit = 4 * (2 * distance / config.linear_speed + 6 * math.pi / config.angular_speed) + 60
    run_ticks(system, tick, limit, period=SEND_PERIOD, on_step=on_step)
    # Let the last messages in flight arrive (they are counted, no more are sent).
    run_ticks(system, lambda now: False, 3.0, on_step=on_step)
    if state["expired"]:  # the input expiring after the last command is not a timeout
        timeouts[state["last_section"]] -= 1
    sent = (tablet_link or station_link).sent_count
    return TrialResult(
        controller,
        seed,
        periods,
        timeouts,
        state["discards"],
        sent,
        state["received"],
        state["max_delay"],
        points,
        zone,
        system.sim.collisions,
    )


def format_table(rows: list[dict[str, Any]], config: LatencyConfig) -> str:
    lines = [
        "Latency analysis (thesis Table 6.8): period of received speed commands (ms)",
        "Test  Controller    Section 1       Section 2       Section 3       Section 4"
        "       mux      watchdog  delays",
        "#                   mean    std     mean    std     mean    std     mean    std"
        "     timeouts discards  >1 s",
    ]
    for r in rows:
        cells = []
        for s in ("1", "2", "3", "4"):
            sec = r["sections"].get(s, {})
            mean, std = sec.get("mean_ms"), sec.get("std_ms")
            cells.append(
                f"{mean if mean is not None else float('nan'):<7.1f} "
                f"{std if std is not None else float('nan'):<7.1f}"
            )
        lines.append(
            f"{r['test']:<5} {r['controller']:<13} {' '.join(cells)} {r['mux_timeouts']:>8}"
            f" {r['watchdog_discards']:>9} {r['points_over_1s']:>6}"
        )
    lines.append(
        f"mux timeout {config.mux_timeout:g} s, tablet watchdog {config.watchdog_ceiling:g} s, "
        f"commands every {SEND_PERIOD * 1000:.0f} ms"
    )
    return "\n".join(lines)


def run(options: ScenarioOptions, config: LatencyConfig | None = None) -> ScenarioResult:
    config = config or LatencyConfig()
    rows: list[dict[str, Any]] = []
    points: list[list[float]] = []
    zone: LossyZone | None = None
    collisions = 0
    for controller in CONTROLLERS:
        for test in range(1, config.runs + 1):
            trial = run_trial(options, controller, options.seed + test - 1, config)
            rows.append(trial.row(test))
            points += [[x, y] for x, y in trial.points_over_1s]
            zone = trial.zone
            collisions += trial.collisions
    figures: dict[str, Any] = {
        "rows": rows,
        "points_over_1s": points,
        "mux_timeout_s": config.mux_timeout,
        "watchdog_ceiling_s": config.watchdog_ceiling,
        "mux_timeouts_total": sum(r["mux_timeouts"] for r in rows),
        "watchdog_discards_total": sum(r["watchdog_discards"] for r in rows),
        "collisions": collisions,
        "seed": options.seed,
    }
    if zone is not None:
        figures["lossy_zone"] = {"x": zone.x, "y": zone.y, "radius": zone.radius}
    table = format_table(rows, config)
    if zone is not None:
        table += (
            f"\nlossy zone at ({zone.x:.1f}, {zone.y:.1f}) r {zone.radius:g} m; "
            f"{len(points)} commands delayed > 1 s; collisions {collisions}"
        )
    return ScenarioResult("latency", table, figures)
