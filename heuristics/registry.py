"""The algorithm registry: every algorithm cfopt can run, each described by an
:class:`AlgorithmSpec`.

``cfopt run``, the sweeps, the reports and the audit look algorithms up here, so an
algorithm registered once is available everywhere.  Everything cfopt knows about an
algorithm is in its spec: the centralized function, its typed options (from which the
command line builds its flags), its version (part of a stored trial's key), the stability
its results promise (what the audit checks them for) and, optionally, its distributed
protocol.

Three ways to add an algorithm:

1. from Python, :func:`register_algorithm` (a spec, or a plain callable wrapped into one;
   it also works as a decorator);
2. from an installed package, an entry point in group ``cfopt.algorithms``
   (:data:`ENTRY_POINT_GROUP`), loaded on the registry's first use in every process --
   the command, its worker processes, dask workers, MPI ranks; each entry loads a spec, a
   callable (named after the entry) or a list of specs::

       [project.entry-points."cfopt.algorithms"]
       my-greedy = "mypkg:greedy_spec"

3. without registering, by reference: wherever a name is accepted, ``MODULE:ATTR``
   (:func:`get_algorithm`, ``cfopt run mymod:greedy m.json``), ``MODULE`` imported with
   the current directory first on ``sys.path`` (as ``python -m`` does), ``ATTR`` a spec
   or a callable (a dotted path for a nested attribute).

An algorithm is a callable ``(mission, *, seed=None, **options) -> heuristics.Run |
cfopt.Assignment``.  A returned assignment becomes a :class:`heuristics.Run` with what can
be measured from outside (the wall-clock time); its counters are then *not reported*
(``Run.counted`` is ``False``), never zeros.  An exception raised by an algorithm that is
not cfopt's own is :class:`AlgorithmFailed` (a :class:`cfopt.MissionError`): the
algorithm's failure, reported with its name, not a bug of cfopt.

Examples
--------
>>> import cfopt, heuristics
>>> def greedy(mission, *, seed=None):
...     return cfopt.Assignment.empty(mission)
>>> spec = heuristics.AlgorithmSpec(name="nothing", run=greedy, summary="assigns no robot")
>>> m = cfopt.Mission.from_arrays([[1]], [[1]], [3.0])
>>> run = spec(m, seed=0)
>>> run.algorithm, run.counted, run.to_dict(m)["messages"]
('nothing', False, None)
>>> get_algorithm("grape-s").stability, get_algorithm("grape-s").version
(<Stability.SEED: 'seed'>, '2')
"""

from __future__ import annotations

import importlib
import importlib.metadata
import inspect
import math
import numbers
import os
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np

from cfopt import Assignment, Mission, MissionError
from cfopt.checks import SeedLike, require_text, shown
from cfopt.errors import MissionTypeError
from heuristics._run import ORDERS, Run, seed_label
from heuristics.grape_s import grape_s
from heuristics.grape_s_select import grape_s_select
from heuristics.pair_grape_s import pair_grape_s
from heuristics.pair_grape_s_chain import pair_grape_s_chain
from heuristics.rachna import MAX_ROUNDS, rachna_dt
from heuristics.rachna import SCHEDULES as RACHNA_SCHEDULES
from heuristics.reward import REWARDS
from heuristics.sda import SCHEDULES as SDA_SCHEDULES
from heuristics.sda import sda

__all__ = [
    "ALGORITHMS",
    "ENTRY_POINT_GROUP",
    "AlgorithmFailed",
    "AlgorithmRegistry",
    "AlgorithmSpec",
    "Option",
    "Stability",
    "algorithm_directory",
    "algorithm_names",
    "get_algorithm",
    "register_algorithm",
    "run_algorithm",
]

#: The entry-point group an installed package registers algorithms in.
ENTRY_POINT_GROUP = "cfopt.algorithms"
#: The types an :class:`Option` may have.
OPTION_TYPES = (bool, int, float, str)
#: Measures a run may report beyond the common counts (:attr:`AlgorithmSpec.measures`).
MEASURES = ("exchanges", "pairwise_step_ran")


