"""Test Scenario 1 (thesis §6.1, Tables 6.1/6.2): are speed commands turned into the right motion?

The thesis drove a circuit (Fig. 6.1) with speed commands given on the Processing Unit itself
(no Base Station, so no latency): section 1 straight along a corridor, section 2 pure rotations
counter-clockwise, section 3 straight back, section 4 pure rotations clockwise. Durations were
compared with the expected ones,

    ExpectedDuration(Corridor)      = Distance / SpeedCommands        (6.1)
    ExpectedDuration(PureRotations) = 2 pi / SpeedCommands            (6.2)

    error rate = |expected - measured| / expected,

sections 1 and 3 (and 2 and 4) averaged; once uncalibrated (Table 6.1: test 1 at 0.6 m/s, test 2
at 0.3 m/s) and once calibrated (Table 6.2: 0.42 m/s and 0.30 m/s), rotations at 0.6 rad/s.

Here: the corridor is the longest straight collision-free segment between two topological nodes
(`straight_segments`), the run D = 26 m when it fits (else the segment less 1 m at each end). The
robot starts at node 0, localised, and the supervisor drives it to the start of the stretch. Then
a script on the Processing Unit sends ``station_vel`` every 100 ms through the stack's multiplexer:

* straight sections: the commanded speed, plus a small heading/lateral hold on the robot's own
  localised pose (|w| <= 0.2 rad/s) so the 0.1 % wheel-radius mismatch of the odometry model does
  not steer it into a wall over 26 m (the operator of the thesis would have done the same);
* rotations: 0.6 rad/s until the robot has turned 2 pi, then on until it faces back along the
  corridor (the turn-around is not timed), using its own pose estimate to stop.

"Measured duration" = simulated time from the first command until the TRUE robot (simulator
ground truth, metrics only) has advanced D along the corridor (or turned 2 pi), interpolated
between 20 ms steps. The acceleration ramp (0.6 m/s^2, 2 rad/s^2) is part of it, as it was in the
thesis's stopwatch figures. The odometry's own reading at that moment is reported beside it.
No people walk in the corridor (``people`` is ignored): the test is about the drive.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from interbot_core.geometry import Pose2D, angle_diff
from robot_daemon.recording.recorder import jsonable
from robot_daemon.scenarios.runner import (
    ScenarioOptions,
    ScenarioResult,
    SimulatedSystem,
    StraightSegment,
    drive_to_pose,
    run_ticks,
    straight_segments,
)

logger = logging.getLogger(__name__)

TARGET_DISTANCE = 26.0  # [m] thesis Tables 6.1/6.2
END_MARGIN = 1.0  # [m] kept free at each end of the stretch
ANGULAR_SPEED = 0.6  # [rad/s] thesis Tables 6.1/6.2
LINEAR_SPEEDS = {"uncalibrated": (0.6, 0.3), "calibrated": (0.42, 0.30)}  # [m/s] tests 1, 2
SETTLE_S = 1.5  # [s] standstill between sections
# A section's measurements (its state), in the order of SectionResult's last four fields.
MEASURED = ("measured", "odom_at", "true", "odom")
HOLD_MAX_W = 0.2  # [rad/s] heading/lateral hold on straight sections
SECTION_TIMEOUT_FACTOR = 2.0  # a section gives up after this many expected durations


class OdometryScenarioError(RuntimeError):
    """The map offers no usable straight stretch, or the robot could not reach it."""


def expected_duration(amount: float, speed: float) -> float:
    """Eq. (6.1)/(6.2): distance [m] (or 2 pi [rad]) over the commanded speed [s]."""
    return amount / abs(speed)


def error_rate(expected: float, measured: float) -> float:
    """|expected - measured| / expected (a fraction)."""
    return abs(expected - measured) / expected


@dataclass(frozen=True)
class SectionResult:
    """One timed section of the circuit."""

    test: int
    section: int  # 1..4 (thesis Fig. 6.1)
    kind: str  # linear | angular
    command: float  # [m/s] or [rad/s], signed
    target: float  # [m] or [rad]
    expected_s: float
    measured_s: float  # nan if not reached
    odometry_at_target: float  # [m] or [rad] the encoders' reading when the truth reached target
    true_total: float  # [m] or [rad] covered by the truth until standstill
    odometry_total: float  # [m] or [rad] reported by the encoders until standstill

    @property
    def error(self) -> float:
        return error_rate(self.expected_s, self.measured_s)


def choose_stretch(
    segments: list[StraightSegment], target: float = TARGET_DISTANCE, margin: float = END_MARGIN
) -> tuple[Pose2D, float]:
    """Start pose and run length D on the longest segment: D = target if it fits."""
    if not segments:
        raise OdometryScenarioError(
            "no straight collision-free segment between topological nodes; "
            "the map needs a corridor at least 1 m wide between two nodes"
        )
    seg = segments[0]
    length = min(target, seg.length - 2 * margin)
    if length < 2.0:
        raise OdometryScenarioError(
            f"the longest straight stretch (nodes {seg.nodes}) is {seg.length:.1f} m; "
            "at least 4 m are needed"
        )
    heading = seg.heading
    start = Pose2D(
        seg.start[0] + margin * math.cos(heading),
        seg.start[1] + margin * math.sin(heading),
        heading,
    )
    return start, length


class CircuitDriver:
    """Drives the Fig. 6.1 circuit through ``station_vel`` and times it against the truth."""

    def __init__(self, system: SimulatedSystem, start: Pose2D, distance: float) -> None:
        self.system = system
        self.start = start
        self.distance = distance
        self.results: list[SectionResult] = []

    # -- measurement helpers ---------------------------------------------------------------

    def _odom_pose(self) -> Pose2D:
        odom = self.system.stack.last_odometry
        return odom.pose if odom is not None else Pose2D(0.0, 0.0, 0.0)

    def _hold(self, origin: Pose2D) -> float:
        """Heading/lateral hold on the robot's own pose estimate [rad/s]."""
        pose = self.system.stack.pose
        if pose is None:
            return 0.0
        rel = pose.relative_to(origin)
        w = -0.6 * rel.y - 1.5 * angle_diff(pose.yaw, origin.yaw)
        return max(-HOLD_MAX_W, min(HOLD_MAX_W, w))

    # -- sections --------------------------------------------------------------------------

    def linear(self, test: int, section: int, speed: float, origin: Pose2D) -> SectionResult:
        """Drive ``self.distance`` along ``origin``'s heading at ``speed``; time it."""
        system, sim = self.system, self.system.sim
        truth0, odom_prev = sim.true_pose(), self._odom_pose()
        ux, uy = math.cos(origin.yaw), math.sin(origin.yaw)
        expected = expected_duration(self.distance, speed)
        state: dict[str, Any] = {"t0": None, "measured": math.nan, "odom": 0.0, "true": 0.0}
        state.update(prev_progress=0.0, prev_time=system.now, odom_at=math.nan)
        last_truth = [truth0]

        def on_step(now: float) -> None:
            nonlocal odom_prev
            truth = sim.true_pose()
            state["true"] += truth.distance_to(last_truth[0])
            last_truth[0] = truth
            odom = self._odom_pose()
            state["odom"] += odom.distance_to(odom_prev)
            odom_prev = odom
            progress = (truth.x - truth0.x) * ux + (truth.y - truth0.y) * uy
            if math.isnan(state["measured"]) and progress >= self.distance:
                p0, t0 = state["prev_progress"], state["prev_time"]
                f = (self.distance - p0) / (progress - p0) if progress > p0 else 1.0
                state["measured"] = t0 + f * (now - t0) - state["t0"]
                state["odom_at"] = state["odom"]
            state["prev_progress"], state["prev_time"] = progress, now

        def tick(now: float) -> bool:
            if state["t0"] is None:
                state["t0"] = now
            if not math.isnan(state["measured"]):
                return True
            system.stack.on_twist("station_vel", speed, self._hold(origin), now)
            return False

        reached = run_ticks(system, tick, SECTION_TIMEOUT_FACTOR * expected + 5.0, on_step=on_step)
        if not reached:
            logger.warning(
                "test %d section %d: the robot did not cover %.1f m", test, section, self.distance
            )
        self.settle(on_step)
        measured = (state[key] for key in MEASURED)
        return SectionResult(test, section, "linear", speed, self.distance, expected, *measured)

    def rotation(self, test: int, section: int, rate: float, face_after: float) -> SectionResult:
        """Turn 2 pi at ``rate`` (timed), continue until facing ``face_after`` (not timed)."""
        system, sim = self.system, self.system.sim
        target = 2.0 * math.pi
        expected = expected_duration(target, rate)
        sign = 1.0 if rate > 0 else -1.0
        state: dict[str, Any] = {"t0": None, "measured": math.nan, "true": 0.0, "odom": 0.0}
        state.update(prev_time=system.now, odom_at=math.nan, phase="turn")
        yaw_truth, yaw_odom = [sim.true_pose().yaw], [self._odom_pose().yaw]

        def on_step(now: float) -> None:
            truth, odom = sim.true_pose(), self._odom_pose()
            before = state["true"]
            state["true"] += sign * angle_diff(truth.yaw, yaw_truth[0])
            state["odom"] += sign * angle_diff(odom.yaw, yaw_odom[0])
            yaw_truth[0], yaw_odom[0] = truth.yaw, odom.yaw
            if math.isnan(state["measured"]) and state["true"] >= target:
                t0 = state["prev_time"]
                f = (target - before) / (state["true"] - before) if state["true"] > before else 1
                state["measured"] = t0 + f * (now - t0) - state["t0"]
                state["odom_at"] = state["odom"]
            state["prev_time"] = now

        def tick(now: float) -> bool:
            if state["t0"] is None:
                state["t0"] = now
            w = rate
            if not math.isnan(state["measured"]):
                pose = system.stack.pose
                err = angle_diff(face_after, pose.yaw) if pose is not None else math.pi
                if state["phase"] == "turn" and abs(err) < 0.3:
                    state["phase"] = "align"
                if state["phase"] == "align":
                    if abs(err) < 0.02:
                        system.stack.on_twist("station_vel", 0.0, 0.0, now)
                        return True
                    w = max(-0.4, min(0.4, 1.5 * err))
            system.stack.on_twist("station_vel", 0.0, w, now)
            return False

        run_ticks(system, tick, SECTION_TIMEOUT_FACTOR * expected + 20.0, on_step=on_step)
        self.settle(on_step)
        measured = (state[key] for key in MEASURED)
        return SectionResult(test, section, "angular", rate, target, expected, *measured)

    def settle(self, on_step: Callable[[float], None] | None = None) -> None:
        """Zero commands for SETTLE_S; ``on_step`` goes on measuring the standstill."""
        system = self.system

        def tick(now: float) -> bool:
            system.stack.on_twist("station_vel", 0.0, 0.0, now)
            return False

        run_ticks(system, tick, SETTLE_S, on_step=on_step)

    def circuit(self, test: int, speed: float) -> list[SectionResult]:
        """Sections 1-4: out, rotate CCW, back, rotate CW; ends where it started."""
        out = self.start
        back = Pose2D(
            out.x + self.distance * math.cos(out.yaw),
            out.y + self.distance * math.sin(out.yaw),
            out.yaw + math.pi,
        )
        rows = [
            self.linear(test, 1, speed, out),
            self.rotation(test, 2, ANGULAR_SPEED, back.yaw),
            self.linear(test, 3, speed, back),
            self.rotation(test, 4, -ANGULAR_SPEED, out.yaw),
        ]
        self.results += rows
        return rows


