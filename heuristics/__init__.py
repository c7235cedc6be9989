"""heuristics: the coalition-formation algorithms under audit, one module each.

>>> import cfopt, heuristics
>>> m = cfopt.generate_mission(robots=30, percent_tasks=10, service_types=5,
...                            services_per_robot=1, seed=0)
>>> run = heuristics.grape_s(m)
>>> run.assignment.percent_utility(m), run.iterations, run.rounds
(100.0, 30, 31)
>>> sorted(heuristics.ALGORITHMS)
['grape-s', 'grape-s-select', 'pair-grape-s', 'pair-grape-s-chain', 'rachna-dt', 'sda']
"""

from heuristics._run import Run, RunStatus, belief_bytes, broadcast_cost
from heuristics.grape_s import grape_s
from heuristics.grape_s_select import grape_s_select
from heuristics.mpi import mpi_run
from heuristics.pair_grape_s import pair_grape_s
from heuristics.pair_grape_s_chain import pair_grape_s_chain
from heuristics.rachna import rachna_dt
from heuristics.registry import (
    ALGORITHMS,
    AlgorithmFailed,
    AlgorithmSpec,
    Option,
    Stability,
    algorithm_names,
    get_algorithm,
    register_algorithm,
    run_algorithm,
)
from heuristics.sda import sda
from heuristics.simulate import simulate

__all__ = [
    "ALGORITHMS",
    "AlgorithmFailed",
    "AlgorithmSpec",
    "Option",
    "Run",
    "RunStatus",
    "Stability",
    "algorithm_names",
    "belief_bytes",
    "broadcast_cost",
    "get_algorithm",
    "grape_s",
    "grape_s_select",
    "mpi_run",
    "pair_grape_s",
    "pair_grape_s_chain",
    "rachna_dt",
    "register_algorithm",
    "run_algorithm",
    "sda",
    "simulate",
]
