"""A pytest plugin that audits a user's coalition-formation heuristic.

Installed with cfopt (entry point ``pytest11: cfopt``), it provides the fixture
:func:`cfopt_audit`::

    def my_heuristic(mission: cfopt.Mission) -> cfopt.Assignment: ...

    def test_my_heuristic(cfopt_audit):
        cfopt_audit(my_heuristic)                              # valid + Nash stable
        cfopt_audit(my_heuristic, pairwise=True, mode="pareto", capped=True)
        cfopt_audit(my_heuristic, nash=False, min_percent=95)  # valid + 95 % of the optimum

Missions are drawn by hypothesis (:func:`proofs.strategies.missions` unless a strategy is
given); every partition the heuristic returns is checked for validity, Nash stability and,
with ``pairwise=True``, pairwise stability.  A failure is shrunk by hypothesis to a small
mission and reported -- the violation, a ``cfopt check MISSION ASSIGNMENT`` line that
replays it from files written for the purpose, the mission and the assignment as JSON --
without the plugin's own source in the traceback.  With ``min_percent`` the utility of
every partition is also compared with the optimum of the exact ILP
(:func:`cfopt.solve_exact`, milliseconds on such small missions), hypothesis steering
towards larger gaps; when it falls below ``min_percent`` % on any mission the test fails
with the worst mission drawn (not shrunk), its replay line and a ``cfopt solve`` line for
the optimum.  hypothesis is imported only when the fixture is used.

Under the seed's reward an unassigned robot earns 0 and any slot it can serve pays more,
so a heuristic that leaves a capable robot idle (an auction that sells only what tasks can
afford, or an exact optimum that skips unprofitable tasks) fails Nash stability by design.
Audit such a heuristic with ``capped=True`` (moves only into slots that are still short:
an idle robot is then stable when every slot it could serve is full) or ``nash=False``
(validity only).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from cfopt import Assignment, ExactStatus, Mission, MissionError, solve_exact
from cfopt.checks import require_bool, require_int, require_number
from proofs.stability import MODES, nash_violations, pairwise_violations

__all__ = ["AuditFailure", "Auditor", "cfopt_audit"]

_SHOWN = 10


class AuditFailure(AssertionError):
    """A heuristic returned an invalid or unstable partition (the message says which)."""


class Auditor:
    """The callable behind the :func:`cfopt_audit` fixture.

    Parameters
    ----------
    directory : pathlib.Path
        Where the counterexample files are written.
    """

    def __init__(self, directory: Path) -> None:
        self.directory = directory

    def __call__(
        self,
        heuristic: Callable[[Mission], Any],
        *,
        missions: Any = None,
        max_examples: int | None = None,
        capped: bool = False,
        pairwise: bool = False,
        mode: str = "strict",
        seed: int | None = None,
        nash: bool = True,
        min_percent: float | None = None,
    ) -> None:
        """Check ``heuristic(mission)`` on drawn missions; raise :class:`AuditFailure`.

        Parameters
        ----------
        heuristic : callable
            ``heuristic(mission)`` returns a :class:`cfopt.Assignment` (or an object with
            an ``assignment`` attribute, like ``heuristics``' run results).  It must be
            deterministic for a given mission (hypothesis replays examples).
        missions : hypothesis strategy, optional
            Missions to draw; default :func:`proofs.strategies.missions` (up to 10 robots,
            5 tasks, 4 services).
        max_examples : int, optional
            Missions to try (default: the active hypothesis profile's).
        capped : bool, default False
            Check stability with capped moves (the move set of Pair-GRAPE-S's phase 1).
        pairwise : bool, default False
            Also require pairwise stability in ``mode``.
        mode : {"strict", "pareto"}, default "strict"
            The pairwise notion (see :func:`proofs.pairwise_violations`).
        seed : int, optional
            Fix hypothesis' random seed.
        nash : bool, default True
            Require Nash stability.  ``False`` checks validity (and pairwise stability
            when asked) only: for heuristics that leave capable robots idle by design.
        min_percent : float, optional
            Also require at least ``min_percent`` % (0 < ``min_percent`` <= 100) of the
            optimum of the exact ILP on every mission drawn (missions whose optimum is
            not proven are left out; an optimum of 0 is met by any partition).  The
            failure shows the worst mission.  Default: the gap is not measured.
        """
        __tracebackhide__ = True
        if not callable(heuristic):
            raise TypeError(f"heuristic: must be callable, got {type(heuristic).__name__}")
        if mode not in MODES:
            raise ValueError(f"mode: must be one of {', '.join(map(repr, MODES))}, got {mode!r}")
        if max_examples is not None:
            require_int("max_examples", max_examples, minimum=1)
        capped = require_bool("capped", capped)
        pairwise = require_bool("pairwise", pairwise)
        nash = require_bool("nash", nash)
        if seed is not None:
            require_int("seed", seed)
        if min_percent is not None:
            min_percent = require_number("min_percent", min_percent, above=0, maximum=100)
        import hypothesis
        from hypothesis import HealthCheck, Phase, given, settings

        from proofs import strategies

        strategy = strategies.missions() if missions is None else missions
        name = getattr(heuristic, "__qualname__", None) or repr(heuristic)

        worst: list[_Gap] = []

        def audit_one(mission: Mission) -> None:
            __tracebackhide__ = True
            assignment = self._check(
                heuristic, name, mission, capped=capped, pairwise=pairwise, mode=mode, nash=nash
            )
            if min_percent is not None:
                _measure_gap(mission, assignment, worst)

        audit_one.__name__ = audit_one.__qualname__ = f"cfopt_audit_{_slug(name)}"
        config: dict[str, Any] = {
            "deadline": None,
            "suppress_health_check": [HealthCheck.too_slow, HealthCheck.data_too_large],
            # hypothesis's "explain" phase lists cfopt's own source lines: noise here
            "phases": [p for p in Phase if p.name != "explain"],
        }
        if max_examples is not None:
            config["max_examples"] = max_examples
        test = settings(**config)(given(strategy)(audit_one))
        if seed is not None:
            test = hypothesis.seed(seed)(test)
        test()
        if min_percent is not None and worst and worst[0].percent < min_percent:
            gap = worst[0]
            problem = (
                f"earns {gap.utility:g} of the optimum {gap.optimum:g} ({gap.percent:.2f} % "
                f"< {min_percent:g} %) on the worst of the missions drawn"
            )
            self._fail(name, gap.mission, gap.assignment, problem, optimum=True)

    def _check(
        self,
        heuristic: Callable[[Mission], Any],
        name: str,
        mission: Mission,
        *,
        capped: bool,
        pairwise: bool,
        mode: str,
        nash: bool = True,
    ) -> Assignment:
        __tracebackhide__ = True
        result = heuristic(mission)
        assignment = (
            result if isinstance(result, Assignment) else getattr(result, "assignment", None)
        )
        if not isinstance(assignment, Assignment):
            self._fail(
                name, mission, None, f"returned {type(result).__name__}, not a cfopt.Assignment"
            )
        try:
            assignment.validate(mission)
        except MissionError as exc:
            self._fail(name, mission, None, f"returned an invalid assignment: {exc}")
        where = " (capped moves)" if capped else ""
        found = nash_violations(mission, assignment, capped=capped) if nash else []
        if found:
            self._fail(name, mission, assignment, f"is not Nash stable{where}", found)
        if pairwise:
            found = pairwise_violations(mission, assignment, mode=mode, capped=capped)
            if found:
                self._fail(
                    name, mission, assignment, f"is not pairwise stable ({mode}){where}", found
                )
        return assignment

    def _fail(
        self,
        name: str,
        mission: Mission,
        assignment: Assignment | None,
        problem: str,
        violations: list[Any] = (),  # type: ignore[assignment]
        *,
        optimum: bool = False,
    ) -> None:
        __tracebackhide__ = True
        self.directory.mkdir(parents=True, exist_ok=True)
        mission_path = self.directory / "mission.json"
        mission_path.write_text(mission.to_json(), encoding="utf-8")
        lines = [f"cfopt_audit: {name}: the partition {problem}"]
        lines += [f"  {v.describe(mission)}" for v in violations[:_SHOWN]]
        if len(violations) > _SHOWN:
            lines.append(f"  ... and {len(violations) - _SHOWN} more")
        if assignment is not None:
            assignment_path = self.directory / "assignment.json"
            assignment_path.write_text(assignment.to_json(mission), encoding="utf-8")
            lines.append(f"replay: cfopt check {mission_path} {assignment_path}")
            if optimum:
                lines.append(f"optimum: cfopt solve {mission_path}")
        else:
            lines.append(f"mission written to {mission_path}")
        lines += ["mission:", mission.to_json().rstrip()]
        if assignment is not None:
            lines += ["assignment:", assignment.to_json(mission).rstrip()]
        raise AuditFailure("\n".join(lines))


@dataclass(frozen=True)
class _Gap:
    """A partition's utility against the optimum on one mission."""

    mission: Mission
    assignment: Assignment
    utility: float
    optimum: float
    percent: float


def _measure_gap(mission: Mission, assignment: Assignment, worst: list[_Gap]) -> None:
    """Steer hypothesis towards larger gaps; keep the worst mission in ``worst``."""
    from hypothesis import target

    best = solve_exact(mission)
    if best.status is not ExactStatus.OPTIMAL:
        return
    utility = assignment.utility(mission)
    percent = 100.0 if best.utility <= 0 else min(100.0, 100.0 * utility / best.utility)
    target(100.0 - percent, label="percent below the optimum")
    if not worst or percent < worst[0].percent:
        worst[:] = [_Gap(mission, assignment, utility, best.utility, percent)]


def _slug(text: str) -> str:
    return re.sub(r"\W+", "_", text).strip("_") or "heuristic"


@pytest.fixture
def cfopt_audit(tmp_path_factory: pytest.TempPathFactory) -> Auditor:
    """Audit a heuristic: ``cfopt_audit(my_heuristic, pairwise=True, max_examples=50)``.

    The counterexample files of a failure go to a fresh temporary directory named in the
    failure message.  See :class:`Auditor` for the options.
    """
    return Auditor(tmp_path_factory.mktemp("cfopt_audit"))
