"""Seeds until decided: a stopping rule on an experiment, checked after each block of seeds.

A rule (:class:`Until`) states a question; :func:`run_until` runs the experiment's seeds in blocks from
its first seed, in order (common random numbers: every configuration of a block faces the same worlds),
and :func:`judge` asks after each block whether the question is answered. Two rules:

* **half_width** (``{"half_width": h}``): stop once the 95% interval of ``of`` of every configuration judged
  is at most ``h`` on each side. The configurations judged are ``judge`` (by default every one but uniform,
  the reference, and the oracle, a bound: :func:`default_judged`). Each interval covers its own truth 95% of
  the time; with ``joint`` every interval is at level ``1 - 0.05 / k`` for ``k`` judged (Bonferroni), so that
  all of them hold at once at least 95% of the time. The interval is the summary's Student-t interval over the seeds run
  (:func:`mgrao_core.statistics.summary.mean_ci95`): a fixed-width sequential interval in the manner of Chow and
  Robbins (1965), with Student's quantile and a minimum of :data:`MIN_SEEDS` seeds as its small-sample
  correction, looked at once per block. Its coverage at a data-dependent stop is not guaranteed in
  theory; it is measured (benchmarks/sequential_coverage.py, docs/statistics.md).
* **decide** (``{"decide": [A, B]}``, optionally ``half_width`` as the margin of "no practical
  difference"): stop once the paired difference ``A - B`` of ``of`` is decided: its interval excludes 0
  (``A`` or ``B`` is better), or lies within ``(-h, h)`` (equivalent). The interval is a confidence
  sequence (:mod:`mgrao_core.statistics.confidence_sequence`: Lai's sequential t, exact for normal data
  of unknown variance, asymptotically valid for others): valid however often it is looked at, so a
  decision taken at the first look that allows it keeps its 5% error; a t-interval looked at after every
  block would not (its false decisions grow with the looks).

Either rule stops at ``max_seeds`` seeds unanswered. ``of`` is ``pct_from_uniform`` (each seed's % from
uniform's run of the same seed; uniform must run, and is not judged itself) or ``final_utility``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from mgrao_core.algorithms import parse_algorithm
from mgrao_core.errors import ConfigError, raise_all
from mgrao_core.params import number_from_text
from mgrao_core.results import ExperimentResult
from mgrao_core.spec import MAX_SEED_VALUE, MAX_SEEDS, ExperimentSpec, make_spec
from mgrao_core.statistics.confidence_sequence import cs_half_width
from mgrao_core.statistics.scores import BEST_FIXED
from mgrao_core.statistics.student import CONFIDENCE, mean_interval
from mgrao_core.statistics.summary import BASELINE, final_utilities, paired_pct_from_uniform

OF = ("pct_from_uniform", "final_utility")
"""What a rule judges: each seed's % from uniform, or its final utility."""
MIN_SEEDS = 10
"""No rule stops before this many seeds."""
DEFAULT_BLOCK = 10
DEFAULT_MAX_SEEDS = 500
MAX_HALF_WIDTH = 1e6
FIELDS = ("half_width", "of", "max_seeds", "block", "decide", "judge", "joint")
NOT_JUDGED = (BASELINE, BEST_FIXED)
"""The configurations a half_width rule leaves out unless told: the reference and the bound."""
REASONS = ("half_width", "decided", "max_seeds", "cancelled")


