"""``--json`` prints one JSON object and nothing else, whatever a dependency prints.

Every command runs as a real process, with its standard output once a pipe and once a
file, and the *whole* of that output must parse as one JSON object.  Solvers are the
known offenders (HiGHS prints a banner on the C-level stdout from its first solver of a
process), so a second set of tests calls the Python API in a fresh process and expects
nothing at all on stdout.

The audit and the reproduction run real claims and real trials, on a shrunken job: a
small wrapper narrows the claims (or the grids) and then starts the ``cfopt`` command
itself, exactly as the console script does.
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from cfopt import generate_mission

#: Starts the ``cfopt`` entry point after narrowing the audit's claims to two real ones
#: that solve the ILP (P1 compares Pair-GRAPE-S with the optimum).
AUDIT_WRAPPER = """
import proofs.claims as claims
full = dict(claims.CLAIMS)
claims.CLAIMS = {key: full[key] for key in ("P1", "G1")}
from cfopt.cli import entry
entry()
"""

#: Starts the ``cfopt`` entry point after shrinking the seed's grids to two small cells.
REPRODUCE_WRAPPER = """
from cfopt import GridCell
from cfopt import reproduce
from cfopt.experiments import Sweep

def tiny(missions=1, base_seed=0, distributed=True):
    cells = (GridCell(100, 10, 10, 5),)
    return [Sweep(cells, missions, reproduce.CENTRALIZED_ALGORITHMS, base_seed)]

reproduce.reproduction_sweeps = tiny
from cfopt.cli import entry
entry()
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("json")
    mission = folder / "m.json"
    generate_mission(
        robots=20, percent_tasks=10, service_types=5, services_per_robot=2, seed=3
    ).to_json(mission)
    solved = subprocess.run(
        [sys.executable, "-m", "cfopt", "solve", str(mission), "--json"],
        capture_output=True,
        text=True,
        check=True,
    )
    optimum = folder / "optimum.json"
    optimum.write_text(solved.stdout, encoding="utf-8")
    return {"folder": folder, "mission": mission, "optimum": optimum}


def _commands(files: dict[str, Path]) -> dict[str, list[str]]:
    m, optimum, folder = str(files["mission"]), str(files["optimum"]), files["folder"]
    commands = {
        "validate": ["validate", m, "--json"],
        "solve": ["solve", m, "--json"],
        "solve-assignment": ["solve", m, "--json", "--formulation", "assignment"],
        "solve-time-limit": ["solve", m, "--json", "--time-limit", "30"],
        "run": ["run", "pair-grape-s", m, "--json"],
        "run-sda": ["run", "sda", m, "--json"],
        "run-network": ["run", "grape-s", m, "--json", "--network", "ring loss=0.1", "--seed", "1"],
        "check": ["check", m, optimum, "--json"],
        "audit": [
            "audit", "--claims-only", "--quick", "--json", "--quiet", "--workers", "1",
            "--force", "-o", str(folder / "audit"),
        ],
        "reproduce": [
            "reproduce", "--missions", "1", "--centralized-only", "--json", "--quiet",
            "--workers", "1", "--force", "-o", str(folder / "reproduce"),
        ],
    }  # fmt: skip
    if importlib.util.find_spec("mpi4py") is not None:
        commands["run-mpi"] = ["run", "grape-s", m, "--json", "--backend", "mpi", "--ranks", "2"]
        commands["mpi-ranks"] = ["grape-s", m, "--json"]
    return commands


def _argv(name: str, args: list[str]) -> list[str]:
    if name == "audit":
        return [sys.executable, "-c", AUDIT_WRAPPER, *args]
    if name == "reproduce":
        return [sys.executable, "-c", REPRODUCE_WRAPPER, *args]
    if name == "mpi-ranks":  # the rank entry under mpiexec, rank 0 printing
        mpiexec = str(Path(sys.executable).with_name("mpiexec"))
        return [mpiexec, "-n", "2", sys.executable, "-m", "cfopt.mpi", *args]
    return [sys.executable, "-m", "cfopt", *args]


NAMES = [
    "validate", "solve", "solve-assignment", "solve-time-limit", "run", "run-sda",
    "run-network", "check", "audit", "reproduce", "run-mpi", "mpi-ranks",
]  # fmt: skip


@pytest.mark.parametrize("stdout", ["pipe", "file"])
@pytest.mark.parametrize("name", NAMES)
def test_json_is_the_whole_of_stdout(
    files: dict[str, Path], name: str, stdout: str, tmp_path: Path
) -> None:
    commands = _commands(files)
    if name not in commands:
        pytest.skip("mpi4py is not installed")
    argv = _argv(name, commands[name])
    if stdout == "pipe":
        result = subprocess.run(argv, capture_output=True, text=True, timeout=600)
        text = result.stdout
    else:
        target = tmp_path / "out.json"
        with target.open("w", encoding="utf-8") as handle:
            result = subprocess.run(
                argv, stdout=handle, stderr=subprocess.PIPE, text=True, timeout=600
            )
        text = target.read_text(encoding="utf-8")
    assert result.returncode == 0, result.stderr
    assert isinstance(json.loads(text), dict), text
    assert text.count("\n") == 1 and text.endswith("}\n")


API_CALLS = {
    "aggregated": "cfopt.solve_exact(m)",
    "assignment": "cfopt.solve_exact(m, formulation='assignment')",
    "time-limit": "cfopt.solve_exact(m, time_limit=30)",
}


@pytest.mark.parametrize("call", sorted(API_CALLS))
def test_the_python_api_prints_nothing_on_stdout(files: dict[str, Path], call: str) -> None:
    script = textwrap.dedent(
        f"""
        import cfopt
        m = cfopt.Mission.from_json({str(files["mission"])!r})
        result = {API_CALLS[call]}
        assert result.status.value == "optimal", result
        """
    )
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout == ""


def test_output_written_to_descriptor_1_by_a_library_goes_to_stderr(
    files: dict[str, Path],
) -> None:
    """The ``cfopt`` command keeps descriptor 1 for itself: what a library writes there
    directly lands on stderr."""
    script = textwrap.dedent(
        f"""
        import os, sys
        sys.argv = ["cfopt", "validate", {str(files["mission"])!r}, "--json"]
        from cfopt import cli
        cli.reserve_stdout()
        os.write(1, b"a library's banner\\n")
        sys.exit(cli.main())
        """
    )
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["valid"] is True
    assert "a library's banner" in result.stderr
