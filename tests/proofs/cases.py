"""Hypothesis cases shared by the checkers' tests: a mission and an assignment of it,
arbitrary or a few moves from stable (uncapped or capped)."""

from __future__ import annotations

from hypothesis import strategies as st

from proofs.strategies import assignments, missions, near_stable_assignments


@st.composite
def missions_with_assignments(draw, max_robots: int, max_tasks: int, max_services: int):
    m = draw(missions(max_robots=max_robots, max_tasks=max_tasks, max_services=max_services))
    a = draw(
        st.one_of(
            assignments(m),
            near_stable_assignments(m),
            near_stable_assignments(m, capped=True),
        )
    )
    return m, a
