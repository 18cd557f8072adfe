"""The suite's kernels: every signature of the simulation kernel the tests may compile, and how to compile them.

numba compiles :func:`mgrao_core.engine.run_block` once per signature, and the signature is chiefly which of its
optional arguments are ``None`` (:data:`OPTIONAL`: several resources, a sparse world's links, an environment outside
the run, tasks that fail, and each learner family's lanes; the kernel's code for an argument that is ``None`` is
neither typed nor compiled). A signature is named by the optional arguments it has, ``+``-joined (``several+mgrao``;
``fixed`` without any: fixed families alone). Each costs between a quarter of a minute and a few minutes to compile
with an empty cache (the more families, the longer), so the suite keeps to the :data:`CENSUS`: a test that runs the
kernel on another signature fails (tests/conftest.py), and adding one is a decision with its cost (the census's
``seconds``, measured with ``python -m tests.support.kernels measure``). Most of it is the kernel of every family
for each kind of world the tests run several families in: the runner runs a chunk whose own kernel is not compiled
on that one (:func:`mgrao_core.runner.ready_kernel`), so one compile serves every combination of families of its
world, where a kernel per combination cost a fifth more (19 signatures: 305 s against 256 s in two processes,
load average about 3). tests/test_kernel_census.py checks that each recipe gives its signature and that
:data:`OPTIONAL` is every optional argument of the kernel.

In a parallel run (``pytest -n``) the census is compiled before the first test, by as many processes as the run has
workers, the longest first, two processes compiling one family's steps at once only for the last signature
(:func:`precompile`, called by tests/conftest.py): the tests then load every kernel from numba's cache (tests that
compile from scratch on purpose use caches of their own). ``python -m tests.support.kernels compile NAME...``
compiles some in this process, ``list`` lists the census, ``measure`` times each signature alone, ``fresh`` the whole.
"""

from __future__ import annotations

import argparse
import fcntl
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from tests.support.project import ROOT

OPTIONAL = ("several", "links", "outside", "failing", "mgrao_lanes", "adaptive_lanes", "independent_q_lanes",
            "bandit_lanes", "balance_lanes")
"""The kernel's arguments that may be ``None``, as :func:`mgrao_core.engine.run_block` names them."""
PARTS = ("several", "links", "outside", "failing", "mgrao", "mgrao-adaptive", "independent-q", "bandit",
         "mgrao-balance")
"""Each optional argument's part of a signature's name (the learner families by their names)."""

COMPILE_TIMEOUT_S = 2400.0
"""The deadline of compiling the whole census (about 5 minutes on 2 quiet cores, 17 under a load average of 7)."""

FROM_SCRATCH = {"NUMBA_OPT": "1"}
"""What a test that compiles the engine from scratch on purpose, in a cache of its own, adds to its processes'
environment: numba's LLVM level 1, where numba's default is 3. Those tests check how the engine compiles and caches
(where the files go, what an edit recompiles, what is said while it compiles, that a cached kernel loads without
numba's compiler), none of which depends on how hard LLVM optimises; at level 1 the same kernels compile 12-18% faster
and compute the same bits (``benchmarks/bench_numba_opt.py``), which the tests that compare numbers check against the
census's. (At level 0 numba cannot cache the kernel at all: "it uses dynamic globals".) The census, on which every
other test's numbers run, and the quick start, which is the README's commands as a user types them, keep numba's
default: the suite tests the machine code users run."""


@dataclass(frozen=True)
class Recipe:
    """A small run that calls the kernel with one signature: ``algorithms`` on ``system`` with ``overrides``, through
    :func:`mgrao_core.run_experiment`, or through the environments' stepper (:class:`mgrao_core.stepper.SteppedWorlds`,
    which gives the kernel an ``outside`` and no learner) when ``stepped``."""

    system: str
    algorithms: tuple[str, ...] = ("uniform",)
    overrides: Mapping[str, Any] = field(default_factory=dict)
    stepped: bool = False
    seconds: float = 60.0
    """What it costs: its seconds in the census's compile from an empty cache, two processes at once on 2 cores
    (load average about 3; ``python -m tests.support.kernels measure`` compiles each alone and prints its seconds)."""

    def run(self) -> None:
        """Run it: 1 seed, 2 episodes (compiling or loading its kernel)."""
        from mgrao_core import make_spec, run_experiment

        spec = make_spec(self.system, list(self.algorithms), seeds=1, episodes=2, overrides=dict(self.overrides))
        if not self.stepped:
            run_experiment(spec)
            return
        import numpy as np

        from mgrao_core.stepper import SteppedWorlds

        worlds = SteppedWorlds(spec.params, [0], block=2)
        p = spec.params
        shape = (1, p.n_children, p.n_resources, p.n_types) if p.n_resources > 1 else (1, p.n_children, p.n_types)
        worlds.observe(worlds.step(np.full(shape, 1.0 / p.n_types)))


