"""numba's LLVM optimisation level (``NUMBA_OPT``) against the engine: compile time, run time, and the same bits.

Run: ``python benchmarks/bench_numba_opt.py`` (``--levels 3,1,0``, ``--repeat 2``). Each point is a fresh process
with an empty numba cache and ``NUMBA_OPT`` set: it compiles the kernel of ``multi``'s default configurations (the
seconds of the first run), loads it once more, then times two runs in CPU seconds (the smallest of three each:
``large``, 4 seeds x 10,000 episodes, and ``multi``, 8 x 5,000) and prints a sha256 of every utility they computed.
Equal digests at two levels mean the same numbers, bit for bit. The engine does not set the level: numba reads it
once per process, for every numba function there, a user's own among them (numba's default is 3). The load average
is printed beside, since a loaded machine compiles slower.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import textwrap

_POINT = textwrap.dedent(
    """
    import hashlib, json, time
    from mgrao_core import make_spec, run_experiment
    start = time.perf_counter()
    run_experiment(make_spec("multi", seeds=1, episodes=2))
    compiled = time.perf_counter() - start
    runs, seconds = [], {}
    for name, spec in (("large", dict(system="large", seeds=4, episodes=10000)),
                       ("multi", dict(system="multi", seeds=8, episodes=5000))):
        run_experiment(make_spec(**{**spec, "seeds": 1, "episodes": 2}))  # its kernel loaded (or compiled) first
        times = []
        for _ in range(3):
            begun = time.process_time()
            result = run_experiment(make_spec(**spec))
            times.append(time.process_time() - begun)
        seconds[name] = min(times)
        runs += result.runs
    digest = hashlib.sha256(b"".join(run.utilities.tobytes() for run in runs)).hexdigest()[:16]
    print(json.dumps({"compile": compiled, "runs": seconds, "digest": digest}))
    """
)


def point(level: str) -> dict:
    with tempfile.TemporaryDirectory(prefix="mgrao-opt-") as home:
        environment = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
        done = subprocess.run([sys.executable, "-c", _POINT], env=environment | {"NUMBA_OPT": level,
                                                                                 "XDG_CACHE_HOME": home},
                              capture_output=True, text=True, timeout=1800, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--levels", default="3,1,0", help="NUMBA_OPT levels, comma-separated (default 3,1,0)")
    parser.add_argument("--repeat", type=int, default=2, help="fresh processes per level, interleaved (default 2)")
    args = parser.parse_args()
    levels = args.levels.split(",")
    print(f"{'NUMBA_OPT':>9} {'compile s':>9} {'large cpu-s':>11} {'multi cpu-s':>11}  digest  (load average)")
    for _ in range(args.repeat):
        for level in levels:
            got = point(level)
            load = " ".join(f"{x:.2f}" for x in os.getloadavg())
            print(f"{level:>9} {got['compile']:9.1f} {got['runs']['large']:11.2f} {got['runs']['multi']:11.2f}  "
                  f"{got['digest']}  ({load})", flush=True)


if __name__ == "__main__":
    main()
