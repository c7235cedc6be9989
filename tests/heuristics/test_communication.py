"""Communication models (``heuristics.communication``): the counts of every centralized
engine under each medium and encoding, checked by hand on 3-robot missions; validation;
the run's communication table; ``cfopt run --medium/--encoding``."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cfopt import Mission, MissionError, generate_mission
from cfopt.cli import main
from heuristics import (
    belief_bytes,
    broadcast_cost,
    grape_s,
    grape_s_select,
    pair_grape_s,
    pair_grape_s_chain,
    rachna_dt,
    sda,
)
from heuristics._reference import encode_belief, grape_s_reference
from heuristics._run import Run
from heuristics.communication import (
    ENCODINGS,
    MEDIA,
    MODELS,
    CommModel,
    belief_size,
    slot_bits,
)
from heuristics.grape_s import grape_s_eager
from proofs.strategies import missions

ENGINES = {
    "grape-s": grape_s,
    "pair-grape-s": pair_grape_s,
    "pair-grape-s-chain": pair_grape_s_chain,
    "sda": sda,
    "grape-s-select": grape_s_select,
    "rachna-dt": rachna_dt,
}


def counts(run: Run) -> dict[tuple[str, str], tuple[int, int]]:
    """The run's communication table as ``(medium, encoding) -> (messages, bytes)``."""
    assert [(md, en) for md, en, _, _ in run.communication] == [
        (c.medium, c.encoding) for c in MODELS
    ]
    return {(md, en): (ms, by) for md, en, ms, by in run.communication}


def by_model(engine, mission: Mission, **options) -> dict[tuple[str, str], tuple[int, int]]:
    """``(messages, bytes)`` of runs made with each explicit model."""
    out = {}
    for medium in MEDIA:
        for encoding in ENCODINGS:
            run = engine(mission, medium=medium, encoding=encoding, **options)
            assert dict(run.options)["medium"] == medium
            assert dict(run.options)["encoding"] == encoding
            out[medium, encoding] = (run.messages, run.bytes)
    return out


# ------------------------------------------------------------------ the sizes
def test_belief_sizes_by_hand() -> None:
    # full: 16-byte header (int32 r, int32 id, int64 time) + one int32 per robot
    assert belief_size(3) == 16 + 4 * 3 == 28 == belief_bytes(3)
    # compact, m S = 2 slots: values 0, 1 and 2 (unassigned) need 2 bits; 3 robots = 6
    # bits = 1 byte
    assert slot_bits(2) == 2 and belief_size(3, 2, encoding="compact") == 16 + 1
    # m S = 4: values 0..4 need 3 bits; 3 robots = 9 bits = 2 bytes
    assert slot_bits(4) == 3 and belief_size(3, 4, encoding="compact") == 16 + 2
    # m S = 3: values 0..3 fit 2 bits exactly
    assert slot_bits(3) == 2 and belief_size(3, 3, encoding="compact") == 16 + 1
    # GRAPE-S-Select's 2 task bits per task: packed with the slots (6 + 4 bits = 2 bytes),
    # 1 byte beside 4-byte slots
    assert belief_size(3, 2, encoding="compact", extra_bits=4) == 16 + 2
    assert belief_size(3, 2, encoding="full", extra_bits=4) == 16 + 12 + 1
    # no slots at all: only "unassigned", 0 bits
    assert slot_bits(0) == 0 and belief_size(5, 0, encoding="compact") == 16


def test_round_costs_by_hand() -> None:
    # 4 rounds of 3 robots, 28-byte beliefs
    assert CommModel("broadcast").rounds_cost(3, 4, 28) == (3 * 4, 3 * 4 * 28)
    assert CommModel("unicast").rounds_cost(3, 4, 28) == (3 * 2 * 4, 3 * 2 * 4 * 28)
    assert CommModel("unicast").rounds_cost(3, 4, 28) == broadcast_cost(3, 4)
    # one robot has no neighbour: nothing is sent on either medium
    assert CommModel("broadcast").rounds_cost(1, 7, 20) == (0, 0)
    assert CommModel("unicast").rounds_cost(1, 7, 20) == (0, 0)


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(0, 40),
    slots=st.integers(0, 300),
    partition=st.data(),
)
def test_compact_size_is_the_encoded_size(n, slots, partition) -> None:
    values = partition.draw(st.lists(st.integers(-1, max(slots - 1, -1)), min_size=n, max_size=n))
    from heuristics._reference import _Belief

    belief = _Belief(1, 2, 0, tuple(values))
    assert len(encode_belief(belief)) == belief_size(n)
    assert len(encode_belief(belief, "compact", slots)) == belief_size(n, slots, encoding="compact")


