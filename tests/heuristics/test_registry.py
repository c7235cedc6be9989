"""``heuristics.AlgorithmSpec`` and the registry: cfopt's own specs, a user's algorithm
wrapped, registration (Python, entry points, ``MODULE:ATTR``) and its refusals.

Every test that registers uses a fresh :class:`heuristics.registry.AlgorithmRegistry`
(monkeypatched in as ``ALGORITHMS``), so nothing leaks into other tests; the entry points
are real ones, read by ``importlib.metadata`` from a ``*.dist-info`` folder on
``sys.path``, under a group of their own.
"""

from __future__ import annotations

import importlib
import inspect
import re
import sys
import textwrap
from pathlib import Path

import pytest

import heuristics
import heuristics.registry as registry
from cfopt import Assignment, GridCell, Mission, MissionError
from heuristics import AlgorithmFailed, AlgorithmSpec, Option, Stability
from heuristics.registry import AlgorithmRegistry, algorithm_directory

MISSION = Mission.from_arrays([[1, 0], [1, 1], [0, 1]], [[1, 1], [0, 1]], [5.0, 3.0])


def nobody(mission: Mission, *, seed=None) -> Assignment:
    """Assigns no robot."""
    return Assignment.empty(mission)


@pytest.fixture
def fresh(monkeypatch: pytest.MonkeyPatch) -> AlgorithmRegistry:
    """A registry of cfopt's own algorithms only, used by every registry function."""
    fresh = AlgorithmRegistry(entry_point_group=None)
    monkeypatch.setattr(registry, "ALGORITHMS", fresh)
    return fresh


# ---------------------------------------------------------------- cfopt's own specs
SHIPPED = {
    # name: (stability, protocol class, protocol options, measures)
    "grape-s": ("seed", "GrapeSProtocol", (), ()),
    "pair-grape-s": ("capped", "PairGrapeSProtocol", (), ("exchanges", "pairwise_step_ran")),
    "sda": ("none", "SdaProtocol", ("eps", "resend_tries"), ()),
    "rachna-dt": ("none", None, (), ()),
    "pair-grape-s-chain": (
        "capped", "PairGrapeSChainProtocol", (), ("exchanges", "pairwise_step_ran"),
    ),
    "grape-s-select": ("own", "GrapeSSelectProtocol", ("exchange",), ()),
}  # fmt: skip


def test_every_shipped_algorithm_is_described() -> None:
    assert heuristics.algorithm_names() == sorted(SHIPPED)
    for name, (stability, protocol, agent_options, measures) in SHIPPED.items():
        spec = heuristics.get_algorithm(name)
        version = "2" if "grape-s" in name and name != "grape-s-select" else "1"
        assert spec.name == name and spec.version == version and spec.shipped
        assert spec.stability is Stability(stability) and spec.measures == measures
        assert spec.summary and "\n" not in spec.summary
        assert [o.name for o in spec.protocol_options] == list(agent_options)
        if protocol is None:
            assert not spec.distributed
        else:
            assert type(spec.make_protocol()).__name__ == protocol


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_options_are_the_engines_keywords_with_their_defaults(name: str) -> None:
    spec = heuristics.get_algorithm(name)
    keywords = inspect.signature(spec.run).parameters
    assert set(keywords) - {"mission", "seed"} == {o.name for o in spec.options}
    for option in spec.options:
        assert keywords[option.name].default == option.default, option.name
    today = {"order", "medium", "encoding", "time_limit"}  # cfopt run's flags before specs
    assert today <= {o.name for o in spec.options}


def test_the_auctions_and_pair_variants_options() -> None:
    flags = {n: [o.flag for o in heuristics.get_algorithm(n).options] for n in SHIPPED}
    assert {"--eps", "--schedule", "--max-rounds"} <= set(flags["rachna-dt"])
    assert {"--eps", "--schedule"} <= set(flags["sda"])
    assert {"--capped", "--reward"} <= set(flags["grape-s"])
    assert "--exchange" in flags["grape-s-select"]
    assert "--eps" not in flags["grape-s"]


