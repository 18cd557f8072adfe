"""Compiling the engine: what a chunk needs compiled, saying so while it is, and compiling every family ahead.

numba compiles the kernel once per *combination*: the learner families a chunk runs (each family's lanes are an
argument, ``None`` without them) and what its world has (several resources, sparse links, tasks that can fail);
:mod:`mgrao_core.engine.kernel` says why. A combination met for the first time compiles (tens of seconds on 2
cores, a few minutes for every family at once on a loaded machine); later processes load it from numba's cache in
well under a second. The runner (:func:`mgrao_core.runner.run_chunk`) says so before it compiles, through its
``on_compile`` callback (:class:`Compiling`: the parts, an estimate, then the seconds it took), which ``mgrao run``
prints and a worker writes to its job, and it runs a chunk on the kernel of *every* family where that kernel is
compiled and the chunk's own is not: a family's code runs only for its own lanes, so the numbers are the same
(tests/core/test_compiling.py checks them bit for bit).

:func:`ahead` lists the experiments whose kernels ``mgrao compile`` compiles ahead (:func:`mgrao_core.runner.
compile_for`): for each kind of world, one with every family. After it, no job waits on the compiler.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

from mgrao_core.algorithms import FAMILIES, LEARNERS, family_of
from mgrao_core.spec import ExperimentSpec, make_spec

ENGINE = "engine"
SEVERAL = "several resources"
SPARSE = "a sparse world"
FAILING = "tasks that can fail"

COMPILE_SECONDS = {ENGINE: 13.5, "mgrao": 18.1, "mgrao-adaptive": 19.7, "independent-q": 2.1, "bandit": 2.6,
                   "mgrao-balance": 28.4, SEVERAL: 10.0, SPARSE: 0.9, FAILING: 14.5}
"""Seconds each part adds to a compile of the kernel on 2 cores (``engine``: the kernel with the fixed allocations
alone): the medians of 3 of ``python benchmarks/bench_compile.py`` on a shared machine at load average 4.6 before
and 5.8 after (docs/model.md, "The engine"); a quiet machine compiles faster, a more loaded one slower. An estimate
is their sum."""


@dataclass(frozen=True)
class Compiling:
    """The engine is being compiled for a chunk's combination, met for the first time (``seconds`` None), or was.

    Attributes:
        parts: what the combination has: its learner families by name, then ``several resources``, ``a sparse
            world``, ``tasks that can fail``; ``engine`` alone for the fixed allocations.
        estimate_s: about how long it takes (:data:`COMPILE_SECONDS`).
        seconds: how long it took, once done; None while it compiles.
    """

    parts: tuple[str, ...]
    estimate_s: float
    seconds: float | None = None

    @property
    def message(self) -> str:
        """What a person reads: ``compiling the engine for mgrao-balance, several resources: first time only, ...``."""
        what = ", ".join(p for p in self.parts if p != ENGINE) or "the fixed allocations"
        if self.seconds is None:
            return f"compiling the engine for {what}: first time only, about {round(self.estimate_s)} s"
        return f"compiled the engine for {what} in {self.seconds:.1f} s (first time only)"

    def as_dict(self) -> dict[str, object]:
        """The notice as JSON: ``parts``, ``estimate_s``, ``seconds``, ``message``."""
        return {"parts": list(self.parts), "estimate_s": self.estimate_s, "seconds": self.seconds,
                "message": self.message}


def parts_of(spec: ExperimentSpec) -> tuple[str, ...]:
    """The parts of ``spec``'s combination: its learner families (registry order), then what its world has."""
    present = {family_of(a).name for a in spec.parsed_algorithms}
    p = spec.params
    world = ((SEVERAL,) if p.n_resources > 1 else ()) + ((SPARSE,) if p.sparse else ()) + (
        (FAILING,) if p.tasks_can_fail else ())
    return (ENGINE, *(f.name for f in LEARNERS if f.name in present), *world)


