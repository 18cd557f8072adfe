"""What every algorithm family declares: labels, parameters, per-lane state, compiled and reference steps.

A *family* is one kind of learner or baseline (``uniform``, ``oracle``, ``mgrao``); a *label* names
one configuration of a family (``mgrao-5:1``); an :class:`Algorithm` is a label parsed for a system.
Each family lives in its own module of :mod:`mgrao_core.algorithms` and is registered in
:data:`mgrao_core.algorithms.FAMILIES`; nothing outside the family's module parses its labels, and
nothing outside it knows its state or its steps. A family is one of two kinds:

* a :class:`FixedFamily` (``uniform``, ``oracle``): every child keeps one allocation for the whole
  run, which the family computes per seed (:meth:`FixedFamily.fixed_weights`); the kernel copies it;
* a *learner* (``mgrao``): each child's state is the family's per-lane arrays (:attr:`Family.state`),
  and its compiled steps (:attr:`Family.steps`, a module the kernel calls) fix the child's allocation
  at the start of an episode, learn from each returned value and materialise the final state.

docs/algorithms.md shows how to add one, and :mod:`mgrao_core.algorithms.template` is a documented
learner to copy.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from mgrao_core.algorithms.state import StateArray, System, nbytes, sizes_of
from mgrao_core.errors import ConfigError
from mgrao_core.parameter import Parameter


class World(Protocol):
    """What a family reads of a seed's world (:class:`mgrao_core.world.World`)."""

    composite_types: np.ndarray
    parent_types: np.ndarray
    profiles: np.ndarray
    resources: np.ndarray


def load(entry: str) -> Any:
    """The object an entry names: ``"package.module"`` (the module) or ``"package.module:name"``.

    A family names its heavy parts (compiled steps, reference step, a fixed allocation's computation)
    by entry rather than importing them, so that the registry loads neither numba nor the modules
    that read the registry; the layer that runs them (the runner, the reference simulator) loads them.
    """
    module, _, name = entry.partition(":")
    loaded = importlib.import_module(module)
    return getattr(loaded, name) if name else loaded

LEARNERS_OWN = ("learning_cost",)
"""Parameters every learner reads as its own and no fixed family reads (:attr:`Family.own_parameters`)."""

PALETTE_SLOTS = 8
"""Colour keys are slots ``0 .. PALETTE_SLOTS - 1`` of the dashboard's colour-blind-safe palette."""


@dataclass(frozen=True)
class Algorithm:
    """A parsed algorithm label.

    Attributes:
        label: the canonical spelling, e.g. ``"mgrao-5:1"``.
        kind: the family's name: ``"uniform"``, ``"oracle"`` or ``"mgrao"``.
        n_groups: parent groups per child (MG-RAO only; 0 otherwise).
        team_size: children that share one learner's state (MG-RAO's y of ``mgrao-x:y``; 1: each child its own).
    """

    label: str
    kind: str
    n_groups: int = 0
    team_size: int = 1


@dataclass(frozen=True)
class LabelForm:
    """One way of writing a family's labels, for forms that build labels from it.

    A literal form (``argument`` None) is the label ``template`` itself; a form with an argument
    is ``template`` with ``{argument}`` (``{x}``, ``{M}``) replaced by a whole number (``pattern`` matches the
    canonical and the accepted spellings, with the number as its first group). A form may take a second
    argument (``second``: MG-RAO's ``{y}`` of ``mgrao-{x}:{y}``), the pattern's second group; its values are
    then typed as pairs, ``x:y``.
    """

    template: str
    pattern: str
    description: str
    argument: str | None = None
    argument_help: str = ""
    second: str | None = None
    second_help: str = ""

    def as_dict(self, n_parents: int | None = None, valid: list[int] | None = None,
                second_valid: list[int] | None = None) -> dict[str, Any]:
        """JSON-ready; ``valid`` (and ``second_valid``) list the arguments' allowed values for a system when known."""
        out: dict[str, Any] = {"template": self.template, "pattern": self.pattern, "description": self.description,
                               "argument": self.argument, "argument_help": self.argument_help}
        if self.argument is not None:
            out["valid"] = valid
        if self.second is not None:
            out |= {"second_argument": self.second, "second_help": self.second_help, "second_valid": second_valid}
        return out


