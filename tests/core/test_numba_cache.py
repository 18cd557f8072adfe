"""numba's cache: in the user's cache or a private temp dir, never in the package, never a failure.

The first tests call :func:`mgrao_core._numba_cache.choose_cache_dir` on real directories (made
unusable in ways that hold even for root: a file where a directory should be, a directory owned by
someone else). The last ones run simulations in fresh interpreters: a writable copy of the package
without a usable cache directory, and a non-editable install into a temporary directory made
read-only, run as ``nobody`` with a missing home.
"""

from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from mgrao_core._numba_cache import choose_cache_dir
from tests.support.docs_crawl import crawl_docs
from tests.support.kernels import FROM_SCRATCH
from tests.support.local_service import free_port, stop, wait_healthy

ROOT = Path(__file__).resolve().parents[2]


def test_the_users_usable_numba_cache_dir_stands(tmp_path: Path) -> None:
    mine = tmp_path / "mine"
    choice = choose_cache_dir({"NUMBA_CACHE_DIR": str(mine), "HOME": str(tmp_path / "home")})
    assert choice.path == str(mine) and not choice.set_env
    assert not (tmp_path / "home").exists()


def test_without_numba_cache_dir_the_engine_caches_under_xdg_cache_home_then_home(tmp_path: Path) -> None:
    # whether or not the package's own __pycache__ is writable: files there would outlive an uninstall
    xdg = tmp_path / "xdg"
    choice = choose_cache_dir({"XDG_CACHE_HOME": str(xdg), "HOME": str(tmp_path / "home")})
    assert choice.set_env and choice.path == str(xdg / "mgrao" / "numba")
    assert (xdg / "mgrao" / "numba").is_dir()
    choice = choose_cache_dir({"XDG_CACHE_HOME": "relative/ignored", "HOME": str(tmp_path / "home")})
    assert choice.path == str(tmp_path / "home" / ".cache" / "mgrao" / "numba")


def test_an_unusable_numba_cache_dir_is_replaced_by_the_users_cache(tmp_path: Path) -> None:
    blocked = tmp_path / "a-file"
    blocked.write_text("")
    choice = choose_cache_dir({"NUMBA_CACHE_DIR": str(blocked), "HOME": str(tmp_path / "home")})
    assert choice.set_env and choice.path == str(tmp_path / "home" / ".cache" / "mgrao" / "numba")


def test_without_a_writable_home_the_cache_is_a_private_directory_under_the_temp_dir(tmp_path: Path) -> None:
    home = tmp_path / "home-is-a-file"
    home.write_text("")
    temp = tmp_path / "tmp"
    temp.mkdir()
    own = temp / f"mgrao-numba-{os.getuid()}"
    own.mkdir(mode=0o755)
    own.chmod(0o755)
    choice = choose_cache_dir({"HOME": str(home)}, temp_dir=str(temp))
    assert choice.set_env and choice.path == str(own)
    assert own.stat().st_mode & 0o777 == 0o700  # tightened: other users cannot plant code in it


@pytest.mark.skipif(not hasattr(os, "chown") or os.geteuid() != 0, reason="needs root to give a directory away")
def test_a_temp_dir_owned_by_someone_else_or_a_symlink_is_not_used(tmp_path: Path) -> None:
    home = tmp_path / "home-is-a-file"
    home.write_text("")
    temp = tmp_path / "tmp"
    temp.mkdir()
    squatted = temp / f"mgrao-numba-{os.getuid()}"
    squatted.mkdir(mode=0o700)
    os.chown(squatted, 65534, 65534)
    assert choose_cache_dir({"HOME": str(home)}, temp_dir=str(temp)).path is None
    squatted.rmdir()
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir(mode=0o700)
    squatted.symlink_to(elsewhere)
    assert choose_cache_dir({"HOME": str(home)}, temp_dir=str(temp)).path is None


@pytest.mark.slow
def test_a_writable_package_without_a_usable_cache_dir_compiles_uncached_and_writes_nothing_beside_it(
        tmp_path: Path) -> None:
    copy = tmp_path / "site"
    shutil.copytree(ROOT / "mgrao_core", copy / "mgrao_core", ignore=shutil.ignore_patterns("__pycache__"))
    home = tmp_path / "home-is-a-file"
    home.write_text("")
    temp = tmp_path / "tmp"
    temp.mkdir()
    (temp / f"mgrao-numba-{os.getuid()}").write_text("")  # a file where the private directory would be
    environment = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "XDG_"))}
    environment |= FROM_SCRATCH | {"PYTHONPATH": str(copy), "HOME": str(home), "TMPDIR": str(temp),
                                   "NUMBA_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-c", SIMULATION], cwd=tmp_path, env=environment, capture_output=True,
                          text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    assert f"MGRAO_CORE {copy}" in done.stdout
    assert "no writable cache directory" in done.stderr and "not cached beside its source" in done.stderr
    assert "cache layout is unknown" not in done.stderr
    assert not list(copy.rglob("*.nb[ci]")), "numba cached the engine beside its source"