@dataclass(frozen=True)
class Until:
    """A stopping rule (module docstring). ``decide`` None is the half_width rule."""

    half_width: float | None = None
    of: str = "pct_from_uniform"
    max_seeds: int = DEFAULT_MAX_SEEDS
    block: int = DEFAULT_BLOCK
    decide: tuple[str, str] | None = None
    judge: tuple[str, ...] = ()
    """The configurations the half_width rule judges (resolved: never empty for it; empty with ``decide``)."""
    joint: bool = False
    """Whether the half_width rule's intervals hold jointly (each at ``1 - 0.05 / k``) rather than one by one."""

    @property
    def level(self) -> float:
        """The level of each interval the rule judges: 95%, or Bonferroni's ``1 - 0.05 / k`` when joint."""
        return coverage_of(self.as_dict())["level"]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready, every field."""
        return {"half_width": self.half_width, "of": self.of, "max_seeds": self.max_seeds, "block": self.block,
                "decide": None if self.decide is None else list(self.decide), "judge": list(self.judge),
                "joint": self.joint}


def _whole(field: str, value: Any, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) \
            or value != int(value):
        raise ConfigError(field, f"must be a whole number between {low} and {high} (got {value!r})")
    if not low <= value <= high:
        raise ConfigError(field, f"must be between {low} and {high} (got {int(value)})")
    return int(value)


def make_until(data: Mapping[str, Any], algorithms: Sequence[str]) -> Until:
    """A validated rule for an experiment of ``algorithms`` (its labels).

    Raises:
        ConfigError: every field refused, each named ``until.<field>`` with its limit.
    """
    if not isinstance(data, Mapping):
        raise ConfigError("until", f"must be an object of {', '.join(FIELDS)} (got {type(data).__name__})")
    errors: list[ConfigError] = []

    def field(name: str, check: Callable[[], Any], default: Any = None) -> Any:
        if name not in data or data[name] is None:
            return default
        try:
            return check()
        except ConfigError as error:
            errors.append(error)
            return default

    errors += [ConfigError(f"until.{name}", f"is not a field of a rule (fields: {', '.join(FIELDS)})")
               for name in data if name not in FIELDS]
    half_width = field("half_width", lambda: _half_width(data["half_width"]))
    of = field("of", lambda: _of(data["of"]), OF[0])
    max_seeds = field("max_seeds", lambda: _whole("until.max_seeds", data["max_seeds"], MIN_SEEDS, MAX_SEEDS),
                      DEFAULT_MAX_SEEDS)
    block = field("block", lambda: _whole("until.block", data["block"], 1, MAX_SEEDS), DEFAULT_BLOCK)
    decide = field("decide", lambda: _pair(data["decide"], algorithms))
    asked = data.get("judge")
    judge = None if asked == [] and data.get("decide") is not None else field(  # a decide rule's own as_dict
        "judge", lambda: _judged(asked, algorithms, of))
    joint = field("joint", lambda: _flag("until.joint", data["joint"]), False)
    if data.get("decide") is not None and (judge or joint):
        errors.append(ConfigError("until.judge" if judge else "until.joint",
                                  "goes with the half_width rule: decide judges its own pair"))
    if block > max_seeds:
        errors.append(ConfigError("until.block", f"must be at most max_seeds, {max_seeds} (got {block})"))
    if decide is None and half_width is None and not any(e.field in ("until.half_width", "until.decide")
                                                         for e in errors):
        errors.append(ConfigError("until.half_width", "is needed unless the rule decides a pair (give half_width, "
                                                      "decide, or both)"))
    if of == "pct_from_uniform" and BASELINE not in algorithms:
        errors.append(ConfigError("until.of", f"pct_from_uniform needs {BASELINE} among the algorithms, or of "
                                              f"final_utility"))
    elif decide is None and of == "pct_from_uniform" and set(algorithms) <= {BASELINE}:
        errors.append(ConfigError("until", f"has nothing to judge: {BASELINE} is the baseline of % from uniform; "
                                           f"run another algorithm beside it"))
    raise_all(errors)
    if decide is None and not judge:
        judge = default_judged(algorithms, of)
    return Until(half_width, of, max_seeds, block, decide, tuple(judge or ()) if decide is None else (), joint)


def coverage_of(rule: Mapping[str, Any]) -> dict[str, Any]:
    """What a rule's intervals cover (``level`` of each, ``coverage``), from its dict (:meth:`Until.as_dict`).

    ``"each"``: each judged interval covers its own configuration's value at ``level`` (95%), not all at once;
    ``"joint"``: every one at ``1 - 0.05 / k`` for ``k`` judged, so that all hold at once at least 95% of the time;
    ``"pair"``: the decide rule's one confidence sequence.
    """
    if rule.get("decide") is not None:
        return {"level": CONFIDENCE, "coverage": "pair"}
    judged = len(rule.get("judge") or ())
    if rule.get("joint") and judged > 1:
        return {"level": 1.0 - (1.0 - CONFIDENCE) / judged, "coverage": "joint"}
    return {"level": CONFIDENCE, "coverage": "each"}


def default_judged(algorithms: Sequence[str], of: str) -> tuple[str, ...]:
    """The configurations a half_width rule judges unless told: every one but uniform and the oracle.

    Uniform is the reference (its % from uniform is 0) and the oracle a bound, not a configuration one asks
    about; where nothing else runs, every configuration the rule can judge (not uniform's % from uniform).
    """
    asked = tuple(a for a in algorithms if a not in NOT_JUDGED)
    if asked:
        return asked
    return tuple(a for a in algorithms if not (of == "pct_from_uniform" and a == BASELINE))


def until_spec(system: str, algorithms: Sequence[str] | None, first_seed: int, episodes: int,
               overrides: Mapping[str, Any], rule: Mapping[str, Any],
               memory_budget: int | None = None) -> tuple[ExperimentSpec, Until]:
    """The spec of a rule's largest run (``max_seeds`` seeds from ``first_seed``) and the rule, both validated.

    What ``mgrao run --until`` and a job with ``until`` run (:func:`run_until`).

    Raises:
        ConfigError: naming the field (``until.<field>`` for the rule's), as :func:`mgrao_core.make_spec` and
            :func:`make_until`; WorkLimitError as :func:`mgrao_core.make_spec`, for ``max_seeds`` seeds.
    """
    budget = {} if memory_budget is None else {"memory_budget": memory_budget}
    probe = make_spec(system, algorithms, [first_seed], episodes, overrides, **budget)
    until = make_until(rule, probe.algorithms)
    if first_seed + until.max_seeds - 1 > MAX_SEED_VALUE:
        raise ConfigError("until.max_seeds", f"the last seed {first_seed + until.max_seeds - 1} would be over "
                                             f"{MAX_SEED_VALUE}: lower max_seeds or the first seed")
    seeds = list(range(first_seed, first_seed + until.max_seeds))
    return make_spec(system, algorithms, seeds, episodes, overrides, **budget), until


def _half_width(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value <= MAX_HALF_WIDTH:
        raise ConfigError("until.half_width", f"must be a number above 0 and at most {MAX_HALF_WIDTH:g} "
                                              f"(got {value!r})")
    return float(value)


def _of(value: Any) -> str:
    if value not in OF:
        raise ConfigError("until.of", f"must be one of {', '.join(OF)} (got {value!r})")
    return value


def _canonical(field: str, value: Any, algorithms: Sequence[str]) -> list[str]:
    """Labels of the algorithms run, in their canonical spelling (``mgrao-01:1`` is ``mgrao-1:1``)."""
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise ConfigError(field, f"must be a list of the algorithms run (got {value!r})")
    labels, missing = [], []
    for label in value:
        try:
            canonical = parse_algorithm(label, None, field).label
        except ConfigError:
            canonical = label
        if canonical in algorithms:
            labels.append(canonical)
        else:
            missing.append(label)
    if missing:
        raise ConfigError(field, f"{', '.join(map(str, missing))}: not run by this experiment (algorithms: "
                                 f"{', '.join(algorithms)})")
    return labels


def _pair(value: Any, algorithms: Sequence[str]) -> tuple[str, str]:
    if isinstance(value, str) or not isinstance(value, Sequence) or len(value) != 2:
        raise ConfigError("until.decide", f"must be two of the algorithms run (got {value!r})")
    a, b = _canonical("until.decide", value, algorithms)
    if a == b:
        raise ConfigError("until.decide", f"must be two different algorithms (got {a} twice)")
    return a, b


def _judged(value: Any, algorithms: Sequence[str], of: str) -> tuple[str, ...]:
    labels = _canonical("until.judge", value, algorithms)
    if not labels:
        raise ConfigError("until.judge", "must name at least one of the algorithms run (omit it to judge every one "
                                         "but uniform and the oracle)")
    if len(set(labels)) < len(labels):
        raise ConfigError("until.judge", f"names an algorithm twice (got {', '.join(labels)})")
    if of == "pct_from_uniform" and BASELINE in labels:
        raise ConfigError("until.judge", f"{BASELINE} is the baseline of % from uniform (0 on every seed): judge "
                                         "other configurations, or of final_utility")
    return tuple(labels)


def _flag(field: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(field, f"must be true or false (got {value!r})")
    return value


def parse_until(text: str) -> dict[str, Any]:
    """A rule from ``KEY=VALUE,...`` (the command line's ``--until``): ``decide=A+B``; numbers as numbers.

    Raises:
        ConfigError: an item without ``=``, or a number that is none (validated further by :func:`make_until`).
    """
    data: dict[str, Any] = {}
    for item in (part.strip() for part in text.split(",")):
        if not item:  # a trailing comma, or two in a row
            continue
        key, sep, value = item.partition("=")
        key, value = key.strip(), value.strip()
        if key in data:
            raise ConfigError(f"until.{key}", f"is given twice (got {item!r} after {key}={data[key]!r})")
        if not sep or not key:
            raise ConfigError("until", f"must be KEY=VALUE items between commas, e.g. half_width=2 or "
                                       f"decide=mgrao-5:1+mgrao-max (got {item!r})")
        if key in ("decide", "judge"):
            data[key] = [label.strip() for label in value.split("+")]
        elif key == "of":
            data[key] = value
        elif key == "joint":
            if value not in ("true", "false"):
                raise ConfigError("until.joint", f"must be true or false (got {value!r})")
            data[key] = value == "true"
        else:
            number = number_from_text(f"until.{key}", value)
            data[key] = int(number) if number.is_integer() and key != "half_width" else number
    return data


@dataclass(frozen=True)
class Verdict:
    """What the rule said after a block.

    Attributes:
        reason: one of :data:`REASONS`, or None to go on.
        seeds: seeds run so far.
        intervals: per configuration judged, ``(mean, low, high)`` of ``of`` over the seeds run (half_width
            rule: the t-intervals; decide rule: the pair's difference under its confidence sequence, keyed
            ``"A - B"``).
        outcome: with a decision, the better configuration, or ``"equivalent"``; else None.
    """

    reason: str | None
    seeds: int
    intervals: dict[str, tuple[float, float, float]]
    outcome: str | None = None
    level: float = CONFIDENCE
    """The level of each interval (Bonferroni's under a joint half_width rule: ``Until.level``, not stored)."""

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready (non-finite numbers as None)."""
        def clean(x: float) -> float | None:
            return x if math.isfinite(x) else None
        return {"reason": self.reason, "seeds": self.seeds, "outcome": self.outcome,
                "intervals": {k: [clean(v) for v in value] for k, value in self.intervals.items()}}


def judged_values(until: Until, finals: Mapping[str, Mapping[int, float]]) -> dict[str, dict[int, float]]:
    """Per configuration judged, each seed's value of ``until.of`` (% from uniform: the seeds it pairs with).

    The half_width rule's configurations (``until.judge``), or with ``decide`` every one but uniform's % from
    uniform (the pair is taken from them).
    """
    wanted = set(until.judge) if until.decide is None else set(finals)
    if until.of == "final_utility":
        return {label: dict(by_seed) for label, by_seed in finals.items() if label in wanted}
    base = finals.get(BASELINE)
    return {label: paired_pct_from_uniform(by_seed, base) for label, by_seed in finals.items()
            if label != BASELINE and label in wanted}


def judge(until: Until, finals: Mapping[str, Mapping[int, float]], seeds_run: int) -> Verdict:
    """The rule's verdict on the final utilities ``finals`` (label -> seed -> final) of ``seeds_run`` seeds."""
    values = judged_values(until, finals)
    done = seeds_run >= until.max_seeds
    if until.decide is None:
        intervals = {label: mean_interval(np.array(list(values[label].values())), until.level)
                     if values.get(label) else (math.nan,) * 3 for label in until.judge}
        judged = min((len(values.get(label, ())) for label in until.judge), default=0)  # % drops unpaired seeds
        narrow = judged >= MIN_SEEDS and all(high - low <= 2 * until.half_width
                                             for _, low, high in intervals.values())
        reason = "half_width" if narrow else "max_seeds" if done else None
        return Verdict(reason, seeds_run, intervals, level=until.level)
    a, b = until.decide
    if until.of == "pct_from_uniform" and BASELINE in until.decide:  # uniform's % is 0 on every seed it pairs with
        values[BASELINE] = {seed: 0.0 for seed in values[b if a == BASELINE else a]}
    common = sorted(set(values[a]) & set(values[b]))
    differences = np.array([values[a][s] - values[b][s] for s in common])
    key = f"{a} - {b}"
    if differences.size < 2:
        return Verdict("max_seeds" if done else None, seeds_run, {key: (math.nan,) * 3})
    mean = float(differences.mean())
    half = cs_half_width(float(differences.std(ddof=1)), differences.size)
    interval = (mean, mean - half, mean + half)
    outcome = None
    if differences.size >= MIN_SEEDS:
        if interval[1] > 0 or interval[2] < 0:
            outcome = a if interval[1] > 0 else b
        elif until.half_width is not None and -until.half_width < interval[1] and interval[2] < until.half_width:
            outcome = "equivalent"
    reason = "decided" if outcome else "max_seeds" if done else None
    return Verdict(reason, seeds_run, {key: interval}, outcome)


@dataclass(frozen=True)
class SequentialResult:
    """An experiment run until its rule answered: the runs, the verdict that stopped it, one per block."""

    result: ExperimentResult
    stopped: Verdict
    blocks: tuple[Verdict, ...]


def next_block(spec: ExperimentSpec, until: Until, judged: int) -> tuple[int, ...]:
    """The seeds of the block after ``judged`` seeds: the next ``block`` of ``spec``'s, up to ``max_seeds``."""
    return spec.seeds[judged : min(judged + until.block, until.max_seeds)]


def replay(spec: ExperimentSpec, until: Until, finals: Mapping[str, Mapping[int, float]]) -> tuple[Verdict, ...]:
    """The verdicts after each block of ``spec`` whose every run is among ``finals``, in order.

    A job resumed after its worker died judges its stored blocks again: the same numbers give the same
    verdicts, so it stops where it would have. Stops at the first verdict that stops; a block stored in part
    is not judged (its missing seeds run first).
    """
    verdicts: list[Verdict] = []
    judged = 0
    while not verdicts or verdicts[-1].reason is None:
        block = next_block(spec, until, judged)
        if not block or any(seed not in finals.get(label, {}) for label in spec.algorithms for seed in block):
            break
        judged += len(block)
        verdicts.append(judge_first(spec, until, finals, judged))
    return tuple(verdicts)


def judge_first(spec: ExperimentSpec, until: Until, finals: Mapping[str, Mapping[int, float]],
                judged: int) -> Verdict:
    """:func:`judge` of the first ``judged`` seeds of ``spec`` (``finals`` may hold more: a block stored in part)."""
    seeds = spec.seeds[:judged]
    return judge(until, {label: {s: finals[label][s] for s in seeds} for label in spec.algorithms}, judged)


def stopped_dict(verdicts: Sequence[Verdict], rule: Mapping[str, Any]) -> dict[str, Any]:
    """What a job says of its rule: the last verdict (none judged yet: reason null, 0 seeds) with ``blocks``.

    With what its intervals cover (:func:`coverage_of` of the rule's dict).
    """
    last = verdicts[-1] if verdicts else Verdict(None, 0, {})
    return last.as_dict() | coverage_of(rule) | {"blocks": [{"seeds": v.seeds, "intervals": v.as_dict()["intervals"]}
                                                            for v in verdicts]}


def run_until(spec: ExperimentSpec, until: Until, run_block: Callable[[ExperimentSpec], ExperimentResult],
              should_stop: Callable[[], bool] | None = None,
              on_block: Callable[[ExperimentResult, Verdict], None] | None = None) -> SequentialResult:
    """Run ``spec``'s configurations on blocks of seeds from its first seed until ``until`` answers.

    Args:
        spec: the experiment over ``until.max_seeds`` seeds from its first (validated so by
            :func:`mgrao_core.make_spec`: every block is a part of it); its seeds run in that order.
        until: the rule (:func:`make_until`).
        run_block: runs one block's spec (:func:`mgrao_core.run_experiment`).
        should_stop: polled between blocks; True stops with reason ``cancelled``.
        on_block: called with each block's runs and the verdict after it.
    """
    if len(spec.seeds) != until.max_seeds:
        raise ValueError(f"the spec runs {len(spec.seeds)} seeds, the rule's max_seeds is {until.max_seeds}")
    runs: list = []
    finals: dict[str, dict[int, float]] = {label: {} for label in spec.algorithms}
    blocks: list[Verdict] = []
    verdict = Verdict(None, 0, {})
    while verdict.reason is None:
        if should_stop is not None and should_stop():
            verdict = Verdict("cancelled", verdict.seeds, verdict.intervals, verdict.outcome, verdict.level)
            break
        seeds = next_block(spec, until, verdict.seeds)
        result = run_block(replace(spec, seeds=tuple(seeds)))
        runs += result.runs
        for run in result.runs:
            finals[run.algorithm][run.seed] = float(final_utilities(run.utilities[None])[0])
        verdict = judge(until, finals, verdict.seeds + len(seeds))
        blocks.append(verdict)
        if on_block is not None:
            on_block(result, verdict)
    whole = replace(spec, seeds=spec.seeds[: verdict.seeds])
    order = {label: i for i, label in enumerate(spec.algorithms)}
    runs.sort(key=lambda run: (order[run.algorithm], run.seed))
    return SequentialResult(ExperimentResult(whole, tuple(runs)), verdict, tuple(blocks))
