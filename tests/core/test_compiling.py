"""Compiling the engine (issue 43, item 2): said while it happens, and done ahead for every family.

Each case runs in a process of its own with an empty numba cache (its own ``NUMBA_CACHE_DIR``), as after an
install, so that what compiles is known; the numbers it computes are compared with this process's.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from mgrao_core import make_spec, run_experiment
from mgrao_core.compiling import FAILING, SEVERAL, Compiling, ahead, estimate_seconds, parts_of

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]
DEADLINE_S = 1800  # compiling every family once on a loaded 2-core machine takes minutes


def in_process(arguments: list[str], cache: Path) -> subprocess.CompletedProcess:
    """Run ``python ARGUMENTS`` from the checkout with numba's cache in ``cache`` (empty: as after an install)."""
    environment = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    environment |= {"NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, *arguments], cwd=ROOT, env=environment, capture_output=True, text=True,
                          timeout=DEADLINE_S)
    assert done.returncode == 0, done.stderr[-3000:]
    return done


def fresh_process(script: str, cache: Path) -> list[dict]:
    """Run ``script`` (which prints JSON lines) in a new interpreter with numba's cache in ``cache``; its lines."""
    done = in_process(["-c", textwrap.dedent(script)], cache)
    return [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]


def test_the_parts_of_a_combination_and_what_is_said() -> None:
    cloud = make_spec("cloud", seeds=1, episodes=2)
    assert parts_of(cloud) == ("engine", "mgrao", "mgrao-balance", SEVERAL, FAILING)
    notice = Compiling(parts_of(cloud), estimate_seconds(parts_of(cloud)))
    assert notice.message.startswith("compiling the engine for mgrao, mgrao-balance, several resources, tasks that "
                                     "can fail: first time only, about ")
    assert Compiling(("engine",), 15.0, 12.34).message == "compiled the engine for the fixed allocations in 12.3 s " \
                                                          "(first time only)"
    assert [parts_of(s)[-1] for s in ahead()][:2] == ["mgrao", "mgrao-balance"]  # the paper's, then every family


SAY = """
    import json
    from mgrao_core import make_spec, run_experiment
    said = []
    spec = make_spec("single", ["uniform"], seeds=2, episodes=5)
    for attempt in (1, 2):
        run_experiment(spec, on_compile=lambda notice: said.append([attempt, notice.as_dict()]))
    print(json.dumps({"said": said}))
"""


def test_a_first_compile_is_said_before_and_after_and_never_again(tmp_path: Path) -> None:
    """Issue 43, item 2: a job sat at "Running: 0% done" for minutes, nothing saying a kernel was compiling."""
    (first,) = fresh_process(SAY, tmp_path)
    said = first["said"]
    assert [attempt for attempt, _ in said] == [1, 1], said  # the second run in the process has it
    before, after = said[0][1], said[1][1]
    assert before["seconds"] is None and before["parts"] == ["engine"]
    assert before["message"].startswith("compiling the engine for the fixed allocations: first time only, about ")
    assert after["seconds"] > 0 and after["message"].startswith("compiled the engine")
    (again,) = fresh_process(SAY, tmp_path)  # a later process loads it from the cache: nothing to say
    assert again["said"] == []
    # mgrao run says so on stderr, beside its progress, and only where it compiles
    run = ["-m", "mgrao_cli", "run", "--system", "single", "--seeds", "1", "--episodes", "3", "--algorithms"]
    loaded = in_process([*run, "uniform"], tmp_path)
    assert "compil" not in loaded.stderr, loaded.stderr
    compiled = in_process([*run, "uniform,bandit"], tmp_path)
    lines = [line for line in compiled.stderr.splitlines() if line.startswith("mgrao: ")]
    assert lines[0].startswith("mgrao: compiling the engine for bandit: first time only, about "), lines
    assert lines[1].startswith("mgrao: compiled the engine for bandit in "), lines
    assert "uniform" in compiled.stdout and "bandit" in compiled.stdout  # the table, on stdout as ever


LABEL_SETS = (["uniform", "mgrao-1:1", "mgrao-max"], ["uniform", "independent-q", "bandit"], ["oracle"])
"""Three chunks of other families (each also a kernel of the suite's census, tests/support/kernels.py)."""
EVERY_FAMILY = f"""
    import json
    from mgrao_core import make_spec, run_experiment
    said = []
    runs = {{}}
    for labels in {LABEL_SETS!r}:
        spec = make_spec("single", labels, seeds=[3, 4], episodes=12)
        result = run_experiment(spec, on_compile=lambda notice: said.append(notice.message))
        runs |= {{f"{{r.algorithm}} {{r.seed}}": [r.utilities.tolist(), r.combined_weights.ravel().tolist()]
                 for r in result.runs}}
    print(json.dumps({{"said": said, "runs": runs}}))
"""


@pytest.mark.timeout(2 * DEADLINE_S)  # mgrao compile's 9 kernels of every family took over 900 s at load average 8-11
def test_mgrao_compile_compiles_every_family_ahead_and_a_run_then_loads_with_the_same_numbers(tmp_path: Path) -> None:
    """Issue 43, item 2: a way to compile every family ahead, so that no job waits on the compiler; the kernel of
    every family runs a chunk of any families of its world, bit for bit as the chunk's own kernel."""
    first = in_process(["-m", "mgrao_cli", "compile"], tmp_path)
    lines = first.stderr.splitlines()
    assert lines[0].startswith(f"compiling the engine ahead: {len(ahead())} kernels, into {tmp_path}"), lines
    assert sum(": compiled in " in line for line in lines) == len(ahead()), lines
    assert "every family, several resources and a sparse world and tasks that can fail" in first.stderr
    again = in_process(["-m", "mgrao_cli", "compile"], tmp_path)
    assert sum(": compiled before" in line for line in again.stderr.splitlines()) == len(ahead()), again.stderr
    (answer,) = fresh_process(EVERY_FAMILY, tmp_path)
    assert answer["said"] == [], answer["said"]  # none of the three compiled its own kernel
    for labels in LABEL_SETS:
        for run in run_experiment(make_spec("single", labels, seeds=[3, 4], episodes=12)).runs:
            utilities, weights = answer["runs"][f"{run.algorithm} {run.seed}"]
            assert np.array_equal(run.utilities, utilities), run.algorithm  # bit for bit
            assert np.array_equal(run.combined_weights.ravel(), weights), run.algorithm
