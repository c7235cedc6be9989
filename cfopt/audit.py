"""The main job, ``cfopt audit``: the seed's claims checked and the optimal-gap report.

:func:`run_audit` runs the claims of :mod:`proofs.claims` (all registered ones, or those
given by id or ``MODULE:ATTR``) and a sweep of the audit grid
(:func:`cfopt.experiments.audit_grid`) on one executor, keeps every finished trial and
every claim verdict in ``DIR/trials.sqlite`` (so an interrupted audit resumes and says
how much it reuses), writes each failed claim's counterexample as a mission and an
assignment file, and renders the report with :func:`cfopt.report.write_report`.
"""

from __future__ import annotations

import concurrent.futures as cf
import hashlib
import os
import sys
import traceback
from collections.abc import Sequence
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

    ``verdicts`` are :class:`proofs.claimkit.Verdict` in claim order; ``report`` is
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
    claim_id: str,
    budget: int,
    seed: int = 0,
    hypothesis_home: str | None = None,
    *,
    reference: str | None = None,
    directory: str | None = None,
    algorithm: str | None = None,
) -> dict[str, Any]:
    """One claim's verdict, as the JSON object of ``Verdict.to_dict()``.

    Runs in an executor's worker (forked or fresh); the verdict travels back (and into the
    store) as JSON and is rebuilt with ``Verdict.from_dict``.  The claim is looked up in
    :data:`proofs.claims.CLAIMS` (which loads the entry points in this process), or, given
    ``reference`` (``MODULE:ATTR``), resolved here with ``directory`` first on
    ``sys.path``, or, given ``algorithm`` (a name or ``MODULE:ATTR``), among that
    algorithm's generic claims (:func:`proofs.claims.algorithm_claims`, resolved with
    ``directory`` first).  ``hypothesis_home`` is where hypothesis may keep its cache
    (default: its own default, ``.hypothesis`` in the current folder).
    """
    where = (reference, directory, algorithm)
    if hypothesis_home is None:
        return _verdict(claim_id, budget, seed, *where)
    from hypothesis.configuration import set_hypothesis_home_dir, storage_directory

    current = storage_directory(intent_to_write=False)
    previous = getattr(current, "path", current)  # a Path before hypothesis 6.1xx
    set_hypothesis_home_dir(hypothesis_home)
    try:
        return _verdict(claim_id, budget, seed, *where)
    finally:
        set_hypothesis_home_dir(previous)


def _verdict(
    claim_id: str,
    budget: int,
    seed: int,
    reference: str | None,
    directory: str | None,
    algorithm: str | None = None,
) -> dict[str, Any]:
    from proofs import claims

    if algorithm is not None:
        reference = f"--algorithm {algorithm}"
        found = {c.id: c for c in claims.algorithm_claims(algorithm, directory=directory)}
    elif reference is None:
        return claims.audit_claims(budget=budget, seed=seed, ids=[claim_id])[0].to_dict()
    else:
        found = {c.id: c for c in claims.resolve_claims(reference, directory=directory)}
    if claim_id not in found:
        raise MissionError(f"{reference}: no longer gives claim {claim_id!r}")
    return found[claim_id].check(budget, seed).to_dict()


@dataclass(frozen=True)
class _ClaimJob:
    """One claim to check: its id, where a worker finds it, and its store version."""

    claim_id: str
    reference: str | None  # MODULE:ATTR, or None: a registered claim
    directory: str | None  # where MODULE is imported from
    version: str
    algorithm: str | None = None  # a generic claim of this algorithm (name or MODULE:ATTR)

    def kwargs(self) -> dict[str, Any]:
        if self.algorithm is not None:
            return {"algorithm": self.algorithm, "directory": self.directory}
        if self.reference is None:
            return {}
        return {"reference": self.reference, "directory": self.directory}


def _source_version(base: str, module: str | None) -> str:
    """``base``, plus a digest of ``module``'s source file for a claim not shipped with
    cfopt (an edited claim of yours is checked again rather than reused from the store)."""
    if module is None:
        return base
    path = getattr(sys.modules.get(module), "__file__", None)
    try:
        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()[:12] if path else ""
    except OSError:
        digest = ""
    return f"{base}+{module}:{digest}"