# ---- a real read-only install, run as an unprivileged user ---------------------------------------

UNPRIVILEGED = 65534  # nobody

SIMULATION = """
import mgrao_core, numba
from mgrao_core import make_spec, run_experiment
result = run_experiment(make_spec("single", ["uniform", "bandit"], seeds=2, episodes=5))
print("MGRAO_CORE", mgrao_core.__file__)
print("CACHE_DIR", numba.config.CACHE_DIR)
print("UTILITIES", result.runs[-1].utilities.tolist())
"""
"""A simulation that compiles the kernel and a learner's steps, each cached in a directory of its own: the fixed
allocations and bandit, whose kernel compiles in about half the time of MG-RAO's (these tests are about where the cache
goes, not what it holds)."""


@dataclass
class ReadOnlyInstall:
    root: Path
    site_dir: Path
    python: str
    deps: list[str]

    def run(self, temp: Path, **env: str) -> subprocess.CompletedProcess:
        """The simulation as ``nobody``, HOME missing, TMPDIR ``temp``, in a fresh environment."""
        environ = {"PATH": "/usr/bin:/bin", "HOME": str(self.root / "no-such-home"), "TMPDIR": str(temp),
                   "PYTHONPATH": os.pathsep.join([str(self.site_dir), *self.deps]), "NUMBA_DEBUG_CACHE": "1",
                   "NUMBA_NUM_THREADS": "1", **FROM_SCRATCH, **env}
        argv = ["runuser", "-u", "nobody", "--", "env", "-i", *(f"{k}={v}" for k, v in environ.items()),
                self.python, "-c", SIMULATION]
        return subprocess.run(argv, cwd=temp, capture_output=True, text=True, timeout=300, check=False)

    def serve(self, temp: Path, port: int) -> subprocess.Popen:
        """``mgrao serve`` of the install as ``nobody`` on 127.0.0.1:``port`` (no workers, SQLite in ``temp``)."""
        environ = {"PATH": "/usr/bin:/bin", "HOME": str(self.root / "no-such-home"), "TMPDIR": str(temp),
                   "PYTHONPATH": os.pathsep.join([str(self.site_dir), *self.deps])}
        argv = ["runuser", "-u", "nobody", "--", "env", "-i", *(f"{k}={v}" for k, v in environ.items()),
                self.python, "-m", "mgrao_cli", "serve", "--host", "127.0.0.1", "--port", str(port), "--workers",
                "0", "--database-url", f"sqlite:///{temp / 'mgrao.db'}"]
        with open(temp / "serve.log", "wb") as log:
            return subprocess.Popen(argv, cwd=temp, stdout=log, stderr=subprocess.STDOUT)

    def private_temp(self, name: str) -> Path:
        temp = self.root / name
        temp.mkdir()
        os.chown(temp, UNPRIVILEGED, -1)
        return temp