# ---------------------------------------------------------------------- stability
class Stability(Enum):
    """What an algorithm's results promise, and so what the audit checks them for.

    ``SEED``: Nash stable under the seed's reward; ``CAPPED``: Nash stable with capped
    moves (Pair-GRAPE-S's move set); ``OWN``: stable by the algorithm's own checker
    (:attr:`AlgorithmSpec.checker`); ``NONE``: nothing.  The strings ``"seed"``,
    ``"capped"``, ``"own"`` and ``"none"`` are accepted wherever a Stability is.

    >>> Stability("capped").description
    'Nash stable with capped moves (Pair-GRAPE-S move set)'
    """

    SEED = "seed"
    CAPPED = "capped"
    OWN = "own"
    NONE = "none"

    @property
    def description(self) -> str:
        """The promise in words."""
        return {
            "seed": "Nash stable under the seed's reward",
            "capped": "Nash stable with capped moves (Pair-GRAPE-S move set)",
            "own": "stable by its own checker",
            "none": "no stability promised",
        }[self.value]


def _stability(value: Any) -> Stability:
    if isinstance(value, Stability):
        return value
    choices = [s.value for s in Stability]
    if isinstance(value, str) and value in choices:
        return Stability(value)
    kind = MissionError if isinstance(value, str) else MissionTypeError
    raise kind(f"stability: must be one of {', '.join(choices)}, got {shown(value)}")


# ------------------------------------------------------------------------ options
def _fits(value: Any, kind: type) -> bool:
    """Whether ``value`` is a value of an option of type ``kind``."""
    if kind is bool:
        return isinstance(value, bool | np.bool_)
    if isinstance(value, bool | np.bool_):
        return False
    if kind is int:
        return isinstance(value, numbers.Integral)
    if kind is float:
        return isinstance(value, numbers.Real) and math.isfinite(value)
    return isinstance(value, str)


@dataclass(frozen=True)
class Option:
    """One typed option of an algorithm: a keyword argument of its function (or of its
    protocol), and a flag of ``cfopt run``.

    Parameters
    ----------
    name : str
        The keyword argument's name, a Python identifier; the flag is ``--`` and the name
        with ``-`` for ``_`` (``max_rounds``: ``--max-rounds``).
    type : {bool, int, float, str}, default str
        A bool option's flags are ``--name`` and ``--no-name``.
    default : object, optional
        The value the function takes when the option is not given (shown in help; the
        command line passes only the options given, so the function's own default
        applies).  ``None`` when the default is computed (say so in ``help``).
    help : str
        One line for ``cfopt run ALGORITHM --help``.
    choices : tuple, optional
        The allowed values.

    Examples
    --------
    >>> Option("max_rounds", int, 100000, "refuse missions needing more rounds").flag
    '--max-rounds'
    >>> Option("order", str, "index", choices=("index", "random")).check("up")
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: order: must be one of index, random, got "up"
    """

    name: str
    type: type = str
    default: Any = None
    help: str = ""
    choices: tuple[Any, ...] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise MissionTypeError(
                f"name: an option's name must be a Python identifier, got {shown(self.name)}"
            )
        if self.type not in OPTION_TYPES:
            raise MissionTypeError(
                f"type: option {self.name!r}: must be bool, int, float or str, got "
                f"{shown(self.type)}"
            )
        require_text("help", self.help, empty=True)
        if self.choices is not None:
            if not isinstance(self.choices, tuple | list) or not self.choices:
                raise MissionTypeError(
                    f"choices: option {self.name!r}: must be a non-empty tuple or None, got "
                    f"{shown(self.choices)}"
                )
            for value in self.choices:
                if not _fits(value, self.type):
                    raise MissionTypeError(
                        f"choices: option {self.name!r}: {shown(value)} is not a "
                        f"{self.type.__name__}"
                    )
            object.__setattr__(self, "choices", tuple(self.choices))
        if self.default is not None:
            self.check(self.default, "default")

    @property
    def flag(self) -> str:
        """The command-line flag, ``--max-rounds`` for ``max_rounds``."""
        return "--" + self.name.replace("_", "-")

    def check(self, value: Any, where: str | None = None) -> Any:
        """``value`` if it is of this option's type (and among its choices);
        :class:`cfopt.MissionError` naming the option (or ``where``) otherwise."""
        place = self.name if where is None else require_text("where", where)
        if not _fits(value, self.type):
            what = {bool: "a bool (True or False)", int: "a whole number", float: "a number"}
            raise MissionTypeError(
                f"{place}: must be {what.get(self.type, 'a string')}, got {shown(value)}"
            )
        if self.choices is not None and value not in self.choices:
            shown_choices = ", ".join(str(c) for c in self.choices)
            raise MissionError(f"{place}: must be one of {shown_choices}, got {shown(value)}")
        return value


def _options(name: str, value: Any) -> tuple[Option, ...]:
    if not isinstance(value, tuple | list) or not all(isinstance(o, Option) for o in value):
        raise MissionTypeError(f"{name}: must be a tuple of heuristics.Option, got {shown(value)}")
    names = [o.name for o in value]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise MissionError(f"{name}: option {twice[0]!r} is given twice")
    return tuple(value)


