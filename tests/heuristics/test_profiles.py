"""The seed-calibrated network profile: its parsing, its halting rule and its derivation."""

from __future__ import annotations

import json
import math

import pytest

import cfopt
from cfopt.cli import main
from cfopt.generate import SEED_NETWORK
from heuristics import simulate
from heuristics.network import NetworkSpec
from heuristics.profiles import (
    PROFILE_BROADCASTS_100,
    PROFILES,
    SEED_PROFILE,
    arrival_ticks,
    seed_broadcast_bytes,
    seed_broadcasts_per_robot,
    seed_profile_derivation,
    seed_quiet_window,
)
from heuristics.simulate import QUIET_FACTOR, quiet_factor_for


def test_the_profile_parses_like_any_spec_and_round_trips() -> None:
    spec = NetworkSpec.parse("seed")
    assert spec.profile == SEED_PROFILE and spec.topology == "complete"
    assert spec.period_ns == 3_000_000
    assert (spec.latency, spec.loss) == (
        NetworkSpec.parse(SEED_NETWORK).latency,
        NetworkSpec.parse(SEED_NETWORK).loss,
    )
    assert spec.to_text() == "seed"
    assert NetworkSpec.parse(spec.to_text()) == spec
    assert NetworkSpec.from_dict(spec.to_dict()) == spec
    assert NetworkSpec.from_dict({"profile": "seed"}) == spec
    assert json.loads(spec.to_json())["profile"] == "seed"
    # the same physics written out is a different network: it halts by cfopt's default
    written = NetworkSpec.parse(PROFILES[SEED_PROFILE].spec)
    assert written != spec and written.quiet_factor(100) is None


def test_tokens_after_the_profile_override_its_fields() -> None:
    spec = NetworkSpec.parse("seed loss=0.05 latency=uniform:1ms:30ms period=5ms")
    assert spec.profile == SEED_PROFILE
    assert spec.loss.rate == 0.05 and spec.latency.durations_ns == (1_000_000, 30_000_000)
    assert spec.period_ns == 5_000_000
    assert spec.to_text() == "seed latency=uniform:1ms:30ms loss=0.05 period=5ms"
    assert NetworkSpec.parse(spec.to_text()) == spec
    assert NetworkSpec.from_dict({"profile": "seed", "loss": 0.05}).loss.rate == 0.05


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("seed radius=0.2", "radius applies only to geometric, not to complete"),
        ("seed loss=0.1 loss=0.2", "key 'loss' given twice"),
        ("seed loss=2", "the loss probability must be in [0, 1)"),
        ("seed seed", "expected key=value"),
        ("seeds", "or a profile: seed"),
    ],
)
def test_bad_tokens_after_a_profile_are_one_line_errors(text: str, message: str) -> None:
    with pytest.raises(cfopt.MissionError) as info:
        NetworkSpec.parse(text)
    assert message in str(info.value)
    assert info.value.cli_message.startswith("--network: ")


def test_a_profile_in_json_is_checked() -> None:
    with pytest.raises(cfopt.MissionError, match="unknown network profile"):
        NetworkSpec.from_dict({"profile": "fast"})
    with pytest.raises(cfopt.MissionError, match="profile's topology is complete"):
        NetworkSpec.from_dict({"profile": "seed", "topology": "ring"})
    with pytest.raises(cfopt.MissionError, match='missing key "topology"'):
        NetworkSpec.from_dict({"loss": 0.1})


def test_the_halting_rule_is_the_derived_quiet_window() -> None:
    spec = NetworkSpec.parse("seed")
    assert [spec.quiet_factor(n) for n in (100, 500)] == [334, 41_667]
    assert seed_quiet_window(500, spec) == math.ceil(500**3 / 3000)
    # small collectives: at least the ticks a message needs to arrive (10 ms over 3 ms)
    assert arrival_ticks(spec) == 5 and spec.quiet_factor(10) == 5
    slow = NetworkSpec.parse("seed latency=uniform:1ms:100ms")
    assert slow.quiet_factor(40) == math.ceil(100 / 3) + 1
    assert quiet_factor_for(spec, 100) == 334
    assert quiet_factor_for(spec, 100, 7) == 7  # an explicit quiet factor wins
    assert quiet_factor_for(NetworkSpec.parse(SEED_NETWORK), 100) == QUIET_FACTOR


