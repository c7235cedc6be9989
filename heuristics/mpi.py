"""Distributed runs as real processes: an algorithm's agents over MPI (mpi4py).

The simulator (:func:`heuristics.simulate`) runs the agents on a modelled network,
reproducibly on one machine; the MPI transport (:mod:`heuristics.transport.mpi`, where
placement, the wire, the clocks and termination are described) runs the *same agent
objects* as MPI processes that exchange real messages, as the seed's own evaluation did.
Any protocol runs on both; this module is the part above the transport:

* :func:`mpi_run` (``cfopt run ALG MISSION --backend mpi --ranks K``) resolves the
  algorithm (a name, or any :class:`heuristics.agents.Protocol` object), pickles the
  protocol into the job's folder, launches ``mpiexec -n K python -m cfopt.mpi ...`` and
  returns the run gathered on rank 0 (the waiting, killing and error lines:
  :mod:`heuristics.mpi_job`);
* :func:`run_ranks` is what every rank executes (``mpiexec -n K python -m cfopt.mpi ALG
  MISSION ...`` on a cluster whose launcher is given); collective over ``comm``.

A protocol object travels to the ranks pickled: it must be picklable, and its class must
be importable there -- defined in a module, not in ``__main__``; the ranks get the
launching process's working directory first on ``sys.path``.

It needs the ``mpi`` extra: ``pip install "cfopt[mpi]"`` (mpi4py, and MPICH's wheel,
which brings ``mpiexec``).
"""

from __future__ import annotations

import dataclasses
import os
import pickle
import shlex
import shutil
import sys
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cfopt import Mission, MissionError, require_mission
from cfopt.checks import require_choice, require_seed
from heuristics._run import Run
from heuristics.agents.protocol import Protocol
from heuristics.distributed import protocol_for
from heuristics.mpi_job import job_folder, run_job
from heuristics.network import NetworkSpec
from heuristics.reward import REWARDS
from heuristics.transport import mpi as transport
from heuristics.transport.driver import (
    DEFAULT_TIME_LIMIT,
    network_spec,
    quiet_factor_for,
    run_limits,
    seed_entropy,
    world_streams,
)
from heuristics.transport.mpi import TransportReport, check_ranks, refuse_channel

__all__ = [
    "INSTALL",
    "LAUNCHER_ENV",
    "TransportReport",
    "launcher",
    "load_protocol",
    "mpi_run",
    "run_ranks",
]

#: What to install for ``backend="mpi"``.
INSTALL = 'pip install "cfopt[mpi]"'
#: Environment variable naming the launcher command (default: ``mpiexec`` next to Python,
#: then on ``PATH``), e.g. ``"mpiexec --oversubscribe"`` for Open MPI.
LAUNCHER_ENV = "CFOPT_MPIEXEC"


def launcher() -> list[str]:
    """The ``mpiexec`` command: ``$CFOPT_MPIEXEC`` (split like a shell), else the
    ``mpiexec`` beside the running Python (where the ``mpi`` extra's MPICH wheel puts
    it), else the one on ``PATH``.  Raises :class:`cfopt.MissionError` (with the install
    command) when there is none, or when mpi4py is missing."""
    try:
        import mpi4py  # noqa: F401
    except ImportError:
        raise MissionError(
            f"backend: mpi4py is not installed; install the mpi extra: {INSTALL}"
        ) from None
    given = os.environ.get(LAUNCHER_ENV)
    if given:
        try:
            command = shlex.split(given)
        except ValueError as exc:  # an unclosed quote, a lone backslash
            raise MissionError(
                f"backend: {LAUNCHER_ENV}={given!r} is not a command line ({exc})"
            ) from None
        if command and shutil.which(command[0]):
            return command
        raise MissionError(f"backend: {LAUNCHER_ENV}={given!r} is not a command that exists")
    beside = Path(sys.executable).parent / "mpiexec"
    if beside.is_file() and os.access(beside, os.X_OK):
        return [str(beside)]
    found = shutil.which("mpiexec")
    if found:
        return [found]
    raise MissionError(
        "backend: no MPI launcher (mpiexec) beside Python or on PATH; install the mpi "
        f"extra: {INSTALL} (MPICH's wheel brings mpiexec), or set {LAUNCHER_ENV}"
    )


