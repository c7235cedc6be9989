"""The claims registry: every claim the audit checks, and how claims of yours join them.

:data:`CLAIMS` maps claim ids to :class:`proofs.claimkit.Claim`, in the audit's order:

1. the seed paper's claims (:mod:`proofs.claims_seed`: L1 ... I1) and its distributed
   claims (:mod:`proofs.claims_distributed`: D1 ... X9);
2. cfopt's claims about its own algorithms (:mod:`proofs.claims_cfopt`: C1 ... O3) and
   about recovery after a robot fails (:mod:`proofs.claims_dynamic`: F1 ... F3);
3. the claims of installed packages: every entry point of group ``cfopt.claims``
   (:data:`ENTRY_POINT_GROUP`), loaded on first use of :data:`CLAIMS`; each entry loads a
   Claim, a list of Claims, or a callable returning either;
4. claims registered from Python with :func:`register_claim` (``proofs.register_claim``),
   in the order registered.

A claim may also be named ``MODULE:ATTR`` without registering it (:func:`resolve_claims`,
``cfopt audit --claims MODULE:ATTR``): ``MODULE`` is imported with the current directory
first on ``sys.path`` (as ``python -m`` does), ``ATTR`` is a Claim, a list of Claims or a
callable returning them.  A second claim with an id already registered, a module that
cannot be imported and an object that is not a Claim are :class:`cfopt.MissionError`.

Every counterexample replays from the command line: ``cfopt run ALGORITHM mission.json``
reproduces the assignment and ``cfopt check mission.json assignment.json`` shows the
violation (see :func:`write_counterexamples`).  How claims are checked, and how to state
one: :mod:`proofs.claimkit`.

Examples
--------
>>> from proofs.claims import CLAIMS
>>> list(CLAIMS)[:6]
['L1', 'T1', 'G1', 'G2', 'G3', 'G4']
>>> v = CLAIMS["X2"].check(2, seed=0)
>>> v.verdict.value, v.counterexample is None
('holds', True)
"""

from __future__ import annotations

import importlib
import importlib.metadata
import os
import sys
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from cfopt import MissionError
from proofs.claimkit import Claim, Scope, Verdict
from proofs.claims_cfopt import cfopt_claims
from proofs.claims_distributed import distributed_claims
from proofs.claims_dynamic import dynamic_claims
from proofs.claims_generic import algorithm_claims as generic_claims
from proofs.claims_seed import seed_claims

__all__ = [
    "CLAIMS",
    "ENTRY_POINT_GROUP",
    "ClaimRegistry",
    "algorithm_claims",
    "audit_claims",
    "claim_origin",
    "format_verdict_table",
    "register_claim",
    "resolve_claims",
    "short_scope",
    "write_counterexamples",
]

#: The entry-point group an installed package registers claims in.
ENTRY_POINT_GROUP = "cfopt.claims"


def _as_claims(value: Any, where: str) -> list[Claim]:
    """``value`` (a Claim, a list or tuple of Claims, or a callable returning either) as a
    list; :class:`cfopt.MissionError` naming ``where`` otherwise."""
    if callable(value) and not isinstance(value, Claim):
        try:
            value = value()
        except Exception as exc:
            raise MissionError(f"{where}: raised {type(exc).__name__}: {exc}") from None
    if isinstance(value, Claim):
        return [value]
    if isinstance(value, (list, tuple)) and all(isinstance(c, Claim) for c in value):
        return list(value)
    raise MissionError(
        f"{where}: must be a proofs.claimkit.Claim, a list of Claims or a callable returning "
        f"them, got {type(value).__name__}"
    )


