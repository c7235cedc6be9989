"""The audit's notes against its own counterexamples.

A claims-only audit at the quick budget runs every claim that can produce a
counterexample (the property and scaling claims); each counterexample it writes is
replayed -- the algorithm rerun through the public API, ``cfopt check`` run on the files
-- and the verdict's note must agree with what the replay finds: every label the note
gives the counterexample holds for it, every tallied label that holds for it is among its
labels and counted at least once.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

import cfopt
import heuristics
from cfopt.audit import COUNTEREXAMPLES, QUICK_BUDGET, run_audit
from cfopt.cli import main
from proofs.claimkit import PropertyCheck, ScalingCheck
from proofs.claims import CLAIMS

#: The labels a note may give a counterexample, and how the replay decides each one:
#: ``cfopt check`` (capped and not) and the exact optimum.
Facts = dict[str, Any]
LABELS: dict[str, Callable[[Facts], bool]] = {
    "capped not Nash stable": lambda f: not f["capped"]["nash_stable"],
    "uncapped not Nash stable": lambda f: not f["uncapped"]["nash_stable"],
    "not pareto pairwise stable": lambda f: not f["capped"]["pareto_stable"],
    "optimal": lambda f: f["percent_of_optimum"] >= 100 - 1e-9,
    "below 100 %": lambda f: f["percent_of_optimum"] < 100 - 1e-9,
    "below 99 %": lambda f: f["percent_of_optimum"] < 99,
    "below 95 %": lambda f: f["percent_of_optimum"] < 95,
}
_EXAMPLE = re.compile(
    r"counterexample \((\d+) robots, (\d+) tasks, (\d+) services\) from ([^:;]+)(?:: ([^;]+))?"
)
_TALLY = re.compile(r"(?:^|; |, )([a-z0-9 %()]+?): (\d+) of (\d+)")


@pytest.fixture(scope="module")
def audit(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    ids = [i for i, c in CLAIMS.items() if isinstance(c.method, PropertyCheck | ScalingCheck)]
    directory = tmp_path_factory.mktemp("audit")
    result = run_audit(
        directory, claims_only=True, budget=QUICK_BUDGET, workers=1, progress=False, claims=ids
    )
    return directory, json.loads(json.dumps(result.to_dict()))


def _check(capsys: pytest.CaptureFixture[str], files: list[str], capped: bool) -> Facts:
    capsys.readouterr()
    assert main(["check", *files, "--json", *(["--capped"] if capped else [])]) == 0
    return json.loads(capsys.readouterr().out)


def _replay(claim: dict[str, Any], folder: Path) -> cfopt.Assignment:
    """The counterexample's algorithm rerun through the public API (as ``cfopt run``)."""
    ce = claim["counterexample"]
    mission = cfopt.Mission.from_json(folder / f"{claim['id']}.mission.json")
    if ce["network"] is not None:
        network = str(folder / f"{claim['id']}.network.json")
        run = heuristics.simulate(mission, ce["algorithm"], network, seed=ce["seed"])
    else:
        order = "random" if "(random order" in ce["detail"] else "index"
        run = heuristics.get_algorithm(ce["algorithm"])(mission, seed=0, order=order)
    return run.assignment


def test_the_audit_found_counterexamples_to_replay(audit) -> None:
    _, data = audit
    failed = {c["id"] for c in data["claims"] if c["counterexample"] is not None}
    assert {"L1", "T1", "P1", "C2", "X6", "D2g"} <= failed
    for claim in data["claims"]:
        assert (claim["verdict"] == "fails") == (claim["counterexample"] is not None)


def test_every_counterexample_agrees_with_its_note(audit, capsys) -> None:
    directory, data = audit
    replayed = [c for c in data["claims"] if c["counterexample"] is not None]
    for claim in replayed:
        _agrees(claim, directory / COUNTEREXAMPLES, capsys)


def _agrees(claim: dict[str, Any], folder: Path, capsys: pytest.CaptureFixture[str]) -> None:
    claim_id, note = claim["id"], claim["note"]
    files = [str(folder / f"{claim_id}.{kind}.json") for kind in ("mission", "assignment")]
    mission = cfopt.Mission.from_json(files[0])
    assignment = cfopt.Assignment.from_json(mission, files[1])
    if isinstance(CLAIMS[claim_id].method, ScalingCheck):  # a fit: its failing part named
        assert ": fails" in note and "exceeds" in claim["counterexample"]["detail"], claim_id
        return
    assert _replay(claim, folder) == assignment, claim_id
    optimum = cfopt.solve_exact(mission).utility
    earned = assignment.utility(mission)
    facts = {
        "capped": _check(capsys, files, capped=True),
        "uncapped": _check(capsys, files, capped=False),
        "percent_of_optimum": 100.0 if optimum <= 0 else 100 * earned / optimum,
    }
    found = _EXAMPLE.search(note)
    assert found, f"{claim_id}: the note does not describe its counterexample: {note}"
    assert tuple(map(int, found.groups()[:3])) == (
        mission.n_robots, mission.n_tasks, mission.n_services,
    ), claim_id  # fmt: skip
    own = set(found[5].split(", ")) if found[5] else set()
    tallies = {label: int(k) for label, k, _ in _TALLY.findall(note)}
    for label, decide in LABELS.items():
        if label in own:
            assert decide(facts), f"{claim_id}: the note says {label!r}, the replay does not"
        if label in tallies and decide(facts):
            assert label in own, f"{claim_id}: {label!r} holds but is not the example's"
            assert tallies[label] >= 1, f"{claim_id}: {label!r} holds, the note counts 0"
    if found[4].strip() == "a grid mission":
        assert "failing grid missions: 0" not in note, claim_id