def mpi_run(
    mission: Mission,
    algorithm: str | Protocol,
    network: str | NetworkSpec = "complete",
    *,
    ranks: int = 2,
    seed: int | None = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    quiet_factor: int | None = None,
    reward: str = "paper",
    options: Mapping[str, Any] | None = None,
) -> Run:
    """Run ``algorithm``'s agents as ``ranks`` MPI processes (module docstring).

    Parameters
    ----------
    mission : cfopt.Mission
    algorithm : str or heuristics.agents.Protocol
        A name with agents (as :func:`heuristics.simulate`'s) or any protocol object
        (picklable, its class importable by the ranks).
    network : str or NetworkSpec, default "complete"
        Topology, injected latency and loss, clocks (as :func:`heuristics.simulate`).
    ranks : int, default 2
        MPI processes, ``1 <= ranks <= n``.
    seed : None or int
        Topology, clocks and the injected draws flow from it (``None``: fresh).
    time_limit : float, default 3600
        Seconds (real; logical with ``sync=true``) after which the run is cut, at most
        :data:`heuristics.simulate.MAX_TIME_LIMIT` (8796).
    quiet_factor, reward, options
        As :func:`heuristics.simulate`.

    Returns
    -------
    Run
        As the simulator's, with ``options`` ``engine="mpi"`` and ``ranks``, and
        ``run.network.transport`` the :class:`TransportReport`.

    Raises
    ------
    cfopt.MissionError
        A bad argument or network (checked before anything is launched), a protocol the
        ranks could not get, or no mpi4py / no launcher (naming ``pip install
        "cfopt[mpi]"``).
    heuristics.mpi_job.MPIJobError
        The MPI job failed (a :class:`cfopt.MissionError` and a :class:`RuntimeError`):
        one line naming the launcher or the rank and how (a rank's own error line as it
        is), e.g. a rank killed or stopped, or the job still running ``time_limit +``
        :data:`heuristics.mpi_job.GRACE` seconds after its ranks started (it is killed).
    RuntimeError
        A rank crashed with a traceback (the end of the job's output is in the message).

    Notes
    -----
    The launcher runs in a session of its own and dies with this process; its ranks die
    with it too, and whatever is left of the job when it ends is killed
    (:mod:`heuristics.mpi_job`).  The job's folder (``cfopt-mpi-PID-*`` in the temporary
    directory) goes with the run; if this process is killed by SIGKILL, the next MPI run
    removes it.

    Examples
    --------
    >>> import cfopt
    >>> m = cfopt.generate_mission(20, 20, 4, 2, seed=1)
    >>> run = mpi_run(m, "grape-s", "complete period=1ms sync=true", ranks=2, seed=0)
    >>> run.network.transport.ranks, run.network.converged, run.assignment.percent_utility(m)
    (2, True, 100.0)
    >>> run.network.transport.wire_bytes == run.network.transport.received_bytes
    True
    """
    started = time.perf_counter()
    require_mission(mission)
    protocol = protocol_for(algorithm, options)
    spec = network_spec(network)
    refuse_channel(spec)
    ranks = check_ranks(mission.n_robots, ranks)
    quiet_factor = quiet_factor_for(spec, mission.n_robots, quiet_factor)
    limit, quiet_factor = run_limits(time_limit, quiet_factor)
    seed = require_seed("seed", seed, generator=False)
    require_choice("reward", reward, REWARDS)
    shipped = _pickled(protocol)
    command = launcher()
    fresh = None if seed is not None else int(np.random.SeedSequence().entropy)
    world = seed if fresh is None else np.random.default_rng(fresh)  # what rank 0 gets
    # the ranks' own network: a bad one is the simulator's error line, before any launch
    spec.build(mission, np.random.default_rng(world_streams(seed_entropy(world))[0]))
    with job_folder() as folder:
        mission_file = folder / "mission.json"
        mission_file.write_text(mission.to_json(), encoding="utf-8")
        protocol_file = folder / "protocol.pickle"
        protocol_file.write_bytes(shipped)
        result_file = folder / "run.pickle"
        name = algorithm if isinstance(algorithm, str) else "protocol"
        program = [sys.executable, "-m", "cfopt.mpi", name, str(mission_file)]
        program += ["--network", spec.to_text(), "--result-file", str(result_file)]
        program += ["--protocol-file", str(protocol_file), "--sys-path", os.getcwd()]
        program += ["--time-limit", repr(limit / 1e9), "--quiet-factor", str(quiet_factor)]
        program += ["--reward", reward]
        program += ["--seed", str(seed)] if fresh is None else ["--entropy", str(fresh)]
        run = run_job(
            command,
            ranks,
            program,
            folder=folder,
            result=result_file,
            time_limit=limit / 1e9,
            kind=Run,
        )
    report = run.network
    launched = dataclasses.replace(report.transport, launch_seconds=time.perf_counter() - started)
    return dataclasses.replace(run, network=dataclasses.replace(report, transport=launched))