SEVERAL = {"n_resources": 2}
SPARSE = {"topology": "ring", "children_per_parent": 2}
FAILING = {"task_need": 1.5}

MGRAO, ADAPTIVE, BALANCE = "mgrao-1:1", "mgrao-adaptive:2", "mgrao-balance"
LEARNERS = (MGRAO, ADAPTIVE, "independent-q", "bandit")

EVERY = ("uniform", "oracle", *LEARNERS, BALANCE)
"""Every family: the runner runs a chunk of fewer families on this kernel of its kind of world, where that one is
compiled and the chunk's own is not, with the same numbers (mgrao_core.runner.ready_kernel)."""

CENSUS: dict[str, Recipe] = {  # seconds: each one's compile in the census's own run (see Recipe.seconds)
    # every family, for the three kinds of world whose chunks the tests run with several families
    "mgrao+mgrao-adaptive+independent-q+bandit+mgrao-balance": Recipe("single", EVERY, seconds=107),
    "several+mgrao+mgrao-adaptive+independent-q+bandit+mgrao-balance": Recipe("single", EVERY, SEVERAL, seconds=72),
    "several+failing+mgrao+mgrao-adaptive+independent-q+bandit+mgrao-balance": Recipe("single", EVERY,
                                                                                     SEVERAL | FAILING, seconds=71),
    # the other kinds' tests run the fixed allocations and MG-RAO alone: their own kernels are smaller
    "failing+mgrao": Recipe("single", ("uniform", MGRAO), FAILING, seconds=27),
    "links+mgrao": Recipe("multi", ("uniform", MGRAO), SPARSE, seconds=18),
    "several+links+mgrao": Recipe("multi", ("uniform", MGRAO), SEVERAL | SPARSE, seconds=40),
    # the environments' steps (an outside, no learner)
    "outside": Recipe("single", stepped=True, seconds=10),
    "several+outside": Recipe("single", overrides=SEVERAL, stepped=True, seconds=17),
    "several+outside+failing": Recipe("single", overrides=SEVERAL | FAILING, stepped=True, seconds=31),
}
"""Every signature the tests may compile, by name, with a run that compiles it."""


def in_census(name: str) -> bool:
    """Whether a test may run the kernel on the signature ``name``: the census's, or any of a kind of world whose kernel
    of every family the census has. The runner runs such a chunk on that one (nothing compiled) unless numba's cache
    holds the chunk's own kernel, as a user's cache may after ``mgrao run``: loading it compiles nothing either."""
    if name in CENSUS:
        return True
    world = [part for part in name.split("+") if part in PARTS[:4]]
    return "+".join([*world, *PARTS[4:]]) in CENSUS


def kernel_name(arguments: Sequence[Any]) -> str:
    """The name of the signature of a call of the kernel with ``arguments`` (Python values or numba types)."""
    from numba.core import types

    from mgrao_core.engine.kernel import run_block

    names = list(_parameters(run_block))
    present = [not (arguments[names.index(a)] is None or isinstance(arguments[names.index(a)], types.NoneType))
               for a in OPTIONAL]
    return "+".join(part for part, here in zip(PARTS, present, strict=True) if here) or "fixed"


def _parameters(dispatcher: Any) -> Iterable[str]:
    import inspect

    return inspect.signature(dispatcher.py_func).parameters


class _Named(Exception):
    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.name = name


def signature_of(recipe: Recipe) -> str:
    """The name of the signature ``recipe`` calls the kernel with, found without compiling it."""
    from mgrao_core import engine

    kernel = engine.run_block

    def name_it(*arguments: Any) -> None:
        raise _Named(kernel_name(arguments))

    engine.run_block = name_it
    try:
        recipe.run()
    except _Named as named:
        return named.name
    finally:
        engine.run_block = kernel
    raise AssertionError(f"{recipe} never called the kernel")


def loaded_signatures() -> list[Any]:
    """The signatures of the kernel this process has compiled or loaded so far (numba types), if numba is loaded."""
    engine = sys.modules.get("mgrao_core.engine")
    return list(engine.run_block.signatures) if engine is not None else []


# ---- compiling the census ---------------------------------------------------------------------------------------


