"""The seed paper's claims (L1, T1, G1-G4, P1, R1, X1-X8, H4, S1, I1), executable.

Every claim quotes a statement of the seed paper (Diehl and Adams, "GRAPE-S: Near
Real-Time Coalition Formation for Multiple Service Collectives") with its section, names
the missions it ranges over (its family and :class:`proofs.claimkit.Scope`) and checks it
with :mod:`proofs.claimkit`'s machinery: property claims on seeded grid missions, a
seed-family sweep, a hypothesis search with shrinking and (for the stability lemma and
theorem) an exhaustive small-scope search; complexity claims by fitted exponents on size
ladders; the hypothesis H4, an aggregate over the seed's 10:5 grid, by the paired test
the paper's comparison comes down to (:class:`HypothesisMethod`).  The checks use
``proofs``' own stability checkers and call the algorithms through the public registry
(``heuristics.get_algorithm``).  The seed's distributed claims are in
:mod:`proofs.claims_distributed`; :data:`proofs.claims.CLAIMS` gathers them all.

Examples
--------
>>> [c.id for c in seed_claims()][:6]
['L1', 'T1', 'G1', 'G2', 'G3', 'G4']
>>> v = {c.id: c for c in seed_claims()}["X2"].check(2, seed=0)
>>> v.verdict.value, v.counterexample is None, v.scope.value
('holds', True, "a generalisation to the paper's family at any size")
"""

from __future__ import annotations

from cfopt import Mission, paper_grid
from proofs.claimkit import (
    ACHIEVABLE_FAMILY,
    ALL_COMPOSITIONS,
    ANY_FAMILY,
    EASY_COMPOSITIONS,
    HARD_COMPOSITIONS,
    SMALL_SCOPE_FAMILY,
    UNICAST,
    CheckResult,
    Claim,
    Counterexample,
    Evaluation,
    Evaluator,
    ScalingPart,
    Scope,
    bound_runner,
    budget_note,
    capped_nash_claim,
    exponent_verdict,
    generated_missions,
    grid_cells,
    paired_comparison,
    property_claim,
    scaling_claim,
    small_scope,
    structural_missions,
    tally_summary,
)
from proofs.claimkit import format_number as fmt
from proofs.scaling import fit_rungs
from proofs.stability import is_pairwise_stable, nash_violations, pairwise_violations

__all__ = ["LADDER_FAMILY", "SDA_LADDER_SIZES", "HypothesisMethod", "seed_claims"]

#: SDA's ladder: its counted work is ~n^3, so 400 robots would take seconds.
SDA_LADDER_SIZES = (25, 50, 100, 200)
#: The family of the complexity claims X1-X8.
LADDER_FAMILY = (
    "size ladder n = 25..400 (SDA: ..200), 10 % tasks (m proportional to n), 10:5, "
    "load 1; u_max = 50, d_G = 1 (fully connected)"
)


# ---------------------------------------------------------- the properties
def _theorem1(claim: Claim, m: Mission) -> Evaluation:
    run = claim.run("pair-grape-s", m, seed=0, order="index")
    a = run.assignment
    pareto = not is_pairwise_stable(m, a, mode="pareto", capped=True)
    tallies = ("not pareto pairwise stable",) if pareto else ()
    if not pareto or is_pairwise_stable(m, a, mode="strict", capped=True):
        return Evaluation(None, 0.0, tallies)  # strict violations are pareto violations
    strict = pairwise_violations(m, a, mode="strict", capped=True)
    v = strict[0]
    detail = (
        f"Pair-GRAPE-S's partition is not pairwise stable (strict, capped moves): "
        f"{v.kind} deviation {v.describe(m)}"
    )
    return Evaluation(Counterexample(m, a, "pair-grape-s", detail), float(len(strict)), tallies)


def _g1(claim: Claim, m: Mission) -> Evaluation:
    run = claim.run("grape-s", m, seed=0, order="index")
    found = nash_violations(m, run.assignment)
    if not found:
        return Evaluation(None)
    detail = f"GRAPE-S's partition is not Nash stable: {found[0].describe(m)}"
    return Evaluation(Counterexample(m, run.assignment, "grape-s", detail), float(len(found)))


