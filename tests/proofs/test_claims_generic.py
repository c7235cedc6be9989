"""The generic claims of any algorithm (:mod:`proofs.claims_generic`) and ``cfopt audit
--algorithm``: a good function holds what it declares, a broken, a raising and a
half-optimal one fail with counterexamples that replay, the audit checks them in real
processes and stores them."""

from __future__ import annotations

import json
import re
import textwrap
from pathlib import Path

import numpy as np
import pytest

import cfopt
import heuristics
from cfopt import Assignment, Mission, MissionError
from proofs.claimkit import VerdictKind
from proofs.claims_generic import (
    REPLAY_SEED,
    algorithm_claims,
    claim_prefix,
    validity_problems,
)
from tests.cfopt.test_user_algorithm import cfopt as cfopt_process

BUDGET = 2


def _spec(function, name=None, **fields) -> heuristics.AlgorithmSpec:
    return heuristics.AlgorithmSpec(name=name or function.__name__, run=function, **fields)


def _claims(spec: heuristics.AlgorithmSpec, **options) -> dict[str, object]:
    return {c.id.rsplit(".", 1)[1]: c for c in algorithm_claims(spec, **options)}


# ------------------------------------------------------------- the functions
def grape(mission, *, seed=None):
    """GRAPE-S's partition, as a plain assignment (so its runs are not counted)."""
    return heuristics.grape_s(mission, seed=seed).assignment


def grape_capped(mission, *, seed=None):
    return heuristics.grape_s(mission, seed=seed, capped=True).assignment


def select(mission, *, seed=None):
    return heuristics.grape_s_select(mission, seed=seed).assignment


def anyone_anywhere(mission, *, seed=None):
    """Broken: every robot on the first task's first service, whether it has it or not."""
    zeros = [0] * mission.n_robots
    return Assignment(task=zeros, service=zeros)


def raises_from_three(mission, *, seed=None):
    if mission.n_robots >= 3:
        raise ValueError("three robots are too many")
    return grape(mission, seed=seed)


def half(mission, *, seed=None):
    """The optimum with every second completed task's robots sent home."""
    best = cfopt.solve_exact(mission).assignment
    task, service = best.task.copy(), best.service.copy()
    for j in best.completed_tasks(mission)[::2]:
        task[best.task == j] = service[best.task == j] = -1
    return Assignment(task=task, service=service)


def quartic(mission, *, seed=None):
    """A counted run whose work is n^4 (and a valid, empty partition)."""
    return _counted(mission, mission.n_robots**4)


def linear(mission, *, seed=None):
    return _counted(mission, 7 * mission.n_robots)


def _counted(mission: Mission, work: int) -> heuristics.Run:
    return heuristics.Run(
        algorithm="counted",
        assignment=Assignment.empty(mission),
        iterations=1,
        rounds=1,
        messages=0,
        bytes=0,
        work=work,
        seconds=0.0,
        seed=None,
    )


# ------------------------------------------------------------------- claims
def test_the_claims_follow_the_declared_stability() -> None:
    ids = {s: [c.id for c in algorithm_claims(_spec(grape, stability=s))] for s in ("seed", "none")}
    assert ids["seed"] == ["grape.valid", "grape.stable", "grape.95pct", "grape.scaling"]
    assert ids["none"] == ["grape.valid", "grape.95pct", "grape.scaling"]
    claims = algorithm_claims(_spec(grape), min_percent=90, exhaustive=False)
    assert claims[1].id == "grape.90pct"
    assert all(c.scope.value.startswith("a generalisation") for c in claims)
    assert "small scope" in algorithm_claims(_spec(grape))[0].family
    assert "small scope" not in claims[0].family


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("mymod:greedy", "mymod-greedy"),
        ("pkg.sub:make.spec", "pkg.sub-make.spec"),
        ("grape-s", "grape-s"),
        (":::", "algorithm"),
    ],
)
def test_claim_ids_come_from_the_algorithm_name(name: str, expected: str) -> None:
    assert claim_prefix(name) == expected


def test_a_long_name_is_cut_and_keeps_the_ids_apart() -> None:
    a, b = claim_prefix("m" * 80 + ":a"), claim_prefix("m" * 80 + ":b")
    assert a != b and len(a) <= 48
    spec = _spec(grape, name="x" * 100)
    assert all(len(c.id) <= 64 for c in algorithm_claims(spec))