# ------------------------------------------------------------------------- errors
class AlgorithmFailed(MissionError):
    """An algorithm that is not cfopt's own raised, or returned neither a
    :class:`heuristics.Run` nor a valid :class:`cfopt.Assignment`: that algorithm's
    failure on that mission, not a bug of cfopt (the command line says so in one
    ``error:`` line and exits with 2; a sweep records the trial as failed, with the
    mission's replay line, and goes on).

    ``algorithm`` is the algorithm's name, ``problem`` what went wrong.
    """

    def __init__(self, algorithm: str, problem: str) -> None:
        super().__init__(f"{algorithm}: {problem}")
        self.algorithm, self.problem = algorithm, problem

    def __reduce__(self) -> tuple[Any, ...]:  # travels back from worker processes
        return (type(self), (self.algorithm, self.problem))


def _described(exc: BaseException) -> str:
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


# ------------------------------------------------------------------------ the spec
@dataclass(frozen=True)
class AlgorithmSpec:
    """Everything cfopt knows about one algorithm (frozen).

    Parameters
    ----------
    name : str
        The registry name (``"grape-s"``): no spaces, no ``:``.
    run : callable
        ``run(mission, *, seed=None, **options) -> heuristics.Run | cfopt.Assignment``:
        the centralized algorithm.
    version : str, default "1"
        Part of the key of every stored trial: changing it makes a sweep compute the
        algorithm's trials again instead of reusing stored ones.
    stability : Stability or {"seed", "capped", "own", "none"}, default "none"
        What the results promise (:class:`Stability`); the audit checks that.
    options : tuple of Option
        The keyword options ``run`` takes beyond ``seed``; ``cfopt run NAME`` has one
        flag per option (its ``--help`` lists them).
    protocol : callable or str, optional
        The distributed protocol: ``protocol(**protocol_options) -> Protocol`` (a
        :class:`heuristics.agents.Protocol` subclass is one), or its ``"MODULE:ATTR"``,
        imported when first needed.  Without it the algorithm has no distributed runs.
    protocol_options : tuple of Option
        The options of ``protocol`` (``cfopt run NAME MISSION --network SPEC`` flags).
    checker : callable or str, optional
        With ``stability="own"`` (and only then): ``checker(mission, assignment) -> list``
        of violations (empty: stable), or its ``"MODULE:ATTR"``, imported when first
        needed (:meth:`stability_checker`).
    measures : tuple of str
        The measures of :data:`MEASURES` its runs report beyond the common counts
        (``"exchanges"``, ``"pairwise_step_ran"``: the Pair-GRAPE-S variants); stored
        trials keep them only for the algorithms that report them.
    summary : str, optional
        One line for help texts (default: the first line of ``run``'s docstring).

    Notes
    -----
    A spec is callable with ``run``'s signature, so ``get_algorithm(name)(mission,
    seed=0)`` runs it and always returns a :class:`heuristics.Run`.

    Examples
    --------
    >>> import cfopt
    >>> spec = get_algorithm("sda")
    >>> [o.flag for o in spec.options][:2]
    ['--eps', '--schedule']
    >>> type(spec.make_protocol(eps=0.5)).__name__
    'SdaProtocol'
    >>> spec.make_protocol(exchange=True)
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: options: sda's agents take eps, resend_tries, not 'exchange'
    """

    name: str
    run: Callable[..., Any]
    version: str = "1"
    stability: Stability | str = Stability.NONE
    options: tuple[Option, ...] = ()
    protocol: Callable[..., Any] | str | None = None
    protocol_options: tuple[Option, ...] = ()
    checker: Callable[..., Any] | str | None = None
    measures: tuple[str, ...] = ()
    summary: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        name = require_text("name", self.name)
        if any(c.isspace() for c in name) or not name.isprintable():
            raise MissionError(f"name: must have no spaces or control characters, got {name!r}")
        if not callable(self.run):
            raise MissionTypeError(f"run: must be callable, got {shown(self.run)}")
        require_text("version", self.version)
        object.__setattr__(self, "stability", _stability(self.stability))
        object.__setattr__(self, "options", _options("options", self.options))
        object.__setattr__(
            self, "protocol_options", _options("protocol_options", self.protocol_options)
        )
        for what in ("protocol", "checker"):
            value = getattr(self, what)
            if value is not None and not callable(value):
                if not isinstance(value, str):
                    raise MissionTypeError(
                        f"{what}: must be callable, a 'MODULE:ATTR' string or None, got "
                        f"{shown(value)}"
                    )
                _split_reference(value, what)
        if self.protocol is None and self.protocol_options:
            raise MissionError("protocol_options: given without a protocol")
        if (self.stability is Stability.OWN) != (self.checker is not None):
            raise MissionError(
                'checker: give one exactly when stability is "own" (the results are checked '
                f"by it), got stability {self.stability.value!r} and checker {shown(self.checker)}"
            )
        if not isinstance(self.measures, tuple | list) or any(
            m not in MEASURES for m in self.measures
        ):
            raise MissionTypeError(
                f"measures: must be a tuple of {', '.join(MEASURES)}, got {shown(self.measures)}"
            )
        object.__setattr__(self, "measures", tuple(self.measures))
        summary = require_text("summary", self.summary, empty=True)
        if not summary:
            doc = inspect.getdoc(self.run) or ""
            summary = doc.strip().splitlines()[0] if doc.strip() else ""
        object.__setattr__(self, "summary", summary)

    # ------------------------------------------------------------------ running
    @property
    def shipped(self) -> bool:
        """Whether this is one of cfopt's own algorithms (their exceptions are cfopt's bugs)."""
        return _SHIPPED.get(self.name) == self

    def __call__(self, mission: Mission, *, seed: SeedLike = None, **options: Any) -> Run:
        """Run the algorithm on ``mission``; always a :class:`heuristics.Run`.

        A returned :class:`cfopt.Assignment` is checked against the mission and wrapped
        with the wall-clock time and ``counted=False``.  For an algorithm that is not
        cfopt's own, an exception, a result of another type or an invalid assignment is
        :class:`AlgorithmFailed`.
        """
        started = time.perf_counter()
        if self.shipped:
            result = self.run(mission, seed=seed, **options)
        else:
            try:
                result = self.run(mission, seed=seed, **options)
            except Exception as exc:
                raise AlgorithmFailed(self.name, f"raised {_described(exc)}") from exc
        return self._result(result, mission, seed, started, options)

    def _result(
        self, result: Any, mission: Mission, seed: Any, started: float, options: dict[str, Any]
    ) -> Run:
        if isinstance(result, Run):
            if not self.shipped:
                self._validate(result.assignment, mission)
            return result
        if isinstance(result, Assignment):
            self._validate(result, mission)
            return Run(
                algorithm=self.name,
                assignment=result,
                iterations=0,
                rounds=0,
                messages=0,
                bytes=0,
                work=0,
                seconds=time.perf_counter() - started,
                seed=seed_label(seed),
                options=tuple(sorted(options.items())),
                counted=False,
            )
        raise AlgorithmFailed(
            self.name,
            f"returned {shown(result)}, not a heuristics.Run or a cfopt.Assignment",
        )

    def _validate(self, assignment: Assignment, mission: Mission) -> None:
        try:
            assignment.validate(mission)
        except MissionError as exc:
            raise AlgorithmFailed(
                self.name, f"returned an assignment that does not fit the mission ({exc})"
            ) from None

    # --------------------------------------------------------------- distributed
    @property
    def distributed(self) -> bool:
        """Whether the algorithm has a distributed protocol."""
        return self.protocol is not None

    def make_protocol(self, **options: Any) -> Any:
        """The distributed protocol with ``options`` (of :attr:`protocol_options`, each
        checked); :class:`cfopt.MissionError` when there is none or an option is unknown.
        """
        if self.protocol is None:
            with_agents = [n for n in algorithm_names() if ALGORITHMS[n].distributed]
            raise MissionError(
                f"algorithm: {self.name!r} has no distributed agents (available: "
                f"{', '.join(with_agents)})"
            )
        known = {o.name: o for o in self.protocol_options}
        for key, value in options.items():
            if not known:
                raise MissionError(
                    f"options: {self.name}'s agents take none, got {sorted(options)}"
                )
            if key not in known:
                raise MissionError(
                    f"options: {self.name}'s agents take {', '.join(known)}, not {key!r}"
                )
            known[key].check(value, f"options: {key}")
        factory = self.protocol
        if isinstance(factory, str):
            factory = _load_object(factory, f"{self.name}'s protocol")
        return factory(**options)

    def stability_checker(self) -> Callable[..., Any] | None:
        """The checker of a ``stability="own"`` algorithm (a ``"MODULE:ATTR"`` imported
        now); ``None`` for the others."""
        if self.checker is None or callable(self.checker):
            return self.checker
        return _load_object(self.checker, f"{self.name}'s checker")