def test_shipped_runs_are_the_engines_runs() -> None:
    spec = heuristics.get_algorithm("pair-grape-s")
    run = spec(MISSION, seed=3, order="random")
    assert run.counted and run.replace_seconds(0) == heuristics.pair_grape_s(
        MISSION, seed=3, order="random"
    ).replace_seconds(0)
    assert heuristics.run_algorithm("sda", MISSION, seed=1).algorithm == "sda"


def test_a_shipped_engine_error_is_not_wrapped() -> None:
    """An exception of cfopt's own algorithm is cfopt's (a MissionError stays one, a bug
    stays a traceback): never an AlgorithmFailed."""
    with pytest.raises(MissionError, match=r"^order: ") as caught:
        heuristics.get_algorithm("grape-s")(MISSION, order="reverse")
    assert not isinstance(caught.value, AlgorithmFailed)


def test_make_protocol_checks_its_options() -> None:
    sda = heuristics.get_algorithm("sda")
    assert sda.make_protocol(eps=0.5, resend_tries=2).resend_tries == 2
    with pytest.raises(MissionError, match=r"options: sda's agents take eps, resend_tries"):
        sda.make_protocol(exchange=True)
    with pytest.raises(MissionError, match=r"options: resend_tries: must be a whole number"):
        sda.make_protocol(resend_tries=1.5)
    with pytest.raises(MissionError, match=r"grape-s's agents take none"):
        heuristics.get_algorithm("grape-s").make_protocol(eps=1)
    select = heuristics.get_algorithm("grape-s-select")
    assert select.make_protocol(exchange=False).exchange is False
    with pytest.raises(MissionError, match=r"'rachna-dt' has no distributed agents \(avail"):
        heuristics.get_algorithm("rachna-dt").make_protocol()


def test_grape_s_select_has_its_own_checker() -> None:
    import proofs.select_stability

    spec = heuristics.get_algorithm("grape-s-select")
    assert spec.stability_checker() is proofs.select_stability.select_violations
    assert heuristics.get_algorithm("grape-s").stability_checker() is None
    run = spec(MISSION)
    assert spec.stability_checker()(MISSION, run.assignment) == []


def test_the_heuristics_layer_does_not_import_proofs() -> None:
    """The checker is named by "MODULE:ATTR" and imported only when asked for."""
    source = Path(inspect.getfile(registry)).read_text(encoding="utf-8")  # the imported copy
    assert not re.search(r"^\s*(from|import) proofs", source, flags=re.M)


# ---------------------------------------------------------------- a user's function
def test_an_assignment_becomes_a_run_whose_counts_are_not_reported() -> None:
    spec = AlgorithmSpec(name="nobody", run=nobody)
    run = spec(MISSION, seed=4)
    assert run.algorithm == "nobody" and run.seed == 4 and not run.counted
    assert run.assignment == Assignment.empty(MISSION) and run.seconds >= 0
    shown = run.to_dict(MISSION)
    for key in ("iterations", "rounds", "messages", "bytes", "work", "exchanges"):
        assert shown[key] is None, key
    assert shown["pairwise_step_ran"] is None and shown["seconds"] == run.seconds
    assert spec.summary == "Assigns no robot." and spec.stability is Stability.NONE
    assert not spec.shipped and not spec.distributed


def test_a_returned_run_is_kept_as_it_is() -> None:
    inner = heuristics.grape_s(MISSION, seed=0)
    spec = AlgorithmSpec(name="wrapped", run=lambda mission, *, seed=None: inner)
    assert spec(MISSION, seed=0) is inner and inner.counted


def _raises(mission, *, seed=None):
    raise ZeroDivisionError("no robots to divide")


