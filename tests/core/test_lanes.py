"""The chunk's per-lane arrays: allocated and counted from one set of declarations."""

import shutil

import numpy as np
import pytest

from mgrao_core import make_spec
from mgrao_core.algorithms import FAMILIES, KINDS
from mgrao_core.algorithms.state import nbytes
from mgrao_core.budget import chunk_cost
from mgrao_core.engine.cache import PACKAGE_DIR, sources_digest
from mgrao_core.lanes import ENVIRONMENT, allocate_lanes, chunk_sizes, declarations, lane_bytes
from mgrao_core.world import _STREAM_IDS, routing_choices

CASES = [
    ("single", ["uniform", "mgrao-1:1", "mgrao-max", "oracle"], 3, {}),
    ("multi", ["mgrao-2:1", "uniform"], 2, {"routing": "per-task"}),
    ("large", ["mgrao-max"], 1, {}),
    ("single", ["uniform"], 4, {}),
]
RESOURCE_CASES = [
    ("multi", ["uniform", "mgrao-1:1", "mgrao-max", "oracle", "mgrao-adaptive:2", "bandit"], 2, {"n_resources": 3}),
    ("single", ["mgrao-2:1", "independent-q"], 3, {"n_resources": 8, "resource_credit": "by-share"}),
]


def _before(spec, n_seeds):
    """The state bytes as budget.py counted them by hand before the declarations (issue 19)."""
    p = spec.params
    algorithms = spec.parsed_algorithms
    lanes = n_seeds * len(algorithms)
    groups = max([a.n_groups for a in algorithms] + [1])
    return 8 * lanes * (
        p.n_children * (2 * groups * p.n_types + 6 * groups + 2 * p.n_types + 2)
        + 2 * p.n_parents * routing_choices(p) * p.n_children
        + p.n_parents * p.types_per_composite
        + 3
    ) + lanes * p.n_parents


@pytest.mark.parametrize(("system", "algorithms", "seeds", "overrides"), CASES + RESOURCE_CASES)
def test_the_budget_counts_exactly_what_the_runner_allocates(system, algorithms, seeds, overrides):
    spec = make_spec(system, algorithms, seeds=seeds, episodes=5, overrides=overrides)
    arrays = allocate_lanes(spec.params, spec.parsed_algorithms, seeds)
    allocated = sum(a.nbytes for a in arrays.values())
    assert allocated == lane_bytes(spec.params, spec.parsed_algorithms, seeds) == chunk_cost(spec, seeds).state
    assert sorted(arrays) == sorted(a.name for a in declarations())


@pytest.mark.parametrize(("system", "algorithms", "seeds", "overrides"), CASES)
def test_the_budget_grows_only_by_the_kernel_temporaries_it_now_counts(system, algorithms, seeds, overrides):
    # MG-RAO's rebase flag (a byte per lane and child) and algorithm 2's blending vector (groups
    # floats per lane) were allocated inside the kernel, per lane, and not counted; they are now
    # declared state, allocated once per chunk and counted; and (issue 20) each parent's atomic types,
    # per lane since scheduled events and unpredictable parents change them; and (issue 33) each lane's task
    # share, what learning leaves its children's tasks, per child since mgrao-balance's children choose their own
    spec = make_spec(system, algorithms, seeds=seeds, episodes=5, overrides=overrides)
    lanes = seeds * len(algorithms)
    groups = max([a.n_groups for a in spec.parsed_algorithms] + [1])
    parent_types = 8 * spec.params.n_parents * spec.params.types_per_composite  # each lane's parents' atomic types
    # families registered since (issue 21's learners) add their declared state to every lane
    # (an array another family declared already, as mgrao-adaptive shares MG-RAO's, is held once)
    first = {a.name for f in FAMILIES if f.name in ("uniform", "oracle", "mgrao") for a in f.state}
    later = list({a.name: a for f in FAMILIES for a in f.state if a.name not in first}.values())
    added = nbytes(later, chunk_sizes(spec.params, spec.parsed_algorithms, seeds))
    # (issue 42) algorithm 2's blending vector became each learner's row dkls, kept while a row is inactive
    learners = spec.params.n_children * spec.params.n_resources if any(
        a.kind in ("mgrao", "mgrao-adaptive", "mgrao-balance") for a in spec.parsed_algorithms) else 1
    assert chunk_cost(spec, seeds).state == (_before(spec, seeds) + lanes * (spec.params.n_children
                                                                              + 8 * groups * learners
                                                                              + parent_types
                                                                              + 8 * spec.params.n_children) + added)


@pytest.mark.parametrize(("system", "algorithms", "seeds", "overrides"), RESOURCE_CASES)
def test_several_resources_grow_the_learners_state_and_nothing_at_one(system, algorithms, seeds, overrides):
    # MG-RAO's (and mgrao-adaptive's shared) arrays hold one learner per (child, resource), the allocation in
    # force one row per resource; one resource adds no byte (its resource axis is empty)
    one = make_spec(system, algorithms, seeds=seeds, episodes=5, overrides={**overrides, "n_resources": 1})
    several = make_spec(system, algorithms, seeds=seeds, episodes=5, overrides=overrides)
    r = several.params.n_resources
    arrays_one = allocate_lanes(one.params, one.parsed_algorithms, seeds)
    arrays = allocate_lanes(several.params, several.parsed_algorithms, seeds)
    assert arrays_one["resource_weights"].nbytes == 0
    assert arrays["resource_weights"].shape[2] == r
    assert arrays["Y"].shape[1] == r * arrays_one["Y"].shape[1]
    assert chunk_cost(several, seeds).state > chunk_cost(one, seeds).state
    assert chunk_cost(several, seeds).worlds > chunk_cost(one, seeds).worlds
    assert chunk_cost(several, seeds).results > chunk_cost(one, seeds).results


def test_lanes_are_seed_major_with_their_family_codes_and_groups():
    spec = make_spec("single", ["uniform", "mgrao-5:1", "oracle"], seeds=2, episodes=5)
    arrays = allocate_lanes(spec.params, spec.parsed_algorithms, 2)
    assert arrays["seed_index"].tolist() == [0, 0, 0, 1, 1, 1]
    assert arrays["kind"].tolist() == [KINDS["uniform"], KINDS["mgrao"], KINDS["oracle"]] * 2
    assert arrays["groups"].tolist() == [0, 5, 0] * 2
    assert (arrays["n_rows"][[1, 4]] == 5).all() and (arrays["rows"][1, 0] == np.arange(5)).all()


def test_declarations_are_well_formed_and_streams_distinct():
    names = [a.name for a in ENVIRONMENT]
    assert len(names) == len(set(names))
    numbers = list(_STREAM_IDS.values())
    assert len(numbers) == len(set(numbers)) and _STREAM_IDS["oracle"] == 5
    for family in FAMILIES:
        for array in family.state:
            assert array.shape[0] == "lanes" and array.dtype in ("float64", "int64", "bool")


def test_editing_an_algorithm_module_changes_the_kernel_cache_digest(tmp_path):
    package = shutil.copytree(PACKAGE_DIR, tmp_path / "mgrao_core", ignore=shutil.ignore_patterns("__pycache__"))
    before = sources_digest(package)
    assert before == sources_digest(PACKAGE_DIR)
    compiled = package / "algorithms" / "mgrao" / "compiled.py"
    compiled.write_text(compiled.read_text() + "\n# an edit\n")
    assert sources_digest(package) != before