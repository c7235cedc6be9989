"""The ``cfopt`` command line: parse, call the API, print.

Exit codes: 0 success (an unstable or suboptimal answer is still an answer), 2 bad
input or usage (one line on stderr starting ``error:``, no traceback: also a file that
cannot be written, a request too large for this machine's memory), 1 an internal failure
(a bug: the traceback is printed), 130 interrupted by Ctrl-C (SIGINT) and 143 stopped by
SIGTERM, with one line on stderr and everything already stored kept.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import json
import math
import os
import signal
import sys
import textwrap
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, Any, NoReturn

from cfopt import __version__
from cfopt.errors import MissionError, byte_count, plural

if TYPE_CHECKING:
    from cfopt.mission import Mission

__all__ = ["main"]

EXIT_OK, EXIT_BUG, EXIT_BAD_INPUT = 0, 1, 2
#: ``128 + signal number``, as shells report a process ended by that signal.
EXIT_SIGINT, EXIT_SIGTERM = 130, 143
#: Write errors of the streams (a full disk, a quota, a file size limit): bad luck, not a bug.
_WRITE_ERRNOS = {errno.ENOSPC, errno.EFBIG, errno.EIO, getattr(errno, "EDQUOT", errno.ENOSPC)}
#: Violations listed per kind in human-readable output (``--json`` lists them all).
_SHOWN = 10

Handler = Callable[[argparse.Namespace], int]


class Parser(argparse.ArgumentParser):
    """argparse with the house error convention: one ``error:`` line, exit 2."""

    def error(self, message: str) -> NoReturn:
        sys.stderr.write(f"error: {message} (see '{self.prog} --help')\n")
        sys.exit(EXIT_BAD_INPUT)


# ------------------------------------------------------------------ argument types
def _whole_number(low: int) -> Callable[[str], int]:
    def parse(text: str) -> int:
        if len(text.strip()) > 100:
            raise argparse.ArgumentTypeError(
                f"must be a whole number of at most 100 digits, got {len(text)} characters"
            )
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be >= {low}, got {value}")
        return value

    return parse


def _number(*, positive: bool) -> Callable[[str], float]:
    """A number option's parser: finite, and > 0 when ``positive``."""
    what = "a finite number > 0" if positive else "a finite number"

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
        if not math.isfinite(value) or (positive and value <= 0):
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
        return value

    return parse


_positive_number = _number(positive=True)


def time_limit_type(text: str) -> float:
    """``--time-limit SEC``: a finite number of seconds > 0, at most 1e9 (about 31 years;
    a distributed run's own ceiling, 8796 simulated seconds, is the simulator's check)."""
    from cfopt._limits import MAX_TIME_LIMIT

    value = _positive_number(text)
    if value > MAX_TIME_LIMIT:
        raise argparse.ArgumentTypeError(
            f"must be at most {MAX_TIME_LIMIT:g} seconds (about 31 years), got {text!r}"
        )
    return value


def _path_type(what: str, *, dash: bool) -> Callable[[str], str]:
    """A path option: never empty; ``-`` (stdin or stdout) only where ``dash`` allows it."""

    def parse(text: str) -> str:
        if not text:
            raise argparse.ArgumentTypeError(f"must name {what}, got an empty path")
        if text == "-" and not dash:
            raise argparse.ArgumentTypeError(
                f"must name {what}; '-' (stdin or stdout) cannot be one"
            )
        return text

    return parse


_OUTPUT_FILE = _path_type("a file", dash=True)
_REPORT_DIRECTORY = _path_type("a directory (a report is a folder of files)", dash=False)
_STORE_FILE = _path_type("an SQLite file (the result store)", dash=False)
#: ``--force`` for ``-o FILE``: the rule every file output follows.
_FORCE_FILE_HELP = (
    "replace FILE if it exists (atomically: a temporary file beside it is renamed into "
    "place); a directory or a device other than /dev/null is refused even so"
)
#: ``--force`` for ``-o DIR``.
_FORCE_DIRECTORY_HELP = "replace the report files already in DIR (its other files are left alone)"


# ------------------------------------------------------------------------ helpers
def load_mission(path: str) -> Mission:
    """Load a mission from a path, or from standard input for ``-``."""
    from cfopt.mission import Mission

    return Mission.from_json(sys.stdin if path == "-" else path)


def emit_json(obj: Any) -> None:
    """Print one JSON object on stdout (``--json`` output)."""
    sys.stdout.write(json.dumps(obj, ensure_ascii=False) + "\n")


def write_output(text: str, target: str, force: bool) -> None:
    """Write ``text`` to a file (atomically) or to stdout (``-``); never replace a file
    unless forced."""
    from cfopt._jsonio import write_text

    if target == "-":
        sys.stdout.write(text)
    else:
        write_text(text, target, overwrite=force)


class NullOutputs(contextlib.ExitStack):
    """The outputs of one command given as the null device (``-o /dev/null``, ``--store
    /dev/null``), for a ``with`` block: the command still computes and prints, and keeps
    nothing.

    :meth:`place` gives such an output a temporary path instead (removed, with whatever
    was written there, when the block ends); :meth:`shown` and :meth:`discards` say so in
    what the command prints.
    """

    def __init__(self) -> None:
        super().__init__()
        self.folders: list[str] = []

    def place(self, path: str | None, name: str) -> str | None:
        """``path``, or for the null device ``name`` in a fresh temporary folder."""
        import tempfile

        from cfopt._jsonio import is_null_device

        if path is None or path == "-" or not is_null_device(path):
            return path
        folder = self.enter_context(tempfile.TemporaryDirectory(prefix="cfopt-discarded-"))
        self.folders.append(folder)
        return os.path.join(folder, name)

    def discards(self, path: Any) -> bool:
        """Whether ``path`` is one of the temporary places (so: discarded)."""
        text = os.fspath(path) if isinstance(path, str | os.PathLike) else None
        return text is not None and any(
            text == f or text.startswith(f + os.sep) for f in self.folders
        )

    def shown(self, value: Any) -> Any:
        """A JSON-ready ``value`` as printed: the temporary paths in lists left out, the
        others shown as the null device."""
        if isinstance(value, dict):
            return {k: os.devnull if self.discards(v) else self.shown(v) for k, v in value.items()}
        if isinstance(value, list):
            return [self.shown(v) for v in value if not self.discards(v)]
        return value


#: What a command prints for the files it wrote to the null device.
_DISCARDED = f"discarded ({os.devnull})"


def _yes_no(value: bool) -> str:
    return "yes" if value else "no"


def _add_output_options(sub: argparse.ArgumentParser) -> None:
    """``-o FILE`` and ``--force`` for the commands that produce an assignment."""
    sub.add_argument(
        "-o",
        "--output",
        type=_OUTPUT_FILE,
        default=None,
        metavar="FILE",
        help="also write the assignment to FILE (cfopt.assignment/1, what 'cfopt check' "
        "reads; its folder must exist; /dev/null discards it); '-' prints only the "
        "assignment JSON on stdout and the summary on stderr",
    )
    sub.add_argument("--force", action="store_true", help=_FORCE_FILE_HELP)


def _print_result(summary: list[str], assignment_json: str, args: argparse.Namespace) -> None:
    """The summary lines, then the assignment: to FILE, alone on stdout (``-o -``), or after
    the summary."""
    if args.output == "-":
        sys.stderr.write("\n".join(summary) + "\n")
        sys.stdout.write(assignment_json)
        return
    print("\n".join(summary))
    if args.output is None:
        sys.stdout.write(assignment_json)
    else:
        print(f"assignment: {args.output}")


def _save_assignment(assignment_json: str, args: argparse.Namespace) -> None:
    if args.output not in (None, "-"):
        write_output(assignment_json, args.output, args.force)


def _add_workers_option(sub: argparse.ArgumentParser) -> None:
    """``--workers N``, shared by the commands that run trials in parallel."""
    sub.add_argument(
        "--workers",
        type=_whole_number(1),
        default=None,
        metavar="N",
        help="worker processes (default: the usable CPUs; 1 = this process)",
    )