def _as_nobody(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run(["runuser", "-u", "nobody", "--", *argv], capture_output=True, text=True, check=False)


def _interpreter_for_nobody(deps: list[str]) -> str | None:
    """A Python of this minor version that ``nobody`` can run and that imports numba from ``deps``."""
    version = f"{sys.version_info.major}.{sys.version_info.minor}"
    probe = f"import sys, numba; assert sys.version_info[:2] == ({version.replace('.', ', ')})"
    for candidate in dict.fromkeys([os.path.realpath(sys.executable), f"/usr/bin/python{version}",
                                    shutil.which(f"python{version}") or ""]):
        if candidate and os.path.isfile(candidate):
            if _as_nobody("env", "-i", f"PYTHONPATH={os.pathsep.join(deps)}", candidate, "-c",
                          probe).returncode == 0:
                return candidate
    return None


@pytest.fixture(scope="module")
def read_only_install() -> Iterator[ReadOnlyInstall]:
    if sys.platform != "linux" or os.geteuid() != 0 or shutil.which("runuser") is None:
        pytest.skip("needs Linux, root and runuser to run a simulation as an unprivileged user")
    try:
        import wheel  # noqa: F401  (setuptools < 70.1 builds wheels with it; pip builds offline here)
    except ImportError:
        pytest.skip("needs the wheel package to build the project offline (pip install -e '.[test]')")
    deps = [d for d in site.getsitepackages() if os.path.isdir(d)]
    python = _interpreter_for_nobody(deps)
    if python is None:
        pytest.skip(f"user nobody cannot run a Python {sys.version_info.major}.{sys.version_info.minor} that "
                    f"imports numba from {os.pathsep.join(deps)} (neither {os.path.realpath(sys.executable)} nor "
                    f"/usr/bin/python{sys.version_info.major}.{sys.version_info.minor}, or those directories are "
                    "not readable by it)")
    root = Path(tempfile.mkdtemp(prefix="mgrao-readonly-"))
    try:
        root.chmod(0o755)
        source = root / "src"
        source.mkdir()
        for name in ["pyproject.toml", "README.md"]:  # what pyproject.toml installs
            shutil.copy2(ROOT / name, source / name)
        for package in ["backend", "frontend", "mgrao_cli", "mgrao_core", "docs", "mgrao_docs"]:
            shutil.copytree(ROOT / package, source / package, symlinks=True,  # mgrao_docs/docs stays a link
                            ignore=shutil.ignore_patterns("__pycache__"))
        site_dir = root / "site-packages"
        build = subprocess.run(
            [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation", "--no-index",
             "--target", str(site_dir), str(source)], capture_output=True, text=True, timeout=120, check=False)
        assert build.returncode == 0, build.stdout + build.stderr
        shutil.rmtree(source)
        subprocess.run(["chmod", "-R", "a-w", str(site_dir)], check=True)
        yield ReadOnlyInstall(root, site_dir, python, deps)
    finally:
        subprocess.run(["chmod", "-R", "u+w", str(root)], check=False)
        shutil.rmtree(root, ignore_errors=True)


def _utilities(output: str) -> str:
    return next(line for line in output.splitlines() if line.startswith("UTILITIES"))


@pytest.mark.slow
def test_read_only_install_without_a_home_caches_under_the_temp_dir_and_reuses_it(
        read_only_install: ReadOnlyInstall) -> None:
    install = read_only_install
    temp = install.private_temp("tmp")
    first = install.run(temp)
    assert first.returncode == 0, first.stderr[-3000:]
    assert f"MGRAO_CORE {install.site_dir}" in first.stdout  # the installed copy, not the checkout
    cache = temp / f"mgrao-numba-{UNPRIVILEGED}"
    assert f"CACHE_DIR {cache}" in first.stdout
    assert "data saved to" in first.stdout  # NUMBA_DEBUG_CACHE prints there
    assert any(cache.rglob("*.nbc")), "nothing was cached"
    assert not any(install.site_dir.rglob("*.nb[ci]")), "numba wrote into the read-only install"

    second = install.run(temp)
    assert second.returncode == 0, second.stderr[-3000:]
    assert "data loaded from" in second.stdout and "data saved to" not in second.stdout
    assert _utilities(second.stdout) == _utilities(first.stdout)


@pytest.mark.slow
def test_with_no_writable_cache_directory_at_all_the_simulation_runs_uncached(
        read_only_install: ReadOnlyInstall) -> None:
    install = read_only_install
    temp = install.private_temp("tmp-squatted")
    (temp / f"mgrao-numba-{UNPRIVILEGED}").mkdir(mode=0o700)  # root's: not nobody's to use
    result = install.run(temp)
    assert result.returncode == 0, result.stderr[-3000:]
    assert "no writable cache directory" in result.stderr
    assert "data saved to" not in result.stdout
    assert "CACHE_DIR \n" in result.stdout  # numba was left without a cache directory


@pytest.mark.slow
def test_read_only_install_serves_every_docs_page_with_working_links(read_only_install: ReadOnlyInstall) -> None:
    install = read_only_install
    shipped = install.site_dir / "mgrao_docs" / "docs"
    assert not shipped.is_symlink()  # the build copied the files the checkout's link leads to
    assert {p.name for p in shipped.glob("*.md")} == {p.name for p in (ROOT / "docs").glob("*.md")}
    assert {p.name for p in (shipped / "img").iterdir()} == {p.name for p in (ROOT / "docs" / "img").iterdir()}
    temp = install.private_temp("tmp-serve")
    port = free_port()
    process = install.serve(temp, port)
    base = f"http://127.0.0.1:{port}"
    try:
        try:
            wait_healthy(base, process, timeout=120)
        except RuntimeError as error:
            pytest.fail(f"the installed mgrao serve did not start: {error}\n"
                        f"{(temp / 'serve.log').read_text(errors='replace')[-3000:]}")
        pages, problems = crawl_docs(base)
        assert not problems, "\n".join(problems)
        assert {f"/project-docs/{p.stem}.html" for p in (ROOT / "docs").glob("*.md")} <= set(pages)
    finally:
        stop(process, timeout=15)
