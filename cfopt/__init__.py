"""cfopt: optimisation-grounded verification of coalition formation for robot collectives.

The data model (:class:`Mission`, :class:`Assignment`), the seed's instance family
(:func:`generate_mission`, :func:`paper_grid`), and the exact optimum.

>>> import cfopt
>>> m = cfopt.generate_mission(robots=20, percent_tasks=10, service_types=5,
...                            services_per_robot=2, seed=1)
>>> m
<Mission 'seed family n=20 p=10 S:k=5:2 load=1 seed=1': 20 robots, 2 tasks, 5 services>
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from cfopt.assignment import ASSIGNMENT_FORMAT, UNASSIGNED, Assignment
    from cfopt.checks import require_mission
    from cfopt.errors import MissionError
    from cfopt.exact import ExactResult, ExactStatus, solve_exact
    from cfopt.generate import (
        GridCell,
        generate_mission,
        generate_with_witness,
        paper_distributed_grid,
        paper_grid,
    )
    from cfopt.mission import MISSION_FORMAT, Mission

#: Where each public name lives: loaded on first use, so that ``import cfopt`` (and the
#: command line's start) does not pay for numpy, scipy and networkx before it needs them.
_LAZY = {
    "ASSIGNMENT_FORMAT": "cfopt.assignment",
    "UNASSIGNED": "cfopt.assignment",
    "Assignment": "cfopt.assignment",
    "require_mission": "cfopt.checks",
    "MissionError": "cfopt.errors",
    "ExactResult": "cfopt.exact",
    "ExactStatus": "cfopt.exact",
    "solve_exact": "cfopt.exact",
    "GridCell": "cfopt.generate",
    "generate_mission": "cfopt.generate",
    "generate_with_witness": "cfopt.generate",
    "paper_distributed_grid": "cfopt.generate",
    "paper_grid": "cfopt.generate",
    "MISSION_FORMAT": "cfopt.mission",
    "Mission": "cfopt.mission",
}

__version__ = "0.1.0"

__all__ = [
    "ASSIGNMENT_FORMAT",
    "MISSION_FORMAT",
    "UNASSIGNED",
    "Assignment",
    "ExactResult",
    "ExactStatus",
    "GridCell",
    "Mission",
    "MissionError",
    "__version__",
    "generate_mission",
    "generate_with_witness",
    "paper_distributed_grid",
    "paper_grid",
    "require_mission",
    "solve_exact",
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'cfopt' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip this hook
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
