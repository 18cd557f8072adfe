"""Shared helpers of the core tests."""

import numpy as np

from mgrao_core import equations as eq
from mgrao_core import reference


def assert_matches_reference(result, atol=1e-12):
    """Every run of ``result`` equals the dense per-agent reference simulator.

    Utilities and the learned PW must agree to ``atol``, and what became of the atomic tasks exactly. The combined
    weights (algorithm 2) must agree to ``atol`` with algorithm 2 applied to the engine's own PW, and to
    ``1000 * atol`` with the reference's: ``dkl`` of a row within ``d`` of uniform is of order ``n d**2``, so a one-ulp
    difference in PW (lazy versus dense update) changes it by up to 1e-5 relative when every row
    is nearly uniform (a child that hardly received a task), which moves the weights by ~1e-12.
    """
    spec = result.spec
    temperature = spec.params.effective_temperature
    use_counts = spec.params.group_blend == "dkl-and-count"
    for run in result.runs:
        utilities, children, tasks = reference.simulate_run(spec.params, run.algorithm, run.seed, spec.episodes)
        np.testing.assert_allclose(run.utilities, utilities, rtol=0, atol=atol,
                                   err_msg=f"{run.algorithm} seed {run.seed}")
        assert run.tasks == tasks, f"{run.algorithm} seed {run.seed}: {run.tasks} != {tasks}"
        combined = np.stack([c.allocation() for c in children])
        if run.group_weights.size:
            pw = np.stack([c.pw for c in children])
            assert run.group_weights.shape == pw.shape
            np.testing.assert_allclose(run.group_weights, pw, rtol=0, atol=atol)
            on_engine_pw = np.stack([eq.combined_weights(run.group_weights[c], child.counts, temperature,
                                                         use_counts)
                                     for c, child in enumerate(children)])
            np.testing.assert_allclose(run.combined_weights, on_engine_pw, rtol=0, atol=atol)
            np.testing.assert_allclose(run.combined_weights, combined, rtol=0, atol=1000 * atol)
        else:
            np.testing.assert_allclose(run.combined_weights, combined, rtol=0, atol=atol)


def assert_resources_match_reference(result, atol=1e-12):
    """Every run equals the reference: utilities, each resource's allocation and (MG-RAO) PW, to ``atol``."""
    spec = result.spec
    p = spec.params
    for run in result.runs:
        utilities, children, tasks = reference.simulate_run(p, run.algorithm, run.seed, spec.episodes)
        where = f"{run.algorithm} seed {run.seed}"
        assert run.tasks == tasks, f"{where}: {run.tasks} != {tasks}"
        np.testing.assert_allclose(run.utilities, utilities, rtol=0, atol=atol, err_msg=where)
        allocations = np.stack([np.broadcast_to(c.allocation(), (p.n_resources, p.n_types)) for c in children])
        assert run.resource_weights.shape == (p.n_resources, p.n_children, p.n_types)
        np.testing.assert_array_equal(run.combined_weights, run.resource_weights[0])
        if hasattr(children[0], "resources"):  # MG-RAO: a PW per resource
            pw = np.stack([np.stack([r.pw for r in c.resources]) for c in children]).transpose(1, 0, 2, 3)
            np.testing.assert_allclose(run.resource_group_weights, pw, rtol=0, atol=atol, err_msg=where)
            np.testing.assert_array_equal(run.group_weights, run.resource_group_weights[0])
            counts = [[r.counts for r in c.resources] for c in children]
            on_engine_pw = np.stack([[eq.combined_weights(run.resource_group_weights[r, c], counts[c][r],
                                                          p.effective_temperature) for r in range(p.n_resources)]
                                     for c in range(p.n_children)])
            np.testing.assert_allclose(run.resource_weights.transpose(1, 0, 2), on_engine_pw, rtol=0, atol=atol,
                                       err_msg=where)
            np.testing.assert_allclose(run.resource_weights.transpose(1, 0, 2), allocations, rtol=0,
                                       atol=1000 * atol, err_msg=where)
        else:
            np.testing.assert_allclose(run.resource_weights.transpose(1, 0, 2), allocations, rtol=0, atol=atol,
                                       err_msg=where)