def _add_scheduler_option(sub: argparse.ArgumentParser) -> None:
    """``--scheduler ADDRESS|local:N``: run the trials on a dask cluster."""
    from cfopt._limits import CONNECT_TIMEOUT

    sub.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS|local:N",
        help="run the trials on a dask cluster: a running scheduler's address, "
        f"tcp://HOST:PORT or HOST:PORT, that must answer within {CONNECT_TIMEOUT:g} s, or "
        "local:N, a local cluster of N worker processes started for this run; the store "
        'stays with this process (needs: pip install "cfopt[cluster]")',
    )


def _trial_executor(args: argparse.Namespace) -> contextlib.AbstractContextManager[Any]:
    """The executor of ``--scheduler`` for a ``with`` block, or ``None`` (``--workers``)."""
    if args.scheduler is None:
        return contextlib.nullcontext(None)
    if args.workers is not None:
        raise MissionError(
            "--workers: not with --scheduler (the cluster's workers run the trials; "
            "give local:N for N local worker processes)"
        )
    from cfopt.cluster import dask_executor, parse_scheduler

    return dask_executor(parse_scheduler(args.scheduler), logs=False)  # one error line


# ----------------------------------------------------------------------- commands
def _add_generate(sub: argparse.ArgumentParser) -> Handler:
    sub.add_argument(
        "--robots", type=_whole_number(1), required=True, metavar="N", help="collective size n"
    )
    sub.add_argument(
        "--percent-tasks",
        type=_positive_number,
        required=True,
        metavar="P",
        help="tasks as a percentage of n: m = max(1, round(n P / 100))",
    )
    sub.add_argument(
        "--service-types",
        type=_whole_number(1),
        required=True,
        metavar="S",
        help="number of service types",
    )
    sub.add_argument(
        "--services-per-robot",
        type=_whole_number(1),
        required=True,
        metavar="K",
        help="distinct services each robot has (K <= S)",
    )
    sub.add_argument(
        "--load",
        type=_positive_number,
        default=1.0,
        metavar="L",
        help="total requirement / n: 1 achievable (default), >1 over-subscribed, <1 spare robots",
    )
    sub.add_argument(
        "--seed",
        type=_whole_number(0),
        default=None,
        metavar="X",
        help="random seed (same seed, same file, byte for byte); default: fresh",
    )
    sub.add_argument(
        "-o",
        "--output",
        type=_OUTPUT_FILE,
        default="-",
        metavar="FILE",
        help="where to write the mission JSON ('-' = stdout, the default; /dev/null "
        "discards it); its folder must exist",
    )
    sub.add_argument("--force", action="store_true", help=_FORCE_FILE_HELP)

    def run(args: argparse.Namespace) -> int:
        from cfopt.generate import generate_mission

        mission = generate_mission(
            robots=args.robots,
            percent_tasks=args.percent_tasks,
            service_types=args.service_types,
            services_per_robot=args.services_per_robot,
            load=args.load,
            seed=args.seed,
        )
        write_output(mission.to_json(), args.output, args.force)
        return EXIT_OK

    return run


def _add_validate(sub: argparse.ArgumentParser) -> Handler:
    sub.add_argument("mission", metavar="MISSION", help="mission JSON file ('-' = stdin)")
    sub.add_argument("--json", action="store_true", help="print one JSON object")

    def run(args: argparse.Namespace) -> int:
        m = load_mission(args.mission)
        if args.json:
            emit_json(
                {
                    "valid": True,
                    "robots": m.n_robots,
                    "tasks": m.n_tasks,
                    "services": m.n_services,
                    "total_utility": m.total_utility,
                }
            )
        else:
            print(
                f"ok: {plural(m.n_robots, 'robot')}, {plural(m.n_tasks, 'task')}, "
                f"{plural(m.n_services, 'service')}"
            )
        return EXIT_OK

    return run


def _add_audit(sub: argparse.ArgumentParser) -> Handler:
    sub.add_argument(
        "--quick",
        action="store_true",
        help="100-robot cells only, 2 missions each, claims budget 5 (a minute or two)",
    )
    sub.add_argument(
        "--claims-only",
        action="store_true",
        help="only the claims: the verdict table, counterexamples in DIR/counterexamples",
    )
    sub.add_argument(
        "--claims",
        action="append",
        metavar="CLAIM",
        help="check exactly the claims given instead of every registered one (repeatable, "
        "in the order given): a claim id (L1, or one an installed package registers) or "
        "MODULE:ATTR, ATTR a Claim, a list of Claims or a callable returning them, MODULE "
        "imported with the current directory first on sys.path; e.g. --claims L1 --claims "
        "my_claims:CLAIMS. The gap report still runs unless --claims-only",
    )
    sub.add_argument(
        "--algorithm",
        action="append",
        dest="algorithms",
        default=None,
        metavar="NAME",
        help="also put this algorithm on the audit grid, beside the registered ones (which "
        "it runs anyway), and check its generic claims (NAME.valid, NAME.stable as its spec "
        "declares, NAME.95pct of the optimum, NAME.scaling) in the verdict table: a "
        "registered name or MODULE:ATTR (as 'cfopt run' takes); repeatable. With "
        "--claims-only and no --claims, only these claims are checked",
    )
    sub.add_argument("--json", action="store_true", help="print one JSON object")
    sub.add_argument(
        "-o",
        "--output",
        type=_REPORT_DIRECTORY,
        default="cfopt-audit",
        metavar="DIR",
        help="report directory, created if missing (its parent folder must exist; default: "
        "cfopt-audit); its trials.sqlite lets an interrupted audit resume; /dev/null: "
        "compute and print, keep nothing",
    )
    sub.add_argument("--force", action="store_true", help=_FORCE_DIRECTORY_HELP)
    _add_workers_option(sub)
    _add_quiet_option(sub)

    def run(args: argparse.Namespace) -> int:
        with NullOutputs() as null:
            return _audit(args, null, null.place(args.output, "audit"))

    return run


def _audit(args: argparse.Namespace, null: NullOutputs, directory: Any) -> int:
    from cfopt._progress import Progress
    from cfopt.audit import run_audit

    result = run_audit(
        directory,
        quick=args.quick,
        claims_only=args.claims_only,
        algorithms=args.algorithms,
        workers=args.workers,
        force=args.force,
        progress=Progress.auto(quiet=args.quiet),
        claims=args.claims,
    )
    if args.json:
        emit_json(null.shown(result.to_dict()))
        return _report_failures(result.outcome, result.failures)
    from proofs.claims import format_verdict_table

    if result.report is not None:
        print(result.report.summary)
        print()
    print(format_verdict_table(result.verdicts))
    if null.discards(directory):
        print(f"report and counterexamples: {_DISCARDED}")
    else:
        for path in result.claim_files:
            print(f"counterexample: {path}")
        if result.report is not None:
            print(f"report: {result.report.markdown}  {result.report.html}")
    return _report_failures(result.outcome, result.failures)


def _add_reproduce(sub: argparse.ArgumentParser) -> Handler:
    sub.add_argument(
        "--missions",
        type=_whole_number(1),
        default=25,
        metavar="N",
        help="missions per cell (default: the seed's 25; 2 gives a first look in minutes)",
    )
    sub.add_argument(
        "--centralized-only",
        action="store_true",
        help="skip the seed's distributed evaluation (the simulator's runs)",
    )
    sub.add_argument(
        "-o",
        "--output",
        type=_REPORT_DIRECTORY,
        default="cfopt-reproduce",
        metavar="DIR",
        help="report directory, created if missing (its parent folder must exist; default: "
        "cfopt-reproduce); /dev/null: compute and print, keep nothing",
    )
    sub.add_argument(
        "--store",
        type=_STORE_FILE,
        default=None,
        metavar="FILE",
        help="SQLite result store, created or resumed (default: DIR/trials.sqlite); "
        "/dev/null: a store of this run only, removed at its end",
    )
    sub.add_argument("--force", action="store_true", help=_FORCE_DIRECTORY_HELP)
    sub.add_argument("--json", action="store_true", help="print one JSON object")
    _add_workers_option(sub)
    _add_scheduler_option(sub)
    _add_quiet_option(sub)

    def run(args: argparse.Namespace) -> int:
        with NullOutputs() as null:
            return _reproduce(args, null)

    return run


