"""The documented template family (not registered) still satisfies the interface of a learner family."""

import numpy as np
from numba import njit

from mgrao_core import PARAMETERS, get_preset, make_params
from mgrao_core.algorithms import FAMILIES, parse_algorithm, template_steps
from mgrao_core.algorithms import template as template_module
from mgrao_core.algorithms.base import Family, ReferenceChild
from mgrao_core.algorithms.state import SIZES, allocate, sizes_of

FAMILY = template_module.FAMILY


@njit
def _run_steps(tl, lanes, children, task_types, values, weights, final):
    """Every lane: allocate, learn one composite from parent 0, allocate again, finish."""
    for lane in range(lanes):
        for c in range(weights.shape[1]):
            template_steps.allocate(tl, lane, 0, c, weights[lane, c])
        template_steps.learn(tl, lane, 0, 0, 1, children, task_types, values)
        template_steps.finish(tl, lane, 0, final[lane])


def test_the_template_is_a_learner_family_that_is_not_registered():
    assert isinstance(FAMILY, Family) and FAMILY.learns and FAMILY not in FAMILIES
    assert FAMILY.name not in {f.name for f in FAMILIES}
    assert not {p.name for p in FAMILY.parameters} & {p.name for p in PARAMETERS}
    assert all(set(a.shape) <= set(SIZES) for a in FAMILY.state)
    assert FAMILY.steps == template_steps.__name__
    params = make_params({})  # what learning_cost prices: a total per type, as its state holds
    assert FAMILY.learned_numbers(FAMILY.parse("template", 10, "algorithm"), params) == params.n_types


def test_the_templates_labels_describe_themselves():
    algorithm = FAMILY.parse("template", 10, "algorithm")
    assert algorithm.label == "template" and FAMILY.parse("mgrao-1:1", 10, "algorithm") is None
    assert FAMILY.examples(10) == ["template"] and FAMILY.forms(10)[0]["template"] == "template"
    assert 0 <= FAMILY.colour_key(algorithm) < 8 and FAMILY.hint(None)
    params = get_preset("single").params
    assert FAMILY.memory_per_child(algorithm, params) == 8 * params.n_types
    assert parse_algorithm("uniform", 10).kind == "uniform"  # the registry itself is unchanged


def test_the_templates_compiled_steps_equal_its_reference_step():
    params = get_preset("multi").params
    algorithm = FAMILY.parse("template", params.n_parents, "algorithm")
    lanes = 2
    arrays = allocate(FAMILY.state, sizes_of(params, lanes, 0))
    tl = FAMILY.compiled_lanes(arrays, params)
    children = np.arange(params.types_per_composite) % params.n_children
    task_types = np.arange(params.types_per_composite, dtype=np.int64)
    values = np.linspace(0.1, 0.5, params.types_per_composite)
    weights = np.zeros((lanes, params.n_children, params.n_types))
    final = np.zeros_like(weights)
    _run_steps(tl, lanes, children, task_types, values, weights, final)
    reference = FAMILY.reference_children(params, algorithm, None, 0)
    assert all(isinstance(child, ReferenceChild) for child in reference)
    np.testing.assert_allclose(weights[0], [child.allocation() for child in reference], rtol=0, atol=1e-15)
    for k, c in enumerate(children):
        reference[c].learn(0, int(task_types[k]), float(values[k]))
    for lane in range(lanes):
        np.testing.assert_allclose(final[lane], [child.allocation() for child in reference], rtol=0, atol=1e-15)
