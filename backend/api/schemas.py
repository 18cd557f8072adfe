"""Request and response models; their bounds mirror the core library's limits."""

from __future__ import annotations

import unicodedata
from dataclasses import dataclass
from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    GetCoreSchemaHandler,
    GetJsonSchemaHandler,
    StrictBool,
    StrictInt,
    StringConstraints,
)
from pydantic.json_schema import JsonSchemaValue, SkipJsonSchema, WithJsonSchema
from pydantic_core import PydanticCustomError, core_schema

from backend.services.saved_systems import NAME_PATTERN as SAVED_NAME_PATTERN
from backend.store.external import MAX_BATCH_ENTRIES, MAX_PIECE_VALUES
from backend.store.models import has_nul
from mgrao_core import MAX_ALGORITHMS, MAX_EPISODES, MAX_SEEDS, PARAMETERS, PRESETS, search
from mgrao_core.params import PARAMETERS_BY_NAME
from mgrao_core.spec import MAX_SEED_VALUE
from mgrao_core.statistics import sequential

MAX_NAME = 200
MAX_TAG = 50
MAX_TAGS = 20
MAX_NOTES = 10_000
MAX_LABEL = 32
MAX_COMPARE_JOBS = 50

NO_NUL_PATTERN = "^[^\\x00]*$"
"""JSON Schema of text that comes in: no NUL character (PostgreSQL's text cannot hold it)."""
NO_NUL_MESSAGE = "must not contain the NUL character (0x00)"


@dataclass(frozen=True)
class NoNul:
    """The rule for every text that comes in, body or query: no NUL character (422 naming the field).

    PostgreSQL's text and JSON columns cannot store it (it answered 500) while SQLite did, and a NUL
    in ``q`` matched every job there; refused alike on both. Annotate a ``str`` with it: the
    OpenAPI document shows the rule as the pattern :data:`NO_NUL_PATTERN`.
    """

    def __get_pydantic_core_schema__(self, source: Any, handler: GetCoreSchemaHandler) -> core_schema.CoreSchema:
        """The string's own schema, then the check."""
        return core_schema.no_info_after_validator_function(_refuse_nul, handler(source))

    def __get_pydantic_json_schema__(self, schema: core_schema.CoreSchema,
                                     handler: GetJsonSchemaHandler) -> JsonSchemaValue:
        """The string's JSON Schema with the pattern."""
        return handler(schema) | {"pattern": NO_NUL_PATTERN}


def _refuse_nul(value: str) -> str:
    if has_nul(value):
        raise PydanticCustomError("value_error", NO_NUL_MESSAGE)
    return value


CONTROLS = "\\x00-\\x1f\\x7f-\\x9f"
"""Unicode's control characters (category Cc): C0, DEL and C1, terminal escapes among them."""
CONTROL_NAMES = {0x00: "NUL", 0x07: "BEL", 0x08: "BS", 0x09: "TAB", 0x0A: "LF", 0x0C: "FF", 0x0D: "CR", 0x1B: "ESC",
                 0x7F: "DEL"}
"""The control characters an error names as well as numbers."""
LINE_BREAKS = "\t\n\r"
"""The control characters that notes (text of several lines) may hold."""
BIDI_CONTROLS = "\\u202a-\\u202e\\u2066-\\u2069"
"""Unicode's bidirectional embeddings, overrides and isolates (LRE, RLE, PDF, LRO, RLO; LRI, RLI, FSI, PDI): they
reorder the text around them as a reader sees it (a name shown as another, "Trojan Source"), so text a person
reads refuses them as it refuses control characters."""
BIDI_NAMES = {0x202A: "LRE", 0x202B: "RLE", 0x202C: "PDF", 0x202D: "LRO", 0x202E: "RLO",
              0x2066: "LRI", 0x2067: "RLI", 0x2068: "FSI", 0x2069: "PDI"}
"""The bidirectional controls refused, by their Unicode abbreviations."""