class ClaimRegistry(Mapping[str, Claim]):
    """Claims by id: cfopt's own, then the entry points' (loaded on first use), then those
    registered with :meth:`register`.

    ``entry_point_group`` is the entry-point group read (``None``: none).  A fresh
    registry is useful in tests; the audit uses :data:`CLAIMS`.
    """

    def __init__(self, entry_point_group: str | None = ENTRY_POINT_GROUP) -> None:
        self.entry_point_group = entry_point_group
        self._built: dict[str, Claim] | None = None
        self._origins: dict[str, str] = {}

    def _claims(self) -> dict[str, Claim]:
        if self._built is None:
            self._built = {c.id: c for c in (*seed_claims(), *distributed_claims())}
            self._built.update((c.id, c) for c in cfopt_claims())
            self._built.update((c.id, c) for c in dynamic_claims())
            try:
                self._load_entry_points()
            except BaseException:
                self._built, self._origins = None, {}  # the next use reports it again
                raise
        return self._built

    def _load_entry_points(self) -> None:
        if self.entry_point_group is None:
            return
        found = importlib.metadata.entry_points(group=self.entry_point_group)
        for ep in sorted(found, key=lambda e: (e.name, e.value)):
            where = f"entry point {ep.name} = {ep.value} (group {self.entry_point_group})"
            try:
                value = ep.load()
            except Exception as exc:
                raise MissionError(
                    f"{where}: cannot be loaded: {type(exc).__name__}: {exc}"
                ) from None
            for claim in _as_claims(value, where):
                self._add(claim, where)
                self._origins[claim.id] = ep.module

    def _add(self, claim: Claim, where: str) -> None:
        claims = self._claims()
        known = claims.get(claim.id)
        if known is not None and known is not claim:
            raise MissionError(
                f"{where}: claim id {claim.id!r} is already registered (by cfopt, an "
                "installed package or register_claim); choose another id"
            )
        claims[claim.id] = claim

    def register(self, claim: Claim) -> Claim:
        """Add ``claim`` (registering the same object again changes nothing); returns it."""
        if not isinstance(claim, Claim):
            raise MissionError(
                f"claim: must be a proofs.claimkit.Claim, got {type(claim).__name__}"
            )
        self._add(claim, "register_claim")
        return claim

    def origin(self, claim_id: str) -> str | None:
        """The module an entry point loaded claim ``claim_id`` from (``None`` otherwise)."""
        self._claims()
        return self._origins.get(claim_id)

    def __getitem__(self, key: str) -> Claim:
        return self._claims()[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._claims())

    def __len__(self) -> int:
        return len(self._claims())

    def __repr__(self) -> str:
        return f"CLAIMS({', '.join(self)})"


#: The claims, in the audit's order: the seed's stability, optimality and complexity
#: claims (L1 ... X2), further statements of the seed (X3 ... I1), its distributed claims
#: (D1 ... X9), cfopt's claims about its own algorithms (C1 ...), then the claims of
#: installed packages (entry points ``cfopt.claims``) and of :func:`register_claim`.
CLAIMS: Mapping[str, Claim] = ClaimRegistry()


def register_claim(claim: Claim) -> Claim:
    """Register ``claim`` in :data:`CLAIMS`, so the audit checks it (``proofs.register_claim``).

    Returns the claim.  An id already registered (by another claim object) or an object
    that is not a :class:`proofs.claimkit.Claim` is a :class:`cfopt.MissionError`.  The
    audit's worker processes see it when they are forked from this one; for fresh
    processes register it by an entry point or name it as ``MODULE:ATTR``.
    """
    registry = CLAIMS
    if not isinstance(registry, ClaimRegistry):
        raise MissionError("register_claim: proofs.claims.CLAIMS is not a ClaimRegistry")
    return registry.register(claim)


def claim_origin(claim_id: str) -> str | None:
    """The module an installed package's entry point loaded claim ``claim_id`` from;
    ``None`` for cfopt's own claims and those registered from Python."""
    registry = CLAIMS
    return registry.origin(claim_id) if isinstance(registry, ClaimRegistry) else None


def _import(module: str, directory: str) -> Any:
    """``import module`` with ``directory`` first on ``sys.path`` (left there, as
    ``python -m`` leaves the current directory, for the module's own later imports)."""
    if not sys.path or sys.path[0] != directory:
        sys.path.insert(0, directory)
    importlib.invalidate_caches()  # a module written since the last import is found
    return importlib.import_module(module)


