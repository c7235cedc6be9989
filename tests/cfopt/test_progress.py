"""Progress on stderr: heartbeats in a log, reused work on a bar, terminals of no size.

The heartbeats are driven by a fake clock: no test sleeps or measures time.
"""

from __future__ import annotations

import io
import os
import re
import threading

import pytest

from cfopt._progress import HEARTBEAT_SECONDS, Progress, terminal_shape


class FakeClock:
    """A clock that moves only when told."""

    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now

    def advance(self, seconds: float) -> None:
        self.now += seconds


class Terminal(io.StringIO):
    """A stream that says it is a terminal (of whatever size os.get_terminal_size says)."""

    def isatty(self) -> bool:
        return True

    def fileno(self) -> int:
        return 2


def _lines(clock: FakeClock) -> tuple[Progress, io.StringIO]:
    stream = io.StringIO()
    return Progress("lines", stream, clock=clock, tick=None), stream


def test_a_log_gets_a_heartbeat_line_every_30_seconds() -> None:
    clock = FakeClock()
    progress, stream = _lines(clock)
    stage = progress.stage("trials", 1424, "trial", "1424 to run")
    clock.advance(10)
    stage.update()
    assert stream.getvalue() == "trials: 1424 to run\n"  # not yet 30 s
    clock.advance(HEARTBEAT_SECONDS - 10)
    stage.update(2)
    clock.advance(1)
    stage.update()  # one second after a heartbeat: none
    clock.advance(HEARTBEAT_SECONDS)
    stage.update()
    clock.advance(4 * 60 - 2 * HEARTBEAT_SECONDS - 1)
    stage.close("5 run, 0 already stored")
    assert stream.getvalue().splitlines() == [
        "trials: 1424 to run",
        "trials: 3/1424 trials, 30.0 s elapsed, 10.0 s/trial",
        "trials: 5/1424 trials, 1 min 01 s elapsed, 12.2 s/trial",
        "trials: 5 run, 0 already stored (4 min 00 s)",
    ]


def test_a_heartbeat_says_the_rate_reused_work_and_the_postfix() -> None:
    clock = FakeClock()
    progress, stream = _lines(clock)
    stage = progress.stage("claims", 120, "claim", reused=6)
    clock.advance(HEARTBEAT_SECONDS)
    stage.update(60)
    stage.set_postfix(failed=1)
    clock.advance(HEARTBEAT_SECONDS)
    assert stage.beat()
    assert stream.getvalue().splitlines() == [
        "claims: 60/120 claims, 30.0 s elapsed, 2.00 claims/s, 6 reused",
        "claims: 60/120 claims, 1 min 00 s elapsed, 1.00 claims/s, 6 reused, failed 1",
    ]
    assert not stage.beat()  # due again only 30 s later


def test_no_heartbeat_after_close_nor_when_quiet_nor_on_a_bar() -> None:
    clock = FakeClock()
    progress, stream = _lines(clock)
    stage = progress.stage("trials", 2, "trial")
    stage.close()
    clock.advance(10 * HEARTBEAT_SECONDS)
    assert not stage.beat()
    assert stream.getvalue() == "trials: 0 of 2 trials done (0.0 s)\n"
    quiet = Progress("off", io.StringIO(), clock=clock, tick=None)
    silent = quiet.stage("trials", 2, "trial")
    clock.advance(10 * HEARTBEAT_SECONDS)
    assert not silent.beat()
    assert quiet.stream.getvalue() == ""


def test_the_ticker_beats_while_no_unit_finishes() -> None:
    """A stage whose units take minutes still shows signs of life: the background thread
    prints the heartbeat without any update (waited for as a state, with a fake clock)."""
    clock = FakeClock()
    stream = io.StringIO()
    progress = Progress("lines", stream, clock=clock, tick=0.01)
    stage = progress.stage("trials", 3, "trial")
    clock.advance(HEARTBEAT_SECONDS)
    seen = threading.Event()
    for _ in range(100_000):
        if "trials: 0/3 trials, 30.0 s elapsed" in stream.getvalue():
            seen.set()
            break
        seen.wait(0.01)
    stage.close()
    assert seen.is_set(), stream.getvalue()
    assert stream.getvalue().count("elapsed") == 1  # the clock stood still since


@pytest.mark.parametrize("size", [(0, 0), (0, 40), (120, 0)])
def test_a_terminal_of_no_size_still_shows_a_bar(
    monkeypatch: pytest.MonkeyPatch, size: tuple[int, int]
) -> None:
    monkeypatch.setattr(os, "get_terminal_size", lambda fd=None: os.terminal_size(size))
    assert terminal_shape(Terminal()) == (
        (size[0] or 80) - 1,
        (size[1] or 24) - 1,
    )
    stream = Terminal()
    progress = Progress.auto(stream=stream)
    assert progress.mode == "bar"
    stage = progress.stage("trials", 10, "trial")
    stage.update(3)
    stage.close()
    shown = stream.getvalue().replace("\r", "\n")
    assert re.search(r"trials:\s+30%.*3/10", shown), repr(stream.getvalue())


def test_a_resumed_stage_says_reused_on_its_bar(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(os, "get_terminal_size", lambda fd=None: os.terminal_size((100, 30)))
    stream = Terminal()
    stage = Progress("bar", stream).stage("claims", 18, "claim", "18 to check", reused=6)
    stage.update(2)
    stage.close()
    assert "claims, 6 reused:" in stream.getvalue()
    assert "2/18" in stream.getvalue()
