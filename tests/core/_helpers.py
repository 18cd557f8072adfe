"""Shared helpers of the core tests."""

import numpy as np

from mgrao_core import reference


def assert_matches_reference(result, atol=1e-11):
    """Every run of ``result`` equals the dense per-agent reference simulator."""
    spec = result.spec
    temperature = spec.params.effective_temperature
    for run in result.runs:
        utilities, children = reference.simulate(spec.params, run.algorithm, run.seed, spec.episodes)
        np.testing.assert_allclose(run.utilities, utilities, rtol=0, atol=atol,
                                   err_msg=f"{run.algorithm} seed {run.seed}")
        if run.group_weights.size:
            pw = np.stack([c.pw for c in children])
            assert run.group_weights.shape == pw.shape
            np.testing.assert_allclose(run.group_weights, pw, rtol=0, atol=atol)
        combined = np.stack([c.allocation(temperature) for c in children])
        np.testing.assert_allclose(run.combined_weights, combined, rtol=0, atol=atol)