def test_the_derivation_numbers() -> None:
    assert seed_broadcast_bytes() == 3000.0  # 30 MB / 100^2 = 750 MB / 500^2 = 3 GB / 1000^2
    low, high = seed_broadcasts_per_robot(500)
    assert (round(low), round(high)) == (33_333, 80_000)
    assert round(seed_broadcasts_per_robot(100)[1]) == 333
    with pytest.raises(ValueError, match="100 and 500"):
        seed_broadcasts_per_robot(1000)
    text = "\n".join(seed_profile_derivation())
    for figure in (
        "3,000 B per broadcast",
        "= 33,333 to",
        "= 80,000 per robot",
        "at most 333 per robot",
        "262 / 80,000 = 3.3 ms",
        "e >= ln(100) / ln(5) = 2.86",
        "n^3 / 3,000",
        "41,667 at 500 robots",
        "41,667 x 3 ms = 125 s",
        "500^4 B = 62.5 GB",
        "ceil(latency bound / period) + 1, 5 ticks",
        "416 B at 100 robots, 2,016 B at 500",
    ):
        assert figure in text, figure


def test_runs_on_the_profile_are_deterministic_and_use_its_halting_rule() -> None:
    m = cfopt.generate_mission(30, 10, 5, 1, seed=3)
    first = simulate(m, "grape-s", "seed", seed=1)
    again = simulate(m, "grape-s", "seed", seed=1)
    assert first.assignment == again.assignment and first.bytes == again.bytes
    assert dict(first.options)["quiet_factor"] == 9  # ceil(30^3 / 3000)
    assert first.network.spec == "seed" and first.network.converged
    default = simulate(m, "grape-s", SEED_NETWORK, seed=1)
    assert dict(default.options)["quiet_factor"] == QUIET_FACTOR
    # the 3 ms clock and the longer window: more broadcasts than cfopt's default
    assert first.network.transmissions > default.network.transmissions


def test_cfopt_default_sends_about_30_broadcasts_per_robot_at_100_robots() -> None:
    # the figure the derivation quotes for cfopt's default network
    m = cfopt.GridCell(100, 10, 5, 1).mission(0)
    run = simulate(m, "grape-s", SEED_NETWORK, seed=0)
    assert 25 <= run.network.transmissions / m.n_robots <= 35
    assert "about 30 times at 100 robots" in " ".join(seed_profile_derivation())


def test_the_profile_overshoots_the_seeds_100_robot_bound_as_the_derivation_says() -> None:
    # the window is fitted to the bound, the settling ticks come on top
    m = cfopt.GridCell(100, 10, 5, 1).mission(0)
    run = simulate(m, "grape-s", "seed", seed=0)
    per_robot = run.network.transmissions / m.n_robots
    assert abs(per_robot / PROFILE_BROADCASTS_100 - 1) < 0.15, per_robot
    assert per_robot > seed_broadcasts_per_robot(100)[1]
    assert "broadcast about 400 times, 20% above the seed's at most 333" in " ".join(
        seed_profile_derivation()
    )


def test_cli_runs_the_profile_and_documents_it(tmp_path, capsys) -> None:
    path = tmp_path / "m.json"
    path.write_text(cfopt.generate_mission(20, 10, 5, 1, seed=0).to_json())
    assert main(["run", "grape-s", str(path), "--network", "seed loss=0.1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["network"]["spec"] == "seed loss=0.1"
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    assert "'seed' is the seed-calibrated profile" in help_text
    assert main(["run", "grape-s", str(path), "--network", "seed k=4"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: --network: token 'k=4'")
