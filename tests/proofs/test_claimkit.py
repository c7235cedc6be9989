"""The public claims kit: a user's claim checked, registered three ways, found in workers.

The claim under test is about a plain function written here (a greedy assigner), built
from ``proofs.claimkit``'s public names only.  The last tests read the import graph of
``proofs/``: no private name crosses a module boundary and no two modules import each
other, directly or through others.
"""

from __future__ import annotations

import ast
import concurrent.futures as cf
import inspect
import json
import multiprocessing
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

import cfopt
import proofs
import proofs.claims
from cfopt.audit import check_claim
from cfopt.cli import main
from proofs import claimkit as ck
from proofs.claims import ClaimRegistry, resolve_claims, write_counterexamples

PROOFS = Path(proofs.__file__).parent


def _user_module(folder: Path, name: str, claim_id: str = "MY1") -> Path:
    """A module of a user's claims, ``folder/<name>.py``: this file's greedy claim, with
    ``CLAIM`` (id ``claim_id``), ``CLAIMS`` (it and ``<claim_id>b``), ``make`` (a callable
    returning a claim ``MY1``), ``NOT_A_CLAIM`` and ``nested.claim``."""
    sources = "\n\n".join(inspect.getsource(f) for f in (_greedy, _at_least_90, _user_claim))
    text = f"""
from __future__ import annotations

import numpy as np

import cfopt
from proofs import claimkit as ck

{sources}

CLAIM = _user_claim({claim_id!r}, cells=False)
CLAIMS = [CLAIM, _user_claim({claim_id + "b"!r}, cells=False)]
NOT_A_CLAIM = 42
make = _user_claim


class nested:
    claim = CLAIM
"""
    path = folder / f"{name}.py"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture
def isolated(
    monkeypatch: pytest.MonkeyPatch, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[ClaimRegistry]:
    """A fresh registry (no entry points) as ``proofs.claims.CLAIMS``; ``sys.path`` is
    restored and the user modules written to temporary folders are forgotten afterwards."""
    registry = ClaimRegistry(entry_point_group=None)
    monkeypatch.setattr(proofs.claims, "CLAIMS", registry)
    monkeypatch.setattr(sys, "path", list(sys.path))
    before = set(sys.modules)
    yield registry
    base = str(tmp_path_factory.getbasetemp())
    for name in set(sys.modules) - before:
        if (getattr(sys.modules[name], "__file__", None) or "").startswith(base):
            del sys.modules[name]


# ------------------------------------------------------------- a user's claim
def _greedy(mission: cfopt.Mission) -> cfopt.Assignment:
    """Each robot in index order takes the first still-short slot it can serve."""
    short = mission.requirements.copy()
    task = np.full(mission.n_robots, -1)
    service = np.full(mission.n_robots, -1)
    for robot in range(mission.n_robots):
        slots = np.argwhere((short > 0) & mission.capabilities[robot])
        if len(slots):
            task[robot], service[robot] = slots[0]
            short[task[robot], service[robot]] -= 1
    return cfopt.Assignment(task=task, service=service)


def _at_least_90(claim: ck.Claim, mission: cfopt.Mission) -> ck.Evaluation:
    a = _greedy(mission)
    got, best = a.utility(mission), cfopt.solve_exact(mission).utility
    if got >= 0.9 * best:
        return ck.Evaluation(None, max(0.0, 1 - got / best) if best else 0.0, ("ok",))
    detail = f"greedy earns {got:g} of {best:g}"
    return ck.Evaluation(ck.Counterexample(mission, a, "my-greedy", detail), 1 - got / best)


def _user_claim(claim_id: str = "MY1", cells: bool = True) -> ck.Claim:
    """The claim, built from proofs.claimkit's public names only (``cells``: with the
    seed's 10:5 grid cells of 100 robots, else hypothesis-drawn missions only)."""
    return ck.property_claim(
        claim_id,
        "my-greedy earns at least 90 % of the optimum on achievable missions",
        ck.ACHIEVABLE_FAMILY,
        ("my-greedy",),
        _at_least_90,
        scope=ck.Scope.GENERALISATION,
        strategy=ck.structural_missions(achievable=True),
        cells=ck.grid_cells(ck.HARD_COMPOSITIONS) if cells else (),
        summary=ck.tally_summary("ok"),
    )


def test_a_users_claim_fails_with_a_shrunk_counterexample_that_replays(tmp_path: Path) -> None:
    verdict = _user_claim().check(2, seed=0)
    assert verdict.verdict is ck.VerdictKind.FAILS
    assert verdict.scope is ck.Scope.GENERALISATION
    assert "2 grid missions (2 cells, n=100)" in verdict.note and "ok: " in verdict.note
    ce = verdict.counterexample
    assert ce is not None and ce.algorithm == "my-greedy"
    # the search's (shrunk) mission, not a 100-robot grid one: the smallest failure wins
    assert ce.size[0] <= 8
    assert _greedy(ce.mission) == ce.assignment
    optimum = cfopt.solve_exact(ce.mission).utility
    assert optimum == ce.mission.total_utility > 0
    assert ce.assignment.utility(ce.mission) < 0.9 * optimum
    # the files replay: the mission and the assignment load back
    mission_path, assignment_path = write_counterexamples([verdict], tmp_path)
    again = cfopt.Mission.from_json(mission_path)
    assert cfopt.Assignment.from_json(again, assignment_path) == ce.assignment
    # and the verdict round-trips through JSON with its scope
    data = json.loads(json.dumps(verdict.to_dict()))
    assert data["scope"] == "a generalisation to the paper's family at any size"
    assert ck.Verdict.from_dict(data).to_dict() == data


def test_the_same_claim_holds_for_a_correct_algorithm() -> None:
    claim = ck.property_claim(
        "MY2",
        "the exact optimum earns at least 90 % of itself",
        ck.ACHIEVABLE_FAMILY,
        ("exact",),
        lambda claim, m: ck.Evaluation(None),
        scope=ck.Scope.GENERALISATION,
        strategy=ck.structural_missions(achievable=True),
    )
    verdict = claim.check(1, seed=0)
    assert verdict.verdict is ck.VerdictKind.HOLDS and verdict.counterexample is None
    assert 0 < verdict.instances_checked <= ck.SEARCH_FACTOR
    assert verdict.note == f"{verdict.instances_checked} searched"  # no grid: no cells


def test_a_crashing_evaluation_is_a_failure_with_its_mission() -> None:
    def crash(claim: ck.Claim, m: cfopt.Mission) -> ck.Evaluation:
        raise RuntimeError("boom")

    claim = ck.property_claim(
        "MY3", "s", "f", ("mine",), crash,
        scope=ck.Scope.PAPER_SIZES, strategy=ck.structural_missions(achievable=None),
    )  # fmt: skip
    ce = claim.check(1).counterexample
    assert ce is not None and "mine raised RuntimeError: boom" in ce.detail


def test_stored_verdicts_without_a_scope_still_load() -> None:
    data = _user_claim().check(1, seed=0).to_dict()
    del data["scope"]
    assert ck.Verdict.from_dict(data).scope is None


@pytest.mark.parametrize(
    ("change", "match"),
    [
        pytest.param({"id": "../x"}, "Claim.id", id="id-a-path"),
        pytest.param({"id": ""}, "Claim.id", id="id-empty"),
        pytest.param({"algorithms": ()}, "Claim.algorithms", id="no-algorithms"),
        pytest.param({"algorithms": ["a"]}, "Claim.algorithms", id="algorithms-a-list"),
        pytest.param({"method": object()}, "Claim.method", id="method-without-check"),
        pytest.param({"scope": "at the paper's sizes"}, "Claim.scope", id="scope-text"),
    ],
)
def test_claim_fields_are_checked(change: dict, match: str) -> None:
    fields = {
        "id": "MY1", "statement": "s", "family": "f", "algorithms": ("a",),
        "method": _user_claim().method, "scope": ck.Scope.GENERALISATION,
    }  # fmt: skip
    with pytest.raises(cfopt.MissionError, match=match):
        ck.Claim(**{**fields, **change})


# ---------------------------------------------------------------- registration
def test_register_claim_adds_a_claim_after_cfopts_and_refuses_clashes(isolated) -> None:
    builtin = list(isolated)
    claim = _user_claim("MY1")
    assert proofs.register_claim(claim) is claim
    assert list(proofs.claims.CLAIMS) == [*builtin, "MY1"]
    assert proofs.register_claim(claim) is claim  # the same object again: no change
    assert len(isolated) == len(builtin) + 1
    with pytest.raises(cfopt.MissionError, match="'MY1' is already registered"):
        proofs.register_claim(_user_claim("MY1"))
    with pytest.raises(cfopt.MissionError, match="'L1' is already registered"):
        proofs.register_claim(_user_claim("L1"))
    with pytest.raises(
        cfopt.MissionError, match=r"claim: must be a proofs.claimkit.Claim, got str"
    ):
        proofs.register_claim("MY9")
    # the audit's API checks it by id, like cfopt's own
    [verdict] = proofs.claims.audit_claims(budget=1, ids=["MY1"])
    assert verdict.claim_id == "MY1" and verdict.verdict is ck.VerdictKind.FAILS


def _plugin(folder: Path, module: str, claim_id: str, *entries: str) -> Path:
    """An installed distribution in ``folder``: module ``module`` of claims (``claim_id``)
    and ``*.dist-info`` with METADATA and entry points ``name = module:ATTR`` (group
    ``cfopt.claims``).  Returns ``folder``, to put on ``sys.path``."""
    _user_module(folder, module, claim_id)
    info = folder / f"plugin_{module}-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(
        f"Metadata-Version: 2.1\nName: plugin_{module}\nVersion: 1.0\n", encoding="utf-8"
    )
    lines = ["[cfopt.claims]", *(entry.replace("MODULE", module) for entry in entries)]
    (info / "entry_points.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return folder


def test_an_entry_point_is_found_lazily_by_the_registry(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, isolated
) -> None:
    folder = _plugin(tmp_path, "ep_claims_one", "EP1", "one = MODULE:CLAIM", "more = MODULE:CLAIMS")
    monkeypatch.syspath_prepend(folder)  # also clears importlib's caches
    registry = ClaimRegistry()
    assert "ep_claims_one" not in sys.modules  # nothing loaded before first use
    ids = list(registry)
    assert ids[: len(isolated)] == list(isolated)  # cfopt's first, in their order
    assert ids[len(isolated) :] == ["EP1", "EP1b"]  # EP1 twice: the same object, no clash
    assert registry.origin("EP1") == "ep_claims_one" and registry.origin("L1") is None


#: Broken plugins: (claim id of the module, entry point, the error's wording).
BROKEN_PLUGINS = {
    "clash": ("L1", "clash = MODULE:CLAIM", r"entry point clash .*'L1' is already"),
    "type": ("EP3", "w = MODULE:NOT_A_CLAIM", r"must be a proofs\.claimkit\.Claim.*got int"),
    "import": ("EP4", "missing = no_such_module:X", r"no_such_module:X .*cannot be loaded"),
    "attr": ("EP5", "gone = MODULE:nothing", r"cannot be loaded: AttributeError"),
}


@pytest.mark.parametrize(
    ("claim_id", "entry", "match"), BROKEN_PLUGINS.values(), ids=list(BROKEN_PLUGINS)
)
def test_entry_points_that_clash_or_break_are_mission_errors(
    claim_id: str, entry: str, match: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, isolated
) -> None:
    monkeypatch.syspath_prepend(_plugin(tmp_path, f"ep_bad_{claim_id}", claim_id, entry))
    registry = ClaimRegistry()
    with pytest.raises(cfopt.MissionError, match=match):
        list(registry)
    with pytest.raises(cfopt.MissionError, match=match):  # again: never half-built
        len(registry)


def test_module_attr_is_resolved_from_the_current_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, isolated
) -> None:
    _user_module(tmp_path, "cwd_claims")
    (tmp_path / "cwd_broken.py").write_text("raise ImportError('needs a GPU')\n")
    monkeypatch.chdir(tmp_path)
    [claim] = resolve_claims("cwd_claims:CLAIM")
    assert claim.id == "MY1" and sys.path[0] == str(tmp_path)
    assert [c.id for c in resolve_claims("cwd_claims:CLAIMS")] == ["MY1", "MY1b"]
    assert [c.id for c in resolve_claims("cwd_claims:make")] == ["MY1"]  # a callable
    assert resolve_claims("cwd_claims:nested.claim") == [claim]  # dotted
    assert resolve_claims("L1") == [proofs.claims.CLAIMS["L1"]]  # a registered id
    bad = {
        "cwd_claims:NOT_A_CLAIM": "must be a proofs.claimkit.Claim.*got int",
        "cwd_claims:nothing": "cwd_claims has no attribute 'nothing'",
        "cwd_broken:X": "cannot import cwd_broken: ImportError: needs a GPU",
        "no_such_module_xyz:X": "cannot import no_such_module_xyz: ModuleNotFoundError",
        "cwd_claims:": "must be MODULE:ATTR",
        "Q7": "unknown claim 'Q7'",
    }
    for reference, match in bad.items():
        with pytest.raises(cfopt.MissionError, match=match):
            resolve_claims(reference)
    _user_module(tmp_path, "cwd_clash", "L1")
    with pytest.raises(cfopt.MissionError, match="cwd_clash:CLAIM: claim id 'L1'"):
        resolve_claims("cwd_clash:CLAIM")