def _optimal(name: str, label: str) -> Evaluator:
    def evaluate(claim: Claim, m: Mission) -> Evaluation:
        run = claim.run(name, m, seed=0, order="index")
        pct = run.assignment.percent_utility(m)
        if pct >= 100.0:
            return Evaluation(None)
        done = run.assignment.completed_tasks(m).size
        detail = (
            f"{label} earns {fmt(run.assignment.utility(m))} of {fmt(m.total_utility)} "
            f"({pct:.2f} %, {done} of {m.n_tasks} tasks) on an achievable mission"
        )
        return Evaluation(Counterexample(m, run.assignment, name, detail), 100.0 - pct)

    return evaluate


def _g3(claim: Claim, m: Mission) -> Evaluation:
    run = claim.run("grape-s", m, seed=0, order="index")
    if run.iterations == m.n_robots:
        return Evaluation(None)
    detail = f"GRAPE-S needs {run.iterations} iterations, n = {m.n_robots}"
    return Evaluation(
        Counterexample(m, run.assignment, "grape-s", detail),
        float(abs(run.iterations - m.n_robots)),
        ("more than n" if run.iterations > m.n_robots else "fewer than n",),
    )


def _g4(claim: Claim, m: Mission) -> Evaluation:
    run = claim.run("grape-s", m, seed=0, order="index")
    pct = run.assignment.percent_utility(m)
    tallies = ("below 100 %",) if pct < 100 else ()
    if pct >= 95.0:
        return Evaluation(None, 100.0 - pct, tallies)
    detail = f"GRAPE-S earns {pct:.2f} % < 95 % on an achievable 10:5 mission"
    return Evaluation(Counterexample(m, run.assignment, "grape-s", detail), 100.0 - pct, tallies)


def _x2(claim: Claim, m: Mission) -> Evaluation:
    run = claim.run("pair-grape-s", m, seed=0, order="index")
    tallies = ("pairwise step ran",) if run.pairwise_step_ran else ()
    if run.exchanges <= m.n_robots:
        return Evaluation(None, run.exchanges / max(m.n_robots, 1), tallies)
    detail = f"the pairwise step made {run.exchanges} exchanges > n = {m.n_robots}"
    return Evaluation(Counterexample(m, run.assignment, "pair-grape-s", detail), 2.0, tallies)


class HypothesisMethod:
    """H4 as the paper tested it: an aggregate hypothesis over the 10:5 trials of its grid.

    ``n_missions`` seeded missions of each 10:5 cell of the seed's grid (100, 500 and 1000
    robots; 8 cells, so 200 pairs at the audit's budget of 25, the paper's n = 200), each
    run by Pair-GRAPE-S and GRAPE-S (index order, seed 0); their percent utilities are
    compared pair by pair with the Wilcoxon signed-rank test, one-sided both ways.  Holds
    when Pair-GRAPE-S's are significantly higher, fails when significantly lower,
    inconclusive otherwise (at this budget); never a counterexample: a hypothesis about
    the grid is not refuted by one mission.
    """

    cells = tuple(c for c in paper_grid() if (c.service_types, c.services_per_robot) == (10, 5))

    def check(self, claim: Claim, n_missions: int, seed: int) -> CheckResult:
        pair: list[float] = []
        grape: list[float] = []
        for cell in self.cells:
            for i in range(n_missions):
                m = cell.mission(i, base_seed=seed)
                for name, values in (("pair-grape-s", pair), ("grape-s", grape)):
                    run = claim.run(name, m, seed=0, order="index")
                    values.append(run.assignment.percent_utility(m))
        test = paired_comparison(pair, grape)
        kind = test.verdict()
        sizes = ", ".join(str(n) for n in sorted({c.robots for c in self.cells}))
        note = (
            f"{test.describe('Pair-GRAPE-S', 'GRAPE-S')}; the seed's 10:5 grid "
            f"({len(self.cells)} cells, n = {sizes}, {n_missions} missions each); the paper: "
            "Friedman chi2_r (n = 200) = 39.00 over the four algorithms with Conover's "
            "post-hoc test, GRAPE-S significantly worse (p < 0.01)"
        )
        return kind, len(pair), None, budget_note(kind, note)


def _s1(claim: Claim, m: Mission) -> Evaluation:
    pair = claim.run("pair-grape-s", m, seed=0, order="index")
    if not pair.pairwise_step_ran:
        return Evaluation(None)
    first = claim.run("grape-s", m, seed=0, order="index", capped=True)
    if first.assignment.percent_utility(m) < 100.0:
        return Evaluation(None, 0.0, ("pairwise step ran",))
    detail = "the pairwise step ran although Pair-GRAPE-S's GRAPE-S phase was already optimal"
    return Evaluation(
        Counterexample(m, pair.assignment, "pair-grape-s", detail), 1.0, ("pairwise step ran",)
    )


