"""The transports: where a protocol's agents run, and how their messages travel.

Each takes any :class:`heuristics.agents.Protocol` and knows time, delivery and encoded
sizes, never which algorithm it carries:

* :mod:`heuristics.transport.simulator` -- the discrete-event simulator (the kernel: time
  and events);
* :mod:`heuristics.transport.mpi` -- real processes, one MPI rank per block of robots;
* :mod:`heuristics.transport.driver` -- what both do alike: beliefs in flight, a robot's
  tick, direct messages, timers, the :class:`heuristics.Run` at the end.

:func:`heuristics.simulate` and :func:`heuristics.mpi_run` are the entry points (they also
take an algorithm's name).
"""
