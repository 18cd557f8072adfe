"""What the API answers, for its OpenAPI document: response models of the JSON answers, and every status.

The routes build most answers as bytes themselves (streamed or cached), so these models document
them without being applied. Every route can answer 400 (a ``Host`` the server does not answer to),
413 (a body over ``MGRAO_MAX_BODY_BYTES``) and 503 (the database unavailable, with ``Retry-After``);
every write 401 (the bearer token, when ``MGRAO_API_TOKEN`` is set), 403 (a foreign ``Origin``) and
415 (no ``Origin`` and no ``Content-Type: application/json``, even without a body): docs/api.md,
"Errors" and "Cross-site requests". :func:`answers` gives a route's ``responses``.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, Field

from backend.api.schemas import JobOut, Number, Status, Summary


class Problem(BaseModel):
    """Every error but a validation error: ``{"detail": "what went wrong"}``."""

    detail: str


class FieldError(BaseModel):
    """One refused field: ``loc`` (where), ``field`` (its name), ``msg`` (starts with the field, states the limit)."""

    loc: list[str | int]
    field: str
    msg: str
    type: str


class Invalid(BaseModel):
    """422: ``{"detail": [{"loc", "field", "msg", "type"}]}``, one entry per refused field."""

    detail: list[FieldError]


def _error(description: str, model: type[BaseModel] = Problem, headers: dict[str, Any] | None = None) -> dict:
    answer: dict[str, Any] = {"description": description, "model": model}
    if headers:
        answer["headers"] = headers
    return answer


HOST = _error("The Host header names no host the server answers to (MGRAO_ALLOWED_HOSTS).")
TOO_LARGE = _error("The request body is over MGRAO_MAX_BODY_BYTES (see max_body_bytes in GET /api/systems).")
UNAVAILABLE = _error(
    "The database cannot be written or read now (read-only, moved, deleted, locked past the busy timeout); "
    "nothing of the request was changed: retry after Retry-After seconds.",
    headers={"Retry-After": {"description": "Seconds to wait before retrying.", "schema": {"type": "integer"}}})
TOKEN = _error("Missing or wrong bearer token (only when the service has MGRAO_API_TOKEN).",
               headers={"WWW-Authenticate": {"description": "Bearer", "schema": {"type": "string"}}})
FOREIGN = _error("Cross-origin write refused: the Origin header is not this server's own origin.")
NOT_JSON = _error("A write without an Origin header needs Content-Type: application/json, even without a body.")
INVALID = _error("A field is refused: its name, where it is and the limit; or a query parameter the operation "
                 "does not take. Some rules are not in this document's schemas (the work limit, an x of mgrao-x:y "
                 "that must divide n_parents and its y n_children, "
                 "types_per_composite at most n_types, a parameter's own limits, "
                 "GET /api/systems): schema-valid data can still be refused here.", Invalid)
NOT_FOUND = _error("No such job or study (a well-formed id that does not exist).")
CONFLICT = _error("The job's or study's state does not allow this (e.g. nothing stored yet, or still running).")


def answers(*, write: bool = False, found: bool = False, conflict: bool = False,
            extra: dict[int, dict] | None = None) -> dict[int | str, dict[str, Any]]:
    """A route's ``responses``: the errors it can answer, and ``extra``.

    Always 400, 413, 422 (at least a query parameter it does not take: backend.api.strict_query)
    and 503; 401, 403 and 415 for a write; 404 for an id (``found``); 409 for a state change (``conflict``).
    """
    out: dict[int | str, dict[str, Any]] = {400: HOST, 413: TOO_LARGE, 422: INVALID, 503: UNAVAILABLE}
    if write:
        out |= {401: TOKEN, 403: FOREIGN, 415: NOT_JSON}
    if found:
        out[404] = NOT_FOUND
    if conflict:
        out[409] = CONFLICT
    return out | (extra or {})


LOCATION = {"Location": {"description": "The new resource's address.", "schema": {"type": "string"}, "required": True}}


def links(parameter: str, pointer: str, operations: dict[str, str]) -> dict[str, dict[str, Any]]:
    """OpenAPI links from a created resource (its id at JSON ``pointer``) to the operations on it.

    Args:
        parameter: the path parameter the id fills (``job_id``).
        pointer: where the answer holds the id (``/id``).
        operations: link name -> operationId.
    """
    return {name: {"operationId": operation, "parameters": {parameter: f"$response.body#{pointer}"}}
            for name, operation in operations.items()}


# ---- answers of the JSON routes (Number and Summary, which jobs carry too, are in schemas) -------------


class Band(BaseModel):
    """A curve over episodes (downsampled): mean and 95% band."""

    episode: list[int]
    mean: list[Number]
    low: list[Number]
    high: list[Number]


class SeedCurve(BaseModel):
    """One seed's curve (``include_seeds=true``)."""

    seed: int
    episode: list[int]
    utility: list[Number]