# -------------------------------------------------------- 3-robot missions by hand
def test_grape_s_by_hand() -> None:
    # 3 one-service robots, t0 needs 2, t1 needs 1: R = 4 rounds (3 moves + quiet).
    # m S = 2 slots: compact belief 16 + ceil(3 x 2 / 8) = 17 bytes; full 16 + 12 = 28.
    m = Mission.from_arrays([[1], [1], [1]], [[2], [1]], [5, 5])
    run = grape_s(m)
    assert run.rounds == 4
    expected = {
        ("broadcast", "full"): (3 * 4, 3 * 4 * 28),  # 12 transmissions, 336 bytes
        ("broadcast", "compact"): (3 * 4, 3 * 4 * 17),  # 204 bytes
        ("unicast", "full"): (3 * 2 * 4, 3 * 2 * 4 * 28),  # 24 messages, 672 bytes
        ("unicast", "compact"): (3 * 2 * 4, 3 * 2 * 4 * 17),  # 408 bytes
    }
    assert counts(run) == expected == by_model(grape_s, m)
    assert (run.messages, run.bytes) == expected["broadcast", "full"]  # the default
    assert dict(run.options)["medium"] == "broadcast"
    assert dict(run.options)["encoding"] == "full"


def test_pair_grape_s_by_hand() -> None:
    # r0 does A, r1 A and B, r2 A; t0 needs A twice, t1 B once.  Capped GRAPE-S: r2 and
    # then r1 fill t0's A (r1's tie between t0/A at 2/2 and t1/B at 1/1 goes to the lower
    # task), the third round is quiet: r0 is left out and t1 short.  The pairwise step:
    # r0 takes r1's place, r1 moves to t1/B: one exchange, one more round.  R = 4.
    # m S = 4 slots: 3 bits per robot, 9 bits = 2 bytes: compact 18 bytes; full 28.
    m = Mission.from_arrays([[1, 0], [1, 1], [1, 0]], [[2, 0], [0, 1]], [2, 1])
    run = pair_grape_s(m)
    assert (run.rounds, run.exchanges) == (4, 1)
    assert run.assignment.task.tolist() == [0, 1, 0]
    expected = {
        ("broadcast", "full"): (3 * 4, 3 * 4 * 28),  # 12, 336
        ("broadcast", "compact"): (3 * 4, 3 * 4 * 18),  # 12, 216
        ("unicast", "full"): (3 * 2 * 4, 3 * 2 * 4 * 28),  # 24, 672
        ("unicast", "compact"): (3 * 2 * 4, 3 * 2 * 4 * 18),  # 24, 432
    }
    assert counts(run) == expected == by_model(pair_grape_s, m)


def test_pair_grape_s_chain_by_hand() -> None:
    # The chain mission: r0 does A, r1 A and B, r2 B and C; one task needs A, B, C once.
    # R = 4 rounds (2 moves, the quiet round, the exchange) and one chain of k = 2
    # partners: 2 requests of 8 + 8 x 2 = 24 bytes and 2 acceptances of 12 bytes, direct
    # messages on both media: 4 messages, 72 bytes.  m S = 3 slots: 2 bits per robot,
    # compact belief 16 + 1 = 17 bytes; full 28.
    m = Mission.from_arrays([[1, 0, 0], [1, 1, 0], [0, 1, 1]], [[1, 1, 1]], [10])
    run = pair_grape_s_chain(m)
    assert (run.rounds, run.exchanges) == (4, 1)
    expected = {
        ("broadcast", "full"): (3 * 4 + 4, 3 * 4 * 28 + 72),  # 16, 408
        ("broadcast", "compact"): (3 * 4 + 4, 3 * 4 * 17 + 72),  # 16, 276
        ("unicast", "full"): (3 * 2 * 4 + 4, 3 * 2 * 4 * 28 + 72),  # 28, 744
        ("unicast", "compact"): (3 * 2 * 4 + 4, 3 * 2 * 4 * 17 + 72),  # 28, 480
    }
    assert counts(run) == expected == by_model(pair_grape_s_chain, m)


