"""The README, followed literally: its command blocks run as written in a temporary folder.

Every ``bash`` block runs with bash (``-e -o pipefail``), in README order, in one folder,
so later blocks see the files earlier ones wrote; the ``python`` blocks run together, in
order, as one script in the same folder (a block that needs dask is left out when dask is
not installed).  Commands that run for minutes or hours -- the main job, the seed's whole
grid, the benchmarks -- are started exactly as written, must still be running (or have
succeeded) after a few seconds, and are then interrupted with SIGINT: cfopt's long jobs
must then end with exit 130 and their one-line "kept ... resume" message.  The quick
start's install steps are what ``.ci/run`` executes; they are checked to be the same text.
"""

from __future__ import annotations

import importlib.util
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")
BLOCKS = re.findall(r"^```(bash|python)\n(.*?)^```", README, flags=re.S | re.M)
#: Commands that run for minutes or longer: started, watched for this many seconds, stopped.
LONG_RUNNING = {
    "cfopt audit\n": 6.0,
    "cfopt audit --quick\n": 6.0,
    "cfopt sweep --grid paper ": 6.0,
    "cfopt reproduce ": 6.0,
    "python benchmarks/": 4.0,
}
#: Only a hang guard: a README block's quick audit takes a minute on a quiet machine and
#: more than ten on a loaded one (no test may depend on the machine's speed).
HANG_GUARD = 3600
INSTALL = re.compile(r"^python3 -m venv \.venv && \. \.venv/bin/activate && python -m pip install ")


def _environment(folder: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env["PYTHONPATH"] = str(ROOT)  # `python benchmarks/...` imports the checkout's packages
    env.pop("PYTEST_ADDOPTS", None)
    return env


def _long_limit(command: str) -> float | None:
    for prefix, seconds in LONG_RUNNING.items():
        if (command + "\n").startswith(prefix):
            return seconds
    return None


def _run_a_while(commands: list[str], folder: Path, seconds: float) -> None:
    """Start long commands as written, side by side; none may fail early; stop each with
    SIGINT."""
    processes = [
        subprocess.Popen(
            ["bash", "-c", command],
            cwd=ROOT if command.startswith("python benchmarks/") else folder,  # from a clone
            env=_environment(folder),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
        for command in commands
    ]
    for command, process in zip(commands, processes, strict=True):
        try:
            _, err = process.communicate(timeout=seconds)
        except subprocess.TimeoutExpired:
            _wait_until_it_stores(command, process, folder)
            os.killpg(process.pid, signal.SIGINT)
            _, err = process.communicate(timeout=60)
        else:
            assert process.returncode == 0, f"{command!r} failed:\n{err}"
            continue
        if command.startswith("cfopt"):
            assert process.returncode == 130, f"{command!r}:\n{err}"
            last = err.strip().splitlines()[-1]
            assert last.startswith("error: interrupted (SIGINT)"), err
            assert "Traceback" not in err
        else:  # a benchmark script: interrupted, not failed
            assert "Traceback" not in err or err.rstrip().endswith("KeyboardInterrupt"), err


def _wait_until_it_stores(command: str, process: subprocess.Popen, folder: Path) -> None:
    """An audit is stopped only once it has its store (a state, not a time: on a loaded
    machine its start alone can take longer than the watch)."""
    if not command.startswith("cfopt audit"):
        return
    store = folder / "cfopt-audit" / "trials.sqlite"
    deadline = time.monotonic() + HANG_GUARD
    while not store.is_file() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)


def _bash(script: str, folder: Path) -> None:
    result = subprocess.run(
        ["bash", "-e", "-o", "pipefail", "-c", script],
        cwd=folder,
        env=_environment(folder),
        capture_output=True,
        text=True,
        timeout=HANG_GUARD,
    )
    assert result.returncode == 0, f"README block failed:\n{script}\n--- stderr:\n{result.stderr}"


def _python(argv: list[str], folder: Path) -> subprocess.CompletedProcess[str]:
    """``python ARGV`` in ``folder``, its output captured."""
    return subprocess.run(
        [sys.executable, *argv],
        cwd=folder,
        env=_environment(folder),
        capture_output=True,
        text=True,
        timeout=HANG_GUARD,
    )


def test_the_quick_start_installs_as_ci_does() -> None:
    quick_start = BLOCKS[0][1].strip().splitlines()
    assert all(INSTALL.match(line) for line in quick_start), quick_start
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert all(line in ci for line in quick_start)  # CI runs both commands, literally


def test_every_readme_command_runs_as_written(tmp_path: Path) -> None:
    python_blocks = []
    for position, (language, text) in enumerate(BLOCKS):
        if language == "python":
            if "dask" in text and importlib.util.find_spec("dask") is None:
                continue
            python_blocks.append(text)
            continue
        if position == 0:  # the quick start: installs (see above), then the main job
            last = [line.rsplit(" && ", 1)[-1] for line in text.splitlines()]
            text = "\n".join(command for command in last if command != "python -m pytest")
        commands = [line.split("  #", 1)[0].strip() for line in text.splitlines()]
        limits = [_long_limit(command) for command in commands]
        if all(limits):  # long jobs only: run them side by side for a while
            _run_a_while(commands, tmp_path, max(limits))
        else:
            assert not any(limits), f"mixed block: {text}"
            _bash(text, tmp_path)
    result = _python(["-c", "\n\n".join(python_blocks)], tmp_path)
    assert result.returncode == 0, result.stderr
    # what the blocks promise about their results
    assert (tmp_path / "a.json").is_file() and (tmp_path / "mine-report" / "report.md").is_file()
    assert (tmp_path / "cfopt-audit" / "trials.sqlite").is_file()  # the interrupted main job


def test_the_dask_block_runs_saved_as_a_script(tmp_path: Path) -> None:
    """Saved as a file and run with ``python FILE`` -- how a newcomer runs it -- the
    block's local cluster imports the script again in each worker process."""
    pytest.importorskip("distributed")
    (text,) = [t for kind, t in BLOCKS if kind == "python" and "dask_executor(" in t]
    script = tmp_path / "sweep_on_dask.py"
    script.write_text(text, encoding="utf-8")
    result = _python([str(script)], tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[-1] == "6 trials"  # 2 missions x (exact, grape-s, sda)
    assert (tmp_path / "dask.sqlite").is_file()


@pytest.mark.parametrize("language", ["bash", "python"])
def test_the_readme_has_blocks(language: str) -> None:
    assert any(kind == language for kind, _ in BLOCKS)
