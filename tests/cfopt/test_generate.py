"""The seed's instance family: construction, sizes, loads, determinism, grids."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from cfopt import (
    GridCell,
    MissionError,
    generate_mission,
    generate_with_witness,
    paper_distributed_grid,
    paper_grid,
)
from cfopt.generate import task_count

parameters = st.builds(
    dict,
    robots=st.integers(1, 120),
    percent_tasks=st.sampled_from([1, 5, 10, 33.3, 50, 100]),
    service_types=st.integers(1, 10),
    services_per_robot=st.integers(1, 10),
    seed=st.integers(0, 2**32),
).filter(lambda p: p["services_per_robot"] <= p["service_types"])


@given(parameters)
def test_achievable_missions_need_exactly_n_robots_and_the_witness_completes_them(p) -> None:
    mission, witness = generate_with_witness(**p)
    n = p["robots"]
    assert mission.n_robots == n
    assert (
        mission.n_tasks
        == max(1, round(n * p["percent_tasks"] / 100 + 1e-9))
        == task_count(n, p["percent_tasks"])
    )
    assert int(mission.requirements.sum()) == n
    assert (mission.capabilities.sum(axis=1) == p["services_per_robot"]).all()
    assert (mission.requirements.sum(axis=1) >= 1).all()
    assert set(mission.utilities.tolist()) <= set(range(1, 51))
    # The witness is valid (every robot in a slot it can serve) and completes every task.
    witness.validate(mission)
    assert witness.n_assigned == n
    np.testing.assert_array_equal(witness.counts(mission), mission.requirements)
    assert witness.utility(mission) == mission.total_utility


@given(parameters, st.sampled_from([1.1, 1.25, 2.0, 3.7]))
def test_oversubscribed_missions_have_the_stated_total(p, load) -> None:
    mission, witness = generate_with_witness(**p, load=load)
    total = int(np.floor(load * p["robots"] + 0.5))
    assert int(mission.requirements.sum()) == total
    witness.validate(mission)
    assert witness.n_assigned == p["robots"]
    # Extra units only go to services a task already needed: the slot set is unchanged.
    base = generate_mission(**p)
    np.testing.assert_array_equal(mission.requirements > 0, base.requirements > 0)


@given(parameters, st.sampled_from([0.3, 0.5, 0.9]))
def test_slack_missions_leave_robots_spare_and_stay_achievable(p, load) -> None:
    m_tasks = task_count(p["robots"], p["percent_tasks"])
    total = int(np.floor(load * p["robots"] + 0.5))
    if total < m_tasks:
        with pytest.raises(MissionError, match=r"load: .* needs at least one"):
            generate_with_witness(**p, load=load)
        return
    mission, witness = generate_with_witness(**p, load=load)
    assert int(mission.requirements.sum()) == total
    assert witness.n_assigned == total
    assert witness.utility(mission) == mission.total_utility


def test_same_seed_same_bytes_across_processes() -> None:
    args = [
        "--robots",
        "200",
        "--percent-tasks",
        "10",
        "--service-types",
        "10",
        "--services-per-robot",
        "5",
        "--load",
        "1.25",
        "--seed",
        "42",
    ]
    runs = [
        subprocess.run(
            [sys.executable, "-m", "cfopt", "generate", *args], capture_output=True, check=True
        ).stdout
        for _ in range(2)
    ]
    assert runs[0] == runs[1]
    in_process = generate_mission(200, 10, 10, 5, load=1.25, seed=42).to_json().encode()
    assert runs[0] == in_process


def test_different_seeds_differ_and_generator_seeds_are_accepted() -> None:
    a = generate_mission(50, 10, 5, 2, seed=1)
    assert a != generate_mission(50, 10, 5, 2, seed=2)
    rng = np.random.default_rng(1)
    assert generate_mission(50, 10, 5, 2, seed=rng) == generate_mission(
        50, 10, 5, 2, seed=np.random.default_rng(1)
    )


def test_a_fresh_seed_is_recorded_so_the_mission_can_be_replayed() -> None:
    mission = generate_mission(40, 10, 5, 2)
    seed = mission.metadata["generator"]["seed"]
    assert isinstance(seed, int)
    assert generate_mission(40, 10, 5, 2, seed=seed) == mission


def test_services_are_drawn_uniformly() -> None:
    mission = generate_mission(4000, 10, 10, 3, seed=7)
    frequency = mission.capabilities.mean(axis=0)
    assert np.allclose(frequency, 0.3, atol=0.03)


def test_mean_coalition_size_is_n_over_m() -> None:
    mission = generate_mission(1000, 10, 10, 5, seed=3)
    assert mission.requirements.sum(axis=1).mean() == pytest.approx(1000 / 100)


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        pytest.param({"robots": 0}, "robots: must be a whole number >= 1", id="no-robots"),
        pytest.param({"robots": 2.5}, "robots: must be a whole number", id="float-robots"),
        pytest.param(
            {"services_per_robot": 6},
            "services_per_robot: must be a whole number between",
            id="k-over-s",
        ),
        pytest.param(
            {"percent_tasks": 0}, "percent_tasks: must be a finite number > 0", id="p-zero"
        ),
        pytest.param({"percent_tasks": 101}, "percent_tasks: must be at most 100", id="p-over"),
        pytest.param({"load": -1}, "load: must be a finite number > 0", id="load-negative"),
        pytest.param({"load": float("nan")}, "load: must be a finite number > 0", id="load-nan"),
        pytest.param(
            {"robots": 10, "percent_tasks": 50, "load": 0.1},
            "needs at least one",
            id="load-too-small",
        ),
    ],
)
def test_bad_parameters(kwargs, fragment) -> None:
    args = {
        "robots": 20,
        "percent_tasks": 10,
        "service_types": 5,
        "services_per_robot": 1,
        **kwargs,
    }
    with pytest.raises(MissionError, match=fragment):
        generate_mission(**args)


def test_paper_grid_is_the_seeds_32_cells() -> None:
    cells = paper_grid()
    assert len(cells) == 32 == len(set(cells))
    assert {c.robots for c in cells} == {100, 500, 1000}
    assert not any(c.robots == 100 and c.percent_tasks == 1 for c in cells)
    assert {c.composition for c in cells} == {"5:1", "5:5", "10:1", "10:5"}
    distributed = paper_distributed_grid()
    assert len(distributed) == 20 and {c.robots for c in distributed} == {100, 500}
    assert all(c.load == 1.25 for c in paper_grid(load=1.25))


def test_grid_cell_missions_are_reproducible_and_replayable_by_seed() -> None:
    cell = GridCell(robots=100, percent_tasks=10, service_types=10, services_per_robot=5)
    first = list(cell.missions(3))
    assert first == list(cell.missions(3))
    assert len({m.to_json() for m in first}) == 3
    seed = cell.mission_seed(1)
    assert generate_mission(100, 10, 10, 5, seed=seed) == first[1]
    assert first[1].metadata["generator"]["seed"] == seed
    assert cell.mission(0, base_seed=1) != first[0]