@pytest.mark.parametrize(
    ("stability", "function", "checker"),
    [
        ("seed", grape, None),
        ("capped", grape_capped, None),
        ("own", select, "proofs.select_stability:select_violations"),
    ],
)
def test_a_good_function_is_valid_and_stable_as_it_declares(
    stability: str, function, checker: str | None
) -> None:
    spec = _spec(function, stability=stability, checker=checker)
    claims = _claims(spec, exhaustive=False)
    for kind in ("valid", "stable"):
        verdict = claims[kind].check(BUDGET)
        assert verdict.verdict is VerdictKind.HOLDS, verdict.note
        assert verdict.counterexample is None and verdict.instances_checked > 100


def nobody(mission, *, seed=None):
    return Assignment.empty(mission)


def test_stable_as_declared_uses_the_declared_check() -> None:
    def never(mission, assignment):
        return []

    def always(mission, assignment):
        return ["a complaint of its own"]

    seed = _claims(_spec(nobody, stability="seed"), exhaustive=False)["stable"].check(BUDGET)
    assert seed.verdict is VerdictKind.FAILS  # an idle robot wants any slot it can serve
    assert seed.counterexample.size == (1, 1, 1)
    assert "not Nash stable under the seed's reward: r0: - -> t0/s0" in seed.counterexample.detail
    for checker, expected in ((never, VerdictKind.HOLDS), (always, VerdictKind.FAILS)):
        spec = _spec(nobody, stability="own", checker=checker)
        verdict = _claims(spec, exhaustive=False)["stable"].check(BUDGET)
        assert verdict.verdict is expected
    assert "not stable by its own checker: a complaint of its own" in (
        verdict.counterexample.detail
    )


def test_an_invalid_assignment_fails_validity_with_a_counterexample_that_replays() -> None:
    claims = _claims(_spec(anyone_anywhere))
    verdict = claims["valid"].check(BUDGET)
    assert verdict.verdict is VerdictKind.FAILS
    ce = verdict.counterexample
    assert ce.algorithm == "anyone_anywhere" and ce.seed == REPLAY_SEED
    assert ce.size == (1, 1, 1) or ce.size[0] <= 3  # shrunk to a tiny mission
    replayed = anyone_anywhere(ce.mission, seed=ce.seed)
    problems = validity_problems(ce.mission, replayed)
    assert problems and problems[0] in ce.detail
    with pytest.raises(MissionError):  # cfopt's own validation agrees
        replayed.validate(ce.mission)
    # the counterexample's assignment: the run's, the robots at fault unassigned
    m, s = ce.mission, replayed.service
    fine = m.capabilities[np.arange(m.n_robots), s] & (m.requirements[replayed.task, s] > 0)
    assert ce.assignment.task.tolist() == np.where(fine, replayed.task, -1).tolist()
    ce.assignment.validate(m)
    assert "replay: cfopt run anyone_anywhere MISSION --seed 0" in ce.detail
    # the verdict travels as JSON (the audit's store) and back
    back = type(verdict).from_dict(json.loads(json.dumps(verdict.to_dict())))
    assert back.counterexample.seed == REPLAY_SEED and back.verdict is VerdictKind.FAILS


def test_a_reference_names_the_runs_and_the_spec_names_the_claims() -> None:
    spec = _spec(anyone_anywhere, name="anyone")
    claims = algorithm_claims(spec, reference="mod:SPEC", exhaustive=False)
    assert claims[0].id == "anyone.valid"
    assert claims[0].statement.startswith("anyone returns") and claims[0].algorithms == (
        "mod:SPEC",
    )
    ce = claims[0].check(BUDGET).counterexample
    assert ce.algorithm == "mod:SPEC" and "replay: cfopt run mod:SPEC MISSION --seed 0" in ce.detail


@pytest.mark.parametrize(
    ("result", "problem"),
    [
        (Assignment(task=[0], service=[0]), "it assigns 1 robots, the mission has 2"),
        (Assignment(task=[0, 3], service=[0, 0]), "robot 'r1' has task 3 / service 0 (out"),
        (Assignment(task=[0, 0], service=[0, 0]), "robot 'r1' performs 's0', which it does"),
        (Assignment(task=[0, 1], service=[0, 1]), "robot 'r1' performs 's1' for task 't1', which"),
    ],
)
def test_validity_is_recomputed_from_the_mission(result: Assignment, problem: str) -> None:
    m = Mission.from_arrays([[1, 0], [0, 1]], [[1, 1], [1, 0]], [1.0, 1.0])
    assert validity_problems(m, Assignment(task=[0, 0], service=[0, 1])) == []
    assert validity_problems(m, result)[0].startswith(problem)