def _claim_jobs(chosen: Sequence[str] | None) -> list[_ClaimJob]:
    """The claims to check: every registered one, or those ``chosen`` names (ids or
    ``MODULE:ATTR``, in the order given)."""
    from cfopt.experiments import code_version
    from proofs import claims

    base = code_version("claims")
    if chosen is None:
        return [_registered_job(base, claim_id) for claim_id in claims.CLAIMS]
    jobs: list[_ClaimJob] = []
    folder = os.getcwd()
    for reference in chosen:
        try:
            found = claims.resolve_claims(reference, directory=folder)
        except MissionError as exc:
            raise MissionError(f"claims: {exc}", cli=f"--claims: {exc.cli_message}") from None
        for claim in found:
            if any(job.claim_id == claim.id for job in jobs):
                raise MissionError(
                    f"claims: claim {claim.id!r} is given twice",
                    cli=f"--claims: claim {claim.id!r} is given twice",
                )
            if ":" not in reference:
                jobs.append(_registered_job(base, claim.id))
                continue
            version = _source_version(base, reference.partition(":")[0])
            jobs.append(_ClaimJob(claim.id, reference, folder, version))
    if not jobs:
        raise MissionError("claims: no claims to check", cli="--claims: no claims to check")
    return jobs


def _generic_jobs(algorithms: Sequence[str]) -> list[_ClaimJob]:
    """The generic claims of each algorithm (a name or ``MODULE:ATTR``, resolved from the
    current directory; a worker rebuilds them from the name).  Their version adds the
    spec's name and version and, for an algorithm not shipped with cfopt, a digest of its
    module's source (an edited algorithm is checked again)."""
    from cfopt.experiments import code_version
    from heuristics import get_algorithm
    from proofs import claims

    base, folder = code_version("claims"), os.getcwd()
    jobs = []
    for name in dict.fromkeys(algorithms):
        try:
            spec = get_algorithm(name, directory=folder)
            _import_checker(spec)
            found = claims.algorithm_claims(name, directory=folder)
        except MissionError as exc:
            raise MissionError(
                f"algorithms: {exc}", cli=f"--algorithm: {exc.cli_message}"
            ) from None
        module = _algorithm_module(name, spec)
        version = f"{_source_version(base, module)}+{spec.name}@{spec.version}"
        where = folder if ":" in name else None
        jobs += [_ClaimJob(c.id, None, where, version, name) for c in found]
    return jobs


def _import_checker(spec: Any) -> None:
    """Import a ``stability="own"`` spec's checker now: one that does not import is an
    error of the command, not a counterexample of its claim."""
    try:
        spec.stability_checker()
    except MissionError as exc:
        raise MissionError(f"{spec.name}: its stability checker: {exc}") from None


def _algorithm_module(name: str, spec: Any) -> str | None:
    """The module an algorithm not shipped with cfopt comes from (``None`` for cfopt's)."""
    if spec.shipped:
        return None
    return name.partition(":")[0] if ":" in name else getattr(spec.run, "__module__", None)


def _audit_jobs(
    claims: Sequence[str] | None, algorithms: Sequence[str] | None, claims_only: bool
) -> list[_ClaimJob]:
    """The claims an audit checks: the registered ones (or ``claims``), then the generic
    claims of ``algorithms``; with ``claims_only`` and algorithms but no ``claims``, the
    generic ones alone."""
    generic = _generic_jobs(algorithms or ())
    chosen = [] if (claims is None and claims_only and generic) else _claim_jobs(claims)
    known = {job.claim_id for job in chosen}
    for job in generic:
        if job.claim_id in known:
            raise MissionError(
                f"algorithms: claim {job.claim_id!r} is given twice",
                cli=f"--algorithm: claim {job.claim_id!r} is given twice",
            )
        known.add(job.claim_id)
    return [*chosen, *generic]


def _registered_job(base: str, claim_id: str) -> _ClaimJob:
    from proofs import claims

    return _ClaimJob(claim_id, None, None, _source_version(base, claims.claim_origin(claim_id)))