@pytest.mark.parametrize(
    ("function", "match"),
    [
        pytest.param(_raises, r"^mine: raised ZeroDivisionError: no robots", id="raises"),
        pytest.param(lambda m, *, seed=None: 3, r"^mine: returned 3, not a", id="int"),
        pytest.param(
            lambda m, *, seed=None: Assignment.empty(5),
            r"^mine: returned an assignment that does not fit the mission \(assignment: has 5",
            id="wrong-size",
        ),
        pytest.param(
            lambda m, *, seed=None: Assignment(task=[0, 0, 0], service=[1, 1, 1]),
            r"mine: returned an assignment that does not fit .* cannot perform service",
            id="invalid",
        ),
        pytest.param(lambda m: Assignment.empty(m), r"^mine: raised TypeError: ", id="no-seed"),
    ],
)
def test_a_users_failure_is_algorithm_failed(function, match) -> None:
    with pytest.raises(AlgorithmFailed, match=match) as caught:
        AlgorithmSpec(name="mine", run=function)(MISSION, seed=0)
    assert caught.value.algorithm == "mine" and isinstance(caught.value, MissionError)


def test_algorithm_failed_travels_between_processes() -> None:
    import pickle

    back = pickle.loads(pickle.dumps(AlgorithmFailed("mine", "raised ValueError: x")))
    assert (back.algorithm, back.problem, str(back)) == ("mine", "raised ValueError: x", str(back))


# ------------------------------------------------------------------ the spec's checks
@pytest.mark.parametrize(
    ("fields", "error", "match"),
    [
        pytest.param({"name": ""}, ValueError, "^name: must be a non-empty string", id="empty"),
        pytest.param({"name": "my greedy"}, ValueError, "^name: must have no spaces", id="space"),
        pytest.param({"run": "nobody"}, TypeError, "^run: must be callable", id="run"),
        pytest.param({"version": ""}, ValueError, "^version: ", id="version"),
        pytest.param(
            {"stability": "nash"}, ValueError, "^stability: must be one of seed, capped", id="stab"
        ),
        pytest.param({"stability": "own"}, ValueError, "^checker: give one exactly when", id="own"),
        pytest.param({"checker": "m:f"}, ValueError, "^checker: give one exactly", id="checker"),
        pytest.param({"options": ("order",)}, TypeError, "^options: must be a tuple of", id="opts"),
        pytest.param(
            {"options": (Option("k"), Option("k"))}, ValueError, "given twice", id="twice"
        ),
        pytest.param({"protocol": 3}, TypeError, "^protocol: must be callable", id="proto"),
        pytest.param(
            {"protocol": "nomodule"}, ValueError, "^protocol: must be MODULE:ATTR", id="proto-ref"
        ),
        pytest.param(
            {"protocol_options": (Option("k"),)},
            ValueError,
            "^protocol_options: given without",
            id="popts",
        ),
        pytest.param(
            {"measures": ("speed",)}, TypeError, "^measures: must be a tuple", id="measures"
        ),
        pytest.param({"summary": None}, TypeError, "^summary: ", id="summary"),
    ],
)
def test_bad_specs_are_refused(fields, error, match) -> None:
    with pytest.raises(error, match=match):
        AlgorithmSpec(**{"name": "mine", "run": nobody, **fields})


@pytest.mark.parametrize(
    ("fields", "error", "match"),
    [
        pytest.param(
            {"name": "max-rounds"}, TypeError, "^name: an option's name must be", id="name"
        ),
        pytest.param({"type": list}, TypeError, "^type: option 'k': must be bool", id="type"),
        pytest.param(
            {"choices": ()}, TypeError, "^choices: option 'k': must be a", id="no-choices"
        ),
        pytest.param(
            {"type": int, "choices": (1, "2")}, TypeError, '"2" is not a int', id="choice"
        ),
        pytest.param(
            {"type": int, "default": 1.5},
            TypeError,
            "^default: must be a whole number",
            id="default",
        ),
        pytest.param(
            {"choices": ("a", "b"), "default": "c"},
            ValueError,
            "^default: must be one of a, b",
            id="default-choice",
        ),
        pytest.param({"help": 3}, TypeError, "^help: ", id="help"),
    ],
)
def test_bad_options_are_refused(fields, error, match) -> None:
    with pytest.raises(error, match=match):
        Option(**{"name": "k", **fields})