def test_an_algorithm_that_raises_fails_validity_on_that_mission() -> None:
    claims = _claims(_spec(raises_from_three, stability="seed"), exhaustive=False)
    for kind in ("valid", "stable", "scaling"):
        verdict = claims[kind].check(BUDGET)  # never raises
        assert verdict.verdict is VerdictKind.FAILS
        ce = verdict.counterexample
        assert "raises_from_three raised ValueError: three robots are too many" in ce.detail
        assert ce.mission.n_robots >= 3 and ce.seed == REPLAY_SEED
        with pytest.raises(ValueError, match="too many"):
            raises_from_three(ce.mission, seed=ce.seed)
    assert claims["valid"].check(BUDGET).counterexample.mission.n_robots == 3  # shrunk


def test_returning_something_else_fails_validity() -> None:
    spec = _spec(lambda mission, *, seed=None: {"task": []}, name="wrong-type")
    verdict = _claims(spec, exhaustive=False)["valid"].check(BUDGET)
    assert verdict.verdict is VerdictKind.FAILS
    assert (
        "returned dict, not a heuristics.Run or a cfopt.Assignment" in verdict.counterexample.detail
    )


def test_half_the_optimum_fails_the_95_percent_claim() -> None:
    verdict = _claims(_spec(half))["95pct"].check(BUDGET)
    assert verdict.verdict is VerdictKind.FAILS
    ce = verdict.counterexample
    got = ce.assignment.utility(ce.mission)
    best = cfopt.solve_exact(ce.mission)
    percent = 100.0 * got / best.utility
    assert percent < 95 and percent == pytest.approx(
        float(re.search(r"\(([\d.]+) % < 95 %", ce.detail).group(1)), abs=0.01
    )
    assert half(ce.mission, seed=ce.seed) == ce.assignment  # replays
    assert ce.mission.total_utility == best.utility  # an achievable mission


def test_the_optimum_itself_holds_the_95_percent_claim() -> None:
    def optimum(mission, *, seed=None):
        return cfopt.solve_exact(mission).assignment

    verdict = _claims(_spec(optimum))["95pct"].check(BUDGET)
    assert verdict.verdict is VerdictKind.HOLDS, verdict.note
    assert "below: 0 of" in verdict.note


def test_counted_work_above_the_ceiling_fails_the_scaling_claim() -> None:
    verdict = _claims(_spec(quartic))["scaling"].check(BUDGET)
    assert verdict.verdict is VerdictKind.FAILS  # work ~ n^4 > 3 + 0.25, whatever the clock
    assert "work ~ n^4.00 [4.00, 4.00] vs the ceiling n^3: fails" in verdict.note
    assert "wall time ~ n^" in verdict.note and "noisy" in verdict.note
    ce = verdict.counterexample
    assert ce.mission.n_robots == 400 and f"work {400**4}" in ce.detail
    assert ce.seed == REPLAY_SEED and ce.assignment == Assignment.empty(ce.mission)
    # a higher ceiling, stated by the user, is met by the work
    verdict = _claims(_spec(quartic), max_exponent=4)["scaling"].check(BUDGET)
    assert "work ~ n^4.00 [4.00, 4.00] vs the ceiling n^4: holds" in verdict.note


def test_work_is_fitted_only_when_the_runs_report_it() -> None:
    counted = _claims(_spec(linear))["scaling"].check(BUDGET)
    assert "work ~ n^1.00 [1.00, 1.00] vs the ceiling n^3: holds" in counted.note
    assert counted.instances_checked == 10  # 5 sizes, 2 seeds each
    uncounted = _claims(_spec(grape))["scaling"].check(BUDGET)
    assert "work not reported" in uncounted.note and "work ~" not in uncounted.note