class ResourceWeights(BaseModel):
    """One resource's final weights (a system with several resources): combined per child, and per parent group."""

    resource: int
    combined: list[Any]
    groups: list[Any] | None


class StoredBounds(BaseModel):
    """The weights a run stores at most (``mgrao_core.budget``): beyond, the first children's that fit."""

    combined_values: int
    group_values: int


class ChildrenPage(BaseModel):
    """Which children an answer holds, and which a run stores (an answer of a page, or of more than 100 children)."""

    offset: int = Field(description="The page's first child.")
    count: int = Field(description="Children in the page (combined and groups hold one entry each).")
    total: int = Field(description="The run's children (n_children).")
    combined_stored: int = Field(description="The first children whose combined weights a run stores.")
    groups_stored: int | None = Field(description="The first children whose parent-group weights a run stores; "
                                                  "null when the algorithm learns none.")
    bounds: StoredBounds


class ChildMeans(BaseModel):
    """A run's weights' mean over every child, as one child: ``combined`` and ``groups`` hold one entry."""

    combined: list[Any]
    groups: list[Any] | None
    groups_omitted: str | None = None
    resources: list[ResourceWeights] | None = None


class MeanWeights(BaseModel):
    """Final weights of a page of children: combined per child, and per parent group.

    ``groups`` is empty for uniform and oracle, or null when omitted (beyond the size limit, or not stored),
    with the reason. With several resources (``n_resources`` > 1), ``combined`` and ``groups`` are the first
    resource's and ``resources`` lists every resource's (MG-RAO keeps a PW per resource; the other families one
    split for every resource); null with one resource. ``children`` says which children the page holds (an
    answer of a page, or of a run of more than 100 children); ``mean_over_children`` is the mean over every
    child, for a run of more than 100 children.
    """

    combined: list[Any]
    groups: list[Any] | None
    groups_omitted: str | None = None
    resources: list[ResourceWeights] | None = None
    children: ChildrenPage | None = None
    mean_over_children: ChildMeans | None = None


class SeedPct(BaseModel):
    """One seed's paired % from uniform."""

    seed: int
    pct_from_uniform: Number


class AlgorithmLabel(BaseModel):
    """One label of ``GET /api/algorithms?label=``, canonical and described."""

    label: str = Field(description="The canonical spelling (what jobs store).")
    family: str
    title: str
    groups: int | None = Field(description="Parent groups per child of a learner with groups, else null.")
    team_size: int | None = Field(None, description="Children sharing one model (the y of mgrao-x:y; 1: each child "
                                                    "its own) of a learner with groups, else null.")
    description: str
    colour_key: int = Field(ge=0, le=7, description="The palette slot (0-7) the configuration prefers in every view.")
    sort_key: list[int] = Field(description="Views order configurations by this (family rank, then order), then "
                                            "by label.")
    memory_per_child: int | None = Field(None, description="Bytes of learning state per child (null without a "
                                                           "system).")


