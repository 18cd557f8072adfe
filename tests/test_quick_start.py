"""The README's two quick-start installs, one after the other in one clone and one virtualenv, in either order.

Each install is the README's own command (read from README.md), run offline: ``--no-index`` and
``--no-build-isolation`` added to its ``pip install``, and the fresh virtualenv sees this test run's
installed dependencies (not the project) through a ``.pth`` file, so that only the project is
installed, exactly as the README installs it. After each install a simulation compiles the engine,
as the first job of ``mgrao serve`` would; after both, ``mgrao reproduce`` and ``mgrao serve`` must
work. An earlier version cached the compiled engine in the installed package's ``__pycache__``:
``pip install -e`` then left those files behind as a namespace package ``mgrao_core`` that
shadowed the editable install (``ImportError ... (unknown location)``, 500 on ``/``).
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import site
import subprocess
import sys
import urllib.error
import urllib.request
from dataclasses import dataclass
from fnmatch import fnmatch
from pathlib import Path

import pytest

from tests.support.local_service import free_port, stop, wait_healthy
from tests.test_packaging import quick_start_commands

pytestmark = [pytest.mark.slow, pytest.mark.same_worker]  # one clone and home: the second order reuses the first's

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ["mgrao_core", "mgrao_cli", "backend", "frontend", "mgrao_docs"]
NOT_A_DEPENDENCY = [*PACKAGES, "mgrao-*", "mgrao.egg-link", "__editable__*", "*.pth", "pip", "pip-*", "__pycache__"]
"""What of this run's site-packages the fresh virtualenv must not see: the project itself (an
editable install's finder and metadata among it), ``.pth`` files, and pip (the virtualenv has its own)."""
OFFLINE = ["--no-index", "--no-build-isolation"]
STEP_TIMEOUT_S = 300


def install_steps() -> dict[str, list[str]]:
    """The README's two quick-start commands without their last part (``mgrao serve``, ``pytest``)."""
    serve, test = quick_start_commands()
    steps = {}
    for name, command in (("first", serve), ("second", test)):
        parts = [part.strip() for part in command.split("&&")]
        assert parts[0] == "python3 -m venv .venv" and parts[1].startswith(".venv/bin/pip install "), command
        steps[name] = parts[:2]
    return steps


@dataclass
class Clone:
    """A copy of the project's files as a clone has them, a private cache home, and the dependencies' view."""

    root: Path
    home: Path
    dependencies: Path

    def environment(self) -> dict[str, str]:
        return {"PATH": f"{self.root / '.venv' / 'bin'}:/usr/bin:/bin", "HOME": str(self.home),
                "XDG_CACHE_HOME": str(self.home / ".cache"), "LANG": "C.UTF-8", "PIP_NO_CACHE_DIR": "1",
                "PIP_DISABLE_PIP_VERSION_CHECK": "1"}

    def run(self, argv: list[str], what: str) -> subprocess.CompletedProcess:
        done = subprocess.run(argv, cwd=self.root, env=self.environment(), capture_output=True, text=True,
                              timeout=STEP_TIMEOUT_S, check=False)
        output = f"{done.stdout[-3000:]}\n{done.stderr[-5000:]}"
        assert done.returncode == 0, f"{what} ({shlex.join(argv)}) failed:\n{output}"
        return done

    def install(self, step: list[str]) -> None:
        """One README command's venv and pip parts, run in the clone (pip offline, see the module)."""
        venv, pip = step
        self.run([sys.executable, *venv.split()[1:]], venv)
        site_packages = self.site_packages()
        (site_packages / "test-dependencies.pth").write_text(f"{self.dependencies}\n")
        argv = shlex.split(pip)
        at = argv.index("install") + 1
        self.run([str(self.root / argv[0]), *argv[1:at], *OFFLINE, *argv[at:]], pip)

    def site_packages(self) -> Path:
        (found,) = (self.root / ".venv" / "lib").glob("python*/site-packages")
        return found

    def mgrao(self, *args: str) -> subprocess.CompletedProcess:
        return self.run([str(self.root / ".venv" / "bin" / "mgrao"), *args], f"mgrao {' '.join(args)}")

    def compiled_files(self) -> list[Path]:
        """numba's cache files anywhere in the clone: its packages, its virtualenv."""
        return sorted(self.root.rglob("*.nb[ci]"))


@pytest.fixture(scope="module")
def dependencies(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A directory of symbolic links to this run's installed distributions, the project left out."""
    view = tmp_path_factory.mktemp("dependencies")
    for directory in site.getsitepackages():
        if not os.path.isdir(directory):
            continue
        for entry in Path(directory).iterdir():
            project = any(fnmatch(entry.name, pattern) for pattern in NOT_A_DEPENDENCY)
            if not project and not (view / entry.name).exists():
                (view / entry.name).symlink_to(entry)
    for needed in ("numba", "fastapi", "setuptools", "wheel", "pytest"):
        if not any(view.glob(f"{needed}-*.dist-info")):
            pytest.skip(f"{needed} is not installed in this test run's site-packages (pip install -e '.[test]')")
    return view


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory, dependencies: Path) -> Clone:
    """One clone and one home for both orders: the second finds the engine the first compiled for the same paths."""
    tmp_path = tmp_path_factory.mktemp("quick-start")
    root = tmp_path / "mgrao"
    root.mkdir()
    listed = subprocess.run(["git", "-C", str(ROOT), "ls-files", "-z"], capture_output=True, check=True, timeout=60)
    for name in listed.stdout.decode().split("\0"):  # every tracked file as the work tree has it, links as links
        if name and (ROOT / name).exists():
            (root / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, root / name, follow_symlinks=False)
    home = tmp_path / "home"
    home.mkdir()
    return Clone(root, home, dependencies)


