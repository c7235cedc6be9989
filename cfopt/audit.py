"""The main job, ``cfopt audit``: the seed's claims checked and the optimal-gap report.

:func:`run_audit` runs the claims of :mod:`proofs.claims` and a sweep of the audit grid
(:func:`cfopt.experiments.audit_grid`) on one executor, keeps every finished trial and
every claim verdict in ``DIR/trials.sqlite`` (so an interrupted audit resumes and says
how much it reuses), writes each failed claim's counterexample as a mission and an
assignment file, and renders the report with :func:`cfopt.report.write_report`.
"""

from __future__ import annotations

import concurrent.futures as cf
import os
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cfopt._jsonio import make_directory, output_target
from cfopt._progress import Progress
from cfopt.errors import MissionError, plural
from cfopt.report import Report, check_free, load_trials, report_names_for, write_report
from cfopt.store import ResultStore, store_lock

__all__ = [
    "AUDIT_BUDGET",
    "AUDIT_MISSIONS",
    "AUDIT_STORE",
    "COUNTEREXAMPLES",
    "QUICK_BUDGET",
    "QUICK_MISSIONS",
    "AuditResult",
    "check_claim",
    "run_audit",
]

#: Claims budget (missions per claim) of ``cfopt audit`` and of ``cfopt audit --quick``.
AUDIT_BUDGET, QUICK_BUDGET = 25, 5
#: Missions per cell of ``cfopt audit`` and of ``cfopt audit --quick``.
AUDIT_MISSIONS, QUICK_MISSIONS = 4, 2
#: Where the audit keeps its trials and claim verdicts inside its directory.
AUDIT_STORE = "trials.sqlite"
#: The audit's counterexample folder inside its directory.
COUNTEREXAMPLES = "counterexamples"
#: hypothesis's own cache (constants of the code under test) inside the audit directory,
#: rather than in the folder the audit was started from.
HYPOTHESIS_HOME = ".hypothesis"


@dataclass(frozen=True)
class AuditResult:
    """What :func:`run_audit` found and wrote (frozen).

    ``verdicts`` are :class:`proofs.claims.Verdict` in claim order; ``report`` is
    ``None`` for a claims-only audit; ``outcome`` the sweep's
    :class:`~cfopt.experiments.SweepOutcome` (``None`` for claims only);
    ``claim_files`` the counterexample files written; ``failures`` the claims whose
    check raised, as ``(claim id, traceback)``; ``reused_claims`` how many verdicts came
    from the store of an earlier, interrupted run.
    """

    directory: Path
    verdicts: tuple[Any, ...]
    report: Report | None
    outcome: Any
    claim_files: tuple[Path, ...]
    failures: tuple[tuple[str, str], ...] = ()
    reused_claims: int = 0

    @property
    def ok(self) -> bool:
        """No trial and no claim check raised."""
        return not self.failures and (self.outcome is None or not self.outcome.failures)

    def to_dict(self) -> dict[str, Any]:
        """The ``cfopt audit --json`` object: ``claims`` and ``gap_report``."""
        gap = None
        if self.report is not None:
            gap = dict(self.report.gap_report)
            gap["report_directory"] = os.fspath(self.directory)
            gap["files"] = [os.fspath(p) for p in self.report.files]
            gap["store"] = os.fspath(self.directory / AUDIT_STORE)
        return {
            "claims": [v.to_dict() for v in self.verdicts],
            "gap_report": gap,
            "counterexample_files": [os.fspath(p) for p in self.claim_files],
            "reused_claims": self.reused_claims,
        }


def check_claim(
    claim_id: str, budget: int, seed: int = 0, hypothesis_home: str | None = None
) -> dict[str, Any]:
    """One claim's verdict, as the JSON object of ``Verdict.to_dict()``.

    Runs in an executor's worker; the verdict travels back (and into the store) as JSON
    and is rebuilt with ``Verdict.from_dict``.  ``hypothesis_home`` is where hypothesis
    may keep its cache (default: its own default, ``.hypothesis`` in the current folder).
    """
    from proofs import claims

    if hypothesis_home is None:
        return claims.audit_claims(budget=budget, seed=seed, ids=[claim_id])[0].to_dict()
    from hypothesis.configuration import set_hypothesis_home_dir, storage_directory

    previous = storage_directory(intent_to_write=False).path
    set_hypothesis_home_dir(hypothesis_home)
    try:
        return claims.audit_claims(budget=budget, seed=seed, ids=[claim_id])[0].to_dict()
    finally:
        set_hypothesis_home_dir(previous)


def _claim_ids() -> list[str]:
    from proofs import claims

    return list(claims.CLAIMS)


def _check_directory(directory: Path, files: list[str], force: bool) -> None:
    output_target(directory, overwrite=force, directory=True)
    if force:
        return
    check_free(directory, files)
    cx_dir = directory / COUNTEREXAMPLES
    if os.path.isdir(cx_dir) and any(cx_dir.iterdir()):
        raise MissionError(
            f"{os.fspath(cx_dir)}: already holds counterexamples; pass force=True to replace "
            "them, or choose another directory",
            cli=f"{os.fspath(cx_dir)}: already holds counterexamples; pass --force to replace "
            "them, or choose another directory",
        )


class _Claims:
    """The claims part of an audit: stored verdicts reused, the others checked and stored."""

    def __init__(self, store: Path, budget: int, seed: int, home: Path, progress: Progress):
        from cfopt.experiments import code_version
        from proofs.claims import Verdict

        self.store, self.budget, self.seed, self.home = store, budget, seed, home
        self.version = code_version("claims")
        self.ids = _claim_ids()
        self.verdicts: dict[int, Any] = {}
        self.failures: list[tuple[str, str]] = []
        with ResultStore(store) as db:
            stored = db.claims(budget, seed, self.version)
        for number, claim_id in enumerate(self.ids):
            if claim_id in stored:
                try:
                    self.verdicts[number] = Verdict.from_dict(stored[claim_id])
                except (KeyError, TypeError, ValueError):
                    continue  # an unreadable stored verdict is checked again
        self.reused = len(self.verdicts)
        self.todo = [n for n in range(len(self.ids)) if n not in self.verdicts]
        reused = f", {self.reused} reused from {os.fspath(store)}" if self.reused else ""
        self.stage = progress.stage(
            "claims", len(self.todo), "claim", f"{len(self.todo)} to check{reused}"
        )

    def jobs(self) -> list[tuple[Any, tuple[Any, ...], dict[str, Any]]]:
        home = os.fspath(self.home)
        return [(check_claim, (self.ids[n], self.budget, self.seed, home), {}) for n in self.todo]

    def collect(self, position: int, future: cf.Future) -> None:
        from proofs.claims import Verdict

        number = self.todo[position]
        exc = future.exception()
        self.stage.update(1)
        if exc is not None:
            trace = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
            self.failures.append((self.ids[number], trace))
            return
        data = future.result()
        self.verdicts[number] = Verdict.from_dict(data)
        with ResultStore(self.store) as db:
            db.add_claim(self.ids[number], self.budget, self.seed, self.version, data)

    def close(self) -> tuple[Any, ...]:
        failed = f", {len(self.failures)} failed" if self.failures else ""
        self.stage.close(f"{len(self.todo)} checked, {self.reused} reused{failed}")
        return tuple(self.verdicts[i] for i in sorted(self.verdicts))


def run_audit(
    directory: str | os.PathLike[str] = "cfopt-audit",
    *,
    quick: bool = False,
    claims_only: bool = False,
    workers: int | None = None,
    executor: Any = None,
    force: bool = False,
    progress: bool | Progress = True,
    cells: Any = None,
    missions: int | None = None,
    budget: int | None = None,
    seed: int = 0,
) -> AuditResult:
    """The main job: the seed's claims checked and the optimal-gap report, in ``directory``.

    Parameters
    ----------
    directory : path, default "cfopt-audit"
        Created if missing (its parent folder must exist).  Receives ``report.md``,
        ``report.html``, the CSV tables, the box plots, ``claims.csv``,
        ``counterexamples/`` and the store ``trials.sqlite``.  If any of those report
        files or counterexamples exist already, nothing is computed and
        :class:`cfopt.MissionError` is raised, unless ``force``.  The store is reused:
        an interrupted audit resumes with the trials and claim verdicts it had finished.
    quick : bool
        The quick grid (:func:`cfopt.experiments.quick_grid`, 2 missions per cell) and
        claims budget 5, instead of the audit grid (:func:`cfopt.experiments.audit_grid`,
        4 missions per cell) and budget 25.
    claims_only : bool
        Only the claims: verdicts and counterexamples, no sweep and no report.
    workers, executor
        As in :func:`cfopt.experiments.run_sweep`; claims are checked on the same
        executor, alongside the trials.
    progress : bool or Progress
        Bars on a terminal, one line per stage in a log; ``False`` for silence.
    cells, missions, budget, seed
        Override the grid, missions per cell, claims budget and claims seed.

    Returns
    -------
    AuditResult

    Raises
    ------
    cfopt.experiments.SweepInterrupted
        On SIGINT: what is stored is kept, and the next run resumes from it.
    cfopt.store.StoreBusy
        When another audit or sweep is writing to the same directory's store.
    """
    from cfopt.experiments import (
        Sweep,
        SweepInterrupted,
        audit_grid,
        make_executor,
        quick_grid,
        run_sweep,
        stop_executor,
    )

    directory = Path(directory)
    cells = tuple(cells) if cells is not None else (quick_grid() if quick else audit_grid())
    missions = missions or (QUICK_MISSIONS if quick else AUDIT_MISSIONS)
    budget = budget or (QUICK_BUDGET if quick else AUDIT_BUDGET)
    report_files = [] if claims_only else report_names_for(cells, claims=True)
    _check_directory(directory, report_files, force)
    progress = Progress.coerce(progress)
    make_directory(directory)
    store = directory / AUDIT_STORE
    sweep = None if claims_only else Sweep(cells=cells, missions=missions)
    with store_lock(store, "cfopt audit"):
        claims = _Claims(store, budget, seed, directory / HYPOTHESIS_HOME, progress)
        own = executor is None
        pool = make_executor(workers) if own else executor
        outcome = None
        try:
            if sweep is None:
                futures = [pool.submit(fn, *args, **kw) for fn, args, kw in claims.jobs()]
                for position, future in enumerate(futures):
                    future.exception()  # waits
                    claims.collect(position, future)
            else:
                outcome = run_sweep(
                    sweep,
                    store,
                    executor=pool,
                    progress=progress,
                    extra_jobs=claims.jobs(),
                    on_extra=claims.collect,
                    lock=False,
                )
        except SweepInterrupted as exc:
            if own:
                stop_executor(pool)
            exc.extra = plural(len(claims.verdicts) - claims.reused, "claim verdict")
            raise
        except KeyboardInterrupt as exc:  # claims only: no sweep to say what it kept
            if own:
                stop_executor(pool)
            raise SweepInterrupted(
                os.fspath(store),
                0,
                0,
                getattr(exc, "signal_name", "SIGINT"),
                plural(len(claims.verdicts) - claims.reused, "claim verdict"),
            ) from None
        except BaseException:
            if own:
                stop_executor(pool)
            raise
        finally:
            verdicts = claims.close()
        if own:
            pool.shutdown(wait=True)
    from proofs.claims import write_counterexamples

    claim_files = tuple(
        write_counterexamples(verdicts, directory / COUNTEREXAMPLES, overwrite=force)
    )
    report = None
    if outcome is not None:
        progress.line(
            f"report: writing {os.fspath(directory)} ({plural(len(report_files), 'file')})"
        )
        trials, version = load_trials(store, outcome.code_version)
        wanted = {(c.label, c.mission_seed(i)) for c in sweep.cells for i in range(missions)}
        trials = [t for t in trials if (t.cell, t.mission_seed) in wanted]
        report = write_report(
            trials,
            directory,
            version=version,
            claims=verdicts,
            claim_files=claim_files,
            source=os.fspath(store),
            force=force,
            title="cfopt audit: the seed's claims and the optimal-gap report",
        )
    return AuditResult(
        directory, verdicts, report, outcome, claim_files, tuple(claims.failures), claims.reused
    )