@dataclass(frozen=True)
class Printable:
    """The rule for text a person names or describes something with: NFC, no control character.

    "é" typed as one character (NFC) or as "e" and a combining accent (NFD) is one name, one tag: the text is
    stored in NFC. A control character (a terminal escape, ESC [31m, or a tab in a tag) or a bidirectional
    control (:data:`BIDI_CONTROLS`, RLO U+202E) is refused with 422 naming the field and the character, alike
    on SQLite and PostgreSQL; ``multiline`` text (notes) keeps tabs and line breaks. The OpenAPI document shows
    the rule as a pattern (:meth:`pattern`); a tag's also needs a character that is not white space, as the
    server strips it first.
    """

    multiline: bool = False
    needs_text: bool = False

    def pattern(self) -> str:
        """The JSON Schema pattern of the text this rule accepts."""
        refused = CONTROLS + BIDI_CONTROLS
        allowed = f"[^{refused}]" if not self.multiline else f"(?:[^{refused}]|[{LINE_BREAKS}])"
        if self.needs_text:
            return f"^{allowed}*[^\\s{refused}]{allowed}*$"
        return f"^{allowed}*$"

    def __get_pydantic_core_schema__(self, source: Any, handler: GetCoreSchemaHandler) -> core_schema.CoreSchema:
        """The string's own schema, then the check and the normalisation."""
        return core_schema.no_info_after_validator_function(self._check, handler(source))

    def __get_pydantic_json_schema__(self, schema: core_schema.CoreSchema,
                                     handler: GetJsonSchemaHandler) -> JsonSchemaValue:
        """The string's JSON Schema with the pattern."""
        return handler(schema) | {"pattern": self.pattern()}

    def _check(self, value: str) -> str:
        for i, ch in enumerate(value):
            if unicodedata.category(ch) == "Cc" and not (self.multiline and ch in LINE_BREAKS):
                named = f"{CONTROL_NAMES[ord(ch)]}, " if ord(ch) in CONTROL_NAMES else ""
                raise PydanticCustomError("value_error", f"must not contain control characters ({named}"
                                                         f"U+{ord(ch):04X}, at character {i + 1}): text only")
            if ord(ch) in BIDI_NAMES:
                raise PydanticCustomError("value_error", f"must not contain bidirectional controls "
                                                         f"({BIDI_NAMES[ord(ch)]}, U+{ord(ch):04X}, at character "
                                                         f"{i + 1}): they reorder what a reader sees")
        return unicodedata.normalize("NFC", value)


def text_keys(schema: JsonSchemaValue) -> None:
    """The JSON Schema of an object whose keys are :class:`NoNul` text: the pattern under ``propertyNames``.

    (Pydantic writes a key's pattern as ``patternProperties``, which leaves other keys unconstrained.)
    """
    if "patternProperties" in schema:
        ((pattern, values),) = schema.pop("patternProperties").items()
        schema["additionalProperties"] = values
        schema["propertyNames"] = schema.get("propertyNames", {}) | {"pattern": pattern}


MAX_LIST_ITEMS = 1000
"""Most items of a list or event-list parameter's value in a body (a parameter's own ``max_items`` may be fewer)."""
MAX_EVENT_FIELDS = 32
"""Most fields of one event of an event-list parameter in a body."""


def _sequence_schema(parameter: Any) -> JsonSchemaValue:
    """A ``list`` or ``events`` parameter's value: a JSON array of numbers, or of objects of its fields."""
    if parameter.kind == "list":
        item_kind = parameter.item_kind or "float"
        items: JsonSchemaValue = {"type": "integer" if item_kind == "int" else "number"}
        items |= {k: v for k, v in (("minimum", parameter.minimum), ("maximum", parameter.maximum)) if v is not None}
    else:
        items = {"type": "object", "additionalProperties": False,
                 "properties": {f.name: _parameter_schema(f) for f in parameter.fields},
                 "required": [f.name for f in parameter.fields if f.default is None and not f.nullable]}
        if not items["required"]:
            del items["required"]
    most = MAX_LIST_ITEMS if parameter.max_items is None else min(parameter.max_items, MAX_LIST_ITEMS)
    return {"type": "array", "items": items, "minItems": parameter.min_items, "maxItems": most,
            "description": parameter.help}