@pytest.fixture
def clone(project: Clone) -> Clone:
    """The clone without a virtualenv or anything an earlier install built in it."""
    for built in [".venv", "build", "mgrao.egg-info", "mgrao.db"]:
        path = project.root / built
        if path.is_dir():
            shutil.rmtree(path)
        elif path.exists():
            path.unlink()
    return project


def compile_engine(clone: Clone) -> None:
    """The first simulation after an install: it compiles the engine and caches it."""
    clone.mgrao("run", "--system", "single", "--algorithms", "uniform,oracle,mgrao-max", "--seeds", "1",
                "--episodes", "3")


def assert_both_commands_work(clone: Clone) -> None:
    reproduce = clone.mgrao("reproduce", "--seeds", "2")
    assert "2 seeds x 100 episodes" in reproduce.stdout
    # the README's shell examples: a bare `mgrao` after activating the virtualenv (not on PATH before)
    activated = subprocess.run(["bash", "-c", ". .venv/bin/activate && command -v mgrao && mgrao --help"],
                               cwd=clone.root, env=clone.environment() | {"PATH": "/usr/bin:/bin"},
                               capture_output=True, text=True, timeout=STEP_TIMEOUT_S, check=False)
    assert activated.returncode == 0, activated.stdout + activated.stderr
    assert activated.stdout.startswith(str(clone.root / ".venv" / "bin" / "mgrao")) and "reproduce" in activated.stdout
    port = free_port()
    with open(clone.root / "serve.log", "wb") as log:
        server = subprocess.Popen([str(clone.root / ".venv" / "bin" / "mgrao"), "serve", "--host", "127.0.0.1",
                                   "--port", str(port), "--workers", "0"], cwd=clone.root, env=clone.environment(),
                                  stdout=log, stderr=subprocess.STDOUT)
    try:
        base = f"http://127.0.0.1:{port}"
        try:
            wait_healthy(base, server)
            with urllib.request.urlopen(f"{base}/", timeout=30) as answer:
                assert answer.status == 200
                assert b"<html" in answer.read().lower()
        except (RuntimeError, OSError) as error:
            raise AssertionError(f"mgrao serve: {error}\n{(clone.root / 'serve.log').read_text()[-5000:]}") from None
    finally:
        stop(server)


def assert_cached_outside_the_clone(clone: Clone) -> None:
    assert clone.compiled_files() == [], "numba cached the engine inside the package, where pip can orphan it"
    assert any((clone.home / ".cache" / "mgrao" / "numba").rglob("*.nbi")), "nothing cached in the user's cache"


@pytest.mark.parametrize("order", [("first", "second"), ("second", "first")],
                         ids=["serve-then-test", "test-then-serve"])
def test_the_readmes_two_installs_in_one_clone_in_either_order_leave_a_working_mgrao(clone: Clone,
                                                                                    order: tuple[str, str]) -> None:
    steps = install_steps()
    clone.install(steps[order[0]])
    compile_engine(clone)
    clone.install(steps[order[1]])
    compile_engine(clone)
    assert_both_commands_work(clone)
    assert_cached_outside_the_clone(clone)


def test_the_running_dashboard_survives_the_readmes_second_install_under_it(clone: Clone) -> None:
    """Issue 30, point 2: with the first install's `mgrao serve` running, the second install (`pip install -e`)
    removed the package it served from: `/` answered 500 and `/js/app.js` 404 until a restart."""
    steps = install_steps()
    clone.install(steps["first"])
    port = free_port()
    with open(clone.root / "serve.log", "wb") as log:
        server = subprocess.Popen([str(clone.root / ".venv" / "bin" / "mgrao"), "serve", "--host", "127.0.0.1",
                                   "--port", str(port), "--workers", "0"], cwd=clone.root, env=clone.environment(),
                                  stdout=log, stderr=subprocess.STDOUT)
    base = f"http://127.0.0.1:{port}"

    def fetch(path: str) -> tuple[int, bytes]:
        try:
            with urllib.request.urlopen(f"{base}{path}", timeout=30) as answer:
                return answer.status, answer.read()
        except urllib.error.HTTPError as error:
            return error.code, error.read()

    try:
        wait_healthy(base, server)
        status, index = fetch("/")
        assert status == 200
        modules = re.findall(rb'href="(/v/[0-9a-f]+/js/[a-z]+\.js)"', index)
        plotly = re.search(rb'id="plotly-src" href="([^"]+)"', index)[1].decode()
        before = {path: fetch(path) for path in ["/", "/js/app.js", modules[0].decode(), plotly, "/style.css",
                                                 "/project-docs/", "/project-docs/statistics.html"]}
        assert all(status == 200 for status, _ in before.values()), {p: s for p, (s, _) in before.items()}
        clone.install(steps["second"])  # the editable install: the first's package is gone from site-packages
        assert not (clone.site_packages() / "frontend").exists()
        after = {path: fetch(path) for path in before}
        assert after == before, {p: s for p, (s, _) in after.items()}  # the same answers, without a restart
    finally:
        stop(server)