# ------------------------------------------------------------------- references
def _split_reference(reference: str, what: str) -> tuple[str, str]:
    module, sep, attribute = reference.partition(":")
    if not sep or not module.strip() or not attribute.strip():
        raise MissionError(f"{what}: must be MODULE:ATTR, both non-empty, got {reference!r}")
    return module.strip(), attribute.strip()


def _import(module: str, directory: str | None) -> Any:
    """``import module``, with ``directory`` first on ``sys.path`` when given (left there,
    as ``python -m`` leaves the current directory, for the module's own later imports)."""
    if directory is not None:
        if not sys.path or sys.path[0] != directory:
            sys.path.insert(0, directory)
        importlib.invalidate_caches()  # a module written since the last import is found
    return importlib.import_module(module)


def _attribute(value: Any, reference: str, module: str, attribute: str) -> Any:
    for part in attribute.split("."):
        if not hasattr(value, part):
            raise MissionError(f"{reference}: {module} has no attribute {attribute!r}")
        value = getattr(value, part)
    return value


def _load_object(reference: str, what: str, directory: str | None = None) -> Any:
    """The object ``"MODULE:ATTR"`` names; :class:`cfopt.MissionError` naming ``what``."""
    module, attribute = _split_reference(reference, what)
    try:
        loaded = _import(module, directory)
    except Exception as exc:
        raise MissionError(f"{reference}: cannot import {module}: {_described(exc)}") from None
    return _attribute(loaded, reference, module, attribute)


