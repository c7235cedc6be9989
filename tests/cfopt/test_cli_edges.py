"""The rough edges a newcomer meets on the command line: ``cfopt run --gap`` and the
stability an algorithm declares, flags before ALGORITHM, ``--help``'s list, byte counts,
``/dev/null`` as every output, and what an interrupted audit says it kept."""

from __future__ import annotations

import concurrent.futures as cf
import json
import os
import re
import tempfile
from pathlib import Path
from typing import Any

import pytest

import cfopt
import cfopt.exact
import cfopt.experiments
import proofs
from cfopt.cli import main
from cfopt.errors import byte_count
from heuristics import algorithm_names, get_algorithm

#: Over-subscribed (load 1.5): grape-s-select is stable under its own rule here, not
#: Nash stable under the seed's reward.
OVER = {"robots": 30, "percent_tasks": 20, "service_types": 5, "services_per_robot": 2}


@pytest.fixture
def over(tmp_path: Path) -> tuple[cfopt.Mission, str]:
    m = cfopt.generate_mission(**OVER, load=1.5, seed=0)
    path = tmp_path / "over.json"
    m.to_json(path)
    return m, str(path)


def _json(capsys: pytest.CaptureFixture[str], argv: list[str]) -> dict[str, Any]:
    assert main(argv) == 0
    out, _ = capsys.readouterr()
    return json.loads(out)