# ----------------------------------------------------------------- the audit
def test_cfopt_audit_checks_exactly_the_claims_given(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], isolated
) -> None:
    _user_module(tmp_path, "audit_claims_mod")
    monkeypatch.chdir(tmp_path)
    argv = ["audit", "--claims-only", "--quick", "--json", "--quiet", "--workers", "1"]
    refs = ["--claims", "audit_claims_mod:CLAIMS", "--claims", "G1"]
    assert main([*argv, *refs, "-o", "out"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert [c["id"] for c in data["claims"]] == ["MY1", "MY1b", "G1"]
    assert [c["verdict"] for c in data["claims"]] == ["fails", "fails", "holds"]
    assert {c["scope"] for c in data["claims"]} == {ck.Scope.GENERALISATION.value}
    assert (tmp_path / "out" / "counterexamples" / "MY1.mission.json").is_file()
    # run again: every verdict is reused from the store
    assert main([*argv, *refs, "-o", "out", "--force"]) == 0
    assert json.loads(capsys.readouterr().out)["reused_claims"] == 3
    # ... until the user's claim module changes: then its claims are checked again
    source = tmp_path / "audit_claims_mod.py"
    source.write_text(source.read_text() + "\n# edited\n")
    monkeypatch.delitem(sys.modules, "audit_claims_mod")
    assert main([*argv, *refs, "-o", "out", "--force"]) == 0
    assert json.loads(capsys.readouterr().out)["reused_claims"] == 1


@pytest.mark.parametrize(
    ("reference", "message"),
    [
        pytest.param("nope_module:X", "--claims: nope_module:X: cannot import", id="import"),
        pytest.param("audit_bad_mod:NOT_A_CLAIM", "must be a proofs.claimkit.Claim", id="type"),
        pytest.param("Q7", "--claims: unknown claim 'Q7'", id="unknown-id"),
        pytest.param("audit_clash_mod:CLAIM", "claim id 'L1' is already", id="clash"),
    ],
)
def test_cfopt_audit_claims_errors(
    reference: str,
    message: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    isolated,
) -> None:
    _user_module(tmp_path, "audit_bad_mod")
    _user_module(tmp_path, "audit_clash_mod", "L1")
    monkeypatch.chdir(tmp_path)
    assert main(["audit", "--claims-only", "--claims", reference, "-o", "out"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1
    assert captured.err.startswith("error: ") and message in captured.err
    assert "Traceback" not in captured.err and not (tmp_path / "out").exists()


def test_claims_twice_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["audit", "--claims-only", "--claims", "G1", "--claims", "G1", "-o", str(tmp_path)]
    assert main(argv) == 2
    assert "--claims: claim 'G1' is given twice" in capsys.readouterr().err


def test_a_fresh_worker_process_resolves_module_attr(tmp_path: Path) -> None:
    # a spawned process shares nothing with this one but sys.path: the reference and its
    # folder are all it gets
    _user_module(tmp_path, "spawned_claims_mod")
    context = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(1, mp_context=context) as pool:
        future = pool.submit(
            check_claim, "MY1b", 1, 0, str(tmp_path / "hypothesis"),
            reference="spawned_claims_mod:CLAIMS", directory=str(tmp_path),
        )  # fmt: skip
        data = future.result()
    assert data["id"] == "MY1b" and data["verdict"] == "fails"
    assert data["scope"] == ck.Scope.GENERALISATION.value
    assert "spawned_claims_mod" not in sys.modules


def test_a_fresh_worker_process_finds_an_entry_point_claim(tmp_path: Path) -> None:
    _plugin(tmp_path, "spawned_ep_mod", "EP5", "x = MODULE:CLAIM")
    context = multiprocessing.get_context("spawn")
    sys.path.insert(0, str(tmp_path))  # the installed plugin: on every process's sys.path
    try:
        with cf.ProcessPoolExecutor(1, mp_context=context) as pool:
            data = pool.submit(check_claim, "EP5", 1, 0, str(tmp_path / "hypothesis")).result()
    finally:
        sys.path.remove(str(tmp_path))
    assert data["id"] == "EP5" and data["verdict"] == "fails"


# --------------------------------------------------------- the import graph
def _module_name(path: Path) -> str:
    return "proofs" if path.name == "__init__.py" else f"proofs.{path.stem}"


def _imports(path: Path) -> list[tuple[str, str | None, int]]:
    """``(module, name or None, line)`` of every import in ``path``, lazy ones included."""
    out: list[tuple[str, str | None, int]] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(alias.name, None, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level:  # relative: from the package
                module = ".".join(filter(None, ["proofs", module]))
            out += [(module, alias.name, node.lineno) for alias in node.names]
    return out


def _private_imports(folder: Path) -> list[str]:
    """``from M import _name`` anywhere in the modules of ``folder``."""
    return [
        f"{path.name}:{line}: from {module} import {name}"
        for path in sorted(folder.glob("*.py"))
        for module, name, line in _imports(path)
        if name is not None and name.startswith("_") and module != "__future__"
    ]


def _graph(folder: Path) -> dict[str, set[str]]:
    """Which modules of package ``proofs`` (in ``folder``) each one imports."""
    modules = {_module_name(p): p for p in folder.glob("*.py")}
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for name, path in modules.items():
        for module, imported, _ in _imports(path):
            target = f"{module}.{imported}" if imported else module
            if target in modules:  # `from proofs import strategies`, `import proofs.x`
                graph[name].add(target)
            elif module in modules:
                graph[name].add(module)
        graph[name].discard(name)
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[str]:
    """Every import cycle a depth-first walk meets, as ``a -> b -> a``."""
    cycles: list[str] = []
    done: set[str] = set()

    def visit(node: str, trail: list[str]) -> None:
        for nxt in sorted(graph[node]):
            if nxt in trail:
                cycles.append(" -> ".join([*trail[trail.index(nxt) :], nxt]))
            elif nxt not in done:
                visit(nxt, [*trail, nxt])
        done.add(node)

    for start in sorted(graph):
        if start not in done:
            visit(start, [start])
    return cycles


def test_no_private_name_is_imported_across_modules() -> None:
    assert _private_imports(PROOFS) == []


def test_no_import_cycle_among_the_proofs_modules() -> None:
    graph = _graph(PROOFS)
    assert _cycles(graph) == []
    # the layers: the kit imports no claims module; claim modules never import the registry
    claim_modules = {m for m in graph if m.startswith("proofs.claims_")}
    assert claim_modules == {
        "proofs.claims_seed",
        "proofs.claims_distributed",
        "proofs.claims_cfopt",
        "proofs.claims_generic",
        "proofs.claims_dynamic",
    }
    assert not graph["proofs.claimkit"] & (claim_modules | {"proofs.claims"})
    assert all("proofs.claims" not in graph[m] for m in claim_modules)
    assert claim_modules <= graph["proofs.claims"]


def test_the_import_checks_catch_the_old_layouts_faults(tmp_path: Path) -> None:
    # the registry importing a claim module lazily, which imports private names back
    (tmp_path / "claims.py").write_text("def build():\n    from proofs.chain import chain\n")
    (tmp_path / "chain.py").write_text("from proofs.claims import _Outcome, Claim\n")
    (tmp_path / "kit.py").write_text("from . import chain\n")
    graph = _graph(tmp_path)
    assert graph["proofs.kit"] == {"proofs.chain"}
    assert _cycles(graph) == ["proofs.chain -> proofs.claims -> proofs.chain"]
    assert _private_imports(tmp_path) == ["chain.py:1: from proofs.claims import _Outcome"]