def test_option_values_are_checked_by_type() -> None:
    assert Option("x", float).check(2) == 2 and Option("b", bool).check(True) is True
    for option, value in [(Option("x", float), True), (Option("n", int), 2.0), (Option("s"), 1)]:
        with pytest.raises(TypeError, match=f"^{option.name}: must be"):
            option.check(value)
    with pytest.raises(TypeError, match=r"^x: must be a number, got NaN"):
        Option("x", float).check(float("nan"))


# ----------------------------------------------------------------- registration
def test_register_a_function_by_its_name_or_another(fresh: AlgorithmRegistry) -> None:
    spec = heuristics.register_algorithm(nobody, version="3")
    assert spec.name == "nobody" and spec.version == "3"
    assert heuristics.get_algorithm("nobody") is spec and "nobody" in heuristics.algorithm_names()
    assert heuristics.register_algorithm(spec) is spec  # the same again: no change
    other = heuristics.register_algorithm(nobody, name="idle")
    assert fresh["idle"] is other and fresh.origin("idle") == "by register_algorithm"
    assert fresh.origin("grape-s") == "by cfopt" and fresh.origin("unknown") is None


def test_register_as_a_decorator(fresh: AlgorithmRegistry) -> None:
    @heuristics.register_algorithm
    def first_slot(mission, *, seed=None):
        return Assignment.empty(mission)

    assert isinstance(first_slot, AlgorithmSpec) and "first_slot" in fresh
    assert first_slot(MISSION).algorithm == "first_slot"  # still callable like the function


@pytest.mark.parametrize(
    ("call", "match"),
    [
        pytest.param(
            lambda: heuristics.register_algorithm(nobody, name="grape-s"),
            r"^register_algorithm\('grape-s'\): algorithm name 'grape-s' is already "
            r"registered \(by cfopt\); choose another name",
            id="clash",
        ),
        pytest.param(
            lambda: heuristics.register_algorithm(nobody, name="my:greedy"),
            r"^register_algorithm\('my:greedy'\): name 'my:greedy': a registered name has no ':'",
            id="colon",
        ),
        pytest.param(
            lambda: heuristics.register_algorithm(42),
            r"^algorithm: must be a heuristics.AlgorithmSpec or a callable, got 42",
            id="not-callable",
        ),
        pytest.param(
            lambda: heuristics.register_algorithm(Assignment),
            r"^algorithm: must be a heuristics.AlgorithmSpec or a callable, got type",
            id="a-class",
        ),
    ],
)
def test_registration_refusals(fresh: AlgorithmRegistry, call, match) -> None:
    with pytest.raises(MissionError, match=match):
        call()
    assert sorted(fresh) == sorted(SHIPPED)


def test_algorithms_is_a_read_only_live_view(fresh: AlgorithmRegistry) -> None:
    with pytest.raises(TypeError):
        fresh["nobody"] = nobody  # type: ignore[index]
    assert "nobody" not in fresh
    heuristics.register_algorithm(nobody)
    assert "nobody" in fresh and fresh["nobody"].run is nobody  # the same view, updated


# ---------------------------------------------------------------- entry points
def write_distribution(folder: Path, group: str, entries: dict[str, str], code: str) -> None:
    """A package ``eppkg`` and its ``*.dist-info`` with entry points, as pip installs them."""
    (folder / "eppkg").mkdir(parents=True)
    (folder / "eppkg" / "__init__.py").write_text(textwrap.dedent(code), encoding="utf-8")
    info = folder / "eppkg-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: eppkg\nVersion: 1.0\n")
    lines = "".join(f"{name} = {target}\n" for name, target in entries.items())
    (info / "entry_points.txt").write_text(f"[{group}]\n{lines}", encoding="utf-8")