def _parameter_schema(parameter: Any) -> JsonSchemaValue:
    """One parameter's value as the core reads it: its kind and limits, or text (``"0.5"``, ``"on"``)."""
    text = {"type": "string", "maxLength": 64, "pattern": NO_NUL_PATTERN}
    if parameter.kind in ("list", "events"):
        return _sequence_schema(parameter)
    if parameter.kind == "choice":
        branches: list[JsonSchemaValue] = [{"type": "string", "enum": list(parameter.choices)}]
    elif parameter.kind == "bool":
        branches = [{"type": "boolean"}, {"type": "integer", "enum": [0, 1]}, text]
    else:
        low = "exclusiveMinimum" if parameter.exclusive_minimum else "minimum"
        branches = [{"type": "integer" if parameter.kind == "int" else "number", low: parameter.minimum,
                     "maximum": parameter.maximum}, text]
    if parameter.nullable:
        branches += [{"type": "null"}] + ([text] if text not in branches else [])
    return {"anyOf": branches, "description": parameter.help} if len(branches) > 1 else branches[0]


def parameters_schema(schema: JsonSchemaValue) -> None:
    """``params`` in the OpenAPI document: every parameter of the schema (``GET /api/systems``) by name.

    Numbers may come as text too, as on the command line; text that is not one answers 422 (the
    core's check, naming the parameter), like a value another parameter's limit refuses (e.g.
    ``types_per_composite`` above ``n_types``).
    """
    described = {key: schema[key] for key in ("title", "description") if key in schema}
    schema.clear()
    schema.update(described, type="object", additionalProperties=False,
                  properties={p.name: _parameter_schema(p) for p in PARAMETERS})


Text = Annotated[str, NoNul()]
"""Any text that comes in (a query parameter, a key or a string of a body)."""
Tag = Annotated[str, StringConstraints(strip_whitespace=True, min_length=1, max_length=MAX_TAG),
                Printable(needs_text=True)]
"""A tag: NFC, no control character, stripped of white space and then not empty (the schema's pattern says so)."""
Name = Annotated[str, StringConstraints(strip_whitespace=True, max_length=MAX_NAME), Printable()]
"""A job's, study's or run's name, a saved system's description: one line of text, NFC, stripped."""
Notes = Annotated[str, StringConstraints(max_length=MAX_NOTES), Printable(multiline=True)]
"""Notes: text of several lines (tabs and line breaks kept), NFC."""
Label = Annotated[str, StringConstraints(min_length=1, max_length=MAX_LABEL), NoNul()]
ParamName = Annotated[str, StringConstraints(max_length=64), NoNul()]


def _whole(value: Any) -> Any:
    """An integral number written with a fraction (``3.0``, an integer to JSON Schema) as the integer it is."""
    return int(value) if type(value) is float and value.is_integer() else value


WholeNumber = Annotated[StrictInt, BeforeValidator(_whole)]
"""A JSON integer: ``3`` or ``3.0``; not ``3.5``, ``"3"`` or ``true``."""


def whole(low: int, high: int) -> Any:
    """A :data:`WholeNumber` in [low, high], the bounds published as JSON Schema's ``minimum`` and ``maximum``.

    The bounds go inside the validator that turns ``3.0`` into ``3``: put after it (``Annotated[WholeNumber,
    Field(ge=..)]``), pydantic still checks them but writes them into the OpenAPI document as ``ge`` and ``le``,
    which no JSON Schema reader knows, so clients and Schemathesis would see an unbounded integer.
    """
    return Annotated[StrictInt, Field(ge=low, le=high), BeforeValidator(_whole)]


Seed = whole(0, MAX_SEED_VALUE)
SeedCount = whole(1, MAX_SEEDS)
SeedList = Annotated[list[Seed], Field(min_length=1, max_length=MAX_SEEDS)]
ScalarValue = StrictBool | StrictInt | float | ParamName | None


def _at_most(limit: int, what: str) -> Any:
    def check(value: Any) -> Any:
        if len(value) > limit:
            raise PydanticCustomError("value_error", f"must have at most {limit} {what} (got {len(value)})")
        return value
    return AfterValidator(check)