def serialise_cache_writes() -> None:
    """Make numba's writes of a cache index one process at a time (an ``flock`` beside the index).

    numba saves a new signature by reading the function's index, adding its entry and writing the index back:
    two processes compiling signatures of one function at once can lose one's entry, or number their data files
    alike, so that one loads the other's machine code. Left as numba has it if its internals look different.
    """
    try:
        from numba.core.caching import IndexDataCacheFile
    except ImportError:
        return
    save = getattr(IndexDataCacheFile, "save", None)
    if save is None or getattr(save, "serialised", False) or not hasattr(IndexDataCacheFile, "__init__"):
        return

    def serialised_save(self: Any, key: Any, data: Any) -> None:
        index = getattr(self, "_index_path", None)
        if index is None:
            return save(self, key, data)
        with open(f"{index}.lock", "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # held for one index write: never long
            try:
                return save(self, key, data)
            finally:
                fcntl.flock(lock, fcntl.LOCK_UN)

    serialised_save.serialised = True  # type: ignore[attr-defined]
    IndexDataCacheFile.save = serialised_save


def compile_here(names: Iterable[str], report: Callable[[str, float], None] | None = None) -> None:
    """Run each named recipe in this process (compiling its kernel unless numba's cache has it)."""
    serialise_cache_writes()
    for name in names:
        start = time.perf_counter()
        CENSUS[name].run()
        if report is not None:
            report(name, time.perf_counter() - start)


def _steps(name: str) -> set[str]:
    """What compiling ``name`` may compile first, beside the kernel: the compiled steps of its learner families other
    than MG-RAO's (balance's once with several resources, once without) and those of tasks that fail."""
    parts = name.split("+")
    steps = {part for part in parts if part in ("failing", "mgrao-adaptive", "independent-q", "bandit")}
    if "mgrao-balance" in parts:
        steps.add("mgrao-balance+several" if "several" in parts else "mgrao-balance")
    return steps


def next_to_compile(pending: Sequence[str], compiled: set[str], others: set[str]) -> str | None:
    """What an idle process of :func:`precompile` takes from ``pending`` (longest first), or None to wait.

    The longest whose compiled steps not yet cached (``compiled``) no other process is compiling (``others``); and when
    every pending one shares such steps and one is left, that one: its steps are then compiled twice, by this process
    on a core that would otherwise idle until the other process ends. At the census's end these are the several
    resources' balance steps of its last kernel of every family: the whole census from empty caches in two processes
    took 162 s this way and 199 s waiting (load average about 1.3; ``python -m tests.support.kernels fresh``).
    """
    free = next((name for name in pending if not (_steps(name) - compiled) & others), None)
    return free if free is not None or len(pending) != 1 else pending[0]


@dataclass
class Precompiled:
    """What :func:`precompile` did: each signature's seconds (compiled, or loaded from the cache) and the wall time."""

    seconds: dict[str, float]
    wall: float
    processes: int


class _Compiler:
    """A ``python -m tests.support.kernels serve`` process: compiles each name written to it, says when done."""

    def __init__(self, environment: Mapping[str, str], log: Any) -> None:
        self.process = subprocess.Popen([sys.executable, "-m", "tests.support.kernels", "serve"], cwd=ROOT,
                                        env=dict(environment), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                        stderr=log, text=True, bufsize=1)
        self.name: str | None = None
        self.steps: set[str] = set()

    def give(self, name: str, steps: set[str]) -> None:
        assert self.process.stdin is not None
        self.name, self.steps = name, steps
        self.process.stdin.write(name + "\n")
        self.process.stdin.flush()


def precompile(names: Sequence[str] | None = None, processes: int = 2, timeout: float = COMPILE_TIMEOUT_S,
               env: Mapping[str, str] | None = None) -> Precompiled:
    """Compile the named signatures (default: the whole census) in ``processes`` processes at once.

    Each process takes the longest signature left (the census's ``seconds``) whose families' compiled steps no
    other process is compiling at the time (:func:`_steps`; numba caches them once compiled, and every later
    signature loads them): two processes compiling adaptive groups' steps at once would each spend a minute on
    them. A process with nothing it may take waits for the others, except for the last one (:func:`next_to_compile`).

    Raises:
        RuntimeError: a process failed, or the whole did not finish within ``timeout`` seconds (its output says why).
    """
    import selectors
    import tempfile

    pending = sorted(CENSUS if names is None else names, key=lambda n: -CENSUS[n].seconds)
    start = time.perf_counter()
    deadline = time.monotonic() + timeout
    environment = dict(os.environ if env is None else env)
    environment["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), environment.get("PYTHONPATH")]))
    seconds: dict[str, float] = {}
    compiled: set[str] = set()  # steps compiled (and cached) by a finished signature
    with tempfile.TemporaryFile("w+") as log:
        compilers = [_Compiler(environment, log) for _ in range(max(1, min(processes, len(pending))))]
        selector = selectors.DefaultSelector()
        for compiler in compilers:
            selector.register(compiler.process.stdout, selectors.EVENT_READ, compiler)
        try:
            while pending or any(c.name for c in compilers):
                for compiler in compilers:
                    others = set().union(*(c.steps for c in compilers if c is not compiler))
                    take = next_to_compile(pending, compiled, others)
                    if compiler.name is None and take is not None:
                        pending.remove(take)
                        compiler.give(take, _steps(take) - compiled)
                left = deadline - time.monotonic()
                events = selector.select(timeout=max(0.0, left))
                if not events and left <= 0:
                    raise RuntimeError(f"compiling the kernels took more than {timeout:g} s; left: "
                                       + ", ".join([*(c.name for c in compilers if c.name), *pending]))
                for key, _ in events:
                    compiler = key.data
                    line = compiler.process.stdout.readline()
                    if not line:  # the process ended: it failed
                        compiler.process.wait(timeout=60)
                        log.seek(0)
                        raise RuntimeError(f"compiling {compiler.name} failed ({compiler.process.returncode}):\n"
                                           f"{log.read()[-3000:]}")
                    seconds.update(json.loads(line))
                    compiled |= compiler.steps
                    compiler.name, compiler.steps = None, set()
        finally:
            for compiler in compilers:
                if compiler.process.poll() is None and compiler.name is None:
                    compiler.process.stdin.close()  # done: it ends
                else:
                    compiler.process.kill()
                compiler.process.wait(timeout=60)
                compiler.process.stdout.close()
    return Precompiled(seconds, time.perf_counter() - start, len(compilers))


def _from_empty_cache(names: Sequence[str], processes: int) -> Precompiled:
    """:func:`precompile` of ``names`` in a cache home of its own, empty, without the caller's ``NUMBA_*`` settings."""
    import tempfile

    environment = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    with tempfile.TemporaryDirectory(prefix="mgrao-census-") as home:
        return precompile(names, processes=processes, env=environment | {"XDG_CACHE_HOME": home})


def measure(names: Sequence[str]) -> dict[str, float]:
    """Each named signature's compile time alone: in a process of its own, with an empty numba cache."""
    results = {}
    for name in names:
        results[name] = _from_empty_cache([name], processes=1).seconds[name]
        print(f"{name}: {results[name]:.1f} s", flush=True)
    return results


def fresh(names: Sequence[str], processes: int) -> Precompiled:
    """The named signatures compiled as a parallel run compiles them (:func:`precompile`), from an empty numba cache."""
    done = _from_empty_cache(names, processes)
    print(f"{len(done.seconds)} signatures in {done.wall:.1f} s by {done.processes} processes (load average "
          + " ".join(f"{x:.2f}" for x in os.getloadavg()) + "): "
          + ", ".join(f"{name} {seconds:.0f} s" for name, seconds in done.seconds.items()), flush=True)
    return done


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tests.support.kernels", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("serve", help="compile (or load) each census name read from standard input, a line each")
    compile_ = sub.add_parser("compile", help="compile (or load) the named census signatures in this process")
    compile_.add_argument("names", nargs="*", help="census names (default: all)")
    measure_ = sub.add_parser("measure", help="each signature's compile time with an empty cache")
    measure_.add_argument("names", nargs="*", help="census names (default: all)")
    fresh_ = sub.add_parser("fresh", help="compile as a parallel run does, from an empty cache, and time the whole")
    fresh_.add_argument("names", nargs="*", help="census names (default: all)")
    fresh_.add_argument("--processes", type=int, default=2, help="processes at once (default: 2)")
    sub.add_parser("list", help="the census, with each signature's seconds")
    args = parser.parse_args(argv)
    def report(name: str, seconds: float) -> None:
        print(json.dumps({name: round(seconds, 2)}), flush=True)

    if args.command == "serve":
        compile_here((line.strip() for line in sys.stdin if line.strip()), report)
    elif args.command == "compile":
        compile_here(args.names or CENSUS, report)
    elif args.command == "measure":
        measure(args.names or list(CENSUS))
    elif args.command == "fresh":
        fresh(args.names or list(CENSUS), args.processes)
    else:
        for name, recipe in CENSUS.items():
            print(f"{name:50s} {recipe.seconds:6.0f} s  {recipe}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
