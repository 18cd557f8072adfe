"""The project's own files: quick start, CI script and compose file stay true to each other."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")


def quick_start_commands() -> list[str]:
    section = README.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    return [line.strip() for line in section.splitlines() if line.startswith("    ")]


def test_quick_start_is_two_commands_and_ci_runs_the_test_one():
    commands = quick_start_commands()
    assert len(commands) == 2
    serve, test = commands
    assert serve.endswith("mgrao serve")
    ci_script = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert test in ci_script.splitlines()


def test_the_test_command_runs_the_suite_on_every_core_with_work_stealing():
    # pytest-xdist: one worker per core, an idle one taking tests from a busy one (tests/support/scheduling.py)
    _, test = quick_start_commands()
    assert test.endswith(".venv/bin/python -m pytest -n auto --dist worksteal"), test
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    assert any(re.match(r"pytest-xdist\b", requirement) for requirement in project["optional-dependencies"]["test"])


def test_readme_links_point_to_existing_files():
    for target in re.findall(r"\]\(([^)#]+)\)", README):
        if not target.startswith("http"):
            assert (ROOT / target).is_file(), target


@pytest.mark.skipif(shutil.which("docker-compose") is None, reason="docker-compose is not installed")
def test_compose_file_is_valid():
    result = subprocess.run(
        ["docker-compose", "-f", str(ROOT / "docker-compose.yml"), "config", "-q"],
        capture_output=True, text=True, cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr


@pytest.mark.skipif(shutil.which("docker-compose") is None, reason="docker-compose is not installed")
def test_the_cluster_profile_has_every_service_with_its_health_check_and_one_image():
    import yaml

    result = subprocess.run(["docker-compose", "-f", str(ROOT / "docker-compose.yml"), "--profile", "cluster",
                             "config"], capture_output=True, text=True, cwd=ROOT, check=True)
    services = yaml.safe_load(result.stdout)["services"]
    assert {"postgres", "migrate", "api", "dispatcher", "dask-scheduler", "dask-worker", "mgrao"} <= set(services)
    assert "pg_isready" in " ".join(services["postgres"]["healthcheck"]["test"])
    assert "/api/health" in " ".join(services["api"]["healthcheck"]["test"])
    assert "8787/health" in " ".join(services["dask-scheduler"]["healthcheck"]["test"])
    assert services["migrate"]["command"] == ["mgrao", "migrate"] and services["migrate"]["restart"] == "no"
    assert services["api"]["command"][-2:] == ["--workers", "0"]
    assert services["api"]["depends_on"]["migrate"]["condition"] == "service_completed_successfully"
    assert services["dispatcher"]["command"] == ["mgrao", "dispatcher"]
    assert services["dispatcher"]["environment"]["MGRAO_DASK_ADDRESS"] == "tcp://dask-scheduler:8786"
    assert services["dask-worker"]["scale"] >= 2 and services["dask-worker"]["restart"] == "unless-stopped"
    images = {services[name]["image"] for name in ("api", "dispatcher", "dask-scheduler", "dask-worker", "migrate")}
    assert images == {services["mgrao"]["image"]}  # one image: versions match across the cluster
    assert services["api"]["environment"]["MGRAO_DATABASE_URL"].startswith("postgresql+psycopg://")
    published = [p for s in services.values() for p in s.get("ports", [])]
    assert all(str(p.get("host_ip", p) if isinstance(p, dict) else p).startswith("127.0.0.1") for p in published)


def test_the_docker_image_copies_everything_the_project_needs_to_build(tmp_path: Path) -> None:
    """The Dockerfile's COPY lines, replayed into an empty directory, are enough to build the wheel
    its ``pip install`` builds (pyproject.toml installs docs/reproduction.md too)."""
    pytest.importorskip("wheel", reason="builds the project offline (pip install -e '.[test]')")
    app = tmp_path / "app"
    app.mkdir()
    for line in (ROOT / "Dockerfile").read_text(encoding="utf-8").splitlines():
        if line.startswith("COPY "):
            *sources, target = line.split()[1:]
            for source in sources:
                destination = app / target / Path(source).name if target.endswith("/") else app / target
                if (ROOT / source).is_dir():
                    shutil.copytree(ROOT / source, destination, ignore=shutil.ignore_patterns("__pycache__"))
                else:
                    destination.parent.mkdir(parents=True, exist_ok=True)
                    shutil.copy2(ROOT / source, destination)
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--no-build-isolation",
                            "--no-index", "--wheel-dir", str(tmp_path / "wheels"), str(app)],
                           capture_output=True, text=True, timeout=300, check=False)
    assert build.returncode == 0, build.stdout + build.stderr[-3000:]
    (wheel,) = (tmp_path / "wheels").glob("mgrao-*.whl")
    # every package pyproject.toml installs is in the image's wheel (packages.find skips a folder not copied)
    import zipfile

    from tests.support.project import packages

    expected = set(packages())
    assert expected and all((ROOT / name).is_dir() for name in expected), expected
    shipped = {name.split("/")[0] for name in zipfile.ZipFile(wheel).namelist()}
    assert expected <= shipped, f"the Dockerfile copies no {sorted(expected - shipped)}"


def shell_blocks(markdown: str) -> list[list[str]]:
    """The indented code blocks of a Markdown text, as lists of their lines (indentation removed)."""
    blocks, current = [], []
    for line in [*markdown.splitlines(), ""]:
        if line.startswith("    "):
            current.append(line[4:])
        elif current and line.strip():
            blocks.append(current)
            current = []
    return blocks


def test_the_readmes_shell_examples_run_the_commands_the_quick_start_installed():
    # the quick start installs into .venv: a bare `mgrao` is "command not found" until it is activated
    activate = ". .venv/bin/activate"
    bare = [block for block in shell_blocks(README)
            if any(line.split()[0] in ("mgrao", "dask") for line in block if line.strip())]
    assert bare, "no shell example of mgrao found in README.md"
    for block in bare:
        first = next(i for i, line in enumerate(block) if line.split() and line.split()[0] in ("mgrao", "dask"))
        assert activate in block[:first], f"README.md runs {block[first]!r} without `{activate}` before it"


OUTSIDE_CITATION = re.compile(r"SIMULATION\.md|\.\./shared\b|\bshared/(?:paper|SIMULATION)|/work/shared\b")
"""A citation of files outside the repository (the brief and paper the project began from): the
repository stands on its own; docs/model.md documents the model, the paper is cited by its reference."""


def test_no_tracked_file_cites_files_outside_the_repository():
    try:
        listed = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        pytest.skip("not a git checkout (the tracked files are unknown)")
    found = []
    for name in listed.stdout.decode().split("\0"):
        path = ROOT / name
        if not name or name.startswith("tests/") or path.is_symlink() or not path.is_file():
            continue
        data = path.read_bytes()
        if b"\0" in data:
            continue  # binary
        for number, line in enumerate(data.decode("utf-8", "replace").splitlines(), 1):
            if OUTSIDE_CITATION.search(line):
                found.append(f"{name}:{number}: {line.strip()}")
    assert not found, "cite docs/model.md (and the paper by its reference) instead:\n" + "\n".join(found)
