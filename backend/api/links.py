"""OpenAPI links: from every answer that holds a resource's id to the operations on that resource.

A client reads them in the OpenAPI document (``GET /openapi.json``): the answer of ``POST /api/jobs``
links to ``GET /api/jobs/{job_id}/results`` with the id it holds at ``/id``, a listing to the
operations on its first item, a saved system to the jobs and algorithms of its name. Schemathesis'
stateful phase follows them to chain real calls (tests/backend/test_openapi_contract.py). Each
resource's operations are named once here (:data:`JOB`, :data:`STUDY`, :data:`RUN`, :data:`SAVED`);
a route says only where its answer holds the id (:func:`links`). docs/api.md, "Links", lists them.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Target:
    """An operation on a resource: its operationId, the parameter its id fills, a body it needs beside."""

    operation: str
    parameter: str
    body: dict[str, str] = field(default_factory=dict)  # body member -> what of the answer fills it ("" = the id)


def _job(operation: str, parameter: str = "path.job_id") -> Target:
    return Target(operation, parameter)


JOB = {
    "read": _job("read_job_api_jobs__job_id__get"),
    "status": _job("job_status_api_jobs__job_id__status_get"),
    "patch": _job("patch_job_api_jobs__job_id__patch"),
    "cancel": _job("cancel_job_api_jobs__job_id__cancel_post"),
    "delete": _job("delete_job_api_jobs__job_id__delete"),
    "results": _job("job_results_api_jobs__job_id__results_get"),
    "weights": _job("job_weights_api_jobs__job_id__weights_get"),
    "episodes": _job("job_episodes_api_jobs__job_id__episodes_get"),
    "compare": _job("compare_api_compare_get", "query.jobs"),
    "statistics": _job("statistics_api_compare_statistics_get", "query.jobs"),
    "sample_efficiency": _job("sample_efficiency_api_compare_sample_efficiency_get", "query.jobs"),
}
"""The operations on a job (any job: an external run's too)."""

STUDY = {name: Target(operation, "path.study_id") for name, operation in {
    "read": "read_study_api_studies__study_id__get",
    "plots": "plot_study_api_studies__study_id__plots_get",
    "cancel": "cancel_study_api_studies__study_id__cancel_post",
    "rerun_failed": "rerun_failed_api_studies__study_id__rerun_failed_post",
    "delete": "delete_study_api_studies__study_id__delete",
}.items()}
"""The operations on a study."""

RUN = {
    "read_run": _job("read_external_run_api_external_runs__job_id__get"),
    "batch": _job("add_batch_api_external_runs__job_id__batches_post"),
    "close": _job("close_external_run_api_external_runs__job_id__close_post"),
    "job": JOB["read"], "results": JOB["results"], "episodes": JOB["episodes"],
}
"""The operations on an external run: its own, and its job's."""

SAVED = {
    "read": Target("read_saved_system_api_systems_saved__name__get", "path.name"),
    "replace": Target("replace_saved_system_api_systems_saved__name__put", "path.name",
                      {"name": "", "base": "/base", "params": "/params", "description": "/description"}),
    "delete": Target("delete_saved_system_api_systems_saved__name__delete", "path.name"),
    "algorithms": Target("algorithms_api_algorithms_get", "query.system"),
    "run": Target("submit_job_api_jobs_post", "", {"system": ""}),
}
"""The operations on a saved system, and the jobs and algorithms of its name (replace: with the whole system
as it is, so that a client following the link changes nothing it does not mean to)."""


def links(targets: dict[str, Target], source: str, *, without: Iterable[str] = ()) -> dict[str, dict[str, Any]]:
    """The ``links`` of an answer: to each of ``targets`` (but ``without``), the id taken from ``source``.

    Args:
        targets: :data:`JOB`, :data:`STUDY`, :data:`RUN` or :data:`SAVED` (or a part of one).
        source: where the id is: a JSON pointer into the answer's body (``/id``, ``/data/0/id``), or a
            runtime expression (``$request.path.job_id``: the id the request was about).
        without: link names left out (an answer's own operation).
    """
    value = source if source.startswith("$") else f"$response.body#{source}"
    out = {}
    for name, target in targets.items():
        if name in without:
            continue
        link: dict[str, Any] = {"operationId": target.operation}
        if target.parameter:
            link["parameters"] = {target.parameter: value}
        if target.body:
            link["requestBody"] = {member: value if not pointer else _beside(source, pointer)
                                   for member, pointer in target.body.items()}
        out[name] = link
    return out


def _beside(source: str, pointer: str) -> str:
    """``pointer`` in the object that holds the id at ``source`` (``/0/name`` and ``/base``: ``/0/base``)."""
    if source.startswith("$"):
        raise ValueError(f"a body member beside the id needs the answer's body, not {source}")
    return f"$response.body#{source.rsplit('/', 1)[0]}{pointer}"