def test_sda_max_wage_by_hand() -> None:
    # 3 one-service robots; t0 needs 2 (u 10), t1 needs 1 (u 4); eps 1: wages start at 11,
    # one decrement per round, round robin.  t0 buys r0, r1 at 5 + 5 in round 17; t1 buys
    # r2 at 4 in round 19.  Messages (8-byte header, 12 per entry):
    #   decrement notices, 20 bytes: broadcast 1 per round (19); unicast to each unstaffed
    #     task: 2 x 17 + 1 x 2 = 36
    #   bids (direct): t0's 8 + 2 x 12 = 32, t1's 20; answers (direct): 2 x 8
    #   sale notice after round 17 (2 entries, 32 bytes) to t1 alone: 1 on both media;
    #     after round 19 nobody is left to tell
    m = Mission.from_arrays([[1], [1], [1]], [[2], [1]], [10, 4])
    run = sda(m)
    assert (run.rounds, run.assignment.task.tolist()) == (19, [0, 0, 1])
    direct = (2 + 2, 32 + 20 + 8 + 8)
    cast = (19 + direct[0] + 1, 19 * 20 + direct[1] + 32)  # 24, 480
    uni = (36 + direct[0] + 1, 36 * 20 + direct[1] + 32)  # 41, 820
    expected = {  # the encoding is the beliefs': SDA sends none, so it changes nothing
        ("broadcast", "full"): cast,
        ("broadcast", "compact"): cast,
        ("unicast", "full"): uni,
        ("unicast", "compact"): uni,
    }
    assert counts(run) == expected == by_model(sda, m)
    assert cast == (24, 480) and uni == (41, 820)


def test_sda_uniform_by_hand() -> None:
    # The same mission, uniform schedule: every wage 11 - d after d rounds.  t0 buys r0,
    # r1 at 5 + 5 in round 6, t1 buys r2 at 4 in round 7.
    #   decrement notices, one per service agent (one entry per unsold robot): rounds
    #     1-6 with 3 unsold robots, 8 + 36 = 44 bytes, to 2 tasks; round 7 with r2 alone,
    #     20 bytes, to t1.  Broadcast: 6 x 44 + 20 = 284 in 7; unicast: 12 x 44 + 20 = 548
    #     in 13.
    #   bids, answers and the sale notice as in the max-wage case: 5 messages, 100 bytes
    m = Mission.from_arrays([[1], [1], [1]], [[2], [1]], [10, 4])
    run = sda(m, schedule="uniform")
    assert (run.rounds, run.assignment.task.tolist()) == (7, [0, 0, 1])
    assert counts(run)["broadcast", "full"] == (7 + 5, 284 + 100) == (12, 384)
    assert counts(run)["unicast", "full"] == (13 + 5, 548 + 100) == (18, 648)
    assert counts(run) == by_model(sda, m, schedule="uniform")