Event = Annotated[dict[ParamName, ScalarValue], _at_most(MAX_EVENT_FIELDS, "fields")]
ListValue = Annotated[list[StrictBool | StrictInt | float | ParamName | Event], _at_most(MAX_LIST_ITEMS, "items")]
"""A list or event-list parameter's value (the core checks it against the parameter's own schema)."""
ParamValue = ScalarValue | ListValue
Params = Annotated[dict[ParamName, ParamValue], Field(max_length=len(PARAMETERS), json_schema_extra=parameters_schema)]
_PRESET_SCHEMA = {"type": "string", "enum": list(PRESETS)}
JobSystem = Annotated[Label, WithJsonSchema({
    "anyOf": [_PRESET_SCHEMA, {"type": "string", "pattern": SAVED_NAME_PATTERN}],
    "description": "A preset, or a saved system's name (GET /api/systems/saved)."})]
"""A job's system: a preset or a saved system's name, checked by the route (422 naming the presets otherwise)."""
PresetSystem = Annotated[Label, WithJsonSchema(_PRESET_SCHEMA | {"description": "A preset (GET /api/systems)."})]
"""A preset's name, checked by the core (422 naming the presets otherwise)."""
Status = Literal["queued", "running", "succeeded", "failed", "cancelled", "open"]
Kind = Literal["simulation", "external"]
Sort = Literal["-created_at", "created_at", "name", "-name", "status", "-status"]


class UntilBody(BaseModel):
    """A job's stopping rule (docs/statistics.md "Seeds until decided"), checked again by the core."""

    model_config = ConfigDict(extra="forbid")

    half_width: Annotated[float, Field(gt=0, le=sequential.MAX_HALF_WIDTH)] | None = Field(
        None, description="The 95% interval's half width to reach; with decide, the margin of no practical difference.")
    of: Literal[sequential.OF] = Field("pct_from_uniform", description="What is judged (pct_from_uniform needs "
                                                                      "uniform among the algorithms).")
    max_seeds: whole(sequential.MIN_SEEDS, MAX_SEEDS) = Field(sequential.DEFAULT_MAX_SEEDS,
                                                               description="The most seeds run.")
    block: whole(1, MAX_SEEDS) = Field(sequential.DEFAULT_BLOCK, description="Seeds run between two checks.")
    decide: Annotated[list[Label], Field(min_length=2, max_length=2)] | None = Field(
        None, description="Two of the job's algorithms: stop when their paired difference is decided.")
    judge: Annotated[list[Label], Field(max_length=MAX_ALGORITHMS)] | None = Field(
        None, description="The half_width rule's configurations: whose intervals must be narrow (default: every "
                          "algorithm but uniform and the oracle).")
    joint: StrictBool = Field(False, description="The half_width rule's intervals hold jointly: each at level "
                                                 "1 - 0.05/k for k judged (Bonferroni), not 95% each.")


class JobCreate(BaseModel):
    """Body of ``POST /api/jobs``: what to run (validated again by the core) and how to label it."""

    model_config = ConfigDict(extra="forbid")

    system: JobSystem
    algorithms: Annotated[list[Label], Field(min_length=1, max_length=MAX_ALGORITHMS)] | None = None
    seeds: SeedCount | SeedList = 30
    until: UntilBody | None = Field(None, description="Run seeds in blocks from first_seed until the rule answers "
                                                      "(instead of seeds).")
    first_seed: Seed | None = Field(None, description="With until: the first seed (default 0).")
    episodes: whole(1, MAX_EPISODES) = 100
    params: Params = Field(default_factory=dict)
    name: Name = ""
    tags: Annotated[list[Tag], Field(max_length=MAX_TAGS)] = Field(default_factory=list)
    notes: Notes = ""


MAX_BATCH_JOBS = 200
"""Jobs of one ``POST /api/jobs/batch`` at most (the body limit, ``MGRAO_MAX_BODY_BYTES``, holds too)."""


class JobBatchCreate(BaseModel):
    """Body of ``POST /api/jobs/batch``: many jobs, each as ``POST /api/jobs`` takes it, queued in one transaction."""

    model_config = ConfigDict(extra="forbid")

    jobs: Annotated[list[JobCreate], Field(min_length=1, max_length=MAX_BATCH_JOBS)]


