"""Mission events during a simulated run (heuristics.transport.events): hand-computed
failures on a 3-robot mission, a task arrival the partition absorbs, joins, withdrawals,
utility changes, the default hook of a user's protocol, the timeline's refusals and
``cfopt run --events``."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import cfopt
import heuristics
from cfopt import MissionError
from heuristics.agents import Agent, Protocol
from heuristics.transport.events import Timeline
from proofs.claims_dynamic import survivors_stable

#: Three robots of one service; t0 needs two of them (utility 3), t1 one (utility 1).
#: GRAPE-S (lock-step, complete) ends on r0 -> t1, r1 and r2 -> t0: utility 4, optimal.
THREE = cfopt.Mission.from_arrays(np.ones((3, 1), bool), [[2], [1]], [3.0, 1.0])
SYNC = "complete sync=true"


def _fail(robot: str, at: str = "1s") -> dict[str, Any]:
    return {"events": [{"at": at, "kind": "fail", "robot": robot}]}


def test_a_failure_on_three_robots_hand_computed() -> None:
    """r1 (on t0) fails at 1 s.  Heartbeats every 100 ms from t = 0 (lock-step offsets 0,
    no latency): r1's last beat is at 0.9 s (its 1 s beat comes after the failure), so its
    neighbours first find it silent for more than D = 300 ms at their beat of 1.3 s.  Each
    marks r1 gone in its belief (an update at 1.3 s), runs again from its next tick
    (1.31 s) and broadcasts; at 1.32 s the lower id adopts the higher id's belief: the last
    change, 0.32 s after the failure.  Nobody moves: r0 on t1 has load 1, joining t0
    would give 2/2 = 1, not better; r2 on t0 has 1/2.  The survivors end Nash stable with
    utility 1 (t1 only) against an optimum of 3 (r0 and r2 on t0)."""
    run = heuristics.simulate(THREE, "grape-s", SYNC, seed=0, events=_fail("r1"))
    dyn = run.network.dynamics
    assert run.assignment.task.tolist() == [1, -1, 0]
    assert dyn.events[0].partition == (1, -1, 0) and dyn.events[0].robots == (0, 2)
    assert dyn.initial_optimum == 4.0
    (after,) = dyn.events
    assert (after.kind, after.target, after.at_seconds) == ("fail", "r1", 1.0)
    assert after.optimum == 3.0 and after.utility_after == 1.0 and survivors_stable(THREE, after)
    assert after.reconverge_seconds == pytest.approx(0.32)
    assert (dyn.detector_seconds, dyn.heartbeat_seconds) == (0.3, 0.1)
    # utility over time: 0 at the start, 4 once formed, 1 after the failure; the optimum
    # a step from 4 to 3 at the event
    times = [s[0] for s in dyn.samples]
    assert times == sorted(times) and times[0] == 0.0
    assert {s[2] for s in dyn.samples if s[0] < 1.0} == {4.0}
    assert {s[2] for s in dyn.samples if s[0] >= 1.0} == {3.0}
    assert dyn.samples[-1][1] == 1.0 and any(s[1] == 4.0 for s in dyn.samples)
    # the recovery's traffic: two survivors' beats (12 each from 1 s to the end of the
    # beats, 2.2 s) and their beliefs
    assert after.transmissions > 0 and after.bytes > 0


def test_a_failure_the_partition_does_not_need() -> None:
    """r0 (alone on t1) fails: t0 is still complete, utility 3 = the new optimum."""
    run = heuristics.simulate(THREE, "grape-s", SYNC, seed=0, events=_fail("r0"))
    (after,) = run.network.dynamics.events
    assert (after.utility_after, after.optimum, survivors_stable(THREE, after)) == (3.0, 3.0, True)
    assert after.reconverge_seconds == pytest.approx(0.32)


def test_a_task_arrival_the_partition_absorbs() -> None:
    """t1 arrives at 1 s.  Before, all three robots join t0 (loads 1/2, 2/2, 3/2, each
    better than none); the optimum is 3.  At the announcement every robot runs again; the
    last robot on t0 (load 3/2) finds t1 at 1/1 better and moves: utility 4 = optimum."""
    events = {"events": [{"at": "1s", "kind": "task-arrives", "task": "t1"}]}
    run = heuristics.simulate(THREE, "grape-s", SYNC, seed=0, events=events)
    dyn = run.network.dynamics
    assert dyn.initial_optimum == 3.0
    (after,) = dyn.events
    assert (after.optimum, after.utility_after, survivors_stable(THREE, after)) == (4.0, 4.0, True)
    assert sorted(run.assignment.task.tolist()) == [0, 0, 1]
    assert after.reconverge_seconds is not None and after.reconverge_seconds < 0.1


def test_a_robot_joins_and_is_placed() -> None:
    """r2 is absent until 1 s: r0, r1 form t0 (utility 3 of an optimum 3 for two robots);
    r2's neighbours hear its first heartbeat, run again and broadcast; r2 takes t1."""
    events = {"events": [{"at": "1s", "kind": "join", "robot": "r2"}]}
    run = heuristics.simulate(THREE, "grape-s", SYNC, seed=0, events=events)
    dyn = run.network.dynamics
    assert dyn.initial_optimum == 3.0
    (after,) = dyn.events
    assert (after.optimum, after.utility_after, survivors_stable(THREE, after)) == (4.0, 4.0, True)