class ReferenceChild:
    """A child of the dense reference simulator (:mod:`mgrao_core.reference`), as each family defines it."""

    def allocation(self) -> np.ndarray:
        """The child's resource weights for the coming episode, ``(n_types,)``."""
        raise NotImplementedError

    def learn(self, parent: int, task_type: int, value: float) -> None:
        """The child receives the absolute ``value`` of an atomic task of ``task_type`` from ``parent``."""

    def task_share(self, share: float) -> float:
        """The share of its resources the child's tasks get in the episode its :meth:`allocation` began.

        ``share`` is its family's (:func:`mgrao_core.algorithms.task_share`); a child whose learning changes while it
        runs (``mgrao-balance``) gives its own.
        """
        return share

    def learn_resources(self, parent: int, task_type: int, value: float, shares: np.ndarray) -> None:
        """With several resources: ``shares[r]`` is resource ``r``'s share of the task's quality.

        By default a child learns the whole value, as with one resource (one split for every resource).
        """
        self.learn(parent, task_type, value)


class FixedChild(ReferenceChild):
    """A reference child that keeps one allocation and never learns."""

    def __init__(self, weights: np.ndarray) -> None:
        self.weights = weights

    def allocation(self) -> np.ndarray:
        """The fixed weights."""
        return self.weights



class OneLabel:
    """The label side of a family with a single label, its own name (``uniform``, ``oracle``, ``bandit``...).

    Put it first among a family's bases: ``class Uniform(OneLabel, FixedFamily)``; the family then sets
    ``form_description`` (the label form's few words) beside its ``name``.
    """

    name: str = ""
    form_description: str = ""

    def parse(self, text: str, n_parents: int | None, field: str) -> Algorithm | None:
        """The family's one algorithm when ``text`` is its name, else None."""
        return Algorithm(self.name, self.name) if text == self.name else None

    def forms(self, n_parents: int | None) -> list[dict[str, Any]]:
        """One literal form: the name."""
        return [LabelForm(self.name, f"^{self.name}$", self.form_description).as_dict()]

    def examples(self, n_parents: int | None) -> list[str]:
        """The name."""
        return [self.name]

    def hint(self, n_parents: int | None) -> str:
        """The name."""
        return self.name