def estimate_seconds(parts: tuple[str, ...]) -> float:
    """About how long a compile of these parts takes on 2 cores (:data:`COMPILE_SECONDS`).

    An unknown part (a family registered later) counts as MG-RAO's.
    """
    return sum(COMPILE_SECONDS.get(part, COMPILE_SECONDS["mgrao"]) for part in parts)


def every_family(system: str = "multi") -> list[str]:
    """A label of every registered family valid in ``system`` (each family's first example)."""
    n_parents = make_spec(system, seeds=1, episodes=1).params.n_parents
    return [f.examples(n_parents)[0] for f in FAMILIES]


AHEAD_WORLDS = {SEVERAL: {"n_resources": 2}, SPARSE: {"topology": "ring", "children_per_parent": 2},
                FAILING: {"task_need": 1.0}}
"""What gives a world each part that changes the kernel's arguments (on ``multi``: 3 children, 10 parents)."""

WORLD_NAMES = {"several": SEVERAL, "sparse": SPARSE, "failing": FAILING}
"""The short name of each part of a kind of world, as ``mgrao compile --worlds`` takes them."""
PLAIN = "plain"
"""The kind of world without any part: one resource, complete, no task fails (the paper's)."""


def kinds_of_world() -> list[frozenset[str]]:
    """Every kind of world, as the set of its parts: plain first, then every subset of :data:`AHEAD_WORLDS`."""
    return [frozenset(parts) for size in range(len(AHEAD_WORLDS) + 1)
            for parts in itertools.combinations(AHEAD_WORLDS, size)]


def kind_name(kind: frozenset[str]) -> str:
    """A kind of world by its short names, ``+``-joined in :data:`WORLD_NAMES`' order (``plain`` without parts)."""
    return "+".join(short for short, part in WORLD_NAMES.items() if part in kind) or PLAIN


def kinds_from_text(text: str) -> list[frozenset[str]]:
    """The kinds of world ``text`` names, in :func:`kinds_of_world`'s order.

    ``text`` is ``all``, or kinds separated by commas, each ``plain`` or short names (:data:`WORLD_NAMES`) joined by
    ``+``: ``plain,several+failing``.

    Raises:
        ValueError: a name that is not a part of a world, naming it and the valid ones.
    """
    if text.strip() == "all":
        return kinds_of_world()
    wanted = set()
    for item in (t.strip() for t in text.split(",")):
        names = [n.strip() for n in item.split("+")]
        unknown = [n for n in names if n not in WORLD_NAMES and not (n == PLAIN and len(names) == 1)]
        if unknown:
            raise ValueError(f"{unknown[0]!r} is not a kind of world: give 'all', or kinds separated by commas, each "
                             f"'{PLAIN}' or parts joined by '+' from {', '.join(WORLD_NAMES)}")
        wanted.add(frozenset(WORLD_NAMES[n] for n in names if n != PLAIN))
    return [kind for kind in kinds_of_world() if kind in wanted]


def ahead(system: str = "multi", kinds: list[frozenset[str]] | None = None) -> list[ExperimentSpec]:
    """The experiments whose kernels ``mgrao compile`` compiles, the paper's default configurations first.

    Then a one-seed, one-episode experiment of every family for each kind of world (``kinds``, default every
    subset of :data:`AHEAD_WORLDS`). The kernel of every family runs any chunk of its kind of world (see the
    module's docstring); the paper's own is compiled too where the plain kind is, so that the first run of the
    paper's configurations loads exactly what it compiles alone.
    """
    kinds = kinds_of_world() if kinds is None else kinds
    specs = [make_spec("single", seeds=1, episodes=1)] if frozenset() in kinds else []
    labels = every_family(system)
    for kind in kinds:
        overrides = {k: v for part in AHEAD_WORLDS if part in kind for k, v in AHEAD_WORLDS[part].items()}
        specs.append(make_spec(system, labels, seeds=1, episodes=1, overrides=overrides))
    return specs