def _found_in(module: Any, name: str) -> str | None:
    """The ``sys.path`` directory ``module`` (imported as ``name``) was found in."""
    path = getattr(module, "__file__", None)
    if not path:
        return None
    folder = Path(path).resolve().parent
    if Path(path).name == "__init__.py":
        folder = folder.parent
    for _ in range(name.count(".")):
        folder = folder.parent
    return os.fspath(folder)


def _as_specs(value: Any, where: str, name: str | None = None) -> list[AlgorithmSpec]:
    """``value`` (a spec, a callable named ``name`` or after itself, or a list of specs)
    as a list of specs; :class:`cfopt.MissionError` naming ``where`` otherwise."""
    if isinstance(value, AlgorithmSpec):
        return [value]
    if (
        isinstance(value, list | tuple)
        and value
        and all(isinstance(v, AlgorithmSpec) for v in value)
    ):
        return list(value)
    if callable(value) and not isinstance(value, type | list | tuple):
        label = name or getattr(value, "__name__", None) or type(value).__name__
        try:
            return [AlgorithmSpec(name=label, run=value)]
        except MissionError as exc:
            raise MissionError(f"{where}: {exc}") from None
    raise MissionError(
        f"{where}: must be a heuristics.AlgorithmSpec, a callable or a list of specs, got "
        f"{shown(value)}"
    )


@dataclass(frozen=True)
class _Reference:
    spec: AlgorithmSpec
    directory: str | None


def _resolve(reference: str, directory: str | None) -> _Reference:
    folder = os.path.abspath(directory if directory is not None else os.getcwd())
    cached = _REFERENCES.get((reference, folder))
    if cached is not None:
        return cached
    module, attribute = _split_reference(reference, "algorithm")
    try:
        loaded = _import(module, folder)
    except Exception as exc:
        raise MissionError(f"{reference}: cannot import {module}: {_described(exc)}") from None
    value = _attribute(loaded, reference, module, attribute)
    if isinstance(value, list | tuple):
        raise MissionError(
            f"{reference}: must name one heuristics.AlgorithmSpec or a callable, got a "
            f"{type(value).__name__}"
        )
    (spec,) = _as_specs(value, reference, name=reference)
    known = ALGORITHMS.get(spec.name)
    if known is not None and known != spec:
        raise MissionError(
            f"{reference}: names its algorithm {spec.name!r}, which is already registered; "
            "give it another name"
        )
    found = _Reference(spec, _found_in(loaded, module) or folder)
    _REFERENCES[(reference, folder)] = found
    _DIRECTORIES[reference] = found.directory
    return found


#: Resolved ``MODULE:ATTR`` references: (reference, directory) -> spec and home.
_REFERENCES: dict[tuple[str, str], _Reference] = {}
#: Reference -> the directory its module was found in (for workers elsewhere).
_DIRECTORIES: dict[str, str | None] = {}