def _reproduce(args: argparse.Namespace, null: NullOutputs) -> int:
    from cfopt._progress import Progress
    from cfopt.reproduce import run_reproduce, verdict_tally

    directory = null.place(args.output, "reproduce")
    with _trial_executor(args) as executor:
        result = run_reproduce(
            directory,
            missions=args.missions,
            workers=args.workers,
            executor=executor,
            store=null.place(args.store, "trials.sqlite"),
            distributed=not args.centralized_only,
            force=args.force,
            progress=Progress.auto(quiet=args.quiet),
        )
    if args.json:
        emit_json(null.shown(result.to_dict()))
    else:
        for line in result.sample:
            print(f"sample, {line}")
        print(
            f"{plural(len(result.comparisons), 'comparison')} with the paper: "
            f"{verdict_tally(result.counts())}"
        )
        if null.discards(directory):
            print(f"report: {_DISCARDED}")
        else:
            print(
                f"report: {result.directory / 'reproduction.md'}  "
                f"{result.directory / 'reproduction.html'}"
            )
    code = EXIT_OK
    for outcome in result.outcomes:
        code = max(code, _report_failures(outcome))
    return code


def _add_quiet_option(sub: argparse.ArgumentParser) -> None:
    sub.add_argument(
        "--quiet",
        action="store_true",
        help="no progress on stderr (by default: bars on a terminal, one line per stage otherwise)",
    )


def _add_solve(sub: argparse.ArgumentParser) -> Handler:
    sub.add_argument("mission", metavar="MISSION", help="mission JSON file ('-' = stdin)")
    sub.add_argument(
        "--time-limit",
        type=time_limit_type,
        default=None,
        metavar="SEC",
        help="seconds the whole solve may take (model building included, within 0.25 s); "
        "then the best assignment found and the proven bound are reported with status "
        "time_limit (default: no limit; at most 1e9 s)",
    )
    sub.add_argument(
        "--formulation",
        choices=("aggregated", "assignment"),
        default="aggregated",
        help="ILP formulation: by capability type (default, small) or per robot (cross-check)",
    )
    sub.add_argument("--json", action="store_true", help="print one JSON object")
    _add_output_options(sub)

    def run(args: argparse.Namespace) -> int:
        from cfopt.exact import solve_exact

        m = load_mission(args.mission)
        check_output_free(args)
        result = solve_exact(m, time_limit=args.time_limit, formulation=args.formulation)
        assignment_json = result.assignment.to_json(m)
        _save_assignment(assignment_json, args)
        if args.json:
            emit_json(result.to_dict(m))
            return EXIT_OK
        summary = [
            f"{result.status.value}: utility {result.utility:g} of {result.total_utility:g}, "
            f"bound {result.bound:g}, gap {result.gap:.3g}, {result.seconds:.3f} s "
            f"({result.formulation} formulation)"
        ]
        _print_result(summary, assignment_json, args)
        return EXIT_OK

    return run


def _add_run(sub: argparse.ArgumentParser) -> Handler:
    sub.add_argument(
        "algorithm",
        metavar="ALGORITHM",
        help="a registered algorithm (listed below) or MODULE:ATTR, your own: a "
        "heuristics.AlgorithmSpec or a function (mission, *, seed=None, **options) -> Run or "
        "Assignment in MODULE, imported with the current directory first on sys.path; give it "
        "first: 'cfopt run ALGORITHM --help' lists its options",
    )
    sub.add_argument("mission", metavar="MISSION", help="mission JSON file ('-' = stdin)")
    _add_run_options(sub)

    def run(args: argparse.Namespace) -> int:
        from heuristics.registry import get_algorithm

        spec = get_algorithm(args.algorithm)
        distributed = args.network is not None or args.backend == "mpi"
        if args.ranks is not None and args.backend != "mpi":
            raise MissionError("--ranks: only with --backend mpi")
        _check_event_options(args)
        m = load_mission(args.mission)
        check_output_free(args)
        given = _given_options(args)
        _refuse_foreign(args, spec.name)
        if distributed:
            _refuse_options(given, spec.protocol_options, spec.name, distributed=True)
            result = _distributed(args, m, spec, given)
        else:
            _refuse_options(given, spec.options, spec.name, distributed=False)
            result = _centralized(args, m, spec, given)
        return finish_run(args, m, result, spec)

    return run


def _add_run_options(sub: argparse.ArgumentParser) -> None:
    """``cfopt run``'s own options, those of every algorithm (each algorithm's come from
    its spec: :func:`_add_algorithm_options`)."""
    sub.add_argument(
        "--seed",
        type=_whole_number(0),
        default=None,
        metavar="X",
        help="random seed (same seed, same run); default: fresh",
    )
    sub.add_argument("--network", default=None, metavar="SPEC", help=_NETWORK_HELP + _CHANNEL_HELP)
    sub.add_argument(
        "--time-limit",
        type=time_limit_type,
        default=None,
        metavar="SEC",
        help="wall-clock seconds after which a centralized run stops with the partition "
        "reached (status time_limit; default: no limit; for the algorithms that take "
        "time_limit); with --network simulated seconds after which the run is cut (default "
        "3600, at most 8796; real seconds with --backend mpi)",
    )
    sub.add_argument(
        "--backend",
        choices=("sim", "mpi"),
        default="sim",
        help="with --network: sim (default) runs the agents in the discrete-event simulator; "
        "mpi runs them as real MPI processes (launches mpiexec; needs the mpi extra: "
        'pip install "cfopt[mpi]"; without --network the network is complete)',
    )
    sub.add_argument(
        "--ranks",
        type=_whole_number(1),
        default=None,
        metavar="K",
        help="with --backend mpi: MPI processes, robots split among them in blocks "
        "(default 2, at most one per robot)",
    )
    sub.add_argument(
        "--gap",
        action="store_true",
        help="also solve the mission exactly (cfopt solve's ILP, HiGHS; usually "
        f"milliseconds, at most {_GAP_TIME_LIMIT:g} s) and print the percent of the optimum "
        "the run earns; 'optimal' only when HiGHS proved it, otherwise the proven bound",
    )
    sub.add_argument("--json", action="store_true", help="print one JSON object")
    _add_output_options(sub)
    _add_event_options(sub)


# ------------------------------------------------------------ mission events
def _add_event_options(sub: argparse.ArgumentParser) -> None:
    sub.add_argument(
        "--events",
        default=None,
        metavar="FILE",
        help="with --network (the simulator): a cfopt.events/1 timeline of mission events "
        "(robots fail or join, tasks arrive or are withdrawn, utilities change; a failure "
        "detector with heartbeats); the run reports what followed each event against the "
        "ILP optimum of the mission as it stands",
    )
    sub.add_argument(
        "--plot",
        type=_OUTPUT_FILE,
        default=None,
        metavar="PNG",
        help="with --events: write a plot of utility over simulated time, the optimum as "
        "a step line (refuses an existing file unless --force)",
    )


def _check_event_options(args: argparse.Namespace) -> None:
    if args.events is not None and (args.network is None or args.backend != "sim"):
        raise MissionError("--events: only with --network, in the simulator (--backend sim)")
    if args.plot is not None:
        if args.events is None:
            raise MissionError("--plot: only with --events")
        if os.path.exists(args.plot) and not args.force:
            raise MissionError(f"--plot: {args.plot} exists (--force overwrites it)")


def _judge_events(out: dict[str, Any], result: Any, mission: Mission) -> None:
    """Each event's survivors' stability (proofs' checker) in the JSON of a dynamic run."""
    dynamics = None if result.network is None else result.network.dynamics
    if dynamics is None:
        return
    from proofs.claims_dynamic import survivors_stable

    for event, row in zip(dynamics.events, out["network"]["dynamics"]["events"], strict=True):
        row["survivors_nash_stable"] = survivors_stable(mission, event)