def test_rachna_dt_by_hand() -> None:
    # 3 one-service robots; t0 needs 2 (u 10), t1 needs 1 (u 4); eps = 1/3, all bids
    # simultaneous.  Round 1: t0 bids r0, r1 and t1 bids r0 (each at wage 0 + eps); t0,
    # the lower index, wins the tie.  Round 2: t1 bids r2 and wins.  Round 3: quiet.
    # Messages (8-byte header, 12 per entry):
    #   bids and answers (direct), one service agent each: t0 2 messages, 8 + 24 + 8 = 40
    #     bytes; t1 twice 2 messages, 8 + 12 + 8 = 28 bytes
    #   price announcements by s0 to the 2 tasks needing it: round 1 two changed robots,
    #     8 + 24 = 32 bytes; round 2 one, 20 bytes.  Broadcast: 1 each; unicast: 2 each.
    m = Mission.from_arrays([[1], [1], [1]], [[2], [1]], [10, 4])
    run = rachna_dt(m)
    assert (run.rounds, run.iterations, run.assignment.task.tolist()) == (3, 2, [0, 0, 1])
    direct = (6, 40 + 28 + 28)
    cast = (direct[0] + 2, direct[1] + 32 + 20)  # 8, 148
    uni = (direct[0] + 4, direct[1] + 2 * 32 + 2 * 20)  # 10, 200
    expected = {  # the encoding is the beliefs': RACHNA_dt sends none
        ("broadcast", "full"): cast,
        ("broadcast", "compact"): cast,
        ("unicast", "full"): uni,
        ("unicast", "compact"): uni,
    }
    assert counts(run) == expected == by_model(rachna_dt, m)
    assert cast == (8, 148) and uni == (10, 200)


def test_grape_s_select_by_hand() -> None:
    # 3 robots, t0 and t1 need 2 each (u 10 and 4): R = 6 rounds (module example).
    # Belief: full 16 + 4 x 3 + ceil(2 x 2 task bits / 8) = 29 bytes; compact: 2 bits per
    # slot (m S = 2) and 4 task bits, 10 bits = 2 bytes: 18.
    m = Mission.from_arrays([[1], [1], [1]], [[2], [2]], [10, 4])
    run = grape_s_select(m)
    assert run.rounds == 6
    expected = {
        ("broadcast", "full"): (3 * 6, 3 * 6 * 29),  # 18, 522
        ("broadcast", "compact"): (3 * 6, 3 * 6 * 18),  # 18, 324
        ("unicast", "full"): (3 * 2 * 6, 3 * 2 * 6 * 29),  # 36, 1044
        ("unicast", "compact"): (3 * 2 * 6, 3 * 2 * 6 * 18),  # 36, 648
    }
    assert counts(run) == expected == by_model(grape_s_select, m)


def test_one_robot_sends_nothing_to_nobody() -> None:
    m = Mission.from_arrays([[1]], [[1]], [3])
    for name in ("grape-s", "pair-grape-s", "pair-grape-s-chain", "grape-s-select"):
        run = ENGINES[name](m)
        assert {c[2:] for c in run.communication} == {(0, 0)}, name


# ----------------------------------------------- the table against explicit runs
GENERATED = [
    generate_mission(30, 10, 10, 5, seed=3),
    generate_mission(24, 50, 5, 2, seed=8),
    generate_mission(20, 10, 5, 5, load=1.5, seed=2),
]


@pytest.mark.parametrize("name", sorted(ENGINES))
@pytest.mark.parametrize("mission", GENERATED, ids=["10:5", "5:2", "load-1.5"])
def test_table_agrees_with_runs_made_with_each_model(name, mission) -> None:
    engine = ENGINES[name]
    run = engine(mission, seed=4)
    assert counts(run) == by_model(engine, mission, seed=4)
    assert run.communication_cost() == (run.messages, run.bytes)
    # every model makes the same run: only messages and bytes differ
    other = engine(mission, seed=4, medium="unicast", encoding="compact")
    assert other.communication == run.communication
    assert other.assignment == run.assignment and other.rounds == run.rounds


@settings(max_examples=30, deadline=None)
@given(
    mission=missions(min_robots=0, max_robots=10, max_tasks=4, max_services=3),
    seed=st.integers(0, 2**32 - 1),
    order=st.sampled_from(["index", "random"]),
)
def test_reference_engine_materialises_every_model(mission, seed, order) -> None:
    # The literal GRAPE-S builds each message as bytes and sends it per the medium.
    run = grape_s_eager(mission, seed=seed, order=order)  # the reference's draws
    for (medium, encoding), cost in counts(run).items():
        ref = grape_s_reference(mission, seed=seed, order=order, medium=medium, encoding=encoding)
        assert (ref.messages, ref.bytes) == cost, (medium, encoding)


