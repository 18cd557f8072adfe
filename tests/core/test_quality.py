"""The quality models: one registry, each model's numpy and compiled forms alike, the oracle's inverses exact.

Whatever the model, an unknown one fails loudly: by name with a ConfigError naming it, by code with NaN.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mgrao_core import equations, params, quality
from mgrao_core.engine import environment_of
from mgrao_core.errors import ConfigError
from mgrao_core.params import make_params
from mgrao_core.quality import QUALITY_MODELS, QualityModel, atomic_quality, compiled_atomic_quality, quality_model

WEIGHTS = np.array([0.0, 1e-9, 0.01, 0.05, 1.0 / 3.0, 0.5, 0.999, 1.0])
LOADS = np.array([1.0, 2.0, 3.0, 7.0])


def test_the_registry_gives_the_schema_its_choices_and_the_kernel_distinct_codes() -> None:
    assert params.QUALITY_MODELS == tuple(QUALITY_MODELS) == ("hyperbolic", "exponential", "relative-linear")
    assert params.PARAMETERS_BY_NAME["quality_model"].choices == tuple(QUALITY_MODELS)
    assert sorted(model.code for model in QUALITY_MODELS.values()) == list(range(len(QUALITY_MODELS)))
    assert all(quality_model(name).name == name for name in QUALITY_MODELS)


def test_an_unknown_model_name_fails_naming_it() -> None:
    with pytest.raises(ConfigError, match="'linear'.*hyperbolic, exponential, relative-linear") as raised:
        quality_model("linear")
    assert raised.value.field == "quality_model"
    unvalidated = dataclasses.replace(make_params(), quality_model="linear")  # past the schema's own check
    for compute in (lambda: atomic_quality(np.array([0.5]), 0.5, unvalidated), lambda: environment_of(unvalidated),
                    lambda: unvalidated.effective_absent_quality):
        with pytest.raises(ConfigError, match="'linear'"):
            compute()


def test_a_model_has_exactly_one_inverse_for_the_oracle() -> None:
    hyperbolic = QUALITY_MODELS["hyperbolic"]
    with pytest.raises(ValueError, match="exactly one"):
        QualityModel("both", 9, hyperbolic.quality, hyperbolic.task_quality, hyperbolic.weights_at_level,
                     QUALITY_MODELS["relative-linear"].full_quality_share)
    with pytest.raises(ValueError, match="exactly one"):
        QualityModel("neither", 9, hyperbolic.quality, hyperbolic.task_quality)


def test_the_equations_name_the_quality_models_own_functions() -> None:
    for name in ("atomic_quality", "hyperbolic_quality", "exponential_quality", "relative_linear_quality",
                 "resource_amount"):
        assert getattr(equations, name) is getattr(quality, name)


@pytest.mark.parametrize("model", list(QUALITY_MODELS))
@pytest.mark.parametrize("resource", [0.05, 0.5, 1.0])
def test_the_compiled_form_is_the_numpy_form(model: str, resource: float) -> None:
    system = make_params({"quality_model": model, "half_saturation": 0.125, "quality_at_uniform": 0.4})
    env = environment_of(system)
    compiled = compiled_atomic_quality()
    for load in LOADS:
        expected = atomic_quality(WEIGHTS, resource, system, load)
        got = np.array([compiled(w, resource, load, env) for w in WEIGHTS])
        if model == "exponential":  # numpy's own expm1 against the C library's (numba's): at most 1 ulp apart
            np.testing.assert_array_max_ulp(got, expected, maxulp=1)
        else:
            assert got.tobytes() == expected.tobytes(), (model, resource, load)


def test_an_unknown_code_makes_the_compiled_form_nan_not_another_models_quality() -> None:
    env = environment_of(make_params())._replace(quality_model=len(QUALITY_MODELS))
    assert np.isnan(compiled_atomic_quality()(0.5, 0.5, 1.0, env))


@pytest.mark.parametrize("model", ["hyperbolic", "exponential"])
def test_a_concave_models_inverse_gives_the_weight_of_each_marginal_value(model: str) -> None:
    h = 0.2
    system = make_params({"quality_model": model, "half_saturation": h, "quality_floor": 1e-12})
    values = np.array([0.5, 1.0, 2.0])
    per_weight = np.array([0.3, 0.6, 0.9])  # resource per unit of weight
    for level in (0.05, 0.2, 0.5):  # below every type's marginal value at w = 0, V a / h
        w = QUALITY_MODELS[model].weights_at_level(values, per_weight, h, level)
        step = 1e-6
        q = [atomic_quality(w + d, 1.0, system, 1.0 / per_weight) for d in (-step, step)]
        np.testing.assert_allclose(values * (q[1] - q[0]) / (2 * step), level, rtol=1e-6)


def test_the_linear_models_full_quality_share_is_where_quality_reaches_one() -> None:
    system = make_params({"quality_model": "relative-linear", "quality_at_uniform": 0.3, "n_types": 10})
    loads = np.array([1.0, 2.0, 5.0])
    share = QUALITY_MODELS["relative-linear"].full_quality_share(loads, system.n_types, system.quality_at_uniform)
    np.testing.assert_allclose(atomic_quality(share, 0.7, system, loads), 1.0, rtol=1e-14)
    assert (atomic_quality(share * 0.99, 0.7, system, loads) < 1.0).all()