def resolve_claims(
    reference: str, *, directory: str | os.PathLike[str] | None = None
) -> list[Claim]:
    """The claims ``reference`` names: a registered id (``"L1"``) or ``"MODULE:ATTR"``.

    Parameters
    ----------
    reference : str
        A key of :data:`CLAIMS`, or ``MODULE:ATTR``: ``MODULE`` is imported with
        ``directory`` first on ``sys.path``; ``ATTR`` (dotted for a nested attribute) is a
        Claim, a list of Claims or a callable returning them.  Such claims are not
        registered; their ids must not be ids of :data:`CLAIMS` (other than the same
        objects).
    directory : path, optional
        Where ``MODULE`` is looked for first (default: the current directory).

    Returns
    -------
    list of Claim

    Raises
    ------
    cfopt.MissionError
        Unknown id, a module that cannot be imported, a missing attribute, an object that
        is not a Claim, or an id clash; the message starts with ``reference``.
    """
    if not isinstance(reference, str) or not reference.strip():
        raise MissionError(f"must be a claim id or MODULE:ATTR, got {reference!r}")
    if ":" not in reference:
        if reference not in CLAIMS:
            raise MissionError(f"unknown claim {reference!r} (known: {', '.join(CLAIMS)})")
        return [CLAIMS[reference]]
    module, _, attribute = reference.partition(":")
    if not module or not attribute:
        raise MissionError(f"{reference}: must be MODULE:ATTR, both non-empty")
    folder = os.path.abspath(os.fspath(directory) if directory is not None else os.getcwd())
    try:
        value: Any = _import(module, folder)
    except Exception as exc:
        raise MissionError(
            f"{reference}: cannot import {module}: {type(exc).__name__}: {exc}"
        ) from None
    for part in attribute.split("."):
        if not hasattr(value, part):
            raise MissionError(f"{reference}: {module} has no attribute {attribute!r}")
        value = getattr(value, part)
    claims = _as_claims(value, reference)
    seen: set[str] = set()
    for claim in claims:
        known = CLAIMS.get(claim.id)
        if claim.id in seen or (known is not None and known is not claim):
            raise MissionError(
                f"{reference}: claim id {claim.id!r} is already registered or given twice; "
                "choose another id"
            )
        seen.add(claim.id)
    return claims


def algorithm_claims(
    algorithm: str, *, directory: str | os.PathLike[str] | None = None
) -> list[Claim]:
    """The generic claims of the algorithm ``algorithm`` names, for ``cfopt audit
    --algorithm NAME`` (:func:`proofs.claims_generic.algorithm_claims`: valid, stable as
    its spec declares, 95 % of the optimum, scaling).

    ``algorithm`` is a registered name or ``MODULE:ATTR``, resolved by
    :func:`heuristics.get_algorithm` with ``directory`` (default: the current one) first
    on ``sys.path``; an audit's workers call this with the same arguments to rebuild the
    claims.  An unknown name or a reference that does not resolve is
    :class:`cfopt.MissionError`.
    """
    from heuristics import get_algorithm

    return generic_claims(get_algorithm(algorithm, directory=directory), reference=algorithm)


# --------------------------------------------------------------------- the audit
def audit_claims(
    *, budget: int = 25, seed: int = 0, ids: Iterable[str] | None = None
) -> list[Verdict]:
    """Check claims (all of :data:`CLAIMS`, or ``ids`` in the given order).

    Parameters
    ----------
    budget : int, default 25
        ``n_missions`` of each :meth:`Claim.check`.
    seed : int, default 0
    ids : iterable of str, optional
        Claim ids; an unknown id raises :class:`cfopt.MissionError` naming the known ones.

    Returns
    -------
    list of Verdict

    Notes
    -----
    Imports hypothesis (a runtime dependency) on first use.  With the default budget the
    whole audit takes about a minute (L1 and T1's small-scope searches: ~15 s each).
    """
    chosen = list(CLAIMS) if ids is None else list(ids)
    unknown = [i for i in chosen if i not in CLAIMS]
    if unknown:
        raise MissionError(f"unknown claim {unknown[0]!r} (known: {', '.join(CLAIMS)})")
    return [CLAIMS[i].check(budget, seed) for i in chosen]


