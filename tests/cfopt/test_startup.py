"""The command line's start: what it imports, its public names, a Ctrl-C while it loads.

Behaviour, not time (the figures: benchmarks/bench_startup.py).  Each check runs in a
fresh interpreter, whose ``sys.modules`` tells what was imported.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import cfopt

ROOT = Path(__file__).resolve().parents[2]
#: Never imported by the command line's start, ``--help`` or ``validate``.
HEAVY = (
    *("scipy", "networkx", "cvxpy", "dask", "distributed", "matplotlib", "heuristics"),
    *("cfopt.experiments", "cfopt.cluster", "asyncio"),
)


def _python(code: str, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code), *args],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def _loaded_by(command: list[str]) -> list[str]:
    """The heavy modules loaded by running ``cfopt COMMAND`` in a fresh interpreter."""
    code = f"""
        import json, runpy, sys
        sys.argv = ["cfopt", *{command!r}]
        try:
            runpy.run_module("cfopt", run_name="__main__")
        except SystemExit as exc:
            assert exc.code in (0, None), exc.code
        heavy = {HEAVY!r}
        print(json.dumps(sorted(m for m in heavy if m in sys.modules)), file=sys.stderr)
    """
    done = _python(code)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stderr.strip().splitlines()[-1])


def test_importing_the_command_line_loads_no_heavy_module() -> None:
    done = _python(
        f"""
        import json, sys
        import cfopt.cli
        print(json.dumps(sorted(m for m in {HEAVY!r} + ("numpy",) if m in sys.modules)))
        """
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout) == []


def test_help_and_validate_load_no_heavy_module(tmp_path: Path) -> None:
    mission = tmp_path / "m.json"
    mission.write_text(cfopt.generate_mission(30, 10, 5, 2, seed=1).to_json())
    assert _loaded_by(["--help"]) == []
    assert _loaded_by(["validate", str(mission)]) == []


def test_import_cfopt_is_lazy_but_every_public_name_is_there() -> None:
    done = _python(
        """
        import json, sys
        import cfopt
        before = "numpy" in sys.modules
        names = {n: type(getattr(cfopt, n)).__name__ for n in cfopt.__all__}
        print(json.dumps([before, sorted(names), "cfopt.exact" in sys.modules]))
        """
    )
    assert done.returncode == 0, done.stderr
    before, names, exact = json.loads(done.stdout)
    assert before is False and exact is True
    assert names == sorted(cfopt.__all__)
    assert set(cfopt.__all__) <= set(dir(cfopt))
    with pytest.raises(AttributeError, match="module 'cfopt' has no attribute 'nothing'"):
        cfopt.nothing  # noqa: B018


def test_the_public_names_are_the_defining_modules_objects() -> None:
    from cfopt.exact import solve_exact
    from cfopt.mission import Mission

    assert cfopt.Mission is Mission and cfopt.solve_exact is solve_exact
    assert cfopt.MissionError is cfopt.errors.MissionError


def test_the_readme_names_resolve() -> None:
    # every ``cfopt.X``, ``heuristics.X`` and ``proofs.X`` of the README's Python blocks,
    # in a fresh interpreter: a public name or a submodule
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = "\n".join(re.findall(r"```(?:python|pycon)\n(.*?)```", text, re.S))
    found = sorted(set(re.findall(r"\b(cfopt|heuristics|proofs)\.([A-Za-z_]\w*)", blocks)))
    assert ("cfopt", "solve_exact") in found and ("heuristics", "grape_s") in found
    done = _python(
        f"""
        import importlib
        for package, name in {found!r}:
            module = importlib.import_module(package)
            if not hasattr(module, name):
                importlib.import_module(f"{{package}}.{{name}}")
        """
    )
    assert done.returncode == 0, done.stderr


def test_the_executor_failures_keep_their_names() -> None:
    from cfopt import errors, experiments

    for name in ("WorkerDied", "ExecutorFailed", "SweepInterrupted"):
        assert getattr(experiments, name) is getattr(errors, name)


# --------------------------------------------------------------- Ctrl-C at start-up
_INTERRUPT_ON_IMPORT = """
    import importlib.abc, runpy, sys

    class Interrupt(importlib.abc.MetaPathFinder):
        # Ctrl-C arrives while {name} is being imported (once)
        def find_spec(self, fullname, path=None, target=None):
            if fullname == {name!r}:
                sys.meta_path.remove(self)
                raise KeyboardInterrupt
            return None

    sys.meta_path.insert(0, Interrupt())
    sys.argv = ["cfopt", *sys.argv[1:]]
    runpy.run_module("cfopt", run_name="__main__")
"""


@pytest.mark.parametrize(
    ("module", "command"),
    [
        pytest.param("cfopt.errors", ["--help"], id="loading-the-command-line"),
        pytest.param("argparse", ["--help"], id="loading-argparse"),
        pytest.param("numpy", ["validate", "MISSION"], id="loading-numpy-for-validate"),
    ],
)
def test_ctrl_c_during_start_up_imports_is_one_line_and_130(module, command, tmp_path) -> None:
    mission = tmp_path / "m.json"
    mission.write_text(cfopt.generate_mission(10, 10, 5, 2, seed=1).to_json())
    command = [str(mission) if c == "MISSION" else c for c in command]
    done = _python(_INTERRUPT_ON_IMPORT.format(name=module), *command)
    assert (done.returncode, done.stdout) == (130, "")
    assert done.stderr == "error: interrupted (SIGINT)\n"