def _dynamics_summary(dynamics: Any, mission: Mission) -> list[str]:
    if dynamics is None:
        return []
    from proofs.claims_dynamic import survivors_stable

    lines = [
        f"  events: detector D {dynamics.detector_seconds:g} s, heartbeat "
        f"{dynamics.heartbeat_seconds:g} s; optimum at the start {dynamics.initial_optimum:g}"
    ]
    for e in dynamics.events:
        if e.reconverge_seconds is None:
            back = "beliefs not agreeing"
        else:
            back = f"re-converged in {e.reconverge_seconds:.3f} s"
        lines.append(
            f"  {e.at_seconds:g} s {e.kind} {e.target}: {back}, utility {e.utility_after:g} "
            f"of optimum {e.optimum:g}, survivors Nash stable "
            f"{_yes_no(survivors_stable(mission, e))}, "
            f"{plural(e.transmissions, 'transmission')}, {plural(e.bytes, 'byte')}"
        )
    return lines


#: Seconds ``cfopt run --gap`` gives the exact solve (a sweep's default).
_GAP_TIME_LIMIT = 60.0
#: The ``dest`` prefix of an algorithm's own flags.
_OPTION_DEST = "option:"
#: Options that ``cfopt run``'s own flags give (not flags of their own).
_RUN_FLAGS = {"time_limit": "--time-limit"}


def _option_value(option: Any) -> Callable[[str], Any]:
    """How a flag's text becomes the option's value (bools are flags without one)."""
    if option.type is int:
        return _whole_number(-(10**100))
    if option.type is float:
        return _number(positive=False)
    return str


def _option_help(option: Any, distributed: str) -> str:
    default = "" if option.default is None else f" (default: {option.default})"
    return f"{distributed}{option.help}{default}"


def _add_algorithm_options(sub: argparse.ArgumentParser, spec: Any) -> None:
    """The flags of ``spec``'s options (centralized runs) and protocol options
    (``--network``), and a description of the algorithm for ``--help``."""
    group = sub.add_argument_group(
        f"options of {spec.name}",
        f"{spec.summary or spec.name}. Stability: {spec.stability.description}; version "
        f"{spec.version}; "
        + ("distributed runs with --network." if spec.distributed else "no distributed runs."),
    )
    central = {o.name for o in spec.options}
    agents = {o.name for o in spec.protocol_options}
    for option in (*spec.options, *(o for o in spec.protocol_options if o.name not in central)):
        if option.name in _RUN_FLAGS:
            continue
        where = (
            "" if option.name not in agents else
            "distributed runs: " if option.name not in central else
            "also for distributed runs: "
        )  # fmt: skip
        extra: dict[str, Any] = (
            {"action": argparse.BooleanOptionalAction}
            if option.type is bool
            else {"type": _option_value(option), "choices": option.choices, "metavar": None}
        )
        if option.choices is None and option.type is not bool:
            extra["metavar"] = option.type.__name__.upper()
        try:
            group.add_argument(
                option.flag,
                dest=_OPTION_DEST + option.name,
                default=None,
                help=_option_help(option, where),
                **extra,
            )
        except argparse.ArgumentError:  # a flag of cfopt run itself
            raise MissionError(
                f"{spec.name}: option {option.name!r} takes the flag {option.flag} of "
                "cfopt run itself; rename the option"
            ) from None


def _given_options(args: argparse.Namespace) -> dict[str, Any]:
    """The algorithm's options given on the command line, by name."""
    return {
        key[len(_OPTION_DEST) :]: value
        for key, value in vars(args).items()
        if key.startswith(_OPTION_DEST) and value is not None
    }


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def _refuse_options(
    given: dict[str, Any], allowed: Sequence[Any], name: str, *, distributed: bool
) -> None:
    """Refuse the given options that this kind of run of algorithm ``name`` does not take."""
    names = [o.name for o in allowed if o.name not in _RUN_FLAGS]
    wrong = [n for n in given if n not in names]
    if not wrong:
        return
    flags = " and ".join(map(_flag, wrong))
    if not distributed:
        raise MissionError(f"{flags}: only for distributed runs of {name} (with --network)")
    takes = ", ".join(map(_flag, names)) or "no options"
    raise MissionError(
        f"{flags}: not for distributed runs ({name}'s agents take {takes}; the network spec "
        "and the robots' clocks decide the rest)"
    )


def _centralized(args: argparse.Namespace, m: Mission, spec: Any, given: dict[str, Any]) -> Any:
    from heuristics.registry import AlgorithmFailed

    if args.time_limit is not None:
        if "time_limit" not in {o.name for o in spec.options}:
            raise MissionError(f"--time-limit: {spec.name} takes no time limit")
        given = {**given, "time_limit": args.time_limit}
    try:
        return spec(m, seed=args.seed, **given)
    except AlgorithmFailed as exc:
        raise MissionError(f"{args.algorithm}: {exc.problem} (on {args.mission})") from None


def _prepare_run(sub: argparse.ArgumentParser, argv: Sequence[str]) -> None:
    """Phase one of ``cfopt run``'s parsing: find ALGORITHM, then add its flags and list
    the registered algorithms in the help."""
    from heuristics.registry import ALGORITHMS, algorithm_names, get_algorithm

    pre = Parser(prog=sub.prog, add_help=False)
    pre.add_argument("algorithm", nargs="?")
    _add_run_options(pre)
    _add_any_algorithm_flags(pre, ALGORITHMS.values())
    known, unknown = pre.parse_known_args(argv)
    if known.algorithm is not None and not known.algorithm.startswith("-"):
        try:
            spec = get_algorithm(known.algorithm)
        except MissionError as exc:
            raise _misplaced_option(argv, known.algorithm, unknown) or exc from None
        _add_algorithm_options(sub, spec)
        _add_any_algorithm_flags(sub, ALGORITHMS.values())
    lines = ["algorithms (cfopt run ALGORITHM --help shows an algorithm's options):"]
    rows = [
        (name, spec.summary, spec.stability.value, spec.distributed)
        for name, spec in ((n, ALGORITHMS[n]) for n in algorithm_names())
    ]
    for name, summary, stability, agents in rows:
        text = f"{summary} (stability: {stability}{'; distributed' if agents else ''})"
        lines += textwrap.wrap(
            text, 79, initial_indent=f"  {name:<20} ", subsequent_indent=" " * 23
        )
    lines.append(f"  {'MODULE:ATTR':<20} your own (see ALGORITHM above)")
    sub.epilog = "\n".join(lines)
    sub.formatter_class = argparse.RawDescriptionHelpFormatter


#: The ``dest`` prefix of the flags of other algorithms than the one run (refused).
_FOREIGN_DEST = "foreign:"


def _add_any_algorithm_flags(parser: argparse.ArgumentParser, specs: Any) -> None:
    """The flags of every registered algorithm, hidden, beside those ``parser`` has: so
    that phase one of the parsing knows which take a value (``cfopt run --eps 1 sda
    m.json`` finds ``sda``), and a flag of another algorithm is refused by its name."""
    for spec in specs:
        for option in (*spec.options, *spec.protocol_options):
            if option.name in _RUN_FLAGS:
                continue
            extra: dict[str, Any] = (
                {"action": argparse.BooleanOptionalAction} if option.type is bool else {}
            )
            with contextlib.suppress(argparse.ArgumentError):  # a flag it has already
                parser.add_argument(
                    option.flag,
                    dest=_FOREIGN_DEST + option.name,
                    default=None,
                    help=argparse.SUPPRESS,
                    **extra,
                )


def _refuse_foreign(args: argparse.Namespace, name: str) -> None:
    """Refuse the flags of other algorithms given to a run of algorithm ``name``."""
    given = [
        _flag(("no_" if value is False else "") + key[len(_FOREIGN_DEST) :])
        for key, value in vars(args).items()
        if key.startswith(_FOREIGN_DEST) and value is not None
    ]
    if given:
        raise MissionError(
            f"{' and '.join(given)}: not an option of {name} (another algorithm's; "
            f"'cfopt run {name} --help' lists its options)"
        )