def run_model(options: ScenarioOptions, model: str) -> tuple[list[SectionResult], dict[str, Any]]:
    """Both tests of one odometry model; returns the sections and run facts."""
    opts = dataclasses.replace(options, odometry=model, people=0)
    system = SimulatedSystem(opts, start_node=0)
    system.localise()
    segments = straight_segments(system.grid, system.topo)
    start, distance = choose_stretch(segments)
    if not drive_to_pose(system, start):
        raise OdometryScenarioError(
            f"the robot could not drive from node 0 to the corridor start ({start.x:.2f}, "
            f"{start.y:.2f}) of {opts.map_yaml}"
        )
    driver = CircuitDriver(system, start, distance)
    driver.settle()
    for test, speed in enumerate(LINEAR_SPEEDS[model], start=1):
        driver.circuit(test, speed)
    facts = {
        "segment_nodes": list(segments[0].nodes),
        "distance_m": round(distance, 3),
        "collisions": system.sim.collisions,
        "sim_time_s": round(system.now, 1),
    }
    return driver.results, facts


def summarise(rows: list[SectionResult]) -> list[dict[str, Any]]:
    """Thesis rows: per test, linear sections 1 and 3 averaged, rotations 2 and 4 averaged."""
    out: list[dict[str, Any]] = []
    for kind, sections in (("linear", (1, 3)), ("angular", (2, 4))):
        for test in sorted({r.test for r in rows}):
            chosen = [r for r in rows if r.test == test and r.section in sections]
            if not chosen:
                continue
            measured = sum(r.measured_s for r in chosen) / len(chosen)
            expected = chosen[0].expected_s
            true_total = sum(r.true_total for r in chosen) / len(chosen)
            odom_total = sum(r.odometry_total for r in chosen) / len(chosen)
            out.append(
                {
                    "test": test,
                    "sections": f"{sections[0]} and {sections[1]}",
                    "kind": kind,
                    "speed_command": abs(chosen[0].command),
                    "target": round(chosen[0].target, 4),
                    "expected_s": round(expected, 3),
                    "measured_s": round(measured, 3),
                    "error_pct": round(100 * error_rate(expected, measured), 3),
                    "odometry_at_target": round(
                        sum(r.odometry_at_target for r in chosen) / len(chosen), 4
                    ),
                    "true_total": round(true_total, 4),
                    "odometry_total": round(odom_total, 4),
                    "odometry_vs_true_pct": round(100 * (odom_total - true_total) / true_total, 3)
                    if true_total
                    else math.nan,
                }
            )
    return out