def algorithm_directory(name: str) -> str | None:
    """The directory the module of ``MODULE:ATTR`` reference ``name`` was imported from
    (this process resolved it already); ``None`` for a registered name.

    Workers in another folder (dask, MPI) pass it to :func:`get_algorithm` as
    ``directory`` so that they import the same module.
    """
    return _DIRECTORIES.get(require_text("algorithm", name))


# ---------------------------------------------------------------------- registry
class AlgorithmRegistry(Mapping[str, AlgorithmSpec]):
    """Name -> spec: ``shipped`` (cfopt's own), then the entry points of
    ``entry_point_group`` (loaded on first use; ``None``: none), then those of
    :meth:`register`.  Read-only as a mapping.

    :data:`ALGORITHMS` is the one every command uses; a fresh registry is useful in tests
    (``monkeypatch.setattr(heuristics.registry, "ALGORITHMS", AlgorithmRegistry())``:
    :func:`register_algorithm`, :func:`get_algorithm` and :func:`algorithm_names` use
    whichever is :data:`ALGORITHMS`).
    """

    def __init__(
        self,
        shipped: Sequence[AlgorithmSpec] | None = None,
        entry_point_group: str | None = ENTRY_POINT_GROUP,
    ) -> None:
        specs = SHIPPED if shipped is None else shipped
        if not all(isinstance(spec, AlgorithmSpec) for spec in specs):
            raise MissionTypeError(
                f"shipped: must be a sequence of heuristics.AlgorithmSpec, got {shown(specs)}"
            )
        if entry_point_group is not None:
            require_text("entry_point_group", entry_point_group)
        self._specs = {s.name: s for s in specs}
        self._origins = dict.fromkeys(self._specs, "by cfopt")
        self._group = entry_point_group
        self._loaded = entry_point_group is None

    def _all(self) -> dict[str, AlgorithmSpec]:
        if not self._loaded:
            self._loaded = True
            before = (dict(self._specs), dict(self._origins))
            try:
                self._load_entry_points()
            except BaseException:
                self._specs, self._origins = before  # the next use reports it again
                self._loaded = False
                raise
        return self._specs

    def _load_entry_points(self) -> None:
        found = importlib.metadata.entry_points(group=self._group)
        for ep in sorted(found, key=lambda e: (e.name, e.value)):
            where = f"entry point {ep.name} = {ep.value} (group {self._group})"
            try:
                value = ep.load()
            except Exception as exc:
                raise MissionError(f"{where}: cannot be loaded: {_described(exc)}") from None
            for spec in _as_specs(value, where, name=ep.name):
                self._add(spec, where, f"by {where}")

    def register(self, spec: AlgorithmSpec) -> AlgorithmSpec:
        """Add ``spec`` (the same spec again changes nothing); returns it.  A name taken
        by another algorithm, or with ``:``, is a :class:`cfopt.MissionError`."""
        if not isinstance(spec, AlgorithmSpec):
            raise MissionTypeError(f"spec: must be a heuristics.AlgorithmSpec, got {shown(spec)}")
        return self._add(spec, f"register_algorithm({spec.name!r})", "by register_algorithm")

    def _add(self, spec: AlgorithmSpec, where: str, origin: str) -> AlgorithmSpec:
        specs = self._all()
        if ":" in spec.name:
            raise MissionError(f"{where}: name {spec.name!r}: a registered name has no ':'")
        known = specs.get(spec.name)
        if known is not None and known != spec:
            raise MissionError(
                f"{where}: algorithm name {spec.name!r} is already registered "
                f"({self._origins[spec.name]}); choose another name"
            )
        specs[spec.name] = spec
        self._origins.setdefault(spec.name, origin)
        return spec

    def origin(self, name: str) -> str | None:
        """Who registered ``name``: ``"by cfopt"``, ``"by entry point ..."`` or ``"by
        register_algorithm"``; ``None`` when nobody did."""
        require_text("name", name)
        self._all()
        return self._origins.get(name)

    def __getitem__(self, key: str) -> AlgorithmSpec:
        return self._all()[key]

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._all()))

    def __len__(self) -> int:
        return len(self._all())

    def __repr__(self) -> str:
        return f"ALGORITHMS({', '.join(self)})"


