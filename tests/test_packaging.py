"""The wheel a newcomer installs holds every module of the tree.

An editable install reads the checkout, so it hides a sub-package that the build leaves
out; this test builds the real wheel (``pip wheel``, as ``pip install .`` does) and
compares its file list with the tree.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("cfopt", "heuristics", "proofs")
#: Set by CI's run of the suite against a regular install, from a copy of the tests alone.
INSTALLED = os.environ.get("CFOPT_TEST_INSTALLED") == "1"
needs_source = pytest.mark.skipif(
    not (ROOT / "cfopt").is_dir(), reason="no source tree here: testing an installed copy"
)


def _shipped_files(tree: Path) -> set[str]:
    """Every file of the packages that an installed cfopt needs, as wheel paths."""
    files = set()
    for package in PACKAGES:
        for path in (tree / package).rglob("*"):
            if "__pycache__" in path.parts or not path.is_file():
                continue
            if path.suffix == ".py" or path.name == "py.typed":
                files.add(path.relative_to(tree).as_posix())
    return files


@pytest.mark.skipif(not INSTALLED, reason="only in CI's run against a regular install")
def test_the_suite_imports_the_installed_copy() -> None:
    import cfopt
    import heuristics
    import proofs

    for package in (cfopt, heuristics, proofs):
        where = Path(package.__file__).resolve()
        assert "site-packages" in where.parts, where
        assert ROOT not in where.parents, where


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    # A copy of what a clone holds: setuptools' build/ folder of an earlier build (and
    # the egg-info) would otherwise put back files the configuration leaves out.
    source = tmp_path_factory.mktemp("source")
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    for package in PACKAGES:
        shutil.copytree(
            ROOT / package, source / package, ignore=shutil.ignore_patterns("__pycache__")
        )
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", str(source), "--no-deps", "-q", "-w", str(out)],
        check=True,
        capture_output=True,
    )
    (built,) = out.glob("cfopt-*.whl")
    return built


@needs_source
def test_the_wheel_holds_every_module_of_the_tree(wheel: Path) -> None:
    with zipfile.ZipFile(wheel) as archive:
        names = set(archive.namelist())
    expected = _shipped_files(ROOT)
    assert "heuristics/agents/__init__.py" in expected  # the package that once went missing
    assert expected - names == set()


@needs_source
def test_the_wheel_ships_no_tests_or_benchmarks(wheel: Path) -> None:
    with zipfile.ZipFile(wheel) as archive:
        tops = {name.split("/", 1)[0] for name in archive.namelist()}
    assert tops - {f"{package}" for package in PACKAGES} == {
        name for name in tops if name.endswith(".dist-info")
    }


@needs_source
def test_the_wheel_declares_the_entry_points(wheel: Path) -> None:
    with zipfile.ZipFile(wheel) as archive:
        (entry_points,) = (n for n in archive.namelist() if n.endswith("entry_points.txt"))
        text = archive.read(entry_points).decode()
    assert "cfopt = cfopt.cli:entry" in text
    assert "[pytest11]" in text
