"""The radio channel (heuristics.transport.channel): hand-computed broadcast patterns,
the spec tokens, compact sizes, and runs without a channel unchanged byte for byte."""

from __future__ import annotations

import hashlib
import json
from typing import Any

import numpy as np
import pytest

import cfopt
import heuristics
from cfopt import MissionError
from heuristics.agents import Agent, Protocol
from heuristics.communication import belief_size
from heuristics.network import NetworkSpec
from heuristics.transport.simulator import simulate

MS = 1_000_000


class Note:
    """A 3-byte broadcast whose key is ``(tick + 1, now, robot)``."""

    def __init__(self, key: tuple[int, int, int]) -> None:
        self.key = key


class Talker(Agent):
    """Broadcasts one note at each of its first ``talks`` ticks, then stops after a
    silent tick; records the key it received at every tick (its own belief never
    changes, so every note can change it)."""

    def __init__(self, robot: int, talks: int) -> None:
        self.robot, self.talks = robot, talks
        self.heard: list[tuple[int, Any]] = []

    def tick(self, now: int, received: Any, inbox: list[Any]) -> tuple[Any, list[Any]]:
        self.heard.append((now, None if received is None else received.key))
        self.ticks += 1
        if self.ticks > self.talks:
            self.stopped = True
            return None, []
        return Note((self.ticks, now, self.robot)), []


class Talkers(Protocol):
    def __init__(self, talks: int) -> None:
        self.talks = talks
        self.agents: dict[int, Talker] = {}

    def make_agent(self, context: Any) -> Agent:
        agent = self.agents[context.robot] = Talker(context.robot, self.talks)
        return agent

    def encode(self, belief: Any) -> bytes:
        return b"abc"


def _mission(n: int) -> cfopt.Mission:
    return cfopt.Mission.from_arrays(np.ones((n, 1), bool), [[1]], [1.0])


def test_four_robots_share_one_channel_in_fifo_order() -> None:
    """Complete, lock-step, 3-byte frames at 8000 bit/s (3 ms each), queues of 1.

    Tick 0 (t = 0): robot 0 goes on the air at once, 1..3 sense it and wait in the order
    they came: frames [0, 3), [3, 6), [6, 9), [9, 12) ms (queueing 0, 3, 6, 9).
    Tick 1 (t = 10): robot 3 is still on the air; 0, 1, 2 wait for 12 and 3 joins them
    when its frame ends: [12, 15), [15, 18), [18, 21), [21, 24) (queueing 2, 5, 8, 11).
    Tick 2 (t = 20): 0 and 1 wait for 21; 2 is on the air (its frame queues); 3 still has
    its tick-1 frame waiting, so its tick-2 frame overflows.  At 21 robot 3's waiting
    frame goes first, then 0, 1, 2: [24, 27), [27, 30), [30, 33) (queueing 4, 7, 10).
    Eleven frames, 33 ms of air, 65 ms of queueing, the channel never idle.
    """
    protocol = Talkers(talks=3)
    run = simulate(_mission(4), protocol, "complete sync=true bitrate=8000bit/s queue=1")
    report = run.network.channel
    assert (report.model, report.bitrate, report.queue) == ("shared", "8kbit/s", 1)
    assert report.frames == 11 and run.messages == 11 and run.bytes == 33
    assert report.airtime_seconds == pytest.approx(0.033)
    assert report.queueing_mean_seconds == pytest.approx(0.065 / 11)
    assert report.queueing_max_seconds == pytest.approx(0.011)
    assert (report.overflows, report.collisions) == (1, 0)
    assert run.network.simulated_seconds == pytest.approx(0.033)
    assert report.utilisation == pytest.approx(1.0) == report.peak_utilisation
    assert (run.network.receptions, run.network.losses) == (33, 0)
    # what each robot held at its ticks (10, 20 and 30 ms): the newest note delivered
    # strictly before the tick, its own never delivered to it
    for robot, agent in protocol.agents.items():
        heard = dict(agent.heard)
        assert heard[0] is None
        assert heard[10 * MS] == (1, 0, {0: 2, 1: 2, 2: 1, 3: 2}[robot])
        assert heard[20 * MS] == (2, 10 * MS, 0 if robot == 1 else 1)
        assert heard[30 * MS] == ((2, 10 * MS, 3) if robot == 0 else (3, 20 * MS, 0))


def test_hidden_terminals_collide_on_a_ring() -> None:
    """Ring 0-1-2-3-0, lock-step, one 3 ms frame each at t = 0.

    Robot 0 goes on the air; 1 and 3 sense it and wait; 2 is out of 0's range and goes
    too: both frames overlap at 1 and at 3, all four receptions lost.  At 3 ms 1 and 3
    (out of range of each other) go together: both lost at 0 and at 2.  Every robot
    senses the channel busy over [0, 6) of a run that ends at its silent tick, 10 ms.
    """
    run = simulate(_mission(4), Talkers(talks=1), "ring sync=true bitrate=8000bit/s")
    report = run.network.channel
    assert report.frames == 4 and report.collisions == 8
    assert (run.network.receptions, run.network.losses) == (0, 8)
    assert report.queueing_mean_seconds == pytest.approx(0.0015)  # (0 + 3 + 0 + 3) / 4
    assert report.utilisation == pytest.approx(0.6) == report.peak_utilisation


