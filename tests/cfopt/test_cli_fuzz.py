"""Whole command-line invocations fuzzed by hypothesis: arbitrary bytes or mutated missions
and assignments as the files, arbitrary values for every option.  No invocation may end
with anything but 0 (an answer) or 2 (bad input, one ``error:`` line): an exception that
escapes ``cfopt.cli.main`` is a bug (exit 1) and fails the test.

The bulk runs the command line in this process (``main(argv)``, the entry point the
``cfopt`` script calls); a few examples run it as a real process as well.
"""

from __future__ import annotations

import contextlib
import io
import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cfopt.cli import main
from proofs.strategies import assignments, missions

JSON = st.recursive(
    st.none()
    | st.booleans()
    | st.integers()
    | st.floats()
    | st.text(max_size=5)
    | st.sampled_from([10**400, -(10**309), 2**31, 2**63, 1e308, "\ud800"]),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=4), inner, max_size=3)
    ),
    max_leaves=8,
)
NUMBERS = st.integers(-3, 40).map(str) | st.sampled_from(
    ["1e300", "-1e300", "nan", "inf", "-0", "0.5", "1e-300", "", "x", "9" * 30, "1_0", "0x10"]
)
TEXT = st.text(alphabet=st.characters(blacklist_categories=("Nd", "Cs")), max_size=6)
VALUES = NUMBERS | TEXT


def _paths(value: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix]
    if isinstance(value, dict):
        for key, inner in value.items():
            out += _paths(inner, (*prefix, key))
    elif isinstance(value, list):
        for index, inner in enumerate(value):
            out += _paths(inner, (*prefix, index))
    return out


@st.composite
def mutated(draw: st.DrawFn, data: Any) -> Any:
    """``data`` with one place replaced, removed, or given an extra key."""
    path = draw(st.sampled_from(_paths(data)))
    if not path:
        return draw(JSON)
    parent = data
    for key in path[:-1]:
        parent = parent[key]
    action = draw(st.sampled_from(["replace", "remove", "extra"]))
    if action == "replace":
        parent[path[-1]] = draw(JSON)
    elif action == "remove":
        del parent[path[-1]]
    elif isinstance(parent, dict):
        parent[draw(st.text(max_size=4))] = draw(JSON)
    return data


def _encode(value: Any) -> bytes:
    try:
        return json.dumps(value, allow_nan=True).encode("utf-8", "surrogatepass")
    except (ValueError, RecursionError):
        return b"{}"


@st.composite
def files(draw: st.DrawFn) -> tuple[bytes, bytes]:
    """A mission file and an assignment file, from junk to almost right."""
    kind = draw(st.sampled_from(["bytes", "json", "mutated", "mutated", "valid", "valid", "valid"]))
    mission = draw(missions(max_robots=4, max_tasks=3, max_services=3))
    assignment = draw(assignments(mission)).to_dict(mission)
    if kind == "bytes":
        return draw(st.binary(max_size=200)), draw(st.binary(max_size=100))
    if kind == "json":
        return _encode(draw(JSON)), _encode(draw(JSON))
    if kind == "mutated":
        which = draw(st.sampled_from(["mission", "assignment"]))
        if which == "mission":
            return _encode(draw(mutated(mission.to_dict()))), _encode(assignment)
        return _encode(mission.to_dict()), _encode(draw(mutated(assignment)))
    return _encode(mission.to_dict()), _encode(assignment)


def _option(name: str) -> st.SearchStrategy[list[str]]:
    return st.lists(VALUES, max_size=1).map(lambda v: [name, *v] if v else [])


@st.composite
def _sane_generate(draw: st.DrawFn) -> list[str]:
    types = draw(st.integers(1, 6))
    return [
        "--robots", str(draw(st.integers(1, 40))),
        "--percent-tasks", str(draw(st.floats(0.5, 100))),
        "--service-types", str(types),
        "--services-per-robot", str(draw(st.integers(1, types))),
        "--load", str(draw(st.sampled_from([0.5, 1, 1.25, 2]))),
        "--seed", str(draw(st.integers(0, 2**32))),
    ]  # fmt: skip


@st.composite
def invocations(draw: st.DrawFn) -> list[str]:
    """Half of them with junk option values, half with sensible ones (so that the answers,
    not only the refusals, are exercised)."""
    command = draw(st.sampled_from(["validate", "solve", "run", "check", "generate"]))
    sane = draw(st.booleans())
    argv = [command]
    if command == "generate":
        if sane:
            argv += draw(_sane_generate())
        else:
            for flag in ("--robots", "--percent-tasks", "--service-types", "--services-per-robot"):
                argv += [flag, draw(NUMBERS)] if draw(st.integers(0, 9)) else []
            for flag in ("--load", "--seed"):
                argv += draw(_option(flag))
        argv += draw(st.sampled_from([[], ["-o", "out.json"], ["-o", "-"], ["-o", "m.json"]]))
        return argv
    if command == "run":
        names = st.sampled_from(["grape-s", "pair-grape-s", "sda", "rachna-dt"])
        argv.append(draw(names if sane else names | TEXT))
    argv.append(
        draw(st.sampled_from(["m.json", "m.json", "m.json", "m.json", "missing.json", "."]))
    )
    if command == "check":
        argv.append(draw(st.sampled_from(["a.json", "a.json", "a.json", "m.json", "missing.json"])))
        argv += draw(st.sampled_from([[], ["--capped"]]))
    if command == "solve":
        sane_limit = st.sampled_from([[], ["--time-limit", "10"], ["--time-limit", "1e-9"]])
        argv += draw(sane_limit if sane else _option("--time-limit"))
        argv += draw(st.sampled_from([[], ["--formulation", "assignment"], ["--formulation", "x"]]))
    if command == "run":
        if sane:
            argv += ["--seed", str(draw(st.integers(0, 99)))]
            argv += draw(st.sampled_from([[], ["--order", "random"]]))
        else:
            argv += draw(_option("--seed")) + draw(_option("--order"))
    if command in ("solve", "run"):
        argv += draw(st.sampled_from([[], ["-o", "out.json"], ["-o", "a.json"], ["-o", "-"]]))
    argv += draw(st.sampled_from([[], ["--json"]]))
    return argv


def _in_process(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's usage errors
            code = exc.code
    return code, err.getvalue()


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(argv=invocations(), contents=files())
def test_every_invocation_ends_with_0_or_2(argv: list[str], contents: tuple[bytes, bytes]):
    with tempfile.TemporaryDirectory() as tmp, contextlib.chdir(tmp):
        Path("m.json").write_bytes(contents[0])
        Path("a.json").write_bytes(contents[1])
        code, err = _in_process(argv)
    assert code in (0, 2), (argv, code, err)
    if code == 2:
        assert err.startswith("error: ") and err.count("\n") == 1, err


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(argv=invocations(), contents=files())
def test_real_processes_end_with_0_or_2(argv: list[str], contents: tuple[bytes, bytes]):
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "m.json").write_bytes(contents[0])
        Path(tmp, "a.json").write_bytes(contents[1])
        result = subprocess.run(
            [sys.executable, "-m", "cfopt", *argv], cwd=tmp, capture_output=True, timeout=120
        )
    assert result.returncode in (0, 2), (argv, result.stderr.decode(errors="replace"))
    if result.returncode == 2:
        assert result.stderr.startswith(b"error: ") and result.stderr.count(b"\n") == 1
