"""Benchmark: one global search (branch and bound over the whole map) per scan, ISR and Willow.

For ``SCANS`` simulated scans at seeded random free poses (no people), time
`GlobalSearch.search` over the whole map: ``global_search_{isr,willow}_ms_*`` (median, p99,
max; the grids are precomputed once per map, ``global_search_*_precompute_ms``), the same in
CPU time of this process (``global_search_*_cpu_ms_*``: the search is single-threaded numpy, so
on a shared, loaded machine this is the better estimate of the quiet wall time), and how often
the true pose is the first hypothesis (``*_truth_first``; the rest are look-alike places the
relocaliser has to disambiguate, or the truth ranked lower). Willow Garage is the real map in
``../shared/data`` (skipped where absent). A search whose node budget cut it is not exhaustive;
the relocaliser then runs one search with its larger ``proof_max_nodes`` budget when a
candidate waits on it: ``*_complete`` is the share of searches exhaustive at once, and
``*_proof_ms_*`` the wall time of the larger search on the others (the truth then first:
``*_proof_truth_first``).

    .venv/bin/interbot bench --only global_search --json
"""

from __future__ import annotations

import importlib.util
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

_spec = importlib.util.spec_from_file_location("interbot_bench_common", Path(__file__).with_name("_common.py"))  # fmt: skip
common = importlib.util.module_from_spec(_spec)  # type: ignore[arg-type]
_spec.loader.exec_module(common)  # type: ignore[union-attr]

SCANS = 30
QUICK_SCANS = 2  # ISR only
WILLOW = common.SHARED_DATA / "maps" / "willow.yaml"


def run(quick: bool = False) -> dict[str, Any]:
    out: dict[str, Any] = {}
    n = QUICK_SCANS if quick else SCANS
    with common.quiet_logs():
        out.update(measure("isr", common.ISR_MAP, n))
        if WILLOW.is_file() and not quick:
            out.update(measure("willow", WILLOW, n))
    return out


def measure(name: str, map_yaml: Path, n: int, seed: int = 0) -> dict[str, float]:
    from interbot_core.geometry import Pose2D
    from interbot_core.occupancy_grid import load_map
    from robot_daemon.localisation.global_search import GlobalSearch
    from robot_daemon.localisation.relocaliser import RelocaliserConfig
    from robot_daemon.sim.simulator import SimConfig, Simulator
    from robot_daemon.stack import DEFAULT_LASER_MOUNT

    grid = load_map(map_yaml)
    t0 = time.perf_counter()
    search = GlobalSearch(grid)
    precompute = time.perf_counter() - t0
    sim = Simulator(grid, SimConfig(n_people=0), rng_seed=seed)
    rng = np.random.default_rng(seed)
    cells = np.argwhere(search.candidates[: search.height, : search.width])
    times: list[float] = []
    cpu: list[float] = []
    first = 0
    complete = 0
    proof_times: list[float] = []
    proof_cpu: list[float] = []
    proof_first = 0
    proof_nodes = RelocaliserConfig().proof_max_nodes
    while len(times) < n:
        row, col = cells[rng.integers(cells.shape[0])]
        x = grid.origin_x + (col + 0.5) * search.resolution
        y = grid.origin_y + (row + 0.5) * search.resolution
        base = Pose2D(float(x), float(y), float(rng.uniform(-math.pi, math.pi)))
        if sim.world.clearance_at(base.x, base.y) < 0.35:
            continue  # the robot's footprint does not fit here
        sim.teleport(base)
        sim.step(0.05)
        points = sim.scan().points()
        t0, c0 = time.perf_counter(), time.process_time()
        result = search.search(points)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        laser = base.compose(DEFAULT_LASER_MOUNT)
        first += _truth_first(result.best, laser)
        complete += result.complete
        if not result.complete:
            t0, c0 = time.perf_counter(), time.process_time()
            proof = search.search(points, max_nodes=proof_nodes)
            proof_times.append(time.perf_counter() - t0)
            proof_cpu.append(time.process_time() - c0)
            proof_first += _truth_first(proof.best, laser)
    out = common.summary_ms(times, f"global_search_{name}")
    out.update(common.summary_ms(cpu, f"global_search_{name}_cpu"))
    out[f"global_search_{name}_precompute_ms"] = precompute * 1e3
    out[f"global_search_{name}_truth_first"] = first / n
    out[f"global_search_{name}_complete"] = complete / n
    if proof_times:
        out.update(common.summary_ms(proof_times, f"global_search_{name}_proof"))
        out.update(common.summary_ms(proof_cpu, f"global_search_{name}_proof_cpu"))
        out[f"global_search_{name}_proof_truth_first"] = proof_first / len(proof_times)
    return out


def _truth_first(best: Any, laser: Any) -> bool:
    """The search's first hypothesis is the true laser pose (0.3 m, 0.1 rad)."""
    if best is None or best.pose.distance_to(laser) >= 0.3:
        return False
    return abs(math.remainder(best.pose.yaw - laser.yaw, math.tau)) < 0.1


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))  # command-line output
