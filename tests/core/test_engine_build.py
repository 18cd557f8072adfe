"""The compiled engine as built: the on-disk cache (in the user's cache, by the engine's path) follows every
compiled source (the engine, the quality models, the algorithms) and loads without numba's compiler, and no index
is out of bounds.

Each compiles the kernel afresh in a copy of the package (about 15 s each; at the LLVM level of
:data:`tests.support.kernels.FROM_SCRATCH`, the bounds-checked build at level 0).
"""

import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import mgrao_core
from mgrao_core.algorithms import LEARNERS
from tests.support.kernels import FROM_SCRATCH

pytestmark = pytest.mark.slow

PACKAGE = Path(mgrao_core.__file__).resolve().parent
RUN = """
import json, sys
from mgrao_core import make_spec, run_experiment
out = {}
algorithms = sys.argv[2].split(",") if len(sys.argv) > 2 else None  # None: each system's own
for system in sys.argv[1].split(","):
    result = run_experiment(make_spec(system, algorithms, seeds=[0, 1], episodes=3))
    out[system] = [run.utilities.tolist() for run in result.runs]
print(json.dumps(out))
"""


def _copy_package(tmp_path: Path) -> Path:
    shutil.copytree(PACKAGE, tmp_path / "mgrao_core", ignore=shutil.ignore_patterns("__pycache__"))
    (tmp_path / "run.py").write_text(RUN)
    return tmp_path


def _run(root: Path, systems: str, algorithms: str = "", **env: str) -> str:
    environment = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")} | FROM_SCRATCH | env
    environment |= {"PYTHONPATH": str(root), "XDG_CACHE_HOME": str(root / "cache")}  # the copy's own cache
    done = subprocess.run([sys.executable, "run.py", systems, *([algorithms] if algorithms else [])], cwd=root,
                          env=environment, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return done.stdout


def _engine_cache(root: Path) -> Path:
    """numba's directory for this copy of the engine, in the copy's user cache: named by the engine's absolute path."""
    engine = root / "mgrao_core" / "engine"
    return root / "cache" / "mgrao" / "numba" / f"engine_{hashlib.sha1(str(engine).encode()).hexdigest()}"


def _kernel_index(root: Path) -> bytes:
    """The cache index of the kernel: numba rewrites it when it compiles the kernel, not when it loads it."""
    (index,) = _engine_cache(root).glob("kernel.run_block*.nbi")
    return index.read_bytes()


def _edit(path: Path, old: str, new: str) -> None:
    source = path.read_text()
    assert source.count(old) == 1, f"{old!r} is not once in {path}"
    path.write_text(source.replace(old, new))


LEARNER = "uniform,bandit"
"""What the cache test runs (see there)."""


def test_the_cache_is_the_users_and_editing_any_compiled_source_recompiles_the_kernel(tmp_path: Path) -> None:
    """One copy of the package through every kind of edit, each compiling the kernel afresh.

    It runs the fixed allocations and one learner, bandit, whose compiled steps are cached in their own directory as
    every learner's are: that kernel compiles in about half the time of MG-RAO's (10 s against 18 s here), and an
    edit recompiles whatever kernels the cache holds, whichever families they run.
    """
    root = _copy_package(tmp_path)
    before = _run(root, "single", LEARNER)
    # in the user's cache (never beside the package, where an uninstall would leave it), in numba's
    # directory for this copy of the engine: named by its absolute path, so that copies keep apart
    mine = _engine_cache(root)
    steps = root / "mgrao_core" / "algorithms" / "bandit"  # the learner's compiled steps: their own directory
    theirs = root / "cache" / "mgrao" / "numba" / f"bandit_{hashlib.sha1(str(steps).encode()).hexdigest()}"
    assert list(mine.glob("kernel.run_block*.nbi")) and list(theirs.glob("compiled.*.nbi"))
    learners = {root.joinpath(*f.steps.split(".")[:-1]) for f in LEARNERS}  # each learner's compiled steps
    allowed = {mine} | {root / "cache" / "mgrao" / "numba" / f"{d.name}_{hashlib.sha1(str(d).encode()).hexdigest()}"
                        for d in learners}
    assert {mine, theirs} <= {p.parent for p in (root / "cache").rglob("*.nbi")} <= allowed
    assert not list(root.joinpath("mgrao_core").rglob("*.nb[ci]"))
    compiled = _kernel_index(root)
    unchanged = _run(root, "single", LEARNER)
    assert unchanged == before and _kernel_index(root) == compiled  # unchanged: loaded, not compiled
    package = root / "mgrao_core"
    algorithms = sorted((package / "algorithms").rglob("*.py")) or [package / "algorithms.py"]
    with algorithms[-1].open("a") as module:  # a package of algorithms, or the one module before it
        module.write("\n# edited\n")
    assert _run(root, "single", LEARNER) == before  # a comment: the same numbers, from a kernel compiled afresh
    assert _kernel_index(root) != compiled
    recompiled = _kernel_index(root)
    _edit(package / "quality.py", "x = weight * resource / load\n    return x / (x + env.half_saturation)",
          "return 0.5")
    after = _run(root, "single", LEARNER)
    assert _kernel_index(root) != recompiled  # the kernel inlines quality.py: it must not come from the old cache
    assert '"single": [[5.0, 5.0, 5.0]' in after  # uniform, 10 parents at hyperbolic quality 0.5
    _edit(package / "engine" / "environment.py",
          "taq += ctv[k] * atomic_task_quality(task_share[c] * weights[c, t], resources[c, t], load[c, t], env)",
          "taq += ctv[k] * 0.25")
    after = _run(root, "single", LEARNER)  # the kernel inlines environment.py: it must not come from the old cache
    assert '"single": [[2.5, 2.5, 2.5]' in after  # uniform, 10 parents at quality 0.25


def test_no_index_is_out_of_bounds_in_any_system(tmp_path: Path) -> None:
    root = _copy_package(tmp_path)
    # dynamics, several resources, and tasks that fail with a hierarchy (cloud)
    # at LLVM level 0, which keeps every check and compiles a third faster than the default (64.6 CPU-s against
    # 97.0); numba cannot cache the kernel at that level, and this build is not cached for anyone
    _run(root, "single,multi,volatile,large,drift,bursty,multi-resource,cloud", NUMBA_BOUNDSCHECK="1", NUMBA_OPT="0")


LEAN = """
import json, sys
from mgrao_core import make_spec, run_experiment
result = run_experiment(make_spec("multi", ["uniform", "oracle", "mgrao-1:1", "mgrao-max"], seeds=[0, 1], episodes=3))
compiler = "numba.np.linalg" in sys.modules  # imported by numba's registries, which compiling needs
print(json.dumps({"runs": [[run.utilities.tolist(), run.combined_weights.tolist()] for run in result.runs],
                  "compiler_loaded": compiler}))
"""


def test_a_cached_kernel_loads_without_numbas_compiler_and_computes_the_same(tmp_path: Path) -> None:
    import json

    root = _copy_package(tmp_path)
    (root / "run.py").write_text(LEAN)
    compiled = json.loads(_run(root, ""))
    cached = json.loads(_run(root, ""))
    assert compiled["compiler_loaded"]  # the first process compiled the kernel and the oracle's steps
    assert not cached["compiler_loaded"]  # the second loaded them from the cache alone
    assert cached["runs"] == compiled["runs"]
