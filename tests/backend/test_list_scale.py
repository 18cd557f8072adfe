"""The runs list at a lab's scale (issue 46): what the service does so that the list stays fast, checked by
its effect on answers and plans (the timings are benchmarks/bench_list_probe.py's and bench_lab_scale.py's).
"""

from __future__ import annotations

import gc
from pathlib import Path

from backend_helpers import BASE_URL
from fastapi.testclient import TestClient

from backend.api.app import create_app
from backend.settings import Settings


def test_the_api_leaves_its_start_up_objects_out_of_later_collections(tmp_path: Path) -> None:
    """Python's full collections walked every object the API imported, stalling every request (docs/service.md)."""
    gc.unfreeze()
    assert gc.get_freeze_count() == 0
    try:
        with TestClient(create_app(Settings(database_url=f"sqlite:///{tmp_path / 'm.db'}")), base_url=BASE_URL) as c:
            assert c.get("/api/jobs").status_code == 200
            assert gc.get_freeze_count() > 10_000  # the modules, the app and its routes
    finally:
        gc.unfreeze()  # the test process's objects collected as before
