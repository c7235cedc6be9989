"""``cfopt audit`` plumbing on a tiny injected grid and injected claims.

The claims module is replaced by two fake claims (one holds, one fails with a
counterexample) so that these tests exercise the audit's wiring -- sweep, claims on the
same executor, counterexample files, report, JSON, exit codes, refusal to overwrite --
in seconds; the real claims are tested in ``tests/proofs``.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import cfopt.experiments
import heuristics
import proofs.claims
from cfopt import Assignment, GridCell, generate_mission
from cfopt.cli import main
from cfopt.experiments import ResultStore, code_version
from proofs.claimkit import Counterexample, Scope, Verdict, VerdictKind

TINY = (GridCell(20, 10, 5, 2), GridCell(20, 50, 5, 1, load=1.25))


def _fake_audit_claims(*, budget: int = 25, seed: int = 0, ids=None) -> list[Verdict]:
    out = []
    for claim_id in ids:
        if claim_id == "F1":
            m = generate_mission(4, 50, 2, 1, seed=seed)
            out.append(
                Verdict(
                    claim_id, "a claim that fails", VerdictKind.FAILS, budget,
                    Counterexample(m, Assignment.empty(m), "grape-s", "nothing assigned"),
                    0.01, "fake",
                )
            )  # fmt: skip
        elif claim_id == "BUG":
            raise RuntimeError("the check itself crashed")
        else:
            out.append(
                Verdict(
                    claim_id, "a claim that holds", VerdictKind.HOLDS, budget, None, 0.01,
                    scope=Scope.PAPER_SIZES, network="seed",
                )
            )  # fmt: skip
    return out


@pytest.fixture
def fake_audit(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cfopt.experiments, "quick_grid", lambda: TINY)
    monkeypatch.setattr(proofs.claims, "CLAIMS", {"H1": None, "F1": None})
    monkeypatch.setattr(proofs.claims, "audit_claims", _fake_audit_claims)


def _audit(tmp_path: Path, *extra: str) -> int:
    return main(["audit", "--quick", "--workers", "1", "-o", str(tmp_path / "audit"), *extra])


@pytest.mark.usefixtures("fake_audit")
def test_quick_audit_writes_the_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    assert _audit(tmp_path) == 0
    out = capsys.readouterr().out
    assert "% of optimum" in out and "Cells: median (min, max)" in out
    assert max(len(line) for line in out.splitlines() if str(tmp_path) not in line) <= 100
    assert "over-subscribed (load 1.25)" in out and "achievable (load 1)" in out
    assert "H1" in out and "holds" in out and "fails" in out and "4/2/2" in out
    folder = tmp_path / "audit"
    for name in ("report.md", "report.html", "claims.csv", "trials.sqlite", "summary.csv"):
        assert (folder / name).is_file(), name
    cx = folder / "counterexamples"
    assert sorted(p.name for p in cx.iterdir()) == ["F1.assignment.json", "F1.mission.json"]
    markdown = (folder / "report.md").read_text(encoding="utf-8")
    assert "## Claims: verdicts" in markdown and "| F1 | fails |" in markdown
    assert "Claims of the seed paper" not in markdown  # F1, H1 are the test's own claims
    # the scope beside the verdict, in the terminal table, the report and claims.csv
    assert "paper's sizes, sim: seed" in out
    assert "| H1 | holds | at the paper's sizes, on cfopt's simulator under network `seed` |" in (
        markdown
    )
    assert (folder / "claims.csv").read_text().splitlines()[0].startswith("id,verdict,scope,")
    # a claim ran under the seed profile: the report derives the profile
    assert "## The seed-calibrated network profile" in markdown
    assert "262 / 80,000 = 3.3 ms" in markdown and "n^3 / 3,000" in markdown
    # the replay command of the report works on the written files
    assert main(["check", str(cx / "F1.mission.json"), str(cx / "F1.assignment.json")]) == 0


@pytest.mark.usefixtures("fake_audit")
def test_audit_refuses_to_overwrite(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    assert _audit(tmp_path) == 0
    folder = tmp_path / "audit"
    before = {
        p: p.read_bytes() for p in folder.rglob("*") if p.is_file() and "sqlite" not in p.name
    }
    capsys.readouterr()
    assert _audit(tmp_path) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "--force" in err and err.count("\n") == 1
    assert {p: p.read_bytes() for p in before} == before
    assert _audit(tmp_path, "--force") == 0


@pytest.mark.usefixtures("fake_audit")
def test_audit_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _audit(tmp_path, "--json") == 0
    data = json.loads(capsys.readouterr().out)  # one JSON object, nothing else on stdout
    assert [c["id"] for c in data["claims"]] == ["H1", "F1"]
    for claim in data["claims"]:
        assert {"id", "statement", "verdict", "instances_checked", "counterexample"} <= set(claim)
    failed = data["claims"][1]
    assert failed["verdict"] == "fails"
    assert set(failed["counterexample"]) >= {"mission", "assignment"}
    gap = data["gap_report"]
    # 2 missions per cell, the exact solve and every registered heuristic
    assert gap["trials"] == len(TINY) * 2 * (1 + len(heuristics.ALGORITHMS))
    assert {row["algorithm"] for row in gap["summary"]} == {"exact", *heuristics.ALGORITHMS}
    assert Path(gap["report_directory"]) == tmp_path / "audit"


@pytest.mark.usefixtures("fake_audit")
def test_claims_only(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _audit(tmp_path, "--claims-only") == 0
    out = capsys.readouterr().out
    assert "verdict" in out and "F1" in out and "% of optimum" not in out
    folder = tmp_path / "audit"
    assert not (folder / "report.md").exists()
    assert (folder / "counterexamples" / "F1.mission.json").is_file()
    with ResultStore(folder / "trials.sqlite", create=False) as db:  # verdicts kept to resume
        assert db.count() == 0 and len(db.claims(5, 0, code_version("claims"))) == 2
    assert _audit(tmp_path, "--claims-only") == 2  # the counterexamples are not replaced
    assert "already holds counterexamples" in capsys.readouterr().err


def test_a_crashing_claim_check_exits_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(proofs.claims, "CLAIMS", {"H1": None, "BUG": None})
    monkeypatch.setattr(proofs.claims, "audit_claims", _fake_audit_claims)
    assert _audit(tmp_path, "--claims-only") == 1
    captured = capsys.readouterr()
    assert "the check itself crashed" in captured.err and "Traceback" in captured.err
    assert "H1" in captured.out


def test_audit_usage_errors(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["audit", "--workers", "0"])
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.startswith("error: ")
