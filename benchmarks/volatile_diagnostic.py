"""Why the volatile table is out of reach: what churn does to fixed and learned allocations.

Run: ``python benchmarks/volatile_diagnostic.py`` (about 5 s; ``--seeds N``).

The paper reports that with parents leaving and rejoining (probability 0.25 each per episode)
mgrao-max gains only 7.1% over uniform and mgrao-1:1 3.3% (46.5% of max). When absent parents
contribute nothing, any *fixed* allocation ``w`` keeps its single-system gain: presence does not
depend on ``w``, so ``E[U(w)] = sum_p P(p present) E[taq_p(w)]``, and with every parent present
half the time in the long run both ``U(w)`` and ``U(uniform)`` halve, and so does nothing to their
ratio. The oracle is such a fixed allocation; the learners face a subset that persists from one
episode to the next with probability 0.75, which they can track. This prints, for churn from
none to heavy, the % from uniform of the oracle and of the learners, under both absent-task
readings, on the held-out seeds of ``mgrao reproduce``.
"""

from __future__ import annotations

import argparse

from mgrao_core import make_spec, run_experiment

CHURN = (0.0, 0.1, 0.25, 0.5, 0.75)
ALGORITHMS = ["uniform", "oracle", "mgrao-1:1", "mgrao-max"]


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    args = parser.parse_args()
    print(f"volatile system, {args.seeds} seeds x 100 episodes, % from uniform (95% CI half-width)")
    print(f"{'leave=join':>10} {'absent tasks':>13} {'uniform U':>10} {'oracle':>13} {'mgrao-1:1':>13} "
          f"{'mgrao-max':>13} {'1:1 % of max':>13}")
    for absent in ("excluded", "counted"):
        for churn in CHURN:
            spec = make_spec("volatile", ALGORITHMS, seeds=args.seeds, episodes=100, overrides={
                "leave_probability": churn, "join_probability": churn, "absent_tasks": absent})
            summary = run_experiment(spec).summary()

            def cell(label: str, summary=summary) -> str:
                row = summary[label]
                half = (row.pct_ci95[1] - row.pct_ci95[0]) / 2
                return f"{row.pct_from_uniform:6.1f} ({half:4.1f})"

            print(f"{churn:>10.2f} {absent:>13} {summary['uniform'].final_mean:>10.3f} {cell('oracle'):>13} "
                  f"{cell('mgrao-1:1'):>13} {cell('mgrao-max'):>13} {summary['mgrao-1:1'].pct_of_max:>13.1f}")
    print("paper, churn 0.25:                            mgrao-1:1 3.3, mgrao-max 7.1, 1:1 at 46.5% of max")


if __name__ == "__main__":
    main()
