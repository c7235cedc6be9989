"""The transports know no algorithm: read from their import graph (``ast``) and their
text, not from what happens to be loaded."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import heuristics

TRANSPORT = Path(heuristics.__file__).parent / "transport"
MODULES = sorted(TRANSPORT.glob("*.py"))
#: The algorithms' modules: centralized engines, their cores, their agents.
ALGORITHMS = {
    "heuristics.grape_s",
    "heuristics.pair_grape_s",
    "heuristics.pair_grape_s_chain",
    "heuristics.grape_s_select",
    "heuristics.sda",
    "heuristics.rachna",
    "heuristics._grape_s_fast",
    "heuristics._sda_fast",
    "heuristics._rachna_fast",
    "heuristics._auction",
    "heuristics._reference",
    "heuristics.reward",
    "heuristics.registry",
    "heuristics.distributed",
    "heuristics.agents.grape_s",
    "heuristics.agents.grape_s_select",
    "heuristics.agents.sda",
    "heuristics.agents.belief",  # GRAPE-S's beliefs and selection rule
}
#: All a transport may import of the package: the run, the network, the agent API, itself.
ALLOWED = {
    "heuristics._run",
    "heuristics.network",
    "heuristics.agents.protocol",
    "heuristics.transport",
    "heuristics.transport.driver",
    "heuristics.transport.simulator",
    "heuristics.transport.channel",
    "heuristics.transport.mpi",
}


def imported(path: Path) -> set[str]:
    """Every module ``path`` imports (``from X import Y`` counts ``X`` and ``X.Y``)."""
    package = "heuristics.transport"
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.rsplit(".", node.level - 1)[0]
                base = f"{parent}.{base}" if base else parent
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return found


def test_there_are_transports() -> None:
    assert {p.stem for p in MODULES} >= {"driver", "simulator", "mpi"}


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.stem)
def test_a_transport_imports_no_algorithm(path: Path) -> None:
    modules = imported(path)
    assert not modules & ALGORITHMS
    ours = {m for m in modules if m == "heuristics" or m.startswith("heuristics.")}
    # ``from heuristics.agents.protocol import Protocol`` also lists the imported names
    parents = {m for m in ours if m in ALLOWED or m.rsplit(".", 1)[0] in ALLOWED}
    assert ours == parents, sorted(ours - parents)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.stem)
def test_a_transport_names_no_algorithm(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    for name in [*heuristics.algorithm_names(), "grape", "sda", "rachna"]:
        assert not re.search(rf"\b{re.escape(name)}\b", text, re.IGNORECASE), name


def test_the_import_graph_sees_what_it_must() -> None:
    """The parser finds a forbidden import where there is one."""
    mpi_launcher = Path(heuristics.__file__).parent / "mpi.py"
    assert "heuristics.distributed" in imported(mpi_launcher)
