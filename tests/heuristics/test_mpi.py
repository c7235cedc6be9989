"""Distributed runs as real MPI processes (``--backend mpi``): the same agents as the
simulator's, over mpi4py, launched with ``mpiexec``."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import cfopt
import proofs
from cfopt import GridCell, Mission, MissionError
from heuristics.simulate import simulate

try:
    from heuristics.mpi import launcher, mpi_run

    launcher()
except (ImportError, MissionError) as missing:  # pragma: no cover - CI installs the extra
    if os.environ.get("CI"):
        raise RuntimeError(f"CI must install the mpi extra: {missing}") from missing
    pytest.skip(f"no MPI here ({missing})", allow_module_level=True)

#: Lock-step clocks with a 1 ms period: fast, and move for move the simulator's run.
LOCKSTEP = "complete period=1ms sync=true"
#: Pair-GRAPE-S's requests travel hop by hop on a ring, with a fixed latency per hop.
RING = "ring period=1ms sync=true latency=constant:0.3ms"


def mission_of(robots: int, seed: int = 1) -> Mission:
    return cfopt.generate_mission(robots, 20, 4, 2, seed=seed)


def belief_size(n: int, algorithm: str) -> int:
    """The belief encoder's size, as documented: 16 + 4 n (24 + 4 n with the pass state)."""
    return (24 if algorithm == "pair-grape-s" else 16) + 4 * n


@pytest.mark.parametrize(
    ("algorithm", "robots", "spec", "ranks"),
    [
        ("grape-s", 20, LOCKSTEP, 2),
        ("grape-s", 100, LOCKSTEP, 4),
        ("pair-grape-s", 40, LOCKSTEP, 2),
        ("pair-grape-s", 40, RING, 4),
    ],
)
def test_lockstep_mpi_runs_are_the_simulators_runs(
    algorithm: str, robots: int, spec: str, ranks: int
) -> None:
    m = mission_of(robots)
    sim = simulate(m, algorithm, spec, seed=0)
    run = mpi_run(m, algorithm, spec, ranks=ranks, seed=0)
    a = run.assignment
    a.validate(m)  # raises on a robot in a service it lacks or an unknown slot
    assert proofs.nash_violations(m, a, capped=algorithm == "pair-grape-s") == []
    assert a.utility(m) == sim.assignment.utility(m)
    assert np.array_equal(a.task, sim.assignment.task)
    assert np.array_equal(a.service, sim.assignment.service)
    assert np.array_equal(run.trajectory, sim.trajectory)
    assert (run.iterations, run.messages, run.bytes) == (sim.iterations, sim.messages, sim.bytes)
    assert run.network.beliefs_agree and run.network.converged and not run.network.cut
    transport = run.network.transport
    assert transport.ranks == ranks and sum(transport.robots_per_rank) == robots
    # every message put on the wire was received, decoded and is its encoder's size
    assert transport.wire_messages == transport.received_messages > 0
    assert transport.wire_bytes == transport.received_bytes
    if algorithm == "grape-s":  # complete network: each tick's belief goes to every other rank
        assert transport.wire_messages == run.network.ticks * (ranks - 1)
        assert transport.wire_bytes == transport.wire_messages * belief_size(robots, algorithm)
        assert run.bytes == run.network.ticks * belief_size(robots, algorithm)
    assert dict(run.options)["engine"] == "mpi"