class Share(BaseModel):
    """A share of each child's resources (0-1): the mean over children and runs, and the least and most."""

    mean: Number
    low: Number
    high: Number


class LearningOutcome(BaseModel):
    """What a learner configuration's learning came to over its stored runs (null for uniform and the oracle)."""

    groups: dict[str, int] | None = Field(description="Children (counted once per run) by their number of parent "
                                                      "groups at the end: mgrao-balance's from its recorded "
                                                      "memberships (the children recorded), x for mgrao-x:1 and "
                                                      "mgrao-adaptive:x; null for a learner without groups.")
    children: int = Field(description="The children counted in groups (one per child and run).")
    groups_change: bool = Field(description="Whether its children's group count changes as they learn "
                                            "(mgrao-balance): then groups is what they ended with.")
    taken: Share | None = Field(description="The share of each child's resources its learning took at the end "
                                            "(learning_cost; mgrao-balance's by its groups then); null without a "
                                            "learning cost.")


class ResultConfiguration(BaseModel):
    """One configuration of a job's results."""

    algorithm: str
    config_hash: str
    seeds_done: int
    summary: Summary
    episodes: Band
    weights: MeanWeights
    learning: LearningOutcome | None = None
    seeds: list[SeedCurve] | None = None
    pct_by_seed: list[SeedPct] | None = None
    """With ``?pct_by_seed=true``: each seed's paired % from uniform, in the job's seed order."""


class Results(BaseModel):
    """``GET /api/jobs/{id}/results``."""

    job: JobOut
    paper: dict[str, float] | None
    partial: bool
    oracle_caveats: list[str] | None = Field(None, description="A job with the oracle: why it is no upper bound in "
                                                               "the job's system ([] when it is one); null without "
                                                               "it.")
    algorithms: list[AlgorithmLabel] = Field(description="The registry's description of each of the job's "
                                                         "algorithms (as GET /api/algorithms?label= gives it).")
    points: int
    configurations: list[ResultConfiguration]


class Membership(BaseModel):
    """The parent groups of an algorithm whose groups change, as its children recorded them over the run."""

    every: int = Field(description="Episodes between two records; the first record is at episode 0.")
    children: list[list[list[int]]] = Field(description="Per child (the first that fit the storage bound), per "
                                                        "record, each parent's group.")


class SeedWeights(MeanWeights):
    """One configuration's final weights for one seed (and, for adaptive groups, its recorded memberships)."""

    algorithm: str
    membership: Membership | None = None


class Weights(BaseModel):
    """``GET /api/jobs/{id}/weights``."""

    job_id: int
    seed: int
    seeds: list[int]
    configurations: list[SeedWeights]


class EpisodeRow(BaseModel):
    """One stored episode of ``GET /api/jobs/{id}/episodes?format=json``."""

    job_id: int
    algorithm: str
    seed: int
    episode: int
    utility: Number


class CompareGroup(BaseModel):
    """A configuration (world, algorithm, its own parameters) pooled over the compared jobs."""

    config_hash: str = Field(description="The first contributing job's configuration hash.")
    config_hashes: list[str] = Field(description="Every contributing job's (jobs that differ in another "
                                                 "algorithm's parameters share a uniform configuration).")
    algorithm: str
    label: str = Field(description="The algorithm, and where two configurations of one world share it, what tells "
                                   "them apart: 'mgrao-1:1 (learning_rate=0.2)', 'hedge (job 12)'.")
    system: str = Field(description="The world's system: the saved system its jobs ran (GET /api/systems/saved), "
                                    "else their preset (docs/statistics.md, \"Names\").")
    base: str = Field(description="The preset the system is based on (the jobs' own system); the system itself for "
                                  "a preset's jobs.")
    world: str = Field(description="The world's name: its system's, and where worlds share one, what differs.")
    params: dict[str, Any] = Field(description="The algorithm's own parameters (every learner parameter for a run "
                                               "logged from outside).")
    external: bool
    episodes_per_run: int
    job_ids: list[int] = Field(description="Every job read for it, in the order asked: those whose runs it takes "
                                           "and those only checked (checked_job_ids).")
    checked_job_ids: list[int] = Field(description="Jobs read whose every seed an earlier job gave first (a job whose "
                                                   "seeds are a subset of another's): their runs are checked against "
                                                   "those (mismatched_seeds), none counted twice.")
    mismatched_seeds: list[int] = Field(description="Seeds whose pooled runs differ between jobs (the first job's is "
                                                    "used): built-in runs of one configuration should be identical.")
    summary: Summary
    episodes: Band


