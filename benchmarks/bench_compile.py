"""What each part of a combination adds to compiling the kernel: the figures of ``COMPILE_SECONDS``.

Run: ``python benchmarks/bench_compile.py`` (``--repeat N``, 3 by default). Each point is a fresh process with an
empty numba cache (its own ``NUMBA_CACHE_DIR``) that compiles one combination's kernel and its finish without
running them (:func:`mgrao_core.runner.compile_for`, the seconds its notice reports): the fixed allocations alone
(``engine``), then each learner family beside uniform, and uniform in a world with several resources, a sparse
one and one whose tasks can fail. A part's figure is its combination's median less the engine's; the estimate a
notice gives is the sum of its parts (:func:`mgrao_core.compiling.estimate_seconds`). Whole processes of this
checkout, on this machine's cores; the load average is printed beside, since a loaded machine compiles slower.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

POINT = textwrap.dedent("""
    import json, sys
    from mgrao_core import make_spec
    from mgrao_core.runner import compile_for
    system, labels, overrides = json.loads(sys.argv[1])
    said = []
    compile_for(make_spec(system, labels, seeds=1, episodes=1, overrides=overrides), on_compile=said.append)
    print(json.dumps({"seconds": said[-1].seconds}))
""")

COMBINATIONS = {
    "engine": ("single", ["uniform"], {}),
    "mgrao": ("single", ["uniform", "mgrao-1:1"], {}),
    "mgrao-adaptive": ("single", ["uniform", "mgrao-adaptive:2"], {}),
    "independent-q": ("single", ["uniform", "independent-q"], {}),
    "bandit": ("single", ["uniform", "bandit"], {}),
    "mgrao-balance": ("single", ["uniform", "mgrao-balance"], {}),
    "several resources": ("single", ["uniform"], {"n_resources": 2}),
    "a sparse world": ("multi", ["uniform"], {"topology": "ring", "children_per_parent": 2}),
    "tasks that can fail": ("single", ["uniform"], {"task_need": 1.0}),
}
"""Each part's combination: the engine alone, or the engine and that part."""


def compile_seconds(combination: tuple) -> float:
    """Seconds a fresh process with an empty cache takes to compile ``combination``'s kernel and finish."""
    with tempfile.TemporaryDirectory(prefix="mgrao-compile-") as cache:
        environment = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "MGRAO_"))}
        environment |= {"PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": cache}
        done = subprocess.run([sys.executable, "-c", POINT, json.dumps(combination)], cwd=ROOT, env=environment,
                              capture_output=True, text=True, check=True, timeout=1800)
    return json.loads(done.stdout.splitlines()[-1])["seconds"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="samples of each combination (default 3)")
    args = parser.parse_args()
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())} (cores: {os.cpu_count()})")
    samples: dict[str, list[float]] = {name: [] for name in COMBINATIONS}
    for i in range(args.repeat):
        for name, combination in COMBINATIONS.items():
            samples[name].append(compile_seconds(combination))
            print(f"sample {i + 1} {name}: {samples[name][-1]:.1f} s", flush=True)
    engine = statistics.median(samples["engine"])
    print(f"\nmedians of {args.repeat}, seconds (load average after: "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())})")
    for name, values in samples.items():
        whole = statistics.median(values)
        part = whole if name == "engine" else whole - engine
        print(f"{name:>20}: combination {whole:6.1f}   part {part:6.1f}")


if __name__ == "__main__":
    main()