def test_withdrawal_and_utility_change() -> None:
    """t0 withdrawn at 1 s: its robots are freed, t1 keeps one; t1's utility then 5."""
    events = {
        "events": [
            {"at": "1s", "kind": "task-withdrawn", "task": "t0"},
            {"at": "2s", "kind": "utility", "task": "t1", "utility": 5},
        ]
    }
    run = heuristics.simulate(THREE, "grape-s", SYNC, seed=0, events=events)
    gone, up = run.network.dynamics.events
    assert (gone.optimum, gone.utility_after, survivors_stable(THREE, gone)) == (1.0, 1.0, True)
    assert (up.optimum, up.utility_after) == (5.0, 5.0)
    assert (run.assignment.task == 0).sum() == 0


@pytest.mark.parametrize("algorithm", ["pair-grape-s", "sda", "grape-s-select"])
def test_every_shipped_protocol_runs_with_events(algorithm: str) -> None:
    run = heuristics.simulate(
        THREE, algorithm, "ring latency=uniform:1ms:5ms", seed=0, events=_fail("r1")
    )
    (after,) = run.network.dynamics.events
    assert after.optimum == 3.0 and not run.network.cut
    assert run.assignment.task[1] == -1


class Still(Agent):
    def tick(self, now: int, received: Any, inbox: list[Any]) -> tuple[Any, list[Any]]:
        self.ticks += 1
        self.stopped = self.ticks >= 3
        return None, []


class Quiet(Protocol):
    def make_agent(self, context: Any) -> Agent:
        return Still()


def test_a_protocol_without_the_hook_keeps_working() -> None:
    """The default on_event ignores events: the robots do not react, the run ends."""
    run = heuristics.simulate(THREE, Quiet(), SYNC, seed=0, events=_fail("r2", "50ms"))
    (after,) = run.network.dynamics.events
    assert after.utility_after == 0.0 and after.optimum == 3.0
    assert run.rounds == 3


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"events": [{"at": "1s", "kind": "explode", "robot": "r0"}]}, "events[0].kind"),
        ({"events": [{"at": "1s", "kind": "fail", "robot": "r9"}]}, "no robot 'r9'"),
        ({"events": [{"at": 1, "kind": "fail", "robot": "r0"}]}, "events[0].at"),
        ({"events": [{"at": "1s", "kind": "utility", "task": "t0"}]}, "utility"),
        ({"events": [{"at": "1s", "kind": "utility", "task": "t0", "utility": -1}]}, "> 0"),
        ({"events": [], "detector": 3}, "detector"),
        ({"events": [], "heartbeat": "0ms"}, "heartbeat"),
        ({"format": "x", "events": []}, "format"),
        (
            {
                "events": [
                    {"at": "1s", "kind": "fail", "robot": "r0"},
                    {"at": "2s", "kind": "fail", "robot": "r0"},
                ]
            },
            "twice",
        ),
    ],
)
def test_timeline_refusals(data: Any, message: str) -> None:
    with pytest.raises(MissionError, match=re.escape(message)):
        Timeline.from_dict(data, THREE)


def _cfopt(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "cfopt", *args], cwd=cwd, capture_output=True, text=True
    )


def test_cfopt_run_events(tmp_path: Path) -> None:
    (tmp_path / "m.json").write_text(THREE.to_json(), encoding="utf-8")
    (tmp_path / "e.json").write_text(json.dumps(_fail("r1")), encoding="utf-8")
    base = ["run", "grape-s", "m.json", "--network", SYNC, "--seed", "0", "--events", "e.json"]
    text = _cfopt(*base, "-o", "/dev/null", cwd=tmp_path)
    assert text.returncode == 0, text.stderr
    assert (
        "1 s fail r1: re-converged in 0.320 s, utility 1 of optimum 3, survivors Nash stable yes"
        in (text.stdout)
    )
    out = _cfopt(*base, "--json", "--plot", "u.png", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    event = data["network"]["dynamics"]["events"][0]
    assert event["optimum"] == 3.0 and event["survivors_nash_stable"] is True
    assert event["partition"] == [1, -1, 0] and event["robots"] == [0, 2]
    assert (tmp_path / "u.png").read_bytes()[:4] == b"\x89PNG"
    for bad, place in [
        (["--events", "e.json"], "--events: only with --network"),
        ([*base[3:], "--plot", "u.png"], "--plot: u.png exists"),
    ]:
        args = ["run", "grape-s", "m.json", *bad] if place.startswith("--events") else [
            *base[:3], *bad
        ]  # fmt: skip
        res = _cfopt(*args, cwd=tmp_path)
        assert res.returncode == 2 and res.stderr.startswith(f"error: {place}"), res.stderr
        assert "Traceback" not in res.stderr
    (tmp_path / "bad.json").write_text(json.dumps(_fail("r7")), encoding="utf-8")
    res = _cfopt(*base[:-1], "bad.json", cwd=tmp_path)
    assert res.returncode == 2 and "no robot 'r7'" in res.stderr
    assert res.stderr.count("\n") == 1