class Comparison(BaseModel):
    """``GET /api/compare``."""

    jobs: list[JobOut]
    algorithms: list[AlgorithmLabel] = Field(description="The registry's description of every configuration's "
                                                         "algorithm (as GET /api/algorithms?label= gives it).")
    groups: list[CompareGroup]


class Estimate(BaseModel):
    """A point estimate and its 95% interval."""

    estimate: Number
    ci95: list[Number]


class Anchors(BaseModel):
    """A system's score anchors: mean final utility of uniform and the oracle on the seeds both ran."""

    uniform: Number
    oracle: Number
    gain: Number
    gain_ci95: list[Number] | None
    n_seeds: int
    valid: bool
    reason: str | None = Field(description="Why the system has no scores (null when it has).")
    caveats: list[str] = Field(description="Why the oracle is no upper bound here (scores above 1 are possible).")


class HeadToHead(BaseModel):
    """X minus Y in % from uniform on one system, over the seeds both share with uniform."""

    system: str
    x: str
    y: str
    n_paired: int
    difference: Number
    ci95: list[Number] | None
    p_value: Number
    p_holm: Number


class Aggregated(BaseModel):
    """What the aggregates stand on (docs/statistics.md, "Scores")."""

    systems: list[str] = Field(description="The systems aggregated: one world per system.")
    seeds: dict[str, list[int]] = Field(description="Per aggregated system, its anchor seeds (uniform and oracle "
                                                    "both ran): every score of the system stands on them.")
    n_seeds: dict[str, int] = Field(description="Per aggregated system, how many anchor seeds.")
    runs: dict[str, dict[str, int]] = Field(description="Per aggregated configuration and system, its scored runs.")
    left_out: dict[str, dict[str, dict[str, Any]]] = Field(
        description="Per aggregated system and configuration, the seeds not scored (seeds, reason).")
    worlds_of_system: dict[str, list[str]] = Field(
        description="Systems with several worlds among the jobs: the worlds; one stands for each (aggregate=).")
    weighting: str = Field(description="How systems with different numbers of seeds are weighed.")
    excluded: dict[str, str] = Field(description="Configurations not aggregated, and why.")
    reason: str | None = Field(description="Why nothing is aggregated (null when something is).")


class ComparisonStatistics(BaseModel):
    """``GET /api/compare/statistics`` (docs/statistics.md, "The answer")."""

    jobs: list[int]
    systems: dict[str, dict[str, Summary]] = Field(description="Per system (world) and configuration label.")
    normalisation: dict[str, Anchors]
    scores: dict[str, dict[str, list[float]]] = Field(description="Per aggregated configuration and system, its "
                                                                 "scores on the system's anchor seeds, in seed order.")
    aggregate: dict[str, dict[str, Estimate]] = Field(description="Per configuration: mean, median, iqm, "
                                                                  "optimality_gap.")
    aggregated: Aggregated
    performance_profiles: dict[str, Any] = Field(description="tau, and per configuration share, low, high.")
    probability_of_improvement: dict[str, Estimate] = Field(description="'X>Y': P(X > Y), both orders of every pair.")
    head_to_head: dict[str, Any] = Field(description="pairs (HeadToHead per system) and tests (Holm's family).")
    protocol: dict[str, Any]
    configurations: list[dict[str, Any]] = Field(description="Each configuration's system (its world's name), "
                                                             "base (the preset), label, algorithm, params, job_ids, "
                                                             "checked_job_ids, mismatched_seeds.")