# ------------------------------------------------------------------ run --gap
def test_run_gap_gives_the_percent_of_the_proven_optimum(over, capsys) -> None:
    m, path = over
    data = _json(capsys, ["run", "sda", path, "--gap", "--seed", "1", "--json"])
    best = cfopt.solve_exact(m)
    gap = data["gap"]
    assert gap["status"] == "optimal" and gap["optimum"] == best.utility == gap["incumbent"]
    assert gap["bound"] == pytest.approx(best.utility)
    assert gap["percent_of_optimum"] == pytest.approx(100 * data["utility"] / best.utility)
    assert 0 < gap["percent_of_optimum"] <= 100 + 1e-9
    assert "gap" not in _json(capsys, ["run", "sda", path, "--seed", "1", "--json"])
    assert main(["run", "sda", path, "--gap", "--seed", "1", "-o", os.devnull]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert re.fullmatch(
        rf"optimum: {best.utility:g} \(proven optimal by HiGHS, [0-9.]+ s\): the run earns "
        rf"{gap['percent_of_optimum']:.2f}% of the optimum",
        lines[3],
    ), lines
    assert "% of the total" in lines[0]


def test_run_gap_without_a_proof_says_the_bound(over, capsys, monkeypatch) -> None:
    """An exact solve cut by its time limit is never called optimal: the proven bound
    and the share of it are what the run is told."""
    m, path = over
    real = cfopt.exact.solve_exact

    def cut(mission: cfopt.Mission, **kwargs: Any) -> cfopt.ExactResult:
        done = real(mission)
        return cfopt.ExactResult(
            cfopt.ExactStatus.TIME_LIMIT,
            done.utility - 1,
            done.utility + 3,
            4 / (done.utility + 3),
            done.total_utility,
            done.assignment,
            60.0,
            done.formulation,
        )

    monkeypatch.setattr(cfopt.exact, "solve_exact", cut)
    data = _json(capsys, ["run", "grape-s", path, "--gap", "--json"])
    gap = data["gap"]
    best = real(m).utility
    assert gap["status"] == "time_limit" and gap["optimum"] is None
    assert gap["percent_of_optimum"] is None
    assert (gap["incumbent"], gap["bound"]) == (best - 1, best + 3)
    assert gap["percent_of_bound"] == pytest.approx(100 * data["utility"] / (best + 3))
    assert main(["run", "grape-s", path, "--gap", "-o", os.devnull]) == 0
    line = capsys.readouterr().out.splitlines()[3]
    assert line.startswith("optimum: not proven in 60 s (status time_limit, 60.000 s): best ")
    assert f"proven bound {best + 3:g}; the run earns at least " in line
    assert "optimal by" not in line


# ------------------------------------------------------- the declared stability
@pytest.mark.parametrize("name", algorithm_names())
def test_run_reports_the_stability_its_spec_declares(over, capsys, name: str) -> None:
    m, path = over
    spec = get_algorithm(name)
    data = _json(capsys, ["run", name, path, "--seed", "2", "--json"])
    a = cfopt.Assignment.from_dict(m, {"assignment": data["assignment"]})
    declared = data["declared_stability"]
    assert declared["stability"] == spec.stability.value
    expected = {
        "seed": lambda: proofs.nash_violations(m, a),
        "capped": lambda: proofs.nash_violations(m, a, capped=True),
        "own": lambda: spec.stability_checker()(m, a),
    }
    if spec.stability.value == "none":
        assert declared["stable"] is None and declared["violations"] is None
    else:
        violations = len(expected[spec.stability.value]())
        assert declared["violations"] == violations
        assert declared["stable"] is (violations == 0)
    assert data["nash_stable"] == proofs.is_nash_stable(m, a)  # the seed's, beside it


def test_the_two_stability_lines_say_which_is_which(over, capsys) -> None:
    _, path = over
    assert main(["run", "grape-s-select", path, "--seed", "0", "-o", os.devnull]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].startswith("stability under the seed's reward: Nash no, ")
    assert lines[2] == (
        "stability under its own rule (stable by proofs.select_stability:select_violations): yes"
    )
    assert main(["run", "sda", path, "-o", os.devnull]) == 0
    assert capsys.readouterr().out.splitlines()[2] == (
        "stability under its own rule: none declared (sda promises no stability)"
    )


# ------------------------------------------------------------ flags and help
def test_options_before_the_algorithm_work(over, capsys) -> None:
    _, path = over
    after = _json(capsys, ["run", "sda", path, "--eps", "0.5", "--seed", "3", "--json"])
    before = _json(capsys, ["run", "--eps", "0.5", "--seed", "3", "sda", path, "--json"])
    default = _json(capsys, ["run", "sda", path, "--seed", "3", "--json"])
    assert before["assignment"] == after["assignment"]
    assert before["rounds"] == after["rounds"] != default["rounds"]  # --eps took effect
    no_exchange = ["run", "--no-exchange", "grape-s-select", path, "--seed", "3", "--json"]
    assert (
        _json(capsys, no_exchange)["assignment"]
        == _json(capsys, ["run", "grape-s-select", path, "--seed", "3", "--no-exchange", "--json"])[
            "assignment"
        ]
    )


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        pytest.param(
            ["run", "--bogus", "3", "sda"],
            "error: --bogus 3: give ALGORITHM before its options ('cfopt run ALGORITHM "
            "MISSION --bogus ...'; '3' was read as the algorithm)",
            id="unknown-flag-first",
        ),
        pytest.param(
            ["run", "--eps", "1", "grape-s"],
            "error: --eps: not an option of grape-s (another algorithm's; 'cfopt run "
            "grape-s --help' lists its options)",
            id="another-algorithms-flag",
        ),
        pytest.param(
            ["run", "grape-s", "--no-exchange"],
            "error: --no-exchange: not an option of grape-s (another algorithm's; 'cfopt "
            "run grape-s --help' lists its options)",
            id="another-algorithms-bool-flag",
        ),
    ],
)
def test_misplaced_or_foreign_options_are_one_clear_line(
    over, capsys, argv: list[str], message: str
) -> None:
    _, path = over
    assert main([*argv, path]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == message + "\n"


def test_run_help_lists_every_registered_algorithm(capsys) -> None:
    with pytest.raises(SystemExit) as ended:
        main(["run", "--help"])
    assert ended.value.code == 0
    text = capsys.readouterr().out
    listed = re.findall(r"^  (\S+) +\S", text.split("algorithms (cfopt run", 1)[1], re.M)
    assert listed == [*algorithm_names(), "MODULE:ATTR"]
    assert len(listed) - 1 == len(algorithm_names()) >= 6


# ----------------------------------------------------------------- byte counts
def test_byte_counts_are_for_people_in_text_and_exact_in_json(over, capsys) -> None:
    _, path = over
    data = _json(capsys, ["run", "grape-s", path, "--seed", "1", "--json"])
    assert isinstance(data["bytes"], int) and data["bytes"] >= 1000
    assert main(["run", "grape-s", path, "--seed", "1", "-o", os.devnull]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert f"{byte_count(data['bytes'])} of communication" in first
    assert f"({data['bytes']:,} bytes)" in first
    assert byte_count(503502480000) == "503.5 GB (503,502,480,000 bytes)"
    assert byte_count(999_999) == "1.0 MB (999,999 bytes)"
    net = ["run", "sda", path, "--network", "complete", "--seed", "1", "-o", os.devnull]
    assert main(net) == 0
    lines = capsys.readouterr().out.splitlines()
    assert any(re.search(r"\d+(\.\d)? [kMG]B \([\d,]+ bytes\) transmitted", x) for x in lines)
    assert not any(" MB," in x for x in lines)


# ---------------------------------------------------------- /dev/null everywhere
def _discarded() -> set[str]:
    return {p for p in os.listdir(tempfile.gettempdir()) if p.startswith("cfopt-discarded-")}


def _no_paths_of(value: Any, folder: str) -> bool:
    return folder not in json.dumps(value)


USER_CLAIMS = """
from proofs import claimkit as ck


def _holds(claim, mission):
    return ck.Evaluation(None, 0.0, ("ok",))


def _claim(claim_id):
    return ck.property_claim(
        claim_id, "nothing fails", ck.ACHIEVABLE_FAMILY, ("nobody",), _holds,
        scope=ck.Scope.GENERALISATION, strategy=ck.structural_missions(achievable=True),
        summary=ck.tally_summary("ok"),
    )


FIRST = [_claim("NULL1")]
ALL = [_claim("NULL1"), _claim("NULL2"), _claim("NULL3")]
"""


@pytest.fixture
def user_claims(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    (tmp_path / "null_claims.py").write_text(USER_CLAIMS, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    return tmp_path


def test_dev_null_is_accepted_by_every_command(user_claims: Path, capsys) -> None:
    folder = user_claims
    before = sorted(os.listdir(folder)), _discarded()
    generate = ["generate", "--robots", "10", "--percent-tasks", "10", "--service-types", "5"]
    assert main([*generate, "--services-per-robot", "2", "--seed", "1", "-o", os.devnull]) == 0
    cfopt.generate_mission(10, 10, 5, 2, seed=1).to_json(folder / "m.json")
    before = sorted(os.listdir(folder)), before[1]
    assert main(["solve", "m.json", "-o", os.devnull]) == 0
    assert main(["run", "sda", "m.json", "-o", os.devnull]) == 0
    sweep = ["sweep", "--robots", "10", "--percent-tasks", "10", "--compositions", "5:1"]
    sweep += ["--missions", "1", "--algorithms", "sda", "--workers", "1", "--quiet"]
    capsys.readouterr()
    swept = _json(capsys, [*sweep, "--store", os.devnull, "--json"])
    assert swept["store"] == os.devnull and swept["completed"] == 2
    assert main([*sweep, "--store", "kept.sqlite"]) == 0
    before = sorted(os.listdir(folder)), before[1]
    capsys.readouterr()
    report = _json(capsys, ["report", "kept.sqlite", "-o", os.devnull, "--json"])
    assert report["report_directory"] == os.devnull and report["files"] == []
    assert report["trials"] == 2
    assert main(["report", "kept.sqlite", "-o", os.devnull]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == "report: discarded (/dev/null)"
    audit = ["audit", "--claims-only", "--claims", "null_claims:ALL", "--quick", "--quiet"]
    audited = _json(capsys, [*audit, "--workers", "1", "-o", os.devnull, "--json"])
    assert [c["verdict"] for c in audited["claims"]] == ["holds"] * 3
    assert _no_paths_of(audited, tempfile.gettempdir() + os.sep + "cfopt-discarded-")
    assert main([*audit, "--workers", "1", "-o", os.devnull]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == (
        "report and counterexamples: discarded (/dev/null)"
    )
    assert (sorted(os.listdir(folder)), _discarded()) == before  # nothing kept anywhere


# ------------------------------------------------- an interrupted audit's counts
class _StopsAfter(cf.Executor):
    """Runs the first ``done`` jobs at once; waiting for the next one is a Ctrl-C."""

    def __init__(self, done: int) -> None:
        self.done = done

    def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> cf.Future:
        future: cf.Future = _Interrupting() if self.done <= 0 else cf.Future()
        if self.done > 0:
            future.set_result(fn(*args, **kwargs))
        self.done -= 1
        return future


class _Interrupting(cf.Future):
    def exception(self, timeout: float | None = None) -> BaseException | None:
        raise KeyboardInterrupt


def test_an_interrupted_audit_counts_its_claims_one_way(
    user_claims: Path, capsys, monkeypatch
) -> None:
    """The stage's last line and the interrupted line count the same verdicts: those
    reused from the store, those this run checked, those it did not reach."""
    audit = ["audit", "--claims-only", "--quick", "-o", "out", "--workers", "1"]
    assert main([*audit, "--claims", "null_claims:FIRST", "--quiet"]) == 0
    capsys.readouterr()
    monkeypatch.setattr(cfopt.experiments, "make_executor", lambda workers: _StopsAfter(1))
    assert main([*audit, "--claims", "null_claims:ALL", "--force"]) == 130
    out, err = capsys.readouterr()
    lines = err.splitlines()
    store = os.path.join("out", "trials.sqlite")
    assert lines[0] == f"claims: 2 to check, 1 reused from {store}"
    assert re.fullmatch(r"claims: 1 checked, 1 reused, 1 not checked \(stopped\) \(.+\)", lines[1])
    assert lines[2] == (
        f"error: interrupted (SIGINT): 0 trials and 1 claim verdict computed by this run are "
        f"kept in {store}; run the same command again to resume"
    )
    assert out == "" and len(lines) == 3
    monkeypatch.undo()
    monkeypatch.chdir(user_claims)
    monkeypatch.syspath_prepend(str(user_claims))
    data = _json(capsys, [*audit, "--claims", "null_claims:ALL", "--force", "--json", "--quiet"])
    assert data["reused_claims"] == 2  # what the interrupted run said it kept
