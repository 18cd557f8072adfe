"""Bit-identical numbers: today's runs against the ones saved before the algorithms' restructure.

``tests/fixtures/golden_runs.npz`` holds the utilities and final weights of every case of
:mod:`tests.core.golden_cases`, as computed by the engine before algorithms moved into
``mgrao_core.algorithms``. A restructure must not change a bit of them.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.golden_cases import CASES, FIXTURE, compute


@pytest.fixture(scope="module")
def saved() -> dict[str, np.ndarray]:
    with np.load(FIXTURE) as data:
        return {key: data[key] for key in data.files}


@pytest.mark.parametrize("name", list(CASES))
def test_runs_are_bit_identical(name: str, saved: dict[str, np.ndarray]) -> None:
    now = compute(name)
    before = {key: value for key, value in saved.items() if key.startswith(f"{name}|")}
    assert sorted(now) == sorted(before), "the case's runs (algorithms, seeds) changed"
    for key, value in now.items():
        expected = before[key]
        assert value.shape == expected.shape, f"{key}: shape {value.shape}, was {expected.shape}"
        assert value.dtype == expected.dtype, f"{key}: dtype {value.dtype}, was {expected.dtype}"
        if value.tobytes() != expected.tobytes():
            worst = np.max(np.abs(value - expected)) if value.size else 0.0
            pytest.fail(f"{key}: not bit-identical (largest difference {worst:.3e})")