def test_an_own_checker_is_imported_when_checked_and_a_missing_one_is_an_error() -> None:
    spec = _spec(grape, stability="own", checker="no_such_module_i22:check")
    claims = _claims(spec, exhaustive=False)  # building the claims imports nothing
    with pytest.raises(MissionError, match=r"grape: its stability checker: .*no_such_module_i22"):
        claims["stable"].check(BUDGET)
    assert claims["valid"].check(BUDGET).verdict is VerdictKind.HOLDS


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"spec": "grape-s"}, TypeError, "spec: must be a heuristics.AlgorithmSpec"),
        ({"min_percent": 0}, ValueError, "min_percent: must be"),
        ({"min_percent": 101}, ValueError, "min_percent: must be"),
        ({"max_exponent": -1}, ValueError, "max_exponent: must be"),
        ({"exhaustive": 1}, TypeError, "exhaustive: must be a bool"),
    ],
)
def test_bad_arguments_name_themselves(kwargs, error, match) -> None:
    spec = kwargs.pop("spec", _spec(grape))
    with pytest.raises(error, match=match):
        algorithm_claims(spec, **kwargs)


# -------------------------------------------------------------- the audit
MOD = """
    import cfopt
    import heuristics


    def greedy(mission, *, seed=None):
        \"\"\"Each robot, in order, takes the first short slot it can serve.\"\"\"
        need = mission.requirements.copy()
        task, service = [-1] * mission.n_robots, [-1] * mission.n_robots
        for i in range(mission.n_robots):
            for j, s in zip(*need.nonzero()):
                if mission.capabilities[i, s]:
                    task[i], service[i] = int(j), int(s)
                    need[j, s] -= 1
                    break
        return cfopt.Assignment(task=task, service=service)


    def broken(mission, *, seed=None):
        return cfopt.Assignment(task=[0] * mission.n_robots, service=[0] * mission.n_robots)


    def flaky(mission, *, seed=None):
        if mission.n_robots >= 3:
            raise ValueError("three robots are too many")
        return cfopt.Assignment.empty(mission)


    CAPPED = heuristics.AlgorithmSpec("my-greedy", greedy, stability="capped")
    BAD_CHECKER = heuristics.AlgorithmSpec(
        "bad-checker", greedy, stability="own", checker="no_such_module_i22:check"
    )
"""


def _rows(table: str) -> dict[str, list[str]]:
    rows = {}
    for line in table.splitlines()[1:]:
        if line.startswith("counterexample:"):
            break
        cells = re.split(r"\s{2,}", line.strip())  # id, verdict, scope, missions, size, ...
        rows[cells[0]] = [cells[1], cells[3], cells[4]]
    return rows


@pytest.fixture(scope="module")
def audited(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str, str]:
    folder = tmp_path_factory.mktemp("generic-audit")
    (folder / "mod.py").write_text(textwrap.dedent(MOD), encoding="utf-8")
    args = ["audit", "--claims-only", "--quick", "--quiet", "-o", "out"]
    args += ["--algorithm", "mod:CAPPED", "--algorithm", "mod:broken", "--algorithm", "mod:flaky"]
    first = cfopt_process(*args, cwd=folder)
    assert first.returncode == 0, first.stderr
    again = cfopt_process(*args, "--force", "--json", cwd=folder)
    assert again.returncode == 0, again.stderr
    return folder, first.stdout, again.stdout


def test_the_audit_checks_a_users_algorithms_generic_claims(audited) -> None:
    _, table, _ = audited
    rows = _rows(table)
    assert list(rows) == [
        "my-greedy.valid",
        "my-greedy.stable",
        "my-greedy.95pct",
        "my-greedy.scaling",
        "mod-broken.valid",
        "mod-broken.95pct",
        "mod-broken.scaling",
        "mod-flaky.valid",
        "mod-flaky.95pct",
        "mod-flaky.scaling",
    ]  # a plain function declares no stability: no stable claim; no claim of the seed's
    assert rows["my-greedy.valid"][0] == "holds" and rows["my-greedy.valid"][2] == "-"
    assert rows["my-greedy.stable"][0] == "fails"  # capped moves: a robot wants a shorter slot
    assert rows["my-greedy.95pct"][0] == "fails"
    assert rows["mod-broken.valid"] == ["fails", rows["mod-broken.valid"][1], "1/1/1"]
    assert rows["mod-flaky.valid"][0] == "fails"
    assert rows["mod-flaky.valid"][2].startswith("3/")
    assert rows["my-greedy.scaling"][0] in {"holds", "inconclusive"}  # a measurement