def format_table(title: str, rows: list[dict[str, Any]]) -> str:
    lines = [
        title,
        "Test  Sections   Speed        Distance  Expected      Measured      Error Rate"
        "   Odometry at target / true total / odometry total",
        "#     (Average)  Commands     (m)       Duration (s)  Duration (s)  (Abs.)(%)",
    ]
    for r in rows:
        linear = r["kind"] == "linear"
        unit = "m/s" if linear else "rad/s"
        dist = f"{r['target']:.2f}" if linear else "2 pi"
        lines.append(
            f"{r['test']:<5} {r['sections']:<10} {r['speed_command']:.2f} {unit:<7} {dist:<9} "
            f"{r['expected_s']:<13.3f} {r['measured_s']:<13.3f} {r['error_pct']:<12.3f}"
            f"{r['odometry_at_target']:.3f} / {r['true_total']:.3f} / {r['odometry_total']:.3f}"
            f" {'m' if linear else 'rad'} ({r['odometry_vs_true_pct']:+.2f} %)"
        )
    return "\n".join(lines)


def _mean_error(rows: list[dict[str, Any]], kind: str) -> float:
    errors = [r["error_pct"] for r in rows if r["kind"] == kind]
    return round(sum(errors) / len(errors), 3) if errors else math.nan