def _i1(claim: Claim, m: Mission) -> Evaluation:
    pair = claim.run("pair-grape-s", m, seed=0, order="index")
    grape = claim.run("grape-s", m, seed=0, order="index")
    if pair.assignment == grape.assignment and pair.iterations == grape.iterations:
        return Evaluation(None)
    moved = int((pair.assignment.task != grape.assignment.task).sum()) + int(
        (pair.assignment.service != grape.assignment.service).sum()
    )
    detail = (
        f"Pair-GRAPE-S differs from GRAPE-S: {pair.iterations} vs {grape.iterations} "
        f"iterations, utility {fmt(pair.assignment.utility(m))} vs "
        f"{fmt(grape.assignment.utility(m))}"
    )
    return Evaluation(
        Counterexample(m, pair.assignment, "pair-grape-s", detail),
        float(moved + abs(pair.iterations - grape.iterations)),
    )


def _x1_extra(claim: Claim, seed: int) -> list[str]:
    """GRAPE-S's work in m (n, S fixed) and in S (n, m fixed), each against exponent 1."""
    from proofs.scaling import service_ladder, task_ladder

    runner = bound_runner(claim, "grape-s")
    seeds = [seed, seed + 1]
    out = []
    for variable, rungs in (
        ("m", task_ladder(runner, (2.5, 5, 10, 20, 40), seeds=seeds)),
        ("S", service_ladder(runner, (2, 4, 8, 16), seeds=seeds)),
    ):
        fit = fit_rungs(rungs, "work", variable)
        out.append(
            f"grape-s work ~ {variable}^{fit} vs seed {variable}^1: "
            f"{exponent_verdict(fit, 1).value}"
        )
    return out


