"""``mpiexec -n K python -m cfopt.mpi ALGORITHM MISSION [options]``: one MPI rank of a
distributed run (what ``cfopt run ... --backend mpi --ranks K`` launches itself).

Every rank reads the mission and runs its share of the robots
(:func:`heuristics.mpi.run_ranks`); rank 0 prints the run as ``cfopt run`` does (the
summary, or ``--json``; ``-o FILE`` for the assignment), the other ranks print nothing.
Use it where the cluster's launcher is given (``srun``, a batch script); it needs the
``mpi`` extra: ``pip install "cfopt[mpi]"``.  Exit codes as ``cfopt``'s.
"""

from __future__ import annotations

import argparse
import os
import pickle
import sys
from collections.abc import Sequence

from cfopt import MissionError
from cfopt.cli import (
    EXIT_BAD_INPUT,
    EXIT_SIGINT,
    Parser,
    _error,
    check_output_free,
    finish_run,
    load_mission,
    reserve_stdout,
    time_limit_type,
)

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="python -m cfopt.mpi",
        description="One MPI rank of a distributed run (start it with mpiexec -n K).",
    )
    parser.add_argument(
        "algorithm",
        help="an algorithm with distributed agents (grape-s, pair-grape-s, sda, "
        "pair-grape-s-chain, grape-s-select, or MODULE:ATTR)",
    )
    parser.add_argument("mission", help="mission JSON file")
    parser.add_argument(
        "--network", default="complete", metavar="SPEC", help="as 'cfopt run --network'"
    )
    parser.add_argument(
        "--seed", type=int, default=None, metavar="X", help="random seed (default: fresh)"
    )
    parser.add_argument(
        "--time-limit",
        type=time_limit_type,
        default=None,
        metavar="SEC",
        help="real seconds (default 3600, at most 8796)",
    )
    parser.add_argument("--quiet-factor", type=int, default=None, help=argparse.SUPPRESS)
    parser.add_argument("--reward", default="paper", help=argparse.SUPPRESS)
    parser.add_argument("--result-file", default=None, help=argparse.SUPPRESS)
    # the protocol the launching process built (pickled), and where its module is found
    parser.add_argument("--protocol-file", default=None, help=argparse.SUPPRESS)
    parser.add_argument("--sys-path", default=None, help=argparse.SUPPRESS)
    # the fresh draw of a run without a seed, made by the launching process (which checked
    # the network with it); the run is still recorded as one without a seed
    parser.add_argument("--entropy", type=int, default=None, help=argparse.SUPPRESS)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "-o", "--output", default=None, metavar="FILE", help="as 'cfopt run -o' (rank 0 writes)"
    )
    parser.add_argument("--force", action="store_true", help="replace FILE if it exists")
    return parser


def _launched_rank() -> int:
    """This process's rank as the launcher set it (MPICH/Intel MPI, Open MPI, PMIx), read
    before MPI starts; 0 when none is set."""
    for name in ("PMI_RANK", "OMPI_COMM_WORLD_RANK", "PMIX_RANK"):
        value = os.environ.get(name, "")
        if value.isdigit():
            return int(value)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run this rank; returns the exit code."""
    from heuristics.mpi_job import rank_ended, rank_started

    rank = _launched_rank()
    rank_started(rank)
    code = _rank_main(argv)
    rank_ended(rank, code)
    return code


def _rank_main(argv: Sequence[str] | None) -> int:
    import numpy as np

    from heuristics.mpi import load_protocol, run_ranks
    from heuristics.simulate import DEFAULT_TIME_LIMIT

    args = _parser().parse_args(argv)
    try:
        mission = load_mission(args.mission)
        check_output_free(args)
        algorithm = args.algorithm
        if args.protocol_file is not None:
            algorithm = load_protocol(args.protocol_file, args.sys_path)
        run = run_ranks(
            mission,
            algorithm,
            args.network,
            seed=args.seed if args.entropy is None else np.random.default_rng(args.entropy),
            time_limit=DEFAULT_TIME_LIMIT if args.time_limit is None else args.time_limit,
            quiet_factor=args.quiet_factor,
            reward=args.reward,
        )
        if run is None:
            return 0
        if args.result_file is not None:
            with open(args.result_file, "wb") as out:
                pickle.dump(run, out)
            return 0
        return finish_run(args, mission, run)
    except MissionError as exc:
        if _launched_rank() == 0:  # every rank finds the same bad input: one line is enough
            _error(exc.cli_message)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:  # Ctrl-C reaches every rank: one quiet exit each
        return EXIT_SIGINT


if __name__ == "__main__":
    reserve_stdout()  # rank 0's --json is the whole of stdout, whatever MPI prints
    sys.exit(main())
