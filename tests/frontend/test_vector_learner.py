"""examples/vector_learner.py against a real service: 256 worlds trained at once through the vector environment,
its run in compare beside uniform and mgrao-max of the same system, seeds and episodes, paired seed by seed."""

from __future__ import annotations

from tests.frontend.test_independent_learner import compare_example

WORLDS = 256
EPISODES = 40  # the example's default is 200; fewer keep the test short, through the same code


def test_the_vector_learner_is_compared_beside_uniform_and_mgrao_max(browser, server, screenshots):
    pct = compare_example(browser, server, screenshots, "vector_learner.py", ["--worlds", str(WORLDS)], "large",
                          "softmax-value", WORLDS, EPISODES, "vector-learner-compare.png")
    print(f"softmax-value on large, {WORLDS} worlds x {EPISODES} episodes: {pct:+.1f}% from uniform "
          f"(mean of paired per-seed %)")