def _audited(extra: Sequence[str] | None) -> tuple[str, ...] | None:
    """The audit's algorithms: every registered one, then ``extra`` (``None``: the default)."""
    if not extra:
        return None
    from heuristics.registry import algorithm_names

    return tuple(dict.fromkeys((*algorithm_names(), *extra)))


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

    def __init__(
        self,
        store: Path,
        budget: int,
        seed: int,
        home: Path,
        progress: Progress,
        jobs: Sequence[_ClaimJob],
    ):
        from proofs.claimkit import Verdict

        self.store, self.budget, self.seed, self.home = store, budget, seed, home
        self.planned = tuple(jobs)
        self.ids = [job.claim_id for job in self.planned]
        self.verdicts: dict[int, Any] = {}
        self.failures: list[tuple[str, str]] = []
        with ResultStore(store) as db:
            stored = {v: db.claims(budget, seed, v) for v in {j.version for j in self.planned}}
        for number, job in enumerate(self.planned):
            if job.claim_id in stored[job.version]:
                try:
                    self.verdicts[number] = Verdict.from_dict(stored[job.version][job.claim_id])
                except (KeyError, TypeError, ValueError):
                    continue  # an unreadable stored verdict is checked again
        self.reused = len(self.verdicts)
        self.todo = [n for n in range(len(self.ids)) if n not in self.verdicts]
        reused = f", {self.reused} reused from {os.fspath(store)}" if self.reused else ""
        self.stage = progress.stage(
            "claims",
            len(self.todo),
            "claim",
            f"{len(self.todo)} to check{reused}",
            reused=self.reused,
        )

    def jobs(self) -> list[tuple[Any, tuple[Any, ...], dict[str, Any]]]:
        home = os.fspath(self.home)
        return [
            (check_claim, (self.ids[n], self.budget, self.seed, home), self.planned[n].kwargs())
            for n in self.todo
        ]

    def collect(self, position: int, future: cf.Future) -> None:
        from proofs.claimkit import Verdict

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
            version = self.planned[number].version
            db.add_claim(self.ids[number], self.budget, self.seed, version, data)

    @property
    def checked(self) -> int:
        """Verdicts this run computed (and stored), beside the :attr:`reused` ones."""
        return len(self.verdicts) - self.reused

    def kept(self) -> str:
        """What an interrupted audit computed of the claims, counted as :meth:`close`
        counts them (``"5 claim verdicts"``: the reused ones are not this run's)."""
        return plural(self.checked, "claim verdict")

    def close(self) -> tuple[Any, ...]:
        """End the stage, saying what was checked, reused, failed and left; the verdicts."""
        failed = f", {len(self.failures)} failed" if self.failures else ""
        left = len(self.todo) - self.checked - len(self.failures)
        unchecked = f", {left} not checked (stopped)" if left else ""
        self.stage.close(f"{self.checked} checked, {self.reused} reused{failed}{unchecked}")
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
    claims: Sequence[str] | None = None,
    algorithms: Sequence[str] | None = None,
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
    claims : sequence of str, optional
        Check exactly these claims, in this order: ids of :data:`proofs.claims.CLAIMS`
        (``"L1"``) or ``MODULE:ATTR`` (see :func:`proofs.claims.resolve_claims`; MODULE
        imported with the current directory first on ``sys.path``, in every worker too).
        Default: every registered claim (cfopt's, then the entry points').
    algorithms : sequence of str, optional
        Algorithms put on the grid beside the registered ones (every registered algorithm
        runs anyway): names or ``MODULE:ATTR`` references (:func:`heuristics.get_algorithm`);
        each gets the optimal gap, runtime and (where it reports it) communication, and
        its generic claims (:func:`proofs.claims.algorithm_claims`: valid, stable as its
        spec declares, 95 % of the optimum, scaling) are checked after the others, in the
        same verdicts, store and counterexamples.  With ``claims_only`` and no ``claims``
        only those generic claims are checked.

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
    jobs = _audit_jobs(None if claims is None else list(claims), algorithms, claims_only)
    _check_directory(directory, report_files, force)
    progress = Progress.coerce(progress)
    make_directory(directory)
    store = directory / AUDIT_STORE
    sweep = None if claims_only else Sweep(cells, missions, _audited(algorithms))
    with store_lock(store, "cfopt audit"):
        checks = _Claims(store, budget, seed, directory / HYPOTHESIS_HOME, progress, jobs)
        own = executor is None
        pool = make_executor(workers) if own else executor
        outcome = None
        try:
            if sweep is None:
                futures = [pool.submit(fn, *args, **kw) for fn, args, kw in checks.jobs()]
                for position, future in enumerate(futures):
                    future.exception()  # waits
                    checks.collect(position, future)
            else:
                outcome = run_sweep(
                    sweep,
                    store,
                    executor=pool,
                    progress=progress,
                    extra_jobs=checks.jobs(),
                    on_extra=checks.collect,
                    lock=False,
                )
        except SweepInterrupted as exc:
            if own:
                stop_executor(pool)
            exc.extra = checks.kept()
            raise
        except KeyboardInterrupt as exc:  # claims only: no sweep to say what it kept
            if own:
                stop_executor(pool)
            raise SweepInterrupted(
                os.fspath(store),
                0,
                0,
                getattr(exc, "signal_name", "SIGINT"),
                checks.kept(),
            ) from None
        except BaseException:
            if own:
                stop_executor(pool)
            raise
        finally:
            verdicts = checks.close()
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
        directory, verdicts, report, outcome, claim_files, tuple(checks.failures), checks.reused
    )