# ------------------------------------------------------------- cfopt's algorithms
_ORDER = Option(
    "order", str, "index", "robot order each round: index (the seed's simulator) or seeded "
    "random; the auctions accept it and have no order to choose", ORDERS,
)  # fmt: skip
_MEDIUM = Option(
    "medium", str, "broadcast", "how messages are counted: broadcast (one transmission "
    "reaches every neighbour, the seed's UDP) or unicast (one message per receiver)",
    ("broadcast", "unicast"),
)  # fmt: skip
_ENCODING = Option(
    "encoding", str, "full", "belief size: full (16 + 4 n bytes) or compact (slots "
    "bit-packed, ceil(log2(m S + 1)) bits each; the auctions send no beliefs)",
    ("full", "compact"),
)  # fmt: skip
_TIME_LIMIT = Option(
    "time_limit", float, None, "wall-clock seconds after which the run stops with the "
    "partition reached (status time_limit; default: no limit)",
)  # fmt: skip
_REWARD = Option(
    "reward", str, "paper", "the reward weighting: paper (the seed's) or utility "
    "(utility-weighted, heuristics.reward)", REWARDS,
)  # fmt: skip
_COMMON = (_ORDER, _MEDIUM, _ENCODING, _TIME_LIMIT)
_EXCHANGE = Option(
    "exchange", bool, True, "the exchange phase step (--no-exchange: the ablation without it)"
)
_SDA_EPS = Option("eps", float, 1.0, "the wage decrement")
_PAIRWISE = ("exchanges", "pairwise_step_ran")

#: GRAPE-S and the Pair-GRAPE-S variants (its first phase) draw the random order lazily
#: since version 2: the same law, other draws, so trials of version 1 are not reused.
_LAZY_ORDER = "2"

SHIPPED: tuple[AlgorithmSpec, ...] = (
    AlgorithmSpec(
        "grape-s", grape_s, stability="seed", version=_LAZY_ORDER,
        options=(Option(
            "capped", bool, False, "forbid joining a slot that already holds the robots it "
            "requires (Pair-GRAPE-S's first phase)"), _REWARD, *_COMMON),
        protocol="heuristics.agents.grape_s:GrapeSProtocol",
        summary="GRAPE-S, the seed's hedonic-game coalition formation",
    ),
    AlgorithmSpec(
        "pair-grape-s", pair_grape_s, stability="capped", version=_LAZY_ORDER,
        options=(_REWARD, *_COMMON),
        protocol="heuristics.agents.grape_s:PairGrapeSProtocol", measures=_PAIRWISE,
        summary="Pair-GRAPE-S: capped GRAPE-S, then the seed's pairwise exchanges",
    ),
    AlgorithmSpec(
        "sda", sda, stability="none",
        options=(_SDA_EPS, Option(
            "schedule", str, "max-wage", "the wage decrement schedule", SDA_SCHEDULES),
            *_COMMON),
        protocol="heuristics.agents.sda:SdaProtocol",
        protocol_options=(_SDA_EPS, Option(
            "resend_tries", int, 0, "resends of unanswered messages (0: the seed's plain "
            "protocol)")),
        summary="SDA, the simultaneous descending auction",
    ),
    AlgorithmSpec(
        "rachna-dt", rachna_dt, stability="none",
        options=(Option("eps", float, None, "the wage increase (default 1/n)"),
                 Option("schedule", str, "simultaneous", "how the bids are settled",
                        RACHNA_SCHEDULES),
                 Option("max_rounds", int, MAX_ROUNDS,
                        "refuse missions needing more bidding rounds"), *_COMMON),
        summary="RACHNA_dt, the ascending auction (no distributed agents, as in the seed)",
    ),
    AlgorithmSpec(
        "pair-grape-s-chain", pair_grape_s_chain, stability="capped", version=_LAZY_ORDER,
        options=(_REWARD, *_COMMON),
        protocol="heuristics.agents.grape_s:PairGrapeSChainProtocol", measures=_PAIRWISE,
        summary="Pair-GRAPE-S with chain exchanges (cfopt's own)",
    ),
    AlgorithmSpec(
        "grape-s-select", grape_s_select, stability="own",
        checker="proofs.select_stability:select_violations",
        options=(_EXCHANGE, *_COMMON),
        protocol="heuristics.agents.grape_s_select:GrapeSSelectProtocol",
        protocol_options=(_EXCHANGE,),
        summary="GRAPE-S-Select: GRAPE-S with task selection (cfopt's own)",
    ),
)  # fmt: skip
_SHIPPED = {s.name: s for s in SHIPPED}

#: Name -> :class:`AlgorithmSpec`, a read-only live view: the seed's four algorithms,
#: cfopt's own, the installed packages' (entry points ``cfopt.algorithms``, loaded on
#: first use) and those of :func:`register_algorithm`.
ALGORITHMS: Mapping[str, AlgorithmSpec] = AlgorithmRegistry()