def _pickled(protocol: Protocol) -> bytes:
    """``protocol`` as the ranks will get it; refused when they could not."""
    kind = type(protocol)
    if kind.__module__ == "__main__":
        raise MissionError(
            f"algorithm: the MPI ranks cannot import {kind.__name__}, defined in __main__; "
            "put it in a module (the ranks have the working directory on their path)"
        )
    try:
        return pickle.dumps(protocol)
    except (pickle.PicklingError, TypeError, AttributeError) as exc:
        raise MissionError(
            f"algorithm: the protocol must be picklable to reach the MPI ranks ({exc})"
        ) from None


def load_protocol(path: str | os.PathLike[str], sys_path: str | None = None) -> Protocol:
    """The protocol :func:`mpi_run` pickled into ``path`` (on a rank), with ``sys_path``
    (the launching process's working directory) first on ``sys.path``.  Raises
    :class:`cfopt.MissionError` naming ``algorithm`` when it cannot be loaded."""
    if sys_path and sys_path not in sys.path:
        sys.path.insert(0, sys_path)
    try:
        with open(path, "rb") as file:
            protocol = pickle.load(file)
    except (OSError, EOFError, ImportError, AttributeError, pickle.UnpicklingError) as exc:
        raise MissionError(f"algorithm: the MPI ranks cannot load the protocol ({exc})") from None
    if not isinstance(protocol, Protocol):
        raise MissionError(f"algorithm: {path} holds no heuristics.agents.Protocol")
    return protocol


def run_ranks(
    mission: Mission,
    algorithm: str | Protocol,
    network: str | NetworkSpec = "complete",
    *,
    seed: Any = None,
    time_limit: float = DEFAULT_TIME_LIMIT,
    quiet_factor: int | None = None,
    reward: str = "paper",
    options: Mapping[str, Any] | None = None,
    comm: Any = None,
) -> Run | None:
    """One rank's share of an MPI run (collective over ``comm``, default
    ``MPI.COMM_WORLD``); returns the :class:`heuristics.Run` on rank 0 and ``None`` on
    the others.  Arguments as :func:`mpi_run`; the ranks are ``comm``'s
    (:func:`heuristics.transport.mpi.run_ranks` takes the protocol itself)."""
    require_mission(mission)
    protocol = protocol_for(algorithm, options)
    return transport.run_ranks(
        mission,
        protocol,
        network,
        seed=seed,
        time_limit=time_limit,
        quiet_factor=quiet_factor,
        reward=reward,
        comm=comm,
    )