def _misplaced_option(
    argv: Sequence[str], taken: str, unknown: Sequence[str]
) -> MissionError | None:
    """The error for ``cfopt run --flag VALUE ALGORITHM ...`` with a flag that no
    registered algorithm has (its value was taken for ALGORITHM); ``None`` otherwise."""
    before = list(argv[: list(argv).index(taken)])
    flags = [t for t in before if t.startswith("-") and t.split("=", 1)[0] in unknown]
    if not flags or before[-1] not in flags:
        return None
    return MissionError(
        f"{flags[-1]} {taken}: give ALGORITHM before its options ('cfopt run ALGORITHM "
        f"MISSION {flags[-1]} ...'; {taken!r} was read as the algorithm)"
    )


def finish_run(args: argparse.Namespace, m: Mission, result: Any, spec: Any | None = None) -> int:
    """What ``cfopt run`` prints and writes once ``result`` (a heuristics.Run) is there:
    the stability verdicts (the seed's, and the one ``spec``, the algorithm's
    :class:`heuristics.AlgorithmSpec`, declares), the optimal gap with ``--gap``, the
    summary or ``--json``, and ``-o FILE``."""
    a = result.assignment
    out = result.to_dict(m)
    assignment = out.pop("assignment")
    out.update(seed_stability(m, a))
    if spec is not None:
        out["declared_stability"] = declared_stability(spec, m, a)
    if getattr(args, "gap", False):
        out["gap"] = optimal_gap(m, out["utility"])
    out["assignment"] = assignment
    _judge_events(out, result, m)
    assignment_json = a.to_json(m)
    _save_assignment(assignment_json, args)
    if args.json:
        emit_json(out)
        return EXIT_OK
    summary = [
        f"{result.algorithm}: utility {out['utility']:g} of {out['total_utility']:g} "
        f"({out['percent_utility']:.2f}% of the total), {_counts_text(result)}, "
        f"{result.seconds:.3f} s{_status_note(result)}",
        f"stability under the seed's reward: Nash {_yes_no(out['nash_stable'])}, "
        f"pairwise (strict) {_yes_no(out['pairwise_stable'])}, "
        f"pairwise (pareto) {_yes_no(out['pairwise_stable_pareto'])}",
    ]
    if spec is not None:
        summary.append(_declared_text(spec.name, out["declared_stability"]))
    if "gap" in out:
        summary.append(_gap_text(out["gap"]))
    if result.network is not None:
        summary += _network_summary(result.network)
        summary += _dynamics_summary(result.network.dynamics, m)
    _print_result(summary, assignment_json, args)
    return EXIT_OK


def seed_stability(m: Mission, a: Any) -> dict[str, bool]:
    """The stability verdicts of ``cfopt run --json`` under the seed's reward."""
    import proofs

    return {
        "nash_stable": proofs.is_nash_stable(m, a),
        # strict pairwise stability (the seed's Theorem 1) coincides with Nash stability
        # under the seed's reward; the pareto notion is the informative one, so both
        "pairwise_stable": proofs.is_pairwise_stable(m, a),
        "pairwise_stable_pareto": proofs.is_pairwise_stable(m, a, mode="pareto"),
        "nash_stable_capped": proofs.is_nash_stable(m, a, capped=True),
        "pairwise_stable_capped": proofs.is_pairwise_stable(m, a, capped=True),
    }


def declared_stability(spec: Any, m: Mission, a: Any) -> dict[str, Any]:
    """The stability ``spec`` (an :class:`heuristics.AlgorithmSpec`) declares, checked.

    ``{"stability": "seed" | "capped" | "own" | "none", "promise": words, "stable":
    bool or None (nothing promised), "violations": count or None}``: ``seed`` is checked
    by :func:`proofs.nash_violations`, ``capped`` by it with capped moves and ``own`` by
    the spec's checker.
    """
    import proofs

    kind = spec.stability.value
    promise = spec.stability.description
    if kind == "own" and isinstance(spec.checker, str):
        promise = f"stable by {spec.checker}"
    checkers: dict[str, Callable[[], Any]] = {
        "seed": lambda: proofs.nash_violations(m, a),
        "capped": lambda: proofs.nash_violations(m, a, capped=True),
        "own": lambda: spec.stability_checker()(m, a),
    }
    violations = None if kind not in checkers else len(checkers[kind]())
    return {
        "stability": kind,
        "promise": promise,
        "stable": None if violations is None else violations == 0,
        "violations": violations,
    }


def _declared_text(name: str, declared: dict[str, Any]) -> str:
    if declared["stable"] is None:
        return f"stability under its own rule: none declared ({name} promises no stability)"
    verdict = _yes_no(declared["stable"])
    if declared["violations"]:
        verdict += f", {plural(declared['violations'], 'violation')}"
    return f"stability under its own rule ({declared['promise']}): {verdict}"


def optimal_gap(m: Mission, utility: float) -> dict[str, Any]:
    """``cfopt run --gap``: the exact solve of ``m`` and the share of it ``utility`` is.

    ``status`` is the solve's (``optimal`` only when HiGHS proved it); ``optimum`` the
    proven optimum (``None`` when not proven), ``incumbent`` the best utility the solve
    found and ``bound`` its proven upper bound; ``percent_of_optimum`` (``None`` when not
    proven) and ``percent_of_bound``, at most the percent of the optimum, are the run's.
    """
    from cfopt.exact import ExactStatus, solve_exact

    result = solve_exact(m, time_limit=_GAP_TIME_LIMIT)
    proven = result.status is ExactStatus.OPTIMAL
    return {
        "status": result.status.value,
        "optimum": result.utility if proven else None,
        "incumbent": result.utility,
        "bound": result.bound,
        "percent_of_optimum": _percent(utility, result.utility) if proven else None,
        "percent_of_bound": _percent(utility, result.bound),
        "seconds": result.seconds,
    }


def _percent(part: float, whole: float) -> float:
    return 100.0 if whole == 0 else 100.0 * part / whole


def _gap_text(gap: dict[str, Any]) -> str:
    took = f"{gap['seconds']:.3f} s"
    if gap["status"] == "optimal":
        return (
            f"optimum: {gap['optimum']:g} (proven optimal by HiGHS, {took}): the run earns "
            f"{gap['percent_of_optimum']:.2f}% of the optimum"
        )
    if gap["status"] == "time_limit":
        return (
            f"optimum: not proven in {_GAP_TIME_LIMIT:g} s (status time_limit, {took}): best "
            f"found {gap['incumbent']:g}, proven bound {gap['bound']:g}; the run earns at "
            f"least {gap['percent_of_bound']:.2f}% of the optimum"
        )
    return (
        f"optimum: unknown (the exact solve failed, status {gap['status']}, {took}); "
        f"trivial bound {gap['bound']:g}: the run earns at least "
        f"{gap['percent_of_bound']:.2f}% of the optimum"
    )


def _counts_text(result: Any) -> str:
    """``"3 iterations, 4 rounds, 80 messages, 1 byte"``, or that the algorithm did not
    report them."""
    if not result.counted:
        return "iterations, rounds, messages and bytes not reported"
    return (
        f"{plural(result.iterations, 'iteration')}, {plural(result.rounds, 'round')}, "
        f"{plural(result.messages, 'message')}, {byte_count(result.bytes)} of communication"
    )


def _status_note(result: Any) -> str:
    """What the summary adds for a run its time limit cut (nothing for a complete run)."""
    if result.status.value == "complete":
        return ""
    return " (stopped at the time limit: the partition reached so far)"


_NETWORK_HELP = (
    "run the algorithm's agents on a simulated network: a topology (complete, ring, grid, "
    "'geometric radius=R', 'er p=P', 'smallworld k=K p=P', 'file=PATH' of robot-id pairs) "
    "then key=value tokens: latency=constant:D|uniform:A:B|exponential:MEAN|"
    "lognormal:MEDIAN:SIGMA (durations with ns, us, ms or s; default constant:0ms), "
    "loss=P or loss=ge:P_GOOD_TO_BAD:P_BAD_TO_GOOD:LOSS_IN_BAD (default 0), "
    "medium=broadcast|unicast, period=D (clock, default 10ms), jitter=F (default 0.1), "
    "sync=true (lock-step clocks); or a cfopt.network/1 JSON file; or a profile in place "
    "of the topology, its fields overridden by the tokens after it: 'seed' is the "
    "seed-calibrated profile (complete, latency=uniform:1ms:10ms loss=0.01 as cfopt's "
    "default, period=3ms, robots stopping ceil(n^3/3000) quiet ticks after their last "
    "change: the broadcast period and halting rule the seed paper's figures imply). "
    "Example: --network 'geometric radius=0.25 latency=uniform:1ms:20ms loss=0.05'"
)


