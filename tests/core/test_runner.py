"""Progress reports and cooperative cancellation of a run."""

import pytest

from mgrao_core import Cancelled, make_spec, run_experiment
from mgrao_core.budget import BLOCK_ATOMIC_TASKS, block_episodes


def test_progress_fractions_increase_to_one():
    spec = make_spec("single", seeds=2, episodes=10)
    seen = []
    run_experiment(spec, on_progress=seen.append, episodes_per_block=3)
    assert seen == pytest.approx([0.3, 0.6, 0.9, 1.0])
    assert all(a < b for a, b in zip(seen, seen[1:], strict=False))
    assert seen[-1] == 1.0


def test_progress_in_one_block():
    seen = []
    run_experiment(make_spec("single", seeds=2, episodes=10), on_progress=seen.append)
    assert seen == [1.0]


def test_stop_before_the_first_block():
    with pytest.raises(Cancelled, match="0 of 10"):
        run_experiment(make_spec("single", seeds=2, episodes=10), should_stop=lambda: True)


def test_stop_after_the_first_block():
    calls = []

    def stop():
        calls.append(1)
        return len(calls) > 1

    seen = []
    with pytest.raises(Cancelled, match="4 of 10"):
        run_experiment(make_spec("single", seeds=2, episodes=10), on_progress=seen.append,
                       should_stop=stop, episodes_per_block=4)
    assert seen == [0.4]


def test_never_stopping_runs_to_the_end():
    result = run_experiment(make_spec("single", seeds=1, episodes=5), should_stop=lambda: False,
                            episodes_per_block=2)
    assert result.runs[0].utilities.shape == (5,)


def test_block_size():
    spec = make_spec("large", seeds=30, episodes=100)
    per_episode = 30 * 7 * 50 * 5
    assert block_episodes(spec) == min(100, BLOCK_ATOMIC_TASKS // per_episode)
    assert block_episodes(make_spec("single", seeds=1, episodes=100)) == 100


def test_the_oracle_checks_cancellation_between_its_batches():
    # one seed of a big oracle: the stop check is polled inside the Monte-Carlo estimate, not only
    # after every seed's oracle is done (600 seeds at 1000 parents took an hour before the first check)
    from mgrao_core import Cancelled, run_chunk
    from mgrao_core.budget import ORACLE_BATCH
    from mgrao_core.oracle import EXPECTATION_SAMPLES

    spec = make_spec("single", ["oracle"], seeds=3, episodes=5, overrides={"n_parents": 50})
    calls = []

    def stop_on_third_check() -> bool:
        calls.append(1)
        return len(calls) >= 3

    with pytest.raises(Cancelled, match="oracle's values for seed 0"):
        run_chunk(spec, spec.seeds, should_stop=stop_on_third_check)
    assert len(calls) == 3 < EXPECTATION_SAMPLES // ORACLE_BATCH