class JobPatch(BaseModel):
    """Body of ``PATCH /api/jobs/{id}``: any of the labels."""

    model_config = ConfigDict(extra="forbid")

    name: Name | None = None
    tags: Annotated[list[Tag], Field(max_length=MAX_TAGS)] | None = None
    notes: Notes | None = None


Number = float | None
"""A number of the results: null where the stored value is not finite."""
Rate = Annotated[float, Field(ge=0, le=1)]
"""A share in [0, 1], never null."""


class Summary(BaseModel):
    """A configuration's summary over its seeds (docs/statistics.md, "Pairing")."""

    algorithm: str
    n_runs: int = Field(description="Seeds of the configuration: the final mean and its interval.")
    final_mean: Number
    ci95: list[Number] | None
    pct_from_uniform: Number
    pct_ci95: list[Number] | None
    pct_of_max: Number
    n_paired: int | None = Field(None, description="Seeds it shares with uniform (positive utility): the % from "
                                                   "uniform and its interval.")
    n_paired_max: int | None = Field(None, description="Seeds it shares with uniform and mgrao-max: the % of max.")
    partial: bool | None = Field(None, description="Only some of its seeds pair with uniform (0 < n_paired < "
                                                   "n_runs).")
    failure_rate: Rate = Field(description="Share of its atomic tasks that failed (task_need), pooled over its "
                                           "seeds: failed / allocated; 0 where no task can fail or for runs logged "
                                           "from outside.")
    handover_rate: Rate = Field(description="Share of its atomic tasks a neighbouring child completed (hierarchy: "
                                            "borrow or hand-over), pooled over its seeds: handed over / allocated; "
                                            "0 where no task can fail or for runs logged from outside.")


class JobOut(BaseModel):
    """A job as the API shows it."""

    id: int
    name: str
    tags: list[str]
    notes: str
    system: str
    algorithms: list[str]
    seeds: list[int]
    episodes: int
    params: dict[str, Any]
    config_hash: str
    status: Status
    progress: float
    attempts: int
    error: str | None
    requeue_reason: str | None = None
    """Why the job was last put back in the queue (its worker stopped sending heartbeats), or null."""
    created_at: str
    started_at: str | None
    finished_at: str | None
    duration_s: float | None
    queued_s: float | None = Field(None, description="Seconds from its submission to its (last) start: waiting in "
                                                     "the queue, for a free or warmed-up worker.")
    compile_s: float | None = Field(None, description="Seconds of its run spent compiling the engine for it (a "
                                                      "combination met for the first time); null: none.")
    compiling: dict[str, Any] | None = Field(None, description="While its worker compiles the engine for it: "
                                                               "message, parts, estimate_s, since; else null.")
    version: str
    study_id: int | None = None
    trial_id: int | None = None
    kind: Kind = "simulation"
    saved_system: str | None = Field(None, description="The saved system the job ran (its tag system:NAME names it); "
                                                     "`system` is its base preset. Null for a preset's job.")
    """``simulation`` (run by the service's workers) or ``external`` (logged from outside: docs/platform.md)."""
    until: dict[str, Any] | None = None
    """The job's stopping rule (every field), or null."""
    stopped: dict[str, Any] | None = None
    """With a rule: its last verdict (reason null while it runs; half_width, decided, max_seeds or cancelled), seeds,
    intervals, outcome, and blocks (every block's intervals); null without one."""
    summaries: dict[str, Summary] = {}
    """Per configuration, once the job succeeded (``GET /api/jobs`` and ``GET /api/jobs/{id}``): n_runs,
    final_mean, ci95, pct_from_uniform, pct_ci95, pct_of_max, failure_rate, handover_rate."""


class JobPage(BaseModel):
    """One page of ``GET /api/jobs``."""

    data: list[JobOut]
    next_cursor: str | None
    count: int


class JobBatch(BaseModel):
    """The answer of ``POST /api/jobs/batch``: the queued jobs, in the order submitted."""

    data: list[JobOut]
    count: int


class Health(BaseModel):
    """``GET /api/health``."""

    status: str
    version: str
    database: str
    queued: int | None
    """Jobs queued; null when the database cannot be read (a 503)."""
    running: int | None
    """Jobs running; null when the database cannot be read (a 503)."""
    workers: dict[str, int] | None = None