def _distributed(
    args: argparse.Namespace, mission: Mission, spec: Any, given: dict[str, Any]
) -> Any:
    from cfopt.experiments import distributed_agents
    from heuristics.simulate import DEFAULT_TIME_LIMIT, simulate

    agents, options = distributed_agents(args.algorithm, given)
    if args.backend == "mpi":
        from heuristics.mpi import mpi_run

        if options:  # a registered name: its protocol with these options
            agents = spec.make_protocol(**options)
        return mpi_run(
            mission,
            agents,
            args.network or "complete",
            ranks=2 if args.ranks is None else args.ranks,
            seed=args.seed,
            time_limit=args.time_limit or DEFAULT_TIME_LIMIT,
        )
    run = simulate(
        mission,
        agents,
        args.network,
        seed=args.seed,
        time_limit=args.time_limit or DEFAULT_TIME_LIMIT,
        options=options,
        events=args.events,
    )
    if args.plot is not None:
        from heuristics.transport.events import plot_utility

        plot_utility(run.network.dynamics, args.plot, f"{run.algorithm}, {args.network}")
    return run


def _network_summary(report: Any) -> list[str]:
    lost = report.losses / max(report.receptions + report.losses, 1)
    clock = "simulated" if report.transport is None else "wall-clock"
    if report.cut:
        ending = f"cut at the time limit ({report.simulated_seconds:g} s {clock})"
    else:
        ending = f"robots stopped by {report.simulated_seconds:.3f} s {clock}"
    if report.converged:
        state = f"converged at {report.convergence_seconds:.3f} s"
    elif report.beliefs_agree:
        state = "beliefs agree but are not final"
    else:
        state = "beliefs disagree: each robot performs its own belief's slot"
    return [
        f"network: {report.topology} (d_G {report.diameter}), latency {report.latency}, "
        f"loss {report.loss}, {report.medium}",
        f"  {ending}; {state}",
        f"  {plural(report.transmissions, 'transmission')}, "
        f"{plural(report.receptions, 'reception')}, {lost:.1%} lost, "
        f"{byte_count(report.bytes)} transmitted, {plural(report.proposals, 'proposal')}",
        *_transport_summary(report.transport),
        *_channel_summary(report.channel),
    ]


# ---------------------------------------------------------------- the radio channel
_CHANNEL_HELP = (
    ". A radio channel of finite capacity: bitrate=RATE (bit/s, kbit/s or Mbit/s, e.g. "
    "2Mbit/s), channel=shared|per-link (default shared: robots in range contend, with "
    "carrier sensing and collisions), queue=N (each sender's queue bound, default 16 "
    "frames); encoding=full|compact sizes beliefs on the air"
)


def _channel_summary(channel: Any) -> list[str]:
    if channel is None:
        return []
    return [
        f"  channel: {channel.bitrate} {channel.model}, {plural(channel.frames, 'frame')} "
        f"({channel.airtime_seconds:.3f} s of air), utilisation {channel.utilisation:.1%} "
        f"(busiest robot {channel.peak_utilisation:.1%}), queueing "
        f"{channel.queueing_mean_seconds * 1e3:.3f} ms mean / "
        f"{channel.queueing_max_seconds * 1e3:.3f} ms max, "
        f"{plural(channel.overflows, 'overflow')} (queue {channel.queue}), "
        f"{plural(channel.collisions, 'collision')}"
    ]


def _transport_summary(transport: Any) -> list[str]:
    if transport is None:
        return []
    return [
        f"  MPI: {plural(transport.ranks, 'rank')} ({transport.library}), "
        f"{transport.wall_seconds:.3f} s wall, {plural(transport.wire_messages, 'message')} "
        f"and {byte_count(transport.wire_bytes)} on the wire, "
        f"{plural(transport.missed_ticks, 'missed tick')}"
    ]


def check_output_free(args: argparse.Namespace) -> None:
    """Refuse a ``-o FILE`` that will not be written, before the work rather than after
    it (the rule is :func:`cfopt._jsonio.output_target`'s, which the write applies
    again)."""
    from cfopt._jsonio import output_target

    if args.output not in (None, "-"):
        output_target(args.output, overwrite=args.force)


def load_assignment(mission: Mission, path: str) -> Any:
    """An assignment file, or the ``--json`` output of ``cfopt run`` / ``cfopt solve``.

    The JSON of a run or a solve holds the assignment's list under ``"assignment"``
    beside its figures; only that list is read, and it is validated as a
    ``cfopt.assignment/1`` file would be.
    """
    from cfopt._jsonio import read_json
    from cfopt.assignment import Assignment

    value, name = read_json(sys.stdin if path == "-" else path)
    if (
        isinstance(value, dict)
        and "assignment" in value
        and "utility" in value
        and ("algorithm" in value or "status" in value)
    ):
        value = {"assignment": value["assignment"]}
    try:
        return Assignment.from_dict(mission, value)
    except MissionError as exc:
        raise exc.prefixed(name) from None


def _add_check(sub: argparse.ArgumentParser) -> Handler:
    sub.add_argument("mission", metavar="MISSION", help="mission JSON file ('-' = stdin)")
    sub.add_argument(
        "assignment",
        metavar="ASSIGNMENT",
        help="assignment file ('-' = stdin), or the --json output of cfopt run or cfopt solve",
    )
    sub.add_argument(
        "--capped",
        action="store_true",
        help="robots may not join slots that already hold the robots they require",
    )
    sub.add_argument("--json", action="store_true", help="print one JSON object")

    def run(args: argparse.Namespace) -> int:
        import proofs

        if args.mission == "-" and args.assignment == "-":
            raise MissionError("MISSION and ASSIGNMENT cannot both be read from stdin ('-')")
        m = load_mission(args.mission)
        a = load_assignment(m, args.assignment)
        nash = proofs.nash_violations(m, a, capped=args.capped)
        strict = proofs.pairwise_violations(m, a, mode="strict", capped=args.capped)
        pareto = proofs.pairwise_violations(m, a, mode="pareto", capped=args.capped)
        out = {
            "valid": True,
            "capped": args.capped,
            "utility": a.utility(m),
            "total_utility": m.total_utility,
            "percent_utility": a.percent_utility(m),
            "completed_tasks": [m.task_ids[j] for j in a.completed_tasks(m).tolist()],
            "nash_stable": not nash,
            "nash_violations": [v.to_dict(m) for v in nash],
            "pairwise_stable": not strict,
            "pairwise_violations": [v.to_dict(m) for v in strict],
            "pareto_stable": not pareto,
            "pareto_violations": [v.to_dict(m) for v in pareto],
        }
        if args.json:
            emit_json(out)
            return EXIT_OK
        print(
            f"valid: {a.n_assigned} of {plural(m.n_robots, 'robot')} assigned, utility "
            f"{out['utility']:g} of {out['total_utility']:g} ({out['percent_utility']:.2f}%)"
            + (", capped moves" if args.capped else "")
        )
        for label, items in (
            ("nash stable", nash),
            ("pairwise stable (strict)", strict),
            ("pairwise stable (pareto)", pareto),
        ):
            verdict = "yes" if not items else f"no, {plural(len(items), 'violation')}"
            print(f"{label}: {verdict}")
            for v in items[:_SHOWN]:
                print(f"  {v.describe(m)}")
            if len(items) > _SHOWN:
                print(f"  ... and {len(items) - _SHOWN} more (--json lists them all)")
        return EXIT_OK

    return run