class Family:
    """An algorithm family; each family's module defines one subclass and an instance (``FAMILY``).

    Subclasses set the class attributes and implement :meth:`parse`, :meth:`forms`,
    :meth:`examples`, :meth:`colour_key` and :meth:`order` (the label side), and either derive
    from :class:`FixedFamily` or, for a learner, set :attr:`state` and :attr:`steps` and implement
    :meth:`compiled_lanes` and :meth:`reference_children`.
    """

    name: str = ""
    """The family's name, also :attr:`Algorithm.kind` of its labels."""
    title: str = ""
    """A short human name (``"MG-RAO"``)."""
    description: str = ""
    """One or two sentences for people: what the family does."""
    rank: int = 0
    """Where the family's configurations come in views (lower first)."""
    parameters: tuple[Parameter, ...] = ()
    """The family's own parameters; :data:`mgrao_core.params.PARAMETERS` lists them after the quality's."""
    reads: tuple[str, ...] = ()
    """Parameters declared elsewhere that the family's steps read as a learner's own (MG-RAO's ``resource_credit``,
    the adaptive family's MG-RAO parameters): with :attr:`parameters`, :attr:`own_parameters`."""
    streams: Mapping[str, int] = {}
    """The family's own random streams, name to a number no other stream has ever used
    (:func:`mgrao_core.world.stream`)."""
    state: tuple[StateArray, ...] = ()
    """Each lane's arrays of the family (a learner's children's state). Every lane of a chunk holds
    every registered family's arrays, sized for the chunk's algorithms (one declaration per name:
    two families declaring one name share the array)."""
    steps: str | None = None
    """A learner's compiled steps: the module the kernel calls (an entry, see :func:`load`); it also defines
    ``lanes_of(arrays, params)``, the family's lanes as the steps read them."""
    reference: str | None = None
    """A learner's dense reference step: the entry (:func:`load`) of a function ``(params, algorithm, world,
    seed)`` returning one :class:`ReferenceChild` per child."""
    groups_change: bool = False
    """Whether a child's number of parent groups changes as it runs (``mgrao-balance``): its recorded membership
    (:meth:`membership`) then says how many it ended with, and :meth:`learned_with` what it keeps with them."""

    @property
    def own_parameters(self) -> tuple[str, ...]:
        """The names of the parameters only this family's learning reads: its :attr:`parameters`, then :attr:`reads`.

        A learner's also include ``learning_cost``, which every learner reads and nothing else does (what its
        learning takes from its tasks; uniform and the oracle pay nothing, so their runs are the same at any cost).
        A configuration is a world, a label and these parameters' values (:mod:`mgrao_core.statistics.pairing`):
        two jobs that differ in them run the same world, so their uniform runs pair with both.
        """
        names = (*(p.name for p in self.parameters), *self.reads, *(LEARNERS_OWN if self.learns else ()))
        return tuple(dict.fromkeys(names))

    @property
    def learns(self) -> bool:
        """Whether the family's children learn (it has compiled steps)."""
        return self.steps is not None

    def sizes(self, algorithm: Algorithm, params: System) -> dict[str, int]:
        """The sizes of :data:`~mgrao_core.algorithms.state.FAMILY_SIZES` that ``algorithm``'s lanes need (none)."""
        return {}

    def memory_per_child(self, algorithm: Algorithm, params: System) -> int:
        """Bytes of one child's state (:attr:`state`) for ``algorithm`` in a system.

        Children that share their state in teams (:attr:`Algorithm.team_size` ``y``) each carry ``1 / y`` of a
        team's, rounded up to a whole byte.
        """
        sizes = sizes_of(params, 1, algorithm.n_groups, self.sizes(algorithm, params))
        return math.ceil(nbytes(self.state, sizes | {"children": 1, "learners": sizes["resources"]})
                         / algorithm.team_size)

    def preparation_bytes(self, params: System, n_seeds: int) -> int:
        """Bytes the family allocates, beyond its lane state, to prepare a chunk of ``n_seeds`` seeds."""
        return 0

    def learned_numbers(self, algorithm: Algorithm, params: System) -> int:
        """The numbers one child of ``algorithm`` learns and keeps, as the algorithm defines them.

        What ``learning_cost`` prices (docs/model.md, "The cost of learning"): the algorithm's own quantities (a
        row of weights per group, a count...), not the bytes the engine stores them in, so that a change of
        layout changes no result. A family that learns nothing keeps none; a learner must say.
        """
        if self.learns:
            raise NotImplementedError(f"{self.name} does not declare the numbers its children learn "
                                      "(Family.learned_numbers), so learning_cost cannot price its learning")
        return 0

    def learned_with(self, algorithm: Algorithm, params: System, groups: int) -> int:
        """The numbers one child keeps while it has ``groups`` parent groups.

        :meth:`learned_numbers`, unless the family's group count changes (:attr:`groups_change`).
        """
        return self.learned_numbers(algorithm, params)

    def initialise(self, arrays: Mapping[str, np.ndarray], lanes: np.ndarray, params: System) -> None:
        """Set the initial state of the family's ``lanes`` that the declared fills do not (nothing by default).

        ``arrays`` are every array of the chunk by name (``arrays["groups"]``: each lane's parent groups).
        """

    def compiled_lanes(self, arrays: Mapping[str, np.ndarray], params: System) -> tuple:
        """A learner's lanes as its compiled steps read them (a flat NamedTuple of arrays and numbers).

        Loads the compiled steps (numba): the runner calls it.
        """
        if self.steps is None:
            raise NotImplementedError(f"{self.name} has no compiled steps")
        return load(self.steps).lanes_of(arrays, params)

    def group_weights(self, arrays: Mapping[str, np.ndarray], lane: int, algorithm: Algorithm) -> np.ndarray | None:
        """A lane's final per-group weights ``(children, n_groups, n_types)`` to store, if the family has any."""
        return None

    def membership(self, arrays: Mapping[str, np.ndarray], lane: int, algorithm: Algorithm,
                   params: System) -> tuple[np.ndarray, int] | None:
        """A lane's recorded parent-group memberships to store, if the family's groups change (None: they do not).

        ``(history, every)``: ``history (children, snapshots, n_parents)`` each parent's group in each
        record, the first at episode 0 and one every ``every`` episodes after it.
        """
        return None

    def reference_children(self, params: System, algorithm: Algorithm, world: World,
                           seed: int) -> list[ReferenceChild]:
        """The children of the dense reference simulator for ``algorithm`` (its reference step)."""
        if self.reference is None:
            raise NotImplementedError(f"{self.name} has no reference step")
        return load(self.reference)(params, algorithm, world, seed)

    def parse(self, text: str, n_parents: int | None, field: str) -> Algorithm | None:
        """The algorithm that lower-cased, stripped ``text`` names, or None if it is not this family's.

        ``n_parents`` None checks the grammar alone (no system yet). Raises :class:`ConfigError`
        (naming ``field``) for a label of this family that is invalid for the system.
        """
        raise NotImplementedError

    def check_children(self, algorithm: Algorithm, n_children: int, field: str) -> None:
        """Refuse ``algorithm`` (parsed by :meth:`parse`) where it does not fit a system of ``n_children`` children.

        Nothing to check by default; MG-RAO's ``mgrao-x:y`` needs y to divide ``n_children``. Raises
        :class:`ConfigError` naming ``field``.
        """

    def forms(self, n_parents: int | None) -> list[dict[str, Any]]:
        """The family's :class:`LabelForm` s as JSON, with the arguments valid for ``n_parents``."""
        raise NotImplementedError

    def system_forms(self, params: System | None) -> list[dict[str, Any]]:
        """:meth:`forms` for a system (``params``; None: the grammar alone): by default those of its parent count.

        A family whose label arguments depend on more than the parents (MG-RAO's y, on the children) says so here.
        """
        return self.forms(None if params is None else params.n_parents)

    def examples(self, n_parents: int | None) -> list[str]:
        """Labels of this family valid for a system of ``n_parents`` parents (a few, for forms)."""
        raise NotImplementedError

    def hint(self, n_parents: int | None) -> str:
        """How to write the family's labels, for the error of an unknown label."""
        raise NotImplementedError

    def colour_key(self, algorithm: Algorithm) -> int:
        """The palette slot the configuration prefers (``0 .. PALETTE_SLOTS - 1``), the same in every view."""
        raise NotImplementedError

    def order(self, algorithm: Algorithm) -> int:
        """The configuration's place within its family in views (lower first)."""
        return 0

    def sort_key(self, algorithm: Algorithm) -> tuple[int, int]:
        """Views order configurations by family rank, then by :meth:`order`."""
        return (self.rank, self.order(algorithm))


class FixedFamily(Family):
    """A family whose children keep one allocation for a whole run, computed per seed.

    Its lanes hold that allocation in ``fixed_weights``, which the kernel copies into the child's
    weights at the start of every episode.
    """

    state = (StateArray("fixed_weights", ("lanes", "children", "n_types"), fill="uniform",
                        help="each child's allocation for the whole run"),)

    def fixed_weights(self, params: System, world: World, seed: int,
                      should_stop: Callable[[], bool] | None = None) -> np.ndarray:
        """Each child's allocation, ``(n_children, n_types)``, rows summing to 1."""
        raise NotImplementedError

    def initialise(self, arrays: Mapping[str, np.ndarray], lanes: np.ndarray, params: System) -> None:
        """Nothing: the runner writes :meth:`fixed_weights` into ``fixed_weights`` per seed."""

    def reference_children(self, params: System, algorithm: Algorithm, world: World,
                           seed: int) -> list[ReferenceChild]:
        """Children that keep :meth:`fixed_weights`."""
        return [FixedChild(w) for w in self.fixed_weights(params, world, seed)]


def invalid(field: str, message: str) -> ConfigError:
    """The error of a label that its family recognises but the system does not allow."""
    return ConfigError(field, message)