class SampleEfficiency(BaseModel):
    """``GET /api/compare/sample-efficiency``: IQM of the scores per bucket of episodes."""

    systems: list[str]
    seeds: dict[str, list[int]] = Field(description="Per system, its anchor seeds.")
    runs: dict[str, dict[str, int]] = Field(description="Per configuration and system, its scored runs.")
    points: int
    episodes: dict[str, list[int]] = Field(description="Per system, each bucket's first episode.")
    curves: dict[str, dict[str, list[Number]]] = Field(description="Per configuration: iqm, low, high.")
    excluded: dict[str, str]
    reason: str | None
    bootstrap: dict[str, Any]


class Systems(BaseModel):
    """``GET /api/systems``: presets, the parameter schema, algorithm labels, limits, the studies' limits."""

    systems: list[dict[str, Any]]
    saved: list[dict[str, Any]] = Field(default_factory=list, description="Saved systems (GET /api/systems/saved).")
    parameters: list[dict[str, Any]]
    group_titles: dict[str, str] = Field(description="Each parameter group's heading (a parameter's group: its "
                                                     "title), e.g. quality: Quality (environment).")
    algorithms: dict[str, Any] = Field(description="From the algorithm registry (GET /api/algorithms): fixed "
                                                   "(labels for the form's boxes), pattern (labels with an "
                                                   "argument), baseline, reference and best_fixed (the labels "
                                                   "% from uniform, % of max and the oracle's allocation read).")
    limits: dict[str, Any] = Field(description="max_seeds, max_episodes, max_algorithms, max_work, work_factors "
                                               "(the factors whose product max_work bounds), max_body_bytes, "
                                               "max_response_values (numbers in the curves of one results or "
                                               "compare answer), until (a stopping rule's choices of of, its "
                                               "least seeds, its default max_seeds and block, its largest "
                                               "half_width).")
    studies: dict[str, Any]


class AlgorithmForm(BaseModel):
    """One way of writing a family's labels: a literal label, or a ``template`` with an argument ``{x}`` (or two)."""

    template: str = Field(description="The label itself, or with {x} where the argument goes (mgrao-{x}:1), and "
                                      "{y} where a second one goes (mgrao-{x}:{y}).")
    pattern: str = Field(description="A regular expression matching the lower-cased label, the argument its "
                                     "first group (and the second argument its second).")
    description: str
    argument: str | None = Field(description="The argument's name, null for a literal label.")
    argument_help: str
    valid: list[int] | None = Field(None, description="An argument form's values valid for the system (null "
                                                      "without one); absent for a literal label.")
    second_argument: str | None = Field(None, description="A second argument's name (y of mgrao-{x}:{y}: values "
                                                          "are typed x:y); absent for a form of one argument.")
    second_help: str | None = Field(None, description="What the second argument is.")
    second_valid: list[int] | None = Field(None, description="The second argument's values valid for the system "
                                                             "(null without one).")


class AlgorithmFamily(BaseModel):
    """One algorithm family of ``GET /api/algorithms``: what it does and how its labels are written."""

    name: str
    title: str
    description: str
    rank: int = Field(description="Where the family's configurations come in views (lower first).")
    forms: list[AlgorithmForm]
    examples: list[str] = Field(description="Labels valid for the system (the grammar's own without one).")
    memory_per_child: dict[str, int] | None = Field(None, description="Bytes of learning state per child of each "
                                                                      "example (with a system; null without one).")


class Algorithms(BaseModel):
    """``GET /api/algorithms``: every family, or with ``label`` the labels described, in the order asked."""

    data: list[AlgorithmFamily] | list[AlgorithmLabel]