def _report_failures(outcome: Any, claim_failures: Sequence[tuple[str, str]] = ()) -> int:
    """Print the trials and claim checks that did not finish; the exit code.

    1 when cfopt failed (a trial or a claim check raised: a bug, or workers died), with
    the tracebacks; 2 when only users' algorithms raised -- their failures, not cfopt's --
    each with the commands that replay it; 0 when nothing failed.
    """
    from cfopt.experiments import ALGORITHM_FAILED

    trial_failures = list(outcome.failures) if outcome is not None else []
    theirs = [f for f in trial_failures if f[3].startswith(ALGORITHM_FAILED)]
    ours = [f for f in trial_failures if not f[3].startswith(ALGORITHM_FAILED)]
    for cell, seed, algorithm, record in theirs:
        message, _, replay = record[len(ALGORITHM_FAILED) :].partition("\nreplay: ")
        sys.stderr.write(
            f"trial {algorithm} on {cell} (mission seed {seed}) failed: {message}\n"
            f"  replay: {replay}\n"
        )
    for cell, seed, algorithm, trace in ours:
        sys.stderr.write(f"trial {algorithm} on {cell} (mission seed {seed}) failed:\n{trace}\n")
    for claim_id, trace in claim_failures:
        sys.stderr.write(f"claim {claim_id}: the check failed:\n{trace}\n")
    if ours or claim_failures:
        died = sum(trace.startswith("WorkerDied:") for *_, trace in ours)
        why = "(a bug)" if died < len(ours) + len(claim_failures) else "(workers died)"
        sys.stderr.write(
            f"{plural(len(trial_failures), 'trial')} and "
            f"{plural(len(claim_failures), 'claim check')} failed {why}; finished trials "
            "are kept and the next run retries the rest\n"
        )
        return EXIT_BUG
    if theirs:
        names = sorted({algorithm for _, _, algorithm, _ in theirs})
        _error(
            f"{plural(len(theirs), 'trial')} of {', '.join(names)} failed: the algorithm "
            "raised (above, each with the commands that replay it); they are not stored and "
            "the next run retries them, the other trials are kept"
        )
        return EXIT_BAD_INPUT
    return EXIT_OK


def _number_list(kind: Callable[[str], Any]) -> Callable[[str], list[Any]]:
    def parse(text: str) -> list[Any]:
        items = [item.strip() for item in text.split(",") if item.strip()]
        if not items:
            raise argparse.ArgumentTypeError(f"must be a comma-separated list, got {text!r}")
        return [kind(item) for item in items]

    return parse


def _composition(text: str) -> tuple[int, int]:
    from cfopt.experiments import parse_composition

    try:
        return parse_composition(text)
    except MissionError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _add_sweep(sub: argparse.ArgumentParser) -> Handler:
    sub.add_argument(
        "--grid",
        default=None,
        metavar="NAME|FILE",
        help="paper (default: the seed's 32 cells), paper-distributed (the seed's distributed "
        "evaluation: 100 and 500 robots as agents on a complete network, 1-10 ms latency, "
        "1%% loss), audit, quick, or a .toml/.json grid file whose keys are these options' "
        "names (robots, percent_tasks, compositions, load, network, missions) and/or "
        "[[cells]] tables",
    )
    sub.add_argument(
        "--robots",
        type=_number_list(_whole_number(1)),
        metavar="N[,N...]",
        help="a custom grid instead of --grid: the product of these sizes, --percent-tasks "
        "and --compositions",
    )
    sub.add_argument(
        "--percent-tasks",
        type=_number_list(_positive_number),
        metavar="P[,P...]",
        help="with --robots (default: 1,10,50)",
    )
    sub.add_argument(
        "--compositions",
        type=_number_list(_composition),
        metavar="S:K[,S:K...]",
        help="with --robots: service types:services per robot (default: 5:1,5:5,10:1,10:5)",
    )
    sub.add_argument(
        "--load",
        type=_number_list(_positive_number),
        metavar="L[,L...]",
        help="mission loads (1 achievable, >1 over-subscribed); for paper, "
        "paper-distributed and custom grids (default: 1)",
    )
    sub.add_argument(
        "--network",
        action="append",
        default=None,
        metavar="SPEC",
        help="with --robots: run the cells distributed on this simulated network (see "
        "'cfopt run --help' for SPEC); repeat for several networks",
    )
    sub.add_argument(
        "--missions",
        type=_whole_number(1),
        default=None,
        metavar="K",
        help="missions per cell (default: the grid's: 25 paper, 4 audit, 2 quick, 5 custom)",
    )
    sub.add_argument(
        "--algorithms",
        type=_number_list(str),
        default=None,
        metavar="A[,A...]",
        help="heuristics to run: registered names or MODULE:ATTR (your own, as 'cfopt run' "
        "takes them; default: all registered); the exact solve always runs",
    )
    sub.add_argument(
        "--base-seed",
        type=_whole_number(0),
        default=0,
        metavar="X",
        help="base seed of the missions (default 0)",
    )
    sub.add_argument(
        "--time-limit",
        type=time_limit_type,
        default=60.0,
        metavar="SEC",
        help="seconds per exact solve, model building included; an optimum not proven by "
        "then is marked (default 60, at most 1e9)",
    )
    _add_workers_option(sub)
    _add_scheduler_option(sub)
    sub.add_argument(
        "--store",
        type=_STORE_FILE,
        default="cfopt-sweep.sqlite",
        metavar="FILE",
        help="SQLite result store, created or resumed (default: cfopt-sweep.sqlite); its "
        "folder must exist; one sweep at a time may write to it; /dev/null: a store of "
        "this run only, removed at its end",
    )
    _add_quiet_option(sub)
    sub.add_argument("--json", action="store_true", help="print one JSON object")

    def run(args: argparse.Namespace) -> int:
        from cfopt import experiments
        from cfopt._progress import Progress

        custom = args.robots is not None
        if not custom and (args.percent_tasks or args.compositions or args.network):
            raise MissionError(
                "--percent-tasks, --compositions and --network need --robots (a custom grid)"
            )
        if custom and args.grid is not None:
            raise MissionError("give either --grid or --robots (a custom grid), not both")
        missions = args.missions
        if custom:
            cells = experiments.product_grid(
                args.robots,
                args.percent_tasks or (1.0, 10.0, 50.0),
                args.compositions or ((5, 1), (5, 5), (10, 1), (10, 5)),
                args.load or (1.0,),
                args.network or (None,),
            )
            missions = missions or 5
        else:
            cells, grid_missions = experiments.resolve_grid(args.grid or "paper", args.load)
            missions = missions or grid_missions or 5
        sweep = experiments.Sweep(
            cells=cells,
            missions=missions,
            algorithms=args.algorithms,
            base_seed=args.base_seed,
            time_limit=args.time_limit,
        )
        with NullOutputs() as null, _trial_executor(args) as executor:
            outcome = experiments.run_sweep(
                sweep,
                null.place(args.store, "sweep.sqlite"),
                executor=executor,
                workers=args.workers,
                progress=Progress.auto(quiet=args.quiet),
            )
            store = os.devnull if null.discards(outcome.store) else outcome.store
        if args.json:
            emit_json(
                {
                    "store": store,
                    "code_version": outcome.code_version,
                    "trials": outcome.total,
                    "completed": outcome.completed,
                    "skipped": outcome.skipped,
                    "failed": len(outcome.failures),
                    "seconds": outcome.seconds,
                }
            )
        else:
            cells, missions = plural(len(sweep.cells), "cell"), plural(sweep.missions, "mission")
            if any(c.network is not None for c in sweep.cells):
                per = (
                    f"the exact solve and {plural(len(sweep.heuristics), 'heuristic')}, "
                    "distributed cells only those with agents"
                )
            else:
                per = plural(len(sweep.algorithms or ()), "algorithm")
            print(
                f"{store}: {plural(outcome.completed, 'trial')} run, "
                f"{outcome.skipped} already stored, {len(outcome.failures)} failed, of "
                f"{outcome.total} ({cells} x {missions} x {per}), {outcome.seconds:.1f} s"
            )
        return _report_failures(outcome)

    return run


