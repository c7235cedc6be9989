"""CI must run exactly what the README tells a user to run, and test the bounds it declares."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
QUICK_START = re.compile(r"^## Quick start$.*?^```bash\n(.*?)^```", re.S | re.M)


def _quick_start() -> list[str]:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    found = QUICK_START.search(readme)
    assert found is not None, "the README has no quick start block"
    return found.group(1).strip().splitlines()


def test_ci_runs_both_quick_start_commands_as_written() -> None:
    ci_lines = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    first, second = _quick_start()
    assert "python -m pip install . && cfopt audit" in first  # a regular install, the main job
    assert "pip install -e" not in first
    assert "python -m pytest" in second
    for command in (first, second):
        assert any(line.strip() == f"({command})" for line in ci_lines), command


def _declared_lower_bounds() -> dict[str, str]:
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    bounds = {}
    for name, version in re.findall(r'"([A-Za-z0-9_.-]+)(?:\[[^]]*\])?>=([0-9][^",;\s]*)', text):
        bounds.setdefault(name.lower(), version)
    return bounds


def test_the_lower_bounds_ci_installs_are_the_declared_ones() -> None:
    pins = {}
    for line in (ROOT / ".ci" / "lower-bounds.txt").read_text(encoding="utf-8").splitlines():
        if line.strip() and not line.startswith("#"):
            name, version = line.split("==")
            pins[name.lower()] = version
    declared = _declared_lower_bounds()
    declared.pop("setuptools", None)  # the build backend, not a runtime dependency
    declared.pop("ruff", None)  # a style tool of the dev extra
    declared.pop("import-linter", None)
    assert {name: declared[name] for name in declared} == {
        name: pins[name] for name in declared
    }
