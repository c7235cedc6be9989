"""``cfopt run --network`` and distributed sweeps from the command line."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from cfopt import GridCell
from cfopt.cli import main


def cfopt(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "cfopt", *args], capture_output=True, text=True, cwd=cwd
    )


@pytest.fixture
def mission(tmp_path: Path) -> Path:
    path = tmp_path / "m.json"
    GridCell(20, 10, 5, 2).mission(0).to_json(path)
    (tmp_path / "edges.txt").write_text("r0 r1\nr1 r99\n", encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("spec", "fragment"),
    [
        pytest.param("torus", "--network: token 'torus'", id="unknown-topology"),
        pytest.param("complete latency=constant:-5ms", "latency=constant:-5ms", id="negative"),
        pytest.param("complete loss=1", "the loss probability must be in [0, 1)", id="loss-1"),
        pytest.param("complete loss=-0.1", "loss=-0.1", id="loss-negative"),
        pytest.param("geometric radius=0.01", "disconnected", id="disconnected"),
        pytest.param("file=edges.txt", 'unknown robot id "r99"', id="unknown-robot-in-file"),
        pytest.param("ring latency=uniform:9ms:1ms", "latency=uniform:9ms:1ms", id="a-above-b"),
        pytest.param("complete medium=radio", "medium=radio", id="medium"),
    ],
)
def test_bad_network_specs_exit_2_with_one_line(mission: Path, spec: str, fragment: str) -> None:
    result = cfopt("run", "grape-s", str(mission), "--network", spec, cwd=mission.parent)
    assert result.returncode == 2, result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and fragment in lines[0], lines
    assert result.stdout == ""


def test_distributed_run_output(mission: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = "ring latency=uniform:1ms:10ms loss=0.02"
    assert main(["run", "grape-s", str(mission), "--network", spec, "--seed", "3"]) == 0
    out = capsys.readouterr().out.splitlines()
    at = 3  # after the summary and the two stability lines
    assert out[at].startswith("network: ring (d_G 10), latency uniform:1ms:10ms, loss 0.02")
    assert "robots stopped by" in out[at + 1] or "cut at" in out[at + 1]
    assert re.search(r"\([\d,]+ bytes\) transmitted, | \d+ bytes? transmitted, ", out[at + 2])
    assert main(["run", "grape-s", str(mission), "--network", spec, "--seed", "3", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    network = data["network"]
    for key in (
        "d_G", "latency", "loss", "medium", "simulated_seconds", "convergence_seconds",
        "transmissions", "receptions", "losses", "bytes", "converged", "beliefs_agree", "cut",
    ):  # fmt: skip
        assert key in network, key
    assert network["d_G"] == 10 and data["messages"] == network["transmissions"]


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        pytest.param(["--network", "complete", "--order", "random"], "--order", id="order"),
    ],
)
def test_distributed_usage_errors(
    mission: Path, capsys: pytest.CaptureFixture[str], argv: list[str], fragment: str
) -> None:
    assert main(["run", "grape-s", str(mission), *argv]) == 2
    assert fragment in capsys.readouterr().err


def test_a_distributed_sweep_and_its_report(tmp_path: Path, capsys) -> None:
    store = tmp_path / "d.sqlite"
    argv = [
        "sweep", "--robots", "20", "--percent-tasks", "10", "--compositions", "5:2",
        "--missions", "2", "--network", "complete latency=uniform:1ms:5ms",
        "--algorithms", "grape-s,rachna-dt", "--workers", "1", "--store", str(store), "--quiet",
    ]  # fmt: skip
    assert main(argv) == 0
    assert "4 trials run" in capsys.readouterr().out  # exact + grape-s; rachna-dt has no agents
    assert main(["report", str(store), "-o", str(tmp_path / "r")]) == 0
    markdown = (tmp_path / "r" / "report.md").read_text(encoding="utf-8")
    assert "## Distributed runs" in markdown and "grape-s (distributed)" in markdown
    assert (tmp_path / "r" / "distributed.csv").is_file()