@pytest.mark.parametrize(
    ("algorithm", "mission", "spec", "ranks"),
    [
        # the seed's family at 8 robots, 10:5: a chain of two partners moves three robots
        pytest.param("pair-grape-s-chain", GridCell(8, 10, 10, 5).mission(7), RING, 2, id="chain"),
        pytest.param("pair-grape-s", GridCell(8, 10, 10, 5).mission(5), RING, 4, id="exchange"),
        pytest.param(
            "grape-s", cfopt.generate_mission(4, 50, 2, 1, seed=0), LOCKSTEP, 4, id="one-per-rank"
        ),
    ],
)
def test_lockstep_exchanges_and_one_robot_per_rank(
    algorithm: str, mission: Mission, spec: str, ranks: int
) -> None:
    sim = simulate(mission, algorithm, spec, seed=0)
    run = mpi_run(mission, algorithm, spec, ranks=ranks, seed=0)
    assert np.array_equal(run.trajectory, sim.trajectory)
    assert np.array_equal(run.assignment.task, sim.assignment.task)
    assert (run.messages, run.bytes, run.exchanges) == (sim.messages, sim.bytes, sim.exchanges)
    assert run.network.transport.robots_per_rank == tuple([mission.n_robots // ranks] * ranks)
    assert run.exchanges == (algorithm != "grape-s")  # the pairwise step's one exchange


@pytest.mark.parametrize(
    ("algorithm", "mission", "spec", "options"),
    [
        # the service agents on robots 0-3 (rank 0), the task agents on 4-7 (rank 1)
        pytest.param("sda", GridCell(8, 50, 4, 2).mission(3), LOCKSTEP, None, id="sda"),
        pytest.param(
            "sda", GridCell(12, 50, 4, 2).mission(1), RING, {"resend_tries": 3}, id="sda-ring"
        ),
        pytest.param(
            "grape-s-select", GridCell(16, 25, 4, 2, 1.25).mission(5), LOCKSTEP, None, id="select"
        ),
        pytest.param(
            "grape-s-select",
            GridCell(12, 50, 4, 2, 1.25).mission(2),
            RING,
            {"exchange": False},
            id="select-ring",
        ),
    ],
)
def test_lockstep_runs_of_every_protocol_are_the_simulators_runs(
    algorithm: str, mission: Mission, spec: str, options: dict | None
) -> None:
    """SDA's message-driven agents (start, receive, timers) and GRAPE-S-Select's beliefs
    with task bits, lock-step over 2 ranks: the simulator's run, move for move."""
    sim = simulate(mission, algorithm, spec, seed=0, options=options)
    run = mpi_run(mission, algorithm, spec, ranks=2, seed=0, options=options)
    assert run.assignment.utility(mission) == sim.assignment.utility(mission)
    assert np.array_equal(run.assignment.task, sim.assignment.task)
    assert np.array_equal(run.assignment.service, sim.assignment.service)
    assert np.array_equal(run.trajectory, sim.trajectory)
    assert (run.iterations, run.rounds, run.messages, run.bytes, run.work) == (
        sim.iterations,
        sim.rounds,
        sim.messages,
        sim.bytes,
        sim.work,
    )
    network = run.network
    assert network.converged and network.beliefs_agree and not network.cut
    assert (network.ticks, network.simulated_seconds, network.convergence_seconds) == (
        sim.network.ticks,
        sim.network.simulated_seconds,
        sim.network.convergence_seconds,
    )
    transport = network.transport
    assert transport.wire_messages == transport.received_messages > 0
    assert transport.wire_bytes == transport.received_bytes
    assert dict(run.options) == {**dict(sim.options), "engine": "mpi", "ranks": 2}


def test_message_driven_agents_in_real_time() -> None:
    """SDA free-running: messages handed over as they come, timers in real time, and the
    ranks find the end by counting (nothing in flight, nobody active)."""
    m = GridCell(12, 50, 4, 2).mission(1)
    spec = "complete period=2ms latency=uniform:0.1ms:1ms"
    run = mpi_run(m, "sda", spec, ranks=2, seed=0)
    run.assignment.validate(m)
    assert run.network.converged and not run.network.cut
    assert run.assignment.utility(m) == simulate(m, "sda", spec, seed=0).assignment.utility(m)
    transport = run.network.transport
    assert transport.wire_messages == transport.received_messages > 0
    assert transport.wire_bytes == transport.received_bytes


@pytest.mark.parametrize("algorithm", ["grape-s", "pair-grape-s"])
def test_real_time_runs_end_nash_stable_and_agreed(algorithm: str) -> None:
    """Free-running real-time clocks (the seed's 1-10 ms latency; a 20 ms period and 4
    d_G quiet ticks so that a busy test machine's scheduling pauses stay below the
    termination rule's patience): the robots agree on a final, valid partition."""
    m = mission_of(30, seed=3)
    spec = "complete period=20ms latency=uniform:1ms:10ms"
    run = mpi_run(m, algorithm, spec, ranks=2, seed=1, quiet_factor=4)
    a = run.assignment
    a.validate(m)  # raises on a robot in a service it lacks or an unknown slot
    assert run.network.beliefs_agree and run.network.converged
    assert proofs.nash_violations(m, a, capped=algorithm == "pair-grape-s") == []
    assert run.network.transport.wire_bytes == run.network.transport.received_bytes


def test_lost_and_delayed_messages_are_injected() -> None:
    m = mission_of(30)
    spec = "complete period=1ms sync=true loss=0.3 latency=uniform:0.5ms:3ms"
    run = mpi_run(m, "grape-s", spec, ranks=2, seed=0)
    assert run.network.losses > 0
    assert run.network.receptions + run.network.losses == run.network.ticks * 29
    run.assignment.validate(m)


# ------------------------------------------------------------------- command line
def cfopt_cli(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "cfopt", *args], capture_output=True, text=True, env=env
    )


@pytest.fixture
def mission_file(tmp_path: Path) -> Path:
    path = tmp_path / "m.json"
    GridCell(20, 20, 4, 2).mission(1).to_json(path)
    return path


def test_cli_backend_mpi_json(mission_file: Path) -> None:
    done = cfopt_cli(
        "run", "grape-s", str(mission_file), "--backend", "mpi", "--ranks", "2",
        "--network", LOCKSTEP, "--seed", "0", "--json",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    assert data["nash_stable"] and data["network"]["converged"]
    transport = data["network"]["transport"]
    assert transport["backend"] == "mpi" and transport["ranks"] == 2
    assert transport["wire_bytes"] == transport["received_bytes"] > 0
    assert data["options"]["engine"] == "mpi"


@pytest.mark.parametrize("algorithm", ["pair-grape-s", "sda"])
def test_ranks_started_by_the_users_launcher(mission_file: Path, algorithm: str) -> None:
    """``mpiexec -n K python -m cfopt.mpi ...``: rank 0 alone prints the run."""
    command = [*launcher(), "-n", "2", sys.executable, "-m", "cfopt.mpi", algorithm]
    command += [str(mission_file), "--network", LOCKSTEP, "--seed", "0", "--json"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)  # one JSON object: the other rank printed nothing
    assert data["algorithm"] == algorithm and data["network"]["transport"]["ranks"] == 2
    assert data["network"]["transport"]["launch_seconds"] is None


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        pytest.param(["--ranks", "2"], "--ranks: only with --backend mpi", id="ranks-alone"),
        pytest.param(["--backend", "mpi", "--ranks", "21"], "at most one rank per robot", id="K>n"),
        pytest.param(["--backend", "mpi", "--ranks", "0"], "--ranks", id="zero-ranks"),
    ],
)
def test_bad_mpi_options_exit_2(mission_file: Path, extra: list[str], fragment: str) -> None:
    done = cfopt_cli("run", "grape-s", str(mission_file), *extra)
    assert done.returncode == 2
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and fragment in lines[0], lines