def test_the_counterexamples_replay(audited) -> None:
    folder, _, _ = audited
    found = folder / "out" / "counterexamples"

    def checked(claim: str, *flags: str) -> dict:
        files = [str(found / f"{claim}.{kind}.json") for kind in ("mission", "assignment")]
        done = cfopt_process("check", *files, *flags, "--json", cwd=folder)
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout)

    for claim in ("my-greedy.stable", "my-greedy.95pct", "mod-broken.valid", "mod-flaky.valid"):
        assert checked(claim)["valid"] is True
    # the greedy's assignments, reproduced by `cfopt run` with the recorded seed
    for claim in ("my-greedy.stable", "my-greedy.95pct"):
        mission = str(found / f"{claim}.mission.json")
        run = cfopt_process(
            "run", "mod:CAPPED", mission, "--seed", "0", "-o", "re.json", "--force", cwd=folder
        )
        assert run.returncode == 0, run.stderr
        expected = (found / f"{claim}.assignment.json").read_text()
        assert (folder / "re.json").read_text() == expected
    stable = checked("my-greedy.stable", "--capped")
    assert stable["nash_stable"] is False and stable["nash_violations"]
    percent = checked("my-greedy.95pct")["percent_utility"]
    assert percent < 95  # of the total, which is the optimum of an achievable mission
    # the broken and the raising one: `cfopt run` says what is wrong, one error line
    for name, claim, said in (
        ("mod:broken", "mod-broken.valid", "returned an assignment that does not fit"),
        ("mod:flaky", "mod-flaky.valid", "raised ValueError: three robots are too many"),
    ):
        run = cfopt_process(
            "run", name, str(found / f"{claim}.mission.json"), "--seed", "0", cwd=folder
        )
        assert run.returncode == 2 and said in run.stderr and "Traceback" not in run.stderr


def by_id_of(data: dict) -> dict[str, dict]:
    return {v["id"]: v for v in data["claims"]}


def test_the_verdicts_are_stored_and_reused(audited) -> None:
    _, _, again = audited
    data = json.loads(again)
    assert data["reused_claims"] == 10 and data["gap_report"] is None
    assert by_id_of(data)["my-greedy.stable"]["counterexample"]["algorithm"] == "mod:CAPPED"
    broken = by_id_of(data)["mod-broken.valid"]
    assert broken["verdict"] == "fails" and broken["counterexample"]["seed"] == REPLAY_SEED
    assert broken["counterexample"]["algorithm"] == "mod:broken"
    assert "robot 'r0' performs 's0', which it does not have" in broken["counterexample"]["detail"]


def test_bad_algorithms_are_one_error_line(tmp_path: Path) -> None:
    (tmp_path / "mod.py").write_text(textwrap.dedent(MOD), encoding="utf-8")
    bad = cfopt_process(
        "audit", "--claims-only", "--algorithm", "mod:BAD_CHECKER", "-o", "x", cwd=tmp_path
    )
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert bad.stderr.startswith("error: --algorithm: bad-checker: its stability checker:")
    assert "no_such_module_i22" in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
    unknown = cfopt_process(
        "audit", "--claims-only", "--algorithm", "nosuch", "-o", "x", cwd=tmp_path
    )
    assert unknown.returncode == 2
    assert unknown.stderr.startswith("error: --algorithm: unknown algorithm 'nosuch'")
    assert not (tmp_path / "x").exists()


def test_an_edited_algorithm_is_checked_again(tmp_path: Path) -> None:
    source = (
        "import cfopt\n\n\ndef fn(mission, *, seed=None):\n"
        "    return cfopt.Assignment.empty(mission)\n"
    )
    (tmp_path / "quick.py").write_text(source, encoding="utf-8")
    args = ["audit", "--claims-only", "--quick", "--quiet", "--json", "--force", "-o", "out"]
    args += ["--algorithm", "quick:fn"]
    reused = []
    for edit in ("", "", "# edited\n"):
        (tmp_path / "quick.py").write_text(source + edit, encoding="utf-8")
        done = cfopt_process(*args, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        reused.append(json.loads(done.stdout)["reused_claims"])
    assert reused == [0, 3, 0]