# ------------------------------------------------------------------ validation
@pytest.mark.parametrize("name", sorted(ENGINES))
@pytest.mark.parametrize(
    ("options", "fragment"),
    [
        ({"medium": "udp"}, "medium: must be one of broadcast, unicast, got 'udp'"),
        ({"medium": None}, "medium: must be one of broadcast, unicast, got None"),
        ({"encoding": "zip"}, "encoding: must be one of full, compact, got 'zip'"),
        ({"encoding": 4}, "encoding: must be one of full, compact, got 4"),
    ],
)
def test_bad_model_values_are_refused(name, options, fragment) -> None:
    m = Mission.from_arrays([[1], [1], [1]], [[2], [1]], [10, 4])
    with pytest.raises(MissionError, match=fragment.replace("(", r"\(")):
        ENGINES[name](m, **options)


def test_comm_model_is_frozen_and_validated() -> None:
    model = CommModel()
    assert (model.medium, model.encoding, model.label) == ("broadcast", "full", "broadcast/full")
    with pytest.raises(AttributeError):
        model.medium = "unicast"  # type: ignore[misc]
    with pytest.raises(MissionError, match="medium: must be one of broadcast, unicast"):
        CommModel("Broadcast")
    with pytest.raises(MissionError, match="encoding: must be one of full, compact"):
        CommModel("unicast", "")
    with pytest.raises(MissionError, match="n_slots"):
        belief_size(3, encoding="compact")


# ------------------------------------------------------------------ the Run
def test_run_serialises_and_compares_its_table() -> None:
    m = Mission.from_arrays([[1], [1], [1]], [[2], [1]], [5, 5])
    run = grape_s(m, seed=1)
    d = run.to_dict(m)
    assert d["communication"][0] == {
        "medium": "broadcast",
        "encoding": "full",
        "messages": 12,
        "bytes": 336,
    }
    assert len(d["communication"]) == 4
    assert run == run.replace_seconds(run.seconds)
    assert run.replace_seconds(0.0) == grape_s(m, seed=1).replace_seconds(0.0)
    # a run without a table (RACHNA_dt, distributed runs) still constructs and compares
    bare = Run(
        algorithm="x",
        assignment=run.assignment,
        iterations=0,
        rounds=0,
        messages=0,
        bytes=0,
        work=0,
        seconds=0.0,
        seed=None,
    )
    assert bare.communication == () and "communication" not in bare.to_dict(m)
    assert bare != run and bare == bare.replace_seconds(0.0)
    with pytest.raises(MissionError, match="no broadcast/full row"):
        bare.communication_cost()


# ------------------------------------------------------------------ cfopt run
@pytest.fixture
def mission_file(tmp_path):
    m = Mission.from_arrays([[1], [1], [1]], [[2], [1]], [5, 5])
    path = tmp_path / "m.json"
    m.to_json(path)
    return m, str(path)


def test_cli_run_takes_the_model(mission_file, capsys) -> None:
    m, path = mission_file
    assert main(["run", "grape-s", path, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert (data["messages"], data["bytes"]) == (12, 336)  # broadcast/full: 3 x 4 x 28
    assert data["options"]["medium"] == "broadcast"
    argv = ["run", "grape-s", path, "--medium", "unicast", "--encoding", "compact", "--json"]
    assert main(argv) == 0
    data = json.loads(capsys.readouterr().out)
    assert (data["messages"], data["bytes"]) == (24, 408)  # 3 x 2 x 4 of 16 + 1 bytes
    assert data["options"]["medium"] == "unicast"
    assert data["options"]["encoding"] == "compact"
    assert len(data["communication"]) == 4
    assert main(["run", "sda", path, "--medium", "unicast", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert (data["messages"], data["bytes"]) == sda(m, medium="unicast").communication_cost(
        "unicast"
    )
    assert main(["run", "pair-grape-s-chain", path, "--encoding", "compact", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["options"]["encoding"] == "compact"


def test_cli_run_refuses_the_model_where_it_does_not_apply(mission_file, capsys) -> None:
    _, path = mission_file
    assert main(["run", "grape-s", path, "--encoding", "full", "--network", "complete"]) == 2
    assert "not for distributed runs" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["run", "grape-s", path, "--medium", "udp"])
    assert exc.value.code == 2
    assert "invalid choice: 'udp'" in capsys.readouterr().err