EPPKG = """
    import cfopt, heuristics

    def idle(mission, *, seed=None):
        return cfopt.Assignment.empty(mission)

    SPEC = heuristics.AlgorithmSpec(name="ep-idle", run=idle, version="7")
    MANY = [heuristics.AlgorithmSpec(name=f"ep-{k}", run=idle) for k in ("a", "b")]
    NUMBER = 3
"""
GROUP = "cfopt.test_algorithms"


@pytest.fixture
def installed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    def install(entries: dict[str, str]) -> AlgorithmRegistry:
        write_distribution(tmp_path, GROUP, entries, EPPKG)
        monkeypatch.syspath_prepend(str(tmp_path))
        importlib.invalidate_caches()
        fresh = AlgorithmRegistry(entry_point_group=GROUP)
        monkeypatch.setattr(registry, "ALGORITHMS", fresh)
        return fresh

    yield install
    sys.modules.pop("eppkg", None)


def test_entry_points_load_a_spec_a_callable_and_a_list(installed) -> None:
    fresh = installed({"one": "eppkg:SPEC", "plain": "eppkg:idle", "several": "eppkg:MANY"})
    assert {"ep-idle", "plain", "ep-a", "ep-b"} <= set(fresh)
    assert heuristics.get_algorithm("ep-idle").version == "7"
    assert heuristics.get_algorithm("plain")(MISSION).algorithm == "plain"  # the entry's name
    assert fresh.origin("plain").startswith("by entry point plain = eppkg:idle")


@pytest.mark.parametrize(
    ("entries", "match"),
    [
        pytest.param(
            {"grape-s": "eppkg:idle"},
            rf"^entry point grape-s = eppkg:idle \(group {GROUP}\): algorithm name 'grape-s' "
            r"is already registered \(by cfopt\)",
            id="clash",
        ),
        pytest.param(
            {"gone": "nosuchpkg:idle"},
            rf"^entry point gone = nosuchpkg:idle \(group {GROUP}\): cannot be loaded: "
            r"ModuleNotFoundError",
            id="import-error",
        ),
        pytest.param(
            {"num": "eppkg:NUMBER"},
            r"^entry point num = eppkg:NUMBER .*: must be a heuristics.AlgorithmSpec, a callable "
            r"or a list of specs, got 3",
            id="wrong-object",
        ),
    ],
)
def test_a_broken_entry_point_is_one_error_each_time(installed, entries, match) -> None:
    installed(entries)
    for _ in range(2):  # not half-loaded: the next use says it again
        with pytest.raises(MissionError, match=match):
            heuristics.get_algorithm("grape-s")


# ------------------------------------------------------------------- MODULE:ATTR
USERMOD = """
    import cfopt, heuristics

    def greedy(mission, *, seed=None):
        return cfopt.Assignment.empty(mission)

    class Holder:
        spec = heuristics.AlgorithmSpec(name="held", run=greedy)

    TWIN = heuristics.AlgorithmSpec(name="grape-s", run=greedy)
    SPECS = [Holder.spec]
    NUMBER = 3
"""


@pytest.fixture
def usermod(tmp_path: Path, fresh: AlgorithmRegistry):
    name = f"usermod_{tmp_path.name.replace('-', '_')}"  # one module per test
    (tmp_path / f"{name}.py").write_text(textwrap.dedent(USERMOD), encoding="utf-8")
    yield name, tmp_path
    sys.modules.pop(name, None)