def test_algorithms_without_agents_are_refused(mission_file: Path) -> None:
    done = cfopt_cli("run", "rachna-dt", str(mission_file), "--backend", "mpi")
    assert done.returncode == 2 and "has no distributed agents" in done.stderr
    assert "grape-s, grape-s-select, pair-grape-s, pair-grape-s-chain, sda" in done.stderr


def test_missing_launcher_names_the_install_command(mission_file: Path) -> None:
    env = dict(os.environ, CFOPT_MPIEXEC="/nonexistent/mpiexec")
    done = cfopt_cli("run", "grape-s", str(mission_file), "--backend", "mpi", env=env)
    assert done.returncode == 2 and done.stderr.startswith("error: backend: CFOPT_MPIEXEC")
    env = dict(os.environ, PATH="/nonexistent")
    code = (
        "import sys, heuristics.mpi as h; from pathlib import Path; "
        "h.Path = lambda *a: Path('/nonexistent'); from cfopt.cli import main; "
        f"sys.exit(main(['run', 'grape-s', {str(mission_file)!r}, '--backend', 'mpi']))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert done.returncode == 2, done.stderr
    assert 'pip install "cfopt[mpi]"' in done.stderr and "mpiexec" in done.stderr


def test_missing_mpi4py_names_the_install_command(mission_file: Path) -> None:
    code = (
        "import sys; sys.modules['mpi4py'] = None; from cfopt.cli import main; "
        f"sys.exit(main(['run', 'grape-s', {str(mission_file)!r}, '--backend', 'mpi']))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 2
    assert done.stderr.strip() == (
        'error: backend: mpi4py is not installed; install the mpi extra: pip install "cfopt[mpi]"'
    )


def test_ctrl_c_stops_every_rank_with_one_line(mission_file: Path) -> None:
    """SIGINT to the launcher: mpiexec passes it to the ranks, and the command ends as
    every cfopt command does on Ctrl-C (exit 130, one line)."""
    launcher_process = subprocess.Popen(
        [sys.executable, "-m", "cfopt", "run", "grape-s", str(mission_file), "--backend",
         "mpi", "--network", "complete period=1s", "--seed", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    time.sleep(4)  # the ranks are up and ticking once a second
    launcher_process.send_signal(signal.SIGINT)
    _, err = launcher_process.communicate(timeout=60)
    assert launcher_process.returncode == 130
    assert err.strip() == "error: interrupted (SIGINT)"


def test_bad_input_to_the_ranks_is_one_error_line(mission_file: Path) -> None:
    """Every rank finds the same problem; only rank 0 says it."""
    taken = mission_file.parent / "taken.json"
    taken.write_text("{}", encoding="utf-8")
    command = [*launcher(), "-n", "2", sys.executable, "-m", "cfopt.mpi", "grape-s"]
    done = subprocess.run(
        [*command, str(mission_file), "-o", str(taken)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 2
    assert done.stderr.splitlines() == [
        f"error: {taken}: already exists (pass --force to replace it)"
    ]
    assert taken.read_text(encoding="utf-8") == "{}"