def test_per_link_channels_serialise_only_a_senders_own_frames() -> None:
    """The same pattern as the shared test, one channel per link: no sender waits for
    another, so nothing queues; each robot's radio is busy 9 ms of the 30."""
    run = simulate(
        _mission(4), Talkers(talks=3), "complete sync=true bitrate=8000bit/s channel=per-link"
    )
    report = run.network.channel
    assert (report.frames, report.overflows, report.collisions) == (12, 0, 0)
    assert report.queueing_max_seconds == 0.0
    assert report.utilisation == pytest.approx(0.3)
    assert run.network.simulated_seconds == pytest.approx(0.030)


def test_a_direct_message_queues_behind_the_senders_broadcast() -> None:
    """SDA on a slow shared channel converges and reports its channel; a GRAPE-S run on
    a grid reports collisions among its losses."""
    m = cfopt.generate_mission(
        robots=12, percent_tasks=25, service_types=3, services_per_robot=2, seed=4
    )
    sda = heuristics.simulate(m, "sda", "complete bitrate=200kbit/s", seed=0)
    assert sda.network.converged and sda.network.channel.frames == sda.messages
    grid = heuristics.simulate(m, "grape-s", "grid bitrate=100kbit/s", seed=0)
    report = grid.network.channel
    assert 0 < report.collisions <= grid.network.losses
    assert 0 < report.utilisation <= report.peak_utilisation <= 1


def test_compact_beliefs_are_sized_bit_packed() -> None:
    m = cfopt.generate_mission(
        robots=20, percent_tasks=25, service_types=3, services_per_robot=2, seed=2
    )
    run = heuristics.simulate(m, "grape-s", "complete sync=true encoding=compact", seed=0)
    size = belief_size(20, m.n_tasks * m.n_services, encoding="compact")
    assert run.bytes == run.messages * size < run.messages * (16 + 4 * 20)
    pair = heuristics.simulate(m, "pair-grape-s", "ring encoding=compact", seed=0)
    assert run.network.spec == "complete sync=true encoding=compact"
    assert pair.bytes > 0


def test_channel_tokens_round_trip_and_refusals() -> None:
    spec = NetworkSpec.parse("grid bitrate=2.5Mbit/s channel=per-link queue=4 encoding=compact")
    assert (spec.bitrate, spec.channel, spec.queue, spec.encoding) == (
        2_500_000,
        "per-link",
        4,
        "compact",
    )
    assert spec.to_text() == "grid bitrate=2500kbit/s channel=per-link queue=4 encoding=compact"
    assert NetworkSpec.parse(spec.to_text()) == spec == NetworkSpec.from_dict(spec.to_dict())
    assert "bitrate" not in NetworkSpec.parse("ring").to_dict()
    for text, message in [
        ("ring bitrate=2Mb/s", "bitrate=2Mb/s: '2Mb/s' is not a bit rate"),
        ("ring bitrate=0.5bit/s", "whole number of bit/s >= 1"),
        ("ring queue=3", "queue: only a network with a channel"),
        ("ring bitrate=1kbit/s queue=0", "queue=0: the queue bound must be"),
        ("ring bitrate=1kbit/s channel=mesh", "must be shared or per-link"),
        ("ring encoding=zip", "must be full or compact"),
    ]:
        with pytest.raises(MissionError, match=message.replace("(", r"\(")):
            NetworkSpec.parse(text)


#: Digests of runs computed before the channel existed (the same code as _digest).
BEFORE = [
    ("grape-s", 30, "ring latency=uniform:1ms:5ms loss=0.05", 1, "7d9f3f71912d7166"),
    ("pair-grape-s", 24, "grid latency=uniform:1ms:20ms loss=ge:0.01:0.3:0.5", 2,
     "1f8c1d625c773a46"),
    ("sda", 20, "complete latency=uniform:1ms:10ms loss=0.02", 3, "85606311f306d306"),
    ("grape-s-select", 18, "geometric radius=0.5 latency=exponential:2ms", 4, "14c1bcc2b12bbcec"),
    ("pair-grape-s-chain", 16, "smallworld k=4 p=0.2 medium=unicast", 5, "5ac46f843612786d"),
    ("grape-s", 40, "complete sync=true", 6, "0722972413edc29f"),
]  # fmt: skip


def _digest(run: heuristics.Run) -> str:
    fields = {
        "alg": run.algorithm,
        "task": run.assignment.task.tolist(),
        "service": run.assignment.service.tolist(),
        "it": run.iterations,
        "rounds": run.rounds,
        "messages": run.messages,
        "bytes": run.bytes,
        "work": run.work,
        "traj": run.trajectory.tolist(),
        "options": [list(map(str, o)) for o in run.options],
        "network": run.network.to_dict(),
    }
    return hashlib.sha256(json.dumps(fields, sort_keys=True).encode()).hexdigest()[:16]


@pytest.mark.parametrize(("algorithm", "n", "network", "seed", "digest"), BEFORE)
def test_runs_without_a_channel_are_unchanged(
    algorithm: str, n: int, network: str, seed: int, digest: str
) -> None:
    m = cfopt.generate_mission(
        robots=n, percent_tasks=25, service_types=3, services_per_robot=2, seed=seed
    )
    run = heuristics.simulate(m, algorithm, network, seed=seed)
    assert run.network.channel is None and "channel" not in run.network.to_dict()
    assert _digest(run) == digest