# ---- studies (docs/studies.md): the shape and the bounds; mgrao_core.search.make_plan checks the rest ----------

Preset = Literal[tuple(PRESETS)]  # type: ignore[valid-type]
SavedName = Annotated[str, StringConstraints(pattern=SAVED_NAME_PATTERN)]
"""A saved system's name (``/api/systems/saved``); which exist is known only to the service (else 422)."""
Unset = Field(default=None, json_schema_extra=lambda schema: schema.pop("default", None))
"""An optional field without a default of its own: left out, the core's default applies (null is refused)."""
MAX_STUDY_SYSTEMS = 16
"""Most systems (presets and saved systems) in one study's ``base.system`` list."""
SpaceName = Annotated[str, StringConstraints(max_length=64), NoNul()]


def _space_names(schema: JsonSchemaValue) -> None:
    """A study's space: keyed by a parameter of the schema, ``groups`` or ``team_size`` (the core names others)."""
    text_keys(schema)
    swept = [p.name for p in PARAMETERS if p.kind not in ("list", "events")]  # a list is held fixed in base
    schema["propertyNames"] = {"enum": [*swept, *search.LABEL_DIMENSIONS]}


class StudyBase(BaseModel):
    """``base`` of a study: the experiment every trial runs (``first_seed``: seeds F, F+1, ... for a count)."""

    model_config = ConfigDict(extra="forbid")

    system: Preset | SavedName | Annotated[list[Preset | SavedName],
                                           Field(min_length=1, max_length=MAX_STUDY_SYSTEMS)] = "single"
    algorithms: Annotated[list[Label], Field(min_length=1, max_length=MAX_ALGORITHMS)] | None = None
    seeds: SeedCount | SeedList = 10
    first_seed: Seed = 0
    episodes: whole(1, MAX_EPISODES) = 100
    params: Params = Field(default_factory=dict)
    until: UntilBody | None = Field(None, description="Every trial's jobs run seeds from first_seed until the rule "
                                                      "answers (instead of seeds).")


class StudyDimension(BaseModel):
    """One dimension of a study's space: ``values``, or a range ``low``, ``high`` (``steps`` on a grid, ``log``)."""

    model_config = ConfigDict(extra="forbid")

    values: Annotated[list[ScalarValue], Field(min_length=1, max_length=search.MAX_VALUES)] | SkipJsonSchema[None] \
        = Unset
    low: float | SkipJsonSchema[None] = Unset
    high: float | SkipJsonSchema[None] = Unset
    steps: whole(2, search.MAX_STEPS) | SkipJsonSchema[None] = Unset
    log: StrictBool = False


class StudyObjective(BaseModel):
    """``objective`` of a study: the metric of a configuration (of a system), and its direction."""

    model_config = ConfigDict(extra="forbid")

    metric: Literal[search.METRICS]  # type: ignore[valid-type]
    configuration: Label | SkipJsonSchema[None] = Unset
    direction: Literal[search.DIRECTIONS] | SkipJsonSchema[None] = Unset  # type: ignore[valid-type]
    system: Preset | SavedName | SkipJsonSchema[None] = Unset


class StudyCreate(BaseModel):
    """Body of ``POST /api/studies`` (docs/studies.md, "The format")."""

    model_config = ConfigDict(extra="forbid")

    name: Name = ""
    method: Literal[search.METHODS] = "grid"  # type: ignore[valid-type]
    base: StudyBase
    space: Annotated[dict[SpaceName, StudyDimension],
                     Field(min_length=1, max_length=search.MAX_DIMENSIONS, json_schema_extra=_space_names)]
    objective: StudyObjective
    max_trials: whole(1, search.MAX_TRIALS) = 100
    max_in_flight: whole(1, search.MAX_IN_FLIGHT) = 4
    seed: whole(0, 2**32 - 1) = 0


# ---- runs logged from outside (docs/platform.md) ---------------------------------------------------------------