def _add_report(sub: argparse.ArgumentParser) -> Handler:
    sub.add_argument(
        "store", type=_STORE_FILE, metavar="STORE", help="SQLite result store of cfopt sweep"
    )
    sub.add_argument(
        "-o",
        "--output",
        type=_REPORT_DIRECTORY,
        default="cfopt-report",
        metavar="DIR",
        help="report directory, created if missing (its parent folder must exist; default: "
        "cfopt-report); /dev/null: print the summary, keep no file",
    )
    sub.add_argument("--force", action="store_true", help=_FORCE_DIRECTORY_HELP)
    sub.add_argument(
        "--code-version",
        default=None,
        metavar="V",
        help="report the trials of this code version (default: the most recent)",
    )
    sub.add_argument("--json", action="store_true", help="print the gap report as one JSON object")

    def run(args: argparse.Namespace) -> int:
        from cfopt.report import report_from_store

        with NullOutputs() as null:
            directory = null.place(args.output, "report")
            report = report_from_store(
                args.store, directory, version=args.code_version, force=args.force
            )
            if args.json:
                gap = dict(report.gap_report)
                gap["report_directory"] = args.output
                gap["files"] = [str(p) for p in report.files]
                emit_json(null.shown(gap))
                return EXIT_OK
            print(report.summary)
            shown = _DISCARDED if null.discards(directory) else f"{report.markdown}  {report.html}"
            print(f"report: {shown}")
        return EXIT_OK

    return run


_COMMANDS: list[tuple[str, str, Callable[[argparse.ArgumentParser], Handler]]] = [
    ("generate", "a random mission from the seed's instance family", _add_generate),
    ("validate", "check a mission file", _add_validate),
    ("solve", "the exact optimum of a mission (ILP, HiGHS)", _add_solve),
    ("run", "one heuristic on a mission: utility, cost and stability", _add_run),
    ("check", "validity, utility and stability of an assignment", _add_check),
    ("audit", "the main job: the seed's claims and the optimal-gap report", _add_audit),
    (
        "reproduce",
        "the seed paper's grids, every table and figure beside the paper's published value",
        _add_reproduce,
    ),
    ("sweep", "run grid cells x missions x algorithms into a result store", _add_sweep),
    ("report", "tables, statistics and plots from a result store", _add_report),
]


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The ``cfopt`` argument parser with every subcommand.

    For ``cfopt run`` (``argv`` its command line), the parser also has the flags of the
    algorithm ``argv`` names (from its :class:`heuristics.AlgorithmSpec`) and its help
    lists the registered algorithms; the registry (and its entry points) is read only
    then.
    """
    parser = Parser(
        prog="cfopt",
        description="Optimisation-grounded verification of coalition formation for robot "
        "collectives. Exit codes: 0 success, 2 bad input or usage (also: your algorithm "
        "failed), 1 internal error.",
    )
    parser.add_argument("--version", action="version", version=f"cfopt {__version__}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, summary, add in _COMMANDS:
        sub = commands.add_parser(
            name, help=summary, description=summary[0].upper() + summary[1:] + "."
        )
        sub.set_defaults(handler=add(sub))
        if name == "run" and argv and argv[0] == "run":
            _prepare_run(sub, argv[1:])
    return parser


def _parse(parser: argparse.ArgumentParser, argv: list[str]) -> argparse.Namespace:
    """``parser.parse_args(argv)``; an unknown flag of ``cfopt run`` points at the
    algorithm's own help, which lists its flags."""
    args, extra = parser.parse_known_args(argv)
    if extra:
        unknown = f"unrecognized arguments: {' '.join(extra)}"
        if args.command == "run":
            raise MissionError(
                f"{unknown} (see 'cfopt run {args.algorithm} --help' for its options)"
            )
        parser.error(unknown)
    return args


class _Terminated(KeyboardInterrupt):
    """SIGTERM, turned into an exception so that a sweep stops cleanly (like Ctrl-C)."""

    signal_name = "SIGTERM"


def _on_sigterm(signum: int, frame: Any) -> None:
    raise _Terminated()


def _configure_streams() -> None:
    """UTF-8 on stdout and stderr whatever the locale; text that cannot be encoded (a lone
    surrogate in a file name) is escaped rather than crashing the output."""
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None:
            try:
                reconfigure(encoding="utf-8", errors="backslashreplace")
            except (ValueError, OSError):  # a stream that cannot change any more
                continue


def _silence_stdout() -> None:
    """After a failed write, point stdout at /dev/null so the exit flush cannot fail too."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # io.UnsupportedOperation is both
        pass


def _error(text: str) -> None:
    with contextlib.suppress(OSError, ValueError):
        sys.stderr.write(f"error: {text}\n")
        sys.stderr.flush()


def _interrupted(exc: KeyboardInterrupt) -> int:
    from cfopt.errors import SweepInterrupted  # light: a Ctrl-C may stop a start-up import

    name = getattr(exc, "signal_name", "SIGINT")
    if isinstance(exc, SweepInterrupted):
        kept = plural(exc.completed, "trial") + (f" and {exc.extra}" if exc.extra else "")
        verb = "is" if exc.completed == 1 and not exc.extra else "are"
        _error(
            f"interrupted ({name}): {kept} computed by this run {verb} kept in {exc.store}; "
            "run the same command again to resume"
        )
    else:
        _error(f"interrupted ({name})")
    return EXIT_SIGTERM if name == "SIGTERM" else EXIT_SIGINT


@contextlib.contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    try:
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``cfopt`` with ``argv`` (default: ``sys.argv[1:]``); returns the exit code."""
    _configure_streams()
    try:
        with _sigterm_as_interrupt():
            argv = sys.argv[1:] if argv is None else list(argv)
            args = _parse(build_parser(argv), argv)
            code = args.handler(args)
            sys.stdout.flush()
            return code
    except MissionError as exc:
        _error(exc.cli_message)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt as exc:
        return _interrupted(exc)
    except BrokenPipeError:
        _silence_stdout()  # the reader went away (e.g. `| head`); nothing left to say
        return EXIT_OK
    except MemoryError:
        _error("out of memory: the input is too large for this machine")
        return EXIT_BAD_INPUT
    except OSError as exc:
        if exc.errno not in _WRITE_ERRNOS:
            raise
        _silence_stdout()
        _error(f"cannot write the output ({exc.strerror or exc})")
        return EXIT_BAD_INPUT


def reserve_stdout() -> None:
    """Keep file descriptor 1 for what cfopt prints: anything else goes to stderr.

    ``sys.stdout`` is rebuilt on a copy of descriptor 1, and descriptor 1 itself is
    pointed at stderr, so a library that writes to the C-level stdout (a solver's banner,
    an MPI library's notice) lands on stderr and never inside a ``--json`` object or an
    assignment printed with ``-o -``.  Only for a real process whose ``sys.stdout`` is
    descriptor 1 (not under a test's capture); a no-op when either descriptor is closed.
    """
    import io

    try:
        if sys.stdout is None or sys.stdout.fileno() != 1 or sys.stderr is None:
            return
        sys.stderr.fileno()
        sys.stdout.flush()
        ours = os.dup(1)
    except (OSError, ValueError, AttributeError):  # io.UnsupportedOperation is both
        return
    os.set_inheritable(ours, False)
    line_buffering = sys.stdout.line_buffering
    sys.stdout = io.TextIOWrapper(
        io.FileIO(ours, "w", closefd=True),
        encoding="utf-8",
        errors="backslashreplace",
        line_buffering=line_buffering,
    )
    os.dup2(2, 1)


def entry() -> NoReturn:
    """The ``cfopt`` command (console script and ``python -m cfopt``): :func:`main`, then
    the process ends with its exit code.

    Standard output is reserved for cfopt's own output (:func:`reserve_stdout`).  An
    interrupted command (exit 130 or 143) ends at once, after flushing its output: its
    work is saved by then, and a worker process it killed in the middle of sending a
    result would otherwise leave the interpreter's exit waiting forever for the worker
    pool's result reader.
    """
    reserve_stdout()
    code = main()
    if code in (EXIT_SIGINT, EXIT_SIGTERM):
        with contextlib.suppress(OSError, ValueError):
            sys.stdout.flush()
            sys.stderr.flush()
        os._exit(code)
    sys.exit(code)
