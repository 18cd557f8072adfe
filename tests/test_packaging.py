"""The project's own files: quick start, CI script and compose file stay true to each other."""

from __future__ import annotations

import re
import shutil
import subprocess
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