# ------------------------------------------------------------------ the claims
def seed_claims() -> list[Claim]:
    """The seed's centralized claims, in the audit's order: stability, optimality and
    complexity (L1 ... X2), then its further statements (X3 ... I1)."""
    return [
        capped_nash_claim(
            "L1",
            'Lemma 1 (§4.1): "Algorithm 2 produces a Nash stable solution, given the reward '
            'function specified by Eq. 4.2 and u_js = |S_s|."',
            "pair-grape-s",
            subject="Pair-GRAPE-S's partition",
            note="; Nash stability with capped moves (Pair-GRAPE-S's move set), uncapped "
            "reported in the note",
        ),
        property_claim(
            "T1",
            'Theorem 1 (§4.1): "Algorithm 2 produces a pairwise stable solution, given the '
            'reward function specified by Eq. 4.2 and u_js = |S_s|."',
            ANY_FAMILY
            + SMALL_SCOPE_FAMILY
            + "; strict pairwise stability (both deviators strictly better), "
            "capped moves; the pareto notion reported in the note",
            ("pair-grape-s",),
            _theorem1,
            scope=Scope.GENERALISATION,
            cells=grid_cells(ALL_COMPOSITIONS),
            strategy=structural_missions(achievable=None),
            summary=tally_summary("not pareto pairwise stable"),
            exhaustive=small_scope,
            sweep=ALL_COMPOSITIONS,
        ),
        property_claim(
            "G1",
            'GRAPE-S (§4, Algorithm 1): "The algorithm finishes when Nash stability is reached."',
            ANY_FAMILY + "; uncapped moves",
            ("grape-s",),
            _g1,
            scope=Scope.GENERALISATION,
            cells=grid_cells(ALL_COMPOSITIONS),
            strategy=structural_missions(achievable=None),
            sweep=ALL_COMPOSITIONS,
        ),
        property_claim(
            "G2",
            '§5.1.3: "GRAPE-S produced optimal solutions with five services and one service '
            "per robot, five services and five services per robot, and ten services and one "
            'service per robot."',
            "achievable missions of the seed's generator (load 1) with compositions 5:1, 5:5, "
            "10:1: grid cells n = 100, and generated missions of 2..60 robots, 10 or 50 % tasks",
            ("grape-s",),
            _optimal("grape-s", "GRAPE-S"),
            scope=Scope.GENERALISATION,
            cells=grid_cells(EASY_COMPOSITIONS),
            strategy=generated_missions(EASY_COMPOSITIONS),
            sweep=EASY_COMPOSITIONS,
        ),
        property_claim(
            "G3",
            '§5.1.1: "All other collective compositions [than 10:5] required exactly n '
            'iterations, where n is the collective size."',
            "achievable missions of the seed's generator (load 1), 5:1, 5:5, 10:1: grid cells "
            "n = 100, and generated missions of 2..60 robots, 10 or 50 % tasks",
            ("grape-s",),
            _g3,
            scope=Scope.GENERALISATION,
            cells=grid_cells(EASY_COMPOSITIONS),
            strategy=generated_missions(EASY_COMPOSITIONS),
            summary=tally_summary("more than n", "fewer than n"),
            sweep=EASY_COMPOSITIONS,
        ),
        property_claim(
            "G4",
            "Abstract and §5.1.3: GRAPE-S produces near optimal solutions (> 95 % utility) on "
            "10:5 collectives (the seed itself reports a minimum of 89.68 %, n = 100, 10 % "
            "tasks)",
            "achievable 10:5 missions of the seed's generator (load 1) of the seed's sizes: "
            "grid cells n = 100, and generated missions of 100..150 robots, 10 or 50 % tasks",
            ("grape-s",),
            _g4,
            scope=Scope.PAPER_SIZES,
            cells=grid_cells(HARD_COMPOSITIONS),
            strategy=generated_missions(HARD_COMPOSITIONS, min_robots=100, max_robots=150),
            summary=tally_summary("below 100 %"),
        ),
        property_claim(
            "P1",
            '§5.1.3: "Pair-GRAPE-S produced optimal solutions for all problems"; §1: '
            '"producing optimal solutions for all of the coalition formation problems '
            'considered"',
            ACHIEVABLE_FAMILY + " (load 1, the seed's missions)",
            ("pair-grape-s",),
            _optimal("pair-grape-s", "Pair-GRAPE-S"),
            scope=Scope.GENERALISATION,
            cells=grid_cells(ALL_COMPOSITIONS),
            strategy=structural_missions(achievable=True, load=1.0),
            sweep=ALL_COMPOSITIONS,
        ),
        property_claim(
            "R1",
            '§5.1.3: "RACHNA_dt, and Pair-GRAPE-S when applicable had the highest percent '
            'utilities, producing optimal solutions for all trials"; §3.1.1: "produces '
            'empirically optimal solutions"',
            ACHIEVABLE_FAMILY + " (load 1, the seed's missions); RACHNA_dt as "
            "heuristics.rachna_dt runs it by default: simultaneous bidding, the "
            "faithful reading",
            ("rachna-dt",),
            _optimal("rachna-dt", "RACHNA_dt"),
            scope=Scope.GENERALISATION,
            cells=grid_cells(ALL_COMPOSITIONS),
            strategy=structural_missions(achievable=True, load=1.0),
            sweep=ALL_COMPOSITIONS,
        ),
        scaling_claim(
            "X1",
            '§4: GRAPE-S uses "O(n^2 |S| m d_G) computation" (counted work: slot '
            "examinations; exponent 3 in n with m proportional to n, 1 in m, 1 in S)",
            LADDER_FAMILY,
            [ScalingPart("grape-s", "work", 3, "n^2 m, m ~ n")],
            _x1_extra,
        ),
        property_claim(
            "X2",
            '§4.1: "Algorithm 2 requires at most O(n) reassignments" (checked: the pairwise '
            "step makes at most n exchanges)",
            ANY_FAMILY,
            ("pair-grape-s",),
            _x2,
            scope=Scope.GENERALISATION,
            cells=grid_cells(ALL_COMPOSITIONS),
            strategy=structural_missions(achievable=None),
            summary=tally_summary("pairwise step ran"),
            sweep=ALL_COMPOSITIONS,
        ),
        scaling_claim(
            "X3",
            '§4: GRAPE-S uses "O(n^3 d_G) communication" (messages, counted point to point: '
            "medium=unicast, one message per receiver; d_G = 1)",
            LADDER_FAMILY,
            [ScalingPart("grape-s", "messages", 3, "n^3", UNICAST)],
        ),
        scaling_claim(
            "X4",
            "§4.1: \"Pair-GRAPE-S's overall computational and communication complexities are "
            'identical to GRAPE-S" (O(n^2 |S| m d_G) work, O(n^3 d_G) messages counted point '
            "to point: medium=unicast; the work does not depend on the medium)",
            LADDER_FAMILY,
            [
                ScalingPart("pair-grape-s", "work", 3, "n^2 m, m ~ n", UNICAST),
                ScalingPart("pair-grape-s", "messages", 3, "n^3", UNICAST),
            ],
        ),
        scaling_claim(
            "X5",
            "§3.1.2: \"SDA's computational complexity is O(m n^4 u_max / eps_d)\" (the toolkit's "
            "reading of SDA, heuristics.sda; work: bundle cost-matrix entries)",
            LADDER_FAMILY,
            [ScalingPart("sda", "work", 5, "m n^4, m ~ n", sizes=SDA_LADDER_SIZES)],
        ),
        scaling_claim(
            "X6",
            '§3.1.2: SDA\'s "communication complexity is O((m + n) |S| u_max / eps_d)" (the '
            "toolkit's reading and point-to-point message model of SDA, heuristics.sda "
            "with medium=unicast)",
            LADDER_FAMILY,
            [ScalingPart("sda", "messages", 1, "m + n, m ~ n", UNICAST, sizes=SDA_LADDER_SIZES)],
        ),
        scaling_claim(
            "X7",
            '§3.1.1: "RACHNA_dt\'s computational ... complexities are O(m n^3 log n (u_max))" '
            "(the toolkit's faithful reading, simultaneous bidding, the default of "
            "heuristics.rachna_dt; the log n factor inside the tolerance)",
            LADDER_FAMILY,
            [ScalingPart("rachna-dt", "work", 4, "m n^3 log n, m ~ n")],
        ),
        scaling_claim(
            "X8",
            '§3.1.1: RACHNA_dt\'s communication complexity is "O(n^3 m |S| (u_max))" (the '
            "toolkit's faithful reading, simultaneous bidding, the default of "
            "heuristics.rachna_dt, and its message model counted point to point: "
            "medium=unicast)",
            LADDER_FAMILY,
            [ScalingPart("rachna-dt", "messages", 4, "n^3 m, m ~ n", UNICAST)],
        ),
        Claim(
            "H4",
            "§5.2 (H4): \"The hypothesis (H_4) that Pair-GRAPE-S's utilities are higher than "
            "GRAPE-S's was supported\"; §5: \"Pair-GRAPE-S's utilities were additionally "
            "hypothesized to be higher than GRAPE-S's for ten service collectives with five "
            'services per robot" (an aggregate hypothesis, which the paper tested over its '
            "10:5 trials with Friedman's test and Conover's post-hoc comparisons of its four "
            "algorithms, §5.1.3; checked as one on the two it names: the Wilcoxon signed-rank "
            "test, the paper's paired test of two algorithms (§6.1), of the paired percent "
            "utilities, one-sided, alpha 0.05)",
            "the seed's 10:5 grid: 100 robots (10 and 50 % tasks), 500 and 1000 robots (1, 10 "
            "and 50 % tasks), n_missions seeded achievable missions per cell",
            ("pair-grape-s", "grape-s"),
            HypothesisMethod(),
            Scope.PAPER_SIZES,
        ),
        property_claim(
            "S1",
            '§5.1: "Pair-GRAPE-S uses its extra pairwise stability step only when a '
            'suboptimal solution is initially produced"',
            ACHIEVABLE_FAMILY + " (load 1); 'initially produced' = Pair-GRAPE-S's own "
            "(capped) GRAPE-S phase",
            ("pair-grape-s", "grape-s"),
            _s1,
            scope=Scope.GENERALISATION,
            cells=grid_cells(ALL_COMPOSITIONS),
            strategy=structural_missions(achievable=True, load=1.0),
            summary=tally_summary("pairwise step ran"),
            sweep=ALL_COMPOSITIONS,
        ),
        property_claim(
            "I1",
            '§5: "Pair-GRAPE-S is identical to GRAPE-S for the other three collective '
            "compositions, where the collectives are homogeneous or possesses only single "
            'service robots" (checked: same partition, same iterations)',
            "achievable missions of the seed's generator (load 1), 5:1, 5:5, 10:1: grid cells "
            "n = 100, and generated missions of 2..60 robots, 10 or 50 % tasks",
            ("pair-grape-s", "grape-s"),
            _i1,
            scope=Scope.GENERALISATION,
            cells=grid_cells(EASY_COMPOSITIONS),
            strategy=generated_missions(EASY_COMPOSITIONS),
            sweep=EASY_COMPOSITIONS,
        ),
    ]