def run(options: ScenarioOptions) -> ScenarioResult:
    figures: dict[str, Any] = {"seed": options.seed}
    tables = []
    titles = {
        "uncalibrated": "Test Scenario 1, uncalibrated odometry (thesis Table 6.1)",
        "calibrated": "Test Scenario 1, calibrated odometry (thesis Table 6.2)",
    }
    for model in ("uncalibrated", "calibrated"):
        sections, facts = run_model(options, model)
        rows = summarise(sections)
        figures[f"{model}_rows"] = rows
        figures[f"{model}_linear_error_pct"] = _mean_error(rows, "linear")
        figures[f"{model}_angular_error_pct"] = _mean_error(rows, "angular")
        figures[f"{model}_collisions"] = facts["collisions"]
        figures[f"{model}_sections"] = [
            {**dataclasses.asdict(s), "error_pct": round(100 * s.error, 3)} for s in sections
        ]
        figures["distance_m"] = facts["distance_m"]
        figures["segment_nodes"] = facts["segment_nodes"]
        tables.append(format_table(titles[model], rows))
        tables.append(
            f"collisions {facts['collisions']}; simulated {facts['sim_time_s']:.0f} s; "
            f"stretch between nodes {facts['segment_nodes']}, D = {facts['distance_m']:.2f} m"
        )
    return ScenarioResult("odometry", "\n".join(tables), jsonable(figures))  # NaN -> null
