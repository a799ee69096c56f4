"""How many places can a standing robot tell from one scan? (issue 16: the ceiling of any
standing global search)

For N random free poses (cells at least 0.45 m from walls, as the kidnap scenario's cold
starts, random heading) of the realistic simulated world with people, one scan is taken and
searched over the whole map with the relocaliser's larger node budget; the truth and every
other verified place (not a near-duplicate of the truth) are checked the relocaliser's way
(quality = hit fraction - 2 x see-through fraction) and by their expected scans
(`robot_daemon.localisation.expected_scan`: beams ending where the place expects, beams
through its walls). Each pose gets a class:

- ``A`` truly ambiguous: a rival fits as well (quality >= the truth's - 0.02) and its expected
  scan matches as well (match >= the truth's - 0.02): no standing search can tell;
- ``M`` a rival within the decision's margin (0.1) that the expected-scan check does not clear;
- ``M*`` rivals within the margin, all cleared by the expected-scan check;
- ``T`` the truth itself fails verification (clutter or people in front of it);
- ``C`` clear: no rival within the margin.

A standing robot can decide at most the ``C`` and ``M*`` poses with today's rules. A line
``DANGER`` would mean the expected-scan check clears the truth in favour of a rival.

    python tools/relocalise_ceiling.py --map maps/isr_floor0.yaml --topo maps/isr_floor0_topo.yaml --n 60
    python tools/relocalise_ceiling.py --map ../shared/data/maps/willow.yaml --topo maps/willow_topo.yaml
"""

from __future__ import annotations

import argparse
import collections
import math
from pathlib import Path

import numpy as np

from interbot_core.geometry import Pose2D, angle_diff
from robot_daemon.config import LocaliserSettings
from robot_daemon.localisation.localiser import LocaliserConfig
from robot_daemon.localisation.relocalisation import RelocalisationConfig
from robot_daemon.localisation.relocaliser import Relocaliser
from robot_daemon.localisation.wall_model import wall_model_setting
from robot_daemon.scenarios import kidnap as kd
from robot_daemon.scenarios.runner import ScenarioOptions, SimulatedSystem
from robot_daemon.stack import StackConfig


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--map", type=Path, default=Path("maps/isr_floor0.yaml"))
    parser.add_argument("--topo", type=Path, default=Path("maps/isr_floor0_topo.yaml"))
    parser.add_argument("--seed", type=int, default=1, help="the simulated world's seed")
    parser.add_argument("--n", type=int, default=60, help="poses")
    args = parser.parse_args()
    options = ScenarioOptions(
        map_yaml=args.map, topo_yaml=kd.topo_for(args.map, args.topo) or args.topo, seed=args.seed
    )
    matcher, wall_model = wall_model_setting(LocaliserSettings().map_surface)
    config = StackConfig(
        localiser=LocaliserConfig(matcher=matcher, wall_model=wall_model),
        relocalisation=RelocalisationConfig(on_unset=False, on_lost=False, background=False),
    )
    system = SimulatedSystem(options, stack_config=config)
    mount = system.stack.config.laser_mount
    reloc = Relocaliser(system.grid, system.stack.localiser)
    cfg = reloc.config
    rng = np.random.default_rng(1000 + args.seed)
    free = kd.free_poses(system.grid, kd.MIN_CLEARANCE_M)
    counts: collections.Counter[str] = collections.Counter()
    while sum(counts.values()) < args.n:
        x, y = free[int(rng.integers(free.shape[0]))]
        pose = Pose2D(float(x), float(y), float(rng.uniform(-math.pi, math.pi)))
        if system.sim.world.clearance_at(pose.x, pose.y) < 0.35:
            continue  # the simulated building has a wall or clutter here
        system.sim.teleport(pose)
        for _ in range(3):
            system.step()
        scan = system.sim.scan()
        truth = system.sim.true_pose().compose(mount)
        points = scan.points(cfg.max_range_m)
        result = reloc.search_engine.search(points, None, [], cfg.proof_max_nodes)
        vt = reloc.verify(points, truth)
        at = reloc.expected_scan.agreement(scan, vt.pose)
        rivals = []
        for hyp in result.hypotheses[: cfg.verify_hypotheses]:
            v = reloc.verify(points, hyp.pose)
            same = v.pose.distance_to(truth) <= cfg.duplicate_xy_m and (
                abs(angle_diff(v.pose.yaw, truth.yaw)) <= cfg.duplicate_yaw_rad
            )
            if (
                not same
                and v.confidence >= cfg.min_confidence
                and (v.impossible <= cfg.max_impossible)
            ):
                rivals.append((v, reloc.expected_scan.agreement(scan, v.pose)))
        rivals.sort(key=lambda r: -r[0].quality)
        near = [r for r in rivals if r[0].quality >= vt.quality - cfg.margin]
        cleared = [r for r in near if reloc._clearly_better(at, r[1])]
        truth_ok = vt.confidence >= cfg.min_confidence and vt.impossible <= cfg.max_impossible
        if not truth_ok:
            cls = "T"
        elif any(r[0].quality >= vt.quality - 0.02 and r[1].match >= at.match - 0.02 for r in near):
            cls = "A"
        elif len(cleared) < len(near):
            cls = "M"
        elif near:
            cls = "M*"
        else:
            cls = "C"
        counts[cls] += 1
        if any(reloc._clearly_better(r[1], at) for r in rivals):
            print("DANGER: the truth would be cleared in favour of a rival")
        best = (
            f"rival q={rivals[0][0].quality:.3f} match={rivals[0][1].match:.3f} "
            f"long={rivals[0][1].long:.3f} d={rivals[0][0].pose.distance_to(truth):.1f} m"
            if rivals
            else "no rival"
        )
        print(
            f"{cls:2s} ({pose.x:6.2f}, {pose.y:6.2f}, {pose.yaw:5.2f}) truth q={vt.quality:.3f} "
            f"match={at.match:.3f} long={at.long:.3f} | {best} | {len(rivals)} rival(s)",
            flush=True,
        )
    print(f"{args.map.name}, world seed {args.seed}, {args.n} poses: {dict(counts)}")


if __name__ == "__main__":
    main()