def write_counterexamples(
    verdicts: Iterable[Verdict], directory: str | Path, *, overwrite: bool = False
) -> list[Path]:
    """Write ``<id>.mission.json`` and ``<id>.assignment.json`` for every failed claim, and
    ``<id>.network.json`` when the counterexample is a distributed run.

    Replay with ``cfopt check DIR/<id>.mission.json DIR/<id>.assignment.json`` and
    ``cfopt run ALGORITHM DIR/<id>.mission.json`` (the algorithm is the counterexample's;
    a distributed one with ``--network DIR/<id>.network.json --seed SEED``).  Existing files
    are not overwritten unless ``overwrite=True`` (:class:`cfopt.MissionError` names the
    first one; nothing is written then); each file is written atomically.  ``directory``
    is created if missing (its parent must exist).  Returns the paths written.
    """
    from cfopt._jsonio import check_folder, make_directory, stat_path, write_text

    directory = Path(directory)
    plan: list[tuple[Path, str]] = []
    for v in verdicts:
        ce = v.counterexample
        if ce is None:
            continue
        plan.append((directory / f"{v.claim_id}.mission.json", ce.mission.to_json()))
        plan.append(
            (directory / f"{v.claim_id}.assignment.json", ce.assignment.to_json(ce.mission))
        )
        if ce.network is not None:
            from heuristics.network import NetworkSpec

            spec = NetworkSpec.parse(ce.network)
            plan.append((directory / f"{v.claim_id}.network.json", spec.to_json()))
    if not overwrite:
        for path, _ in plan:
            if stat_path(path, follow_symlinks=False) is not None:
                raise MissionError(
                    f"{path}: exists (use overwrite=True to replace it)",
                    cli=f"{path}: exists (pass --force to replace it)",
                )
    if plan:
        check_folder(directory)
        make_directory(directory)
    for path, text in plan:
        write_text(text, path, overwrite=overwrite)
    return [path for path, _ in plan]


def short_scope(verdict: Verdict) -> str:
    """A verdict's scope in a few words, for terminal tables (:attr:`Verdict.scope_text`
    says it in full): ``paper's sizes``, ``any size`` or ``simulator``, then the network
    (``sim: default`` for cfopt's default network, a profile by its name).

    >>> from proofs.claimkit import Scope, VerdictKind
    >>> short_scope(Verdict("D4", "s", VerdictKind.FAILS, 1, None, 0.0,
    ...                     scope=Scope.PAPER_SIZES, network="seed"))
    "paper's sizes, sim: seed"
    """
    from cfopt.generate import SEED_NETWORK

    words = {
        Scope.PAPER_SIZES: "paper's sizes",
        Scope.GENERALISATION: "any size",
        Scope.SIMULATOR: "simulator",
    }
    base = "-" if verdict.scope is None else words[verdict.scope]
    network = verdict.network
    if network is None:
        return base
    name = "default" if network == SEED_NETWORK else network.split()[0]
    if verdict.scope is Scope.SIMULATOR:
        return f"simulator: {name}"
    return f"{base}, sim: {name}"


def format_verdict_table(
    verdicts: Sequence[Verdict], *, width: int | None = None, columns: int = 120
) -> str:
    """A plain-text table: id, verdict, scope (:func:`short_scope`), missions, size and
    the statement, cut to ``width`` characters (default: what keeps the rows within
    ``columns``, at least 24).

    The counterexample size is ``robots/tasks/services``, ``-`` when there is none.
    """
    header = ("id", "verdict", "scope", "missions", "counterexample", "statement")
    rows = []
    for v in verdicts:
        size = "-" if v.counterexample is None else "/".join(map(str, v.counterexample.size))
        rows.append((v.claim_id, v.verdict.value, short_scope(v), str(v.instances_checked), size))
    widths = [max(len(row[i]) for row in [header, *rows]) for i in range(len(header) - 1)]
    if width is None:
        width = max(24, columns - sum(w + 2 for w in widths))
    body = []
    for v, row in zip(verdicts, rows, strict=True):
        text = " ".join(v.statement.split())
        body.append((*row, text if len(text) <= width else text[: width - 3] + "..."))
    widths = [max(len(row[i]) for row in [header, *body]) for i in range(len(header))]
    return "\n".join(
        "  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip()
        for row in [header, *body]
    )