class StudyOut(BaseModel):
    """A study as listed."""

    id: int
    name: str
    method: str
    status: str
    planned: int
    trials: dict[str, int] = Field(description="Trials per status.")
    best_trial: int | None
    best_value: Number
    objective: dict[str, Any]
    space: dict[str, Any]
    created_at: str
    finished_at: str | None
    revision: int
    version: str


class StudyPage(BaseModel):
    """One page of ``GET /api/studies``."""

    data: list[StudyOut]
    next_cursor: str | None
    count: int


class TrialOut(BaseModel):
    """One trial of a study."""

    number: int
    params: dict[str, Any]
    status: Status | str
    value: Number
    ci95: list[Number] | None
    error: str | None
    runs: int
    job_ids: list[int]
    max_seeds_jobs: list[int] = Field([], description="Its jobs whose stopping rule (the base's until) reached "
                                                      "max_seeds unanswered: the objective is less precise than asked.")


class StudyDetail(BaseModel):
    """``GET /api/studies/{id}``: the study, its definition, and its trials (left out with ``trials=false``)."""

    study: StudyOut
    definition: dict[str, Any]
    trials: list[TrialOut] | None = None
    rerun: int | None = Field(None, description="POST .../rerun-failed: how many trials got new jobs.")


class StudyPlots(BaseModel):
    """``GET /api/studies/{id}/plots``: the aggregates the study view draws (docs/studies.md)."""

    dimensions: list[str]
    direction: str
    trials: int
    history: dict[str, Any]
    importance: dict[str, Any]
    slices: dict[str, Any]
    heatmap: dict[str, Any]
    parallel: dict[str, Any]


class JobChanges(BaseModel):
    """``GET /api/jobs/changes``: ``changed`` false alone, or the new token and the queue's counts."""

    changed: bool
    token: str | None = None
    queued: int | None = None
    running: int | None = None


class JobStatus(BaseModel):
    """``GET /api/jobs/{id}/status``: where a job stands and what a queued job waits for."""

    id: int
    status: str
    progress: float
    ahead: int
    running: int
    workers: dict[str, int]
    stored_runs: int


class JobCheck(BaseModel):
    """``POST /api/jobs/check``: whether the body would be queued (its work), or the 422 ``detail`` it would get."""

    valid: bool
    work: int | None = None
    max_work: int | None = None
    detail: list[dict[str, Any]] | None = None


class ExternalLimits(BaseModel):
    """What one batch may hold (docs/platform.md, "Limits")."""

    max_body_bytes: int = Field(description="Largest request body (MGRAO_MAX_BODY_BYTES): 413 beyond.")
    max_batch_entries: int = Field(description="Pieces of utilities, and seeds' weights, per batch.")
    max_piece_values: int = Field(description="Episode utilities of one piece.")
    max_pieces_per_seed: int = Field(description="Pieces one seed's episodes may come in.")
    weights_shape: list[int] = Field(description="[n_children, n_types]: the shape of a seed's final weights.")


class ExternalSeed(BaseModel):
    """One seed of an external run: episodes stored so far, whether complete, whether its weights are."""

    seed: int
    episodes_stored: int
    complete: bool
    weights: bool


class ExternalRunState(BaseModel):
    """An external run (``POST /api/external-runs``, ``GET``, ``.../close``): its job and what is stored."""

    job: JobOut
    label: str
    status: Status
    progress: float
    seeds_complete: int
    values_stored: int
    seeds: list[ExternalSeed]
    limits: ExternalLimits


class ExternalBatchOut(BaseModel):
    """``POST /api/external-runs/{id}/batches``: whether the batch was a replay, what it stored, where the run is."""

    replayed: bool = Field(description="True when this key's batch was already stored: nothing was stored again.")
    values: int = Field(description="Episode utilities the batch stored (a replay: what it stored the first time).")
    status: Status
    progress: float
    seeds_complete: int
    values_stored: int