EXTERNAL_LABEL_PATTERN = "^[a-z][a-z0-9._-]{0,31}$"
"""An external run's label: 1-32 characters, a lowercase letter then lowercase letters, digits, ``.``, ``_``, ``-``
(and no built-in algorithm's label: the core's grammar, checked by the route)."""
BATCH_KEY_PATTERN = "^[A-Za-z0-9._:-]{1,64}$"
"""A client's key of a batch or of an opening: 1-64 letters, digits, ``.``, ``_``, ``:`` or ``-``."""
ExternalLabel = Annotated[str, StringConstraints(pattern=EXTERNAL_LABEL_PATTERN)]
ClientKey = Annotated[str, StringConstraints(pattern=BATCH_KEY_PATTERN)]
Utility = Annotated[float, Field(allow_inf_nan=False, strict=True)]
"""A utility or weight: a JSON number (an integer too), finite; not a string or a boolean that looks like one."""
EpisodeIndex = whole(0, MAX_EPISODES - 1)


class ExternalRunCreate(BaseModel):
    """Body of ``POST /api/external-runs``: a run's label, its world (as a job's) and its labels."""

    model_config = ConfigDict(extra="forbid")

    label: ExternalLabel = Field(description="The configuration's name beside the built-in ones (never a built-in "
                                             "algorithm's label: GET /api/algorithms).")
    system: PresetSystem
    params: Params = Field(default_factory=dict)
    seeds: SeedCount | SeedList = Field(description="A count S (seeds 0 .. S-1) or the list of seeds, as a job's.")
    episodes: whole(1, MAX_EPISODES)
    key: ClientKey | SkipJsonSchema[None] = Field(None, description="Opening again with the same key and definition "
                                                                    "answers the same run (200): resume after a crash.")
    name: Name = ""
    tags: Annotated[list[Tag], Field(max_length=MAX_TAGS)] = Field(default_factory=list)
    notes: Notes = ""


class UtilityPiece(BaseModel):
    """Episodes ``start .. start + len(values) - 1`` of one seed (a whole seed: start 0 and every episode)."""

    model_config = ConfigDict(extra="forbid")

    seed: Seed
    start: EpisodeIndex = 0
    values: Annotated[list[Utility], Field(min_length=1, max_length=MAX_PIECE_VALUES)]


class SeedWeightsIn(BaseModel):
    """One seed's final weights: per child (``n_children`` rows), its weight on each type (``n_types``)."""

    model_config = ConfigDict(extra="forbid")

    seed: Seed
    weights: Annotated[list[Annotated[list[Annotated[Utility, Field(ge=0)]],
                                      Field(min_length=1, max_length=int(PARAMETERS_BY_NAME["n_types"].maximum))]],
                       Field(min_length=1, max_length=int(PARAMETERS_BY_NAME["n_children"].maximum))]


class ExternalBatchIn(BaseModel):
    """Body of ``POST /api/external-runs/{id}/batches``: pieces of episode utilities, and seeds' final weights."""

    model_config = ConfigDict(extra="forbid")

    key: ClientKey = Field(description="The client's key of this batch: sent again (a retry), it stores nothing twice.")
    utilities: Annotated[list[UtilityPiece], Field(max_length=MAX_BATCH_ENTRIES)] = Field(default_factory=list)
    weights: Annotated[list[SeedWeightsIn], Field(max_length=MAX_BATCH_ENTRIES)] = Field(default_factory=list)


# ---- saved systems (issue 20, "Your own system") ---------------------------------------------------------------

class SavedSystemIn(BaseModel):
    """Body of ``POST /api/systems/saved`` (and of ``PUT``): a name, a base preset and its overrides.

    It is also the file ``mgrao systems export`` writes and the dashboard downloads.
    """

    model_config = ConfigDict(extra="forbid")

    name: SavedName = Field(description="1-32 characters: a lowercase letter, then lowercase letters, digits or "
                                        "'-'; no preset's name.")
    description: Name = ""
    base: Preset
    params: Params = Field(default_factory=dict)


class SavedSystemOut(BaseModel):
    """A saved system: its definition, its resolved parameters and its base preset's algorithms."""

    name: str
    description: str
    base: str
    params: dict[str, Any]
    resolved: dict[str, Any]
    algorithms: list[str]