def register_algorithm(
    algorithm: AlgorithmSpec | Callable[..., Any], *, name: str | None = None, **fields: Any
) -> AlgorithmSpec:
    """Register ``algorithm`` under its name, so every command and sweep can run it.

    Parameters
    ----------
    algorithm : AlgorithmSpec or callable
        A spec, or a function ``(mission, *, seed=None, **options) -> Run | Assignment``
        wrapped into one named after it (its ``__name__``) or ``name``.
    name : str, optional
        The registry name (replaces a spec's own).
    **fields
        Further :class:`AlgorithmSpec` fields (``version``, ``stability``, ``options``...).

    Returns
    -------
    AlgorithmSpec
        The registered spec; it is callable like the function, so this also works as a
        decorator (``@register_algorithm``).

    Raises
    ------
    cfopt.MissionError
        A name already registered by another algorithm, a name with ``:``, or an object
        that is neither a spec nor a callable.

    Notes
    -----
    Processes forked from this one (the default worker pool on Linux) see the
    registration; fresh ones (dask workers, MPI ranks) do not: for them register by an
    entry point, or give ``MODULE:ATTR``.

    Examples
    --------
    >>> register_algorithm(get_algorithm("grape-s")).name  # the same spec: no change
    'grape-s'
    >>> register_algorithm("grape-s")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionTypeError: algorithm: must be a heuristics.AlgorithmSpec or ...
    """
    if name is not None:
        require_text("name", name)
    if isinstance(algorithm, AlgorithmSpec):
        changes = {**fields, **({} if name is None else {"name": name})}
        spec = replace(algorithm, **changes) if changes else algorithm
    elif callable(algorithm) and not isinstance(algorithm, type):
        label = name or getattr(algorithm, "__name__", None) or type(algorithm).__name__
        spec = AlgorithmSpec(name=label, run=algorithm, **fields)
    else:
        raise MissionTypeError(
            f"algorithm: must be a heuristics.AlgorithmSpec or a callable, got {shown(algorithm)}"
        )
    registry = ALGORITHMS
    if not isinstance(registry, AlgorithmRegistry):
        raise MissionError("register_algorithm: heuristics.registry.ALGORITHMS is not a registry")
    return registry.register(spec)


def algorithm_names() -> list[str]:
    """The registered names, sorted.

    >>> algorithm_names()
    ['grape-s', 'grape-s-select', 'pair-grape-s', 'pair-grape-s-chain', 'rachna-dt', 'sda']
    """
    return sorted(ALGORITHMS)


def get_algorithm(name: str, *, directory: str | os.PathLike[str] | None = None) -> AlgorithmSpec:
    """The spec registered as ``name``, or the one ``"MODULE:ATTR"`` names.

    Parameters
    ----------
    name : str
        A registered name, or ``MODULE:ATTR``: ``MODULE`` imported with ``directory`` first
        on ``sys.path``, ``ATTR`` (dotted for a nested attribute) a spec or a callable (a
        callable is wrapped into a spec named ``name``).  Resolved once per process.
    directory : path, optional
        Where ``MODULE`` is looked for first (default: the current directory).

    Returns
    -------
    AlgorithmSpec
        Callable as the algorithm: ``get_algorithm(name)(mission, seed=0, **options)``.

    Raises
    ------
    cfopt.MissionError
        An unknown name (the message lists the known ones), a module that cannot be
        imported, a missing attribute, an object that is neither a spec nor a callable,
        or a spec whose name is registered by another algorithm.

    Examples
    --------
    >>> get_algorithm("grape-s").run.__name__
    'grape_s'
    >>> get_algorithm("grape")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: unknown algorithm 'grape' (known: grape-s, grape-s-select, ...)
    >>> get_algorithm("no_such_module:f")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    cfopt.errors.MissionError: no_such_module:f: cannot import no_such_module: ...
    """
    if not isinstance(name, str):
        raise MissionTypeError(f"algorithm: must be a name (a string), got {shown(name)}")
    if directory is not None and not isinstance(directory, str | os.PathLike):
        raise MissionTypeError(f"directory: must be a path or None, got {shown(directory)}")
    if ":" in name:
        return _resolve(name, None if directory is None else os.fspath(directory)).spec
    try:
        value = ALGORITHMS[name]
    except KeyError:
        raise MissionError(
            f"unknown algorithm {name!r} (known: {', '.join(algorithm_names())})"
        ) from None
    return value if isinstance(value, AlgorithmSpec) else _as_specs(value, name, name=name)[0]


def run_algorithm(name: str, mission: Mission, **options: Any) -> Run:
    """Look ``name`` up and run it on ``mission`` with ``options``."""
    return get_algorithm(name)(mission, **options)
