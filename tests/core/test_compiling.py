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
from mgrao_core.algorithms import LEARNERS
from mgrao_core.compiling import (
    AHEAD_WORLDS,
    FAILING,
    SEVERAL,
    SPARSE,
    Compiling,
    ahead,
    estimate_seconds,
    kind_name,
    kinds_from_text,
    kinds_of_world,
    parts_of,
)
from tests.support.kernels import FROM_SCRATCH

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]
DEADLINE_S = 1800  # compiling every family once on a loaded 2-core machine takes minutes


def in_process(arguments: list[str], cache: Path, returncode: int = 0) -> subprocess.CompletedProcess:
    """Run ``python ARGUMENTS`` from the checkout with numba's cache in ``cache`` (empty: as after an install), and
    check that it exits with ``returncode``."""
    environment = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    environment |= FROM_SCRATCH | {"NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, *arguments], cwd=ROOT, env=environment, capture_output=True, text=True,
                          timeout=DEADLINE_S)
    assert done.returncode == returncode, done.stderr[-3000:]
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
"""Three chunks of other families (each run on a kernel of the suite's census, tests/support/kernels.py)."""
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


def test_mgrao_compile_lists_every_familys_kernel_for_each_kind_of_world_or_the_kinds_given(tmp_path: Path) -> None:
    """What ``mgrao compile`` compiles, without compiling it: the paper's configurations' kernel and one of every
    family for each of the eight kinds of world (``--worlds all``), or the kinds ``--worlds`` names."""
    kinds = kinds_of_world()
    assert len(kinds) == 8 and kinds[0] == frozenset() and kinds[-1] == frozenset(AHEAD_WORLDS)
    every = ahead()
    assert len(every) == 1 + len(kinds) and parts_of(every[0]) == ("engine", "mgrao")  # the paper's configurations
    families = tuple(f.name for f in LEARNERS)
    for spec, kind in zip(every[1:], kinds, strict=True):  # each kind's world has its parts, and only those
        assert parts_of(spec) == ("engine", *families, *(p for p in AHEAD_WORLDS if p in kind)), kind
    listed = in_process(["-m", "mgrao_cli", "compile", "--list"], tmp_path).stdout.splitlines()
    assert listed[0] == "1/9 single's configurations (uniform, mgrao-1:1, mgrao-max)", listed
    assert listed[1] == "2/9 every family, one resource, complete, no task fails (plain)", listed
    assert listed[-1] == "9/9 every family, several resources and a sparse world and tasks that can fail " \
                         "(several+sparse+failing)", listed
    assert [line.rsplit("(", 1)[1] for line in listed[1:]] == [f"{kind_name(k)})" for k in kinds]
    assert kinds_from_text("failing+several, plain") == [frozenset(), frozenset({SEVERAL, FAILING})]
    assert [parts_of(s)[-1] for s in ahead(kinds=kinds_from_text("sparse"))] == [SPARSE]  # no paper's kernel
    some = in_process(["-m", "mgrao_cli", "compile", "--worlds", "plain,sparse+failing", "--list"], tmp_path)
    assert [line.split(" ", 1)[1] for line in some.stdout.splitlines()] == [
        "single's configurations (uniform, mgrao-1:1, mgrao-max)",
        "every family, one resource, complete, no task fails (plain)",
        "every family, a sparse world and tasks that can fail (sparse+failing)"]
    for wrong in ("crowded", "plain+several", "several+"):
        refused = in_process(["-m", "mgrao_cli", "compile", "--worlds", wrong], tmp_path, returncode=2)
        assert "Invalid value for '--worlds'" in refused.stderr, refused.stderr
        assert "is not a kind of world" in refused.stderr and "several, sparse, failing" in refused.stderr


def test_mgrao_compile_compiles_every_family_ahead_and_a_run_then_loads_with_the_same_numbers(tmp_path: Path) -> None:
    """Issue 43, item 2: a way to compile every family ahead, so that no job waits on the compiler; the kernel of
    every family runs a chunk of any families of its world, bit for bit as the chunk's own kernel.

    From an empty cache, for the plain kind of world (two kernels: the paper's configurations' and every family's);
    the other kinds are the same experiments with other worlds (the listing's test above), and compiling all nine
    takes minutes (issue 48).
    """
    first = in_process(["-m", "mgrao_cli", "compile", "--worlds", "plain"], tmp_path)
    lines = first.stderr.splitlines()
    assert lines[0].startswith(f"compiling the engine ahead: 2 kernels, into {tmp_path}"), lines
    assert sum(": compiled in " in line for line in lines) == 2, lines
    assert "2/2 every family, one resource, complete, no task fails (plain): compiled in " in first.stderr
    again = in_process(["-m", "mgrao_cli", "compile", "--worlds", "plain"], tmp_path)
    assert sum(": compiled before" in line for line in again.stderr.splitlines()) == 2, again.stderr
    (answer,) = fresh_process(EVERY_FAMILY, tmp_path)
    assert answer["said"] == [], answer["said"]  # none of the three compiled its own kernel
    for labels in LABEL_SETS:
        for run in run_experiment(make_spec("single", labels, seeds=[3, 4], episodes=12)).runs:
            utilities, weights = answer["runs"][f"{run.algorithm} {run.seed}"]
            assert np.array_equal(run.utilities, utilities), run.algorithm  # bit for bit
            assert np.array_equal(run.combined_weights.ravel(), weights), run.algorithm