def test_references_name_a_callable_or_a_spec(usermod) -> None:
    name, folder = usermod
    spec = heuristics.get_algorithm(f"{name}:greedy", directory=folder)
    assert spec.name == f"{name}:greedy" and spec(MISSION).algorithm == f"{name}:greedy"
    assert heuristics.get_algorithm(f"{name}:greedy", directory=folder) is spec  # resolved once
    assert heuristics.get_algorithm(f"{name}:Holder.spec", directory=folder).name == "held"
    assert algorithm_directory(f"{name}:greedy") == str(folder.resolve())
    assert algorithm_directory("grape-s") is None
    assert f"{name}:greedy" not in heuristics.ALGORITHMS  # a reference is not registered


def test_a_reference_resolves_from_the_current_directory(usermod, monkeypatch) -> None:
    name, folder = usermod
    monkeypatch.chdir(folder)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", str(folder))])
    assert heuristics.get_algorithm(f"{name}:greedy").name == f"{name}:greedy"


@pytest.mark.parametrize(
    ("attribute", "match"),
    [
        pytest.param("TWIN", r":TWIN: names its algorithm 'grape-s', which is already", id="clash"),
        pytest.param("NUMBER", r":NUMBER: must be a heuristics.AlgorithmSpec, a callable", id="3"),
        pytest.param("SPECS", r":SPECS: must name one heuristics", id="list"),
        pytest.param("missing", r":missing: usermod_\w+ has no attribute 'missing'", id="missing"),
    ],
)
def test_bad_references_are_one_error(usermod, attribute, match) -> None:
    name, folder = usermod
    with pytest.raises(MissionError, match=f"^{name}{match}"):
        heuristics.get_algorithm(f"{name}:{attribute}", directory=folder)


def test_a_reference_needs_both_halves() -> None:
    for reference in (":greedy", "mymod:", " : "):
        with pytest.raises(MissionError, match=r"^algorithm: must be MODULE:ATTR"):
            heuristics.get_algorithm(reference)


def test_a_module_that_fails_to_import_is_one_error(tmp_path: Path) -> None:
    (tmp_path / "broken_user_module.py").write_text("raise RuntimeError('half written')\n")
    with pytest.raises(
        MissionError,
        match=r"^broken_user_module:f: cannot import broken_user_module: RuntimeError: half",
    ):
        heuristics.get_algorithm("broken_user_module:f", directory=tmp_path)
    with pytest.raises(MissionError, match=r"^nosuchmodule_xyz:f: cannot import nosuchmodule_xyz"):
        heuristics.get_algorithm("nosuchmodule_xyz:f")


# --------------------------------------------------------------- no name branches
#: Where algorithm names may stand: the registry, the paper's data, the engines naming
#: their own runs, and (until the transports read the registry) simulate.py and mpi.py.
NAMED_HERE = {"registry.py", "paper.py", "simulate.py", "mpi.py", "_reference.py"}


def test_nothing_outside_the_registry_branches_on_an_algorithm_name() -> None:
    names = "|".join(re.escape(n) for n in SHIPPED)
    branch = re.compile(rf"(==|!=|\bin)\s*\(?[^\n]*[\"']({names})[\"']")
    found = [
        f"{path.name}: {line.strip()}"
        for package in ("cfopt", "heuristics")  # the imported copies (installed or not)
        for path in sorted(
            Path(inspect.getfile(importlib.import_module(package))).parent.rglob("*.py")
        )
        if path.name not in NAMED_HERE
        for line in path.read_text(encoding="utf-8").splitlines()
        if branch.search(line) and not line.lstrip().startswith((">>>", "#"))
    ]
    assert found == []


def test_sweep_cells_ask_the_spec_for_agents(fresh: AlgorithmRegistry) -> None:
    from cfopt.experiments import Sweep

    heuristics.register_algorithm(nobody)
    heuristics.register_algorithm(
        nobody, name="nobody-agents", protocol="heuristics.agents.grape_s:GrapeSProtocol"
    )
    cell = GridCell(12, 20, 3, 2, network="complete")
    sweep = Sweep(cells=(cell,), missions=1, algorithms=("nobody", "nobody-agents", "sda"))
    assert sweep.algorithms_for(cell) == ("exact", "nobody-agents", "sda")
