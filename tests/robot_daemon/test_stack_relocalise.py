"""Global localisation on the full stack (issue 16), on simulated time on the ISR floor.

* Start-up with the pose unset: the robot reports ``searching`` (never ``ok`` with no pose)
  and finds itself within 5 s, at the truth.
* A standing kidnap that the localiser's loss test does not see (here: loss detection turned
  off entirely) is caught by the background check and the robot finds itself again.
* The station's "Relocalise" makes a localised robot search again; autonomy waits meanwhile.
* A kidnap that leaves the localiser ``degraded`` (the scan fits the old pose poorly, but not
  badly enough for the loss test) is checked while degraded and found within seconds.
"""

from __future__ import annotations

from robot_daemon.localisation.localiser import LocaliserConfig, LocaliserState
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem
from robot_daemon.stack import StackConfig


def test_start_up_with_the_pose_unset_finds_itself() -> None:
    system = SimulatedSystem(ScenarioOptions(seed=2, people=2), start_node=7)
    stack = system.stack
    states: set[LocaliserState] = set()

    def found() -> bool:
        states.add(stack.localisation_state)
        return stack.localisation_state is LocaliserState.OK

    assert system.run_until(found, 5.0), stack.relocalisation.relocaliser.last_failure
    assert LocaliserState.SEARCHING in states
    estimate = stack.pose
    assert estimate is not None and estimate.distance_to(system.sim.true_pose()) < 0.15
    texts = [e.text for e in stack.drain_events()]
    assert any("finding my position" in t for t in texts)
    assert any(t.startswith("initial pose set to") for t in texts)

    # The station's "Relocalise": searching again, autonomy waits, found again.
    stack.relocalise(system.now)
    assert stack.localisation_state is LocaliserState.SEARCHING
    assert stack._autonomy_blocker(system.now) == "localisation searching"
    assert system.run_until(lambda: stack.localisation_state is LocaliserState.OK, 5.0)
    estimate = stack.pose
    assert estimate is not None and estimate.distance_to(system.sim.true_pose()) < 0.15


def test_standing_kidnap_missed_by_the_loss_test_is_caught_and_relocalised() -> None:
    blind = LocaliserConfig(lost_confidence=0.0, lost_impossible=1.0, lost_after_s=60.0)
    system = SimulatedSystem(
        ScenarioOptions(seed=3, people=0), start_node=2, stack_config=StackConfig(localiser=blind)
    )
    stack, sim = system.stack, system.sim
    system.localise()
    system.run_until(lambda: False, 1.0)
    assert stack.localisation_state is LocaliserState.OK
    target = system.topo.node(18).pose
    sim.teleport(target)
    kidnapped = system.now
    # The localiser alone never reports it (loss detection off): the background check must.
    assert system.run_until(lambda: stack.localisation_state is not LocaliserState.OK, 8.0)
    detected = system.now - kidnapped
    assert detected <= stack.relocalisation.config.relocaliser.background_every_s + 0.5
    assert stack.localiser.state is LocaliserState.OK  # the localiser itself still believed it
    assert system.run_until(lambda: stack.localisation_state is LocaliserState.OK, 10.0)
    estimate = stack.pose
    assert estimate is not None and estimate.distance_to(sim.true_pose()) < 0.15
    assert sim.true_pose().distance_to(target) < 0.05  # it stood still all along


def test_a_kidnap_that_leaves_the_localiser_degraded_is_checked_and_relocalised() -> None:
    """Loss detection off: after the kidnap the localiser reports ``degraded`` (scan fits
    poorly) for ever and never ``ok``, so the background check never ran and no search started
    (the robot stood ~30 m off, "degraded"). The degraded check starts the search after
    ``degraded_after_s``."""
    blind = LocaliserConfig(lost_confidence=0.0, lost_impossible=1.0, lost_after_s=60.0)
    system = SimulatedSystem(
        ScenarioOptions(seed=3, people=0), start_node=2, stack_config=StackConfig(localiser=blind)
    )
    stack, sim = system.stack, system.sim
    system.localise()
    system.run_until(lambda: False, 1.0)
    assert stack.localisation_state is LocaliserState.OK
    sim.teleport(system.topo.node(9).pose)
    kidnapped = system.now
    assert system.run_until(lambda: stack.localiser.state is LocaliserState.DEGRADED, 0.5)
    assert system.run_until(lambda: stack.localisation_state is LocaliserState.SEARCHING, 2.5)
    after = stack.relocalisation.config.degraded_after_s
    assert after <= system.now - kidnapped <= after + 0.5
    assert stack.relocalisation.relocaliser.reason == "degraded"
    assert system.run_until(lambda: stack.localisation_state is LocaliserState.OK, 5.0)
    estimate = stack.pose
    assert estimate is not None and estimate.distance_to(sim.true_pose()) < 0.15
    texts = [e.text for e in stack.drain_events()]
    assert any("localisation degraded and the scan fits another place better" in t for t in texts)
