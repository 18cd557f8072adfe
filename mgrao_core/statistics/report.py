"""A comparison's statistics (:func:`mgrao_core.statistics.comparison.compare`) as a text table, a numeric CSV or LaTeX.

One home for what ``mgrao compare`` prints and what the dashboard offers to download: per system and
configuration ``n_paired``, the final mean and % from uniform with their 95% intervals, then the aggregates over
systems with their bootstrap intervals; the protocol (seeds, episodes, final window, interval method, bootstrap
repetitions) in the CSV's ``#`` header lines and the LaTeX caption. CSV cells are numbers (units in the column
names); LaTeX is a ``table`` holding two ``tabular`` environments, with booktabs rules.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping, Sequence
from typing import Any

from mgrao_core.statistics.metrics import AGGREGATES

FORMATS = ("table", "csv", "latex", "json")
"""What a comparison's statistics can be rendered as (``json`` is the answer itself)."""
_TITLES = {"mean": "Mean", "median": "Median", "iqm": "IQM", "optimality_gap": "Optimality gap"}


def text_table(headers: Sequence[str], rows: Sequence[Sequence[str]], text_columns: int = 1) -> str:
    """Columns padded to their widest cell: the first ``text_columns`` (names) left-aligned, the numbers right."""
    widths = [max([len(h), *(len(r[i]) for r in rows)]) for i, h in enumerate(headers)]
    line = "  ".join(h.ljust(w) for h, w in zip(headers, widths, strict=True))
    body = ["  ".join(c.rjust(w) if i >= text_columns else c.ljust(w)
                      for i, (c, w) in enumerate(zip(r, widths, strict=True))) for r in rows]
    return "\n".join([line, "-" * len(line), *body])


def _fixed(value: float, digits: int) -> str:
    """``value`` to ``digits`` decimals, a rounding residue (``-1e-17``) as the zero it is."""
    return f"{0.0 if abs(value) < 0.5 * 10**-digits else value:.{digits}f}"


def deciding_digits(interval: Sequence[float | None] | None, value: float | None, digits: int = 1,
                    most: int = 4) -> int:
    """The one rounding rule of an interval shown against a figure it is judged by (the paper's % from uniform).

    The decimals at which the interval's ends and ``value`` read as on the side of it that ``value`` is: ``digits``
    unless rounding hides the verdict (the paper's 28.0 outside [23.28, 27.99] would read as its end at one
    decimal), then as many as tell them apart, at most ``most``. The dashboard's ``decidingDigits``
    (frontend/js/stats.js) is the same rule.

    Args:
        interval: the interval's ends (``None`` or a missing end: ``digits``).
        value: the figure judged against it (``None``: ``digits``).
        digits: the decimals shown when they suffice.
        most: the decimals shown at most.

    Returns:
        The decimals to write both with.
    """
    if (not interval or value is None or any(v is None or not math.isfinite(v) for v in interval)
            or not math.isfinite(value)):
        return digits
    low, high = interval
    outside = value < low or value > high
    for d in range(digits, most):
        at = [float(f"{x:.{d}f}") for x in (value, low, high)]
        if (at[0] < at[1] or at[0] > at[2]) == outside:
            return d
    return most


def _number(value: float | None, digits: int) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return _fixed(value, digits)


def _interval(pair: Sequence[float | None] | None, digits: int) -> str:
    if not pair or any(v is None for v in pair):
        return "-"
    return f"[{_fixed(pair[0], digits)}, {_fixed(pair[1], digits)}]"


def _seed_ranges(seeds: Sequence[int]) -> str:
    """``0-19, 40, 50-59``: consecutive seeds as ranges."""
    parts, start, previous = [], None, None
    for seed in sorted(seeds):
        if start is None:
            start = previous = seed
        elif seed == previous + 1:
            previous = seed
        else:
            parts.append(f"{start}-{previous}" if previous > start else f"{start}")
            start = previous = seed
    if start is not None:
        parts.append(f"{start}-{previous}" if previous > start else f"{start}")
    return ", ".join(parts) or "none"


def protocol_lines(answer: Mapping[str, Any]) -> list[str]:
    """The protocol as sentences, one a line: per system its episodes and seeds, then the methods."""
    p = answer["protocol"]
    lines = [f"{name}: {p['episodes'][name]} episodes, seeds {_seed_ranges(p['seeds'][name])}."
             for name in p["episodes"]]
    aggregated = answer["aggregated"]
    if aggregated["systems"]:
        lines.append(f"Aggregates over {len(aggregated['systems'])} system(s), each on its anchor seeds ("
                     + "; ".join(f"{s}: {aggregated['n_seeds'][s]} seeds, {_seed_ranges(aggregated['seeds'][s])}"
                                 for s in aggregated["systems"])
                     + f"); {aggregated['weighting']}.")
        for system, labels in (aggregated.get("left_out") or {}).items():
            for label, out in labels.items():
                lines.append(f"{system}, {label}: seeds {_seed_ranges(out['seeds'])} not scored ({out['reason']}).")
    elif aggregated.get("reason"):
        lines.append(f"No aggregates: {aggregated['reason']}")
    for name, anchors in answer["normalisation"].items():
        if anchors["reason"]:
            lines.append(f"{name} has no scores: {anchors['reason']}.")
        elif anchors["caveats"]:
            lines.append(f"On {name} the oracle is no upper bound (scores above 1 are possible): "
                         f"{'; '.join(anchors['caveats'])}.")
    for c in answer.get("configurations", []):
        if c.get("mismatched_seeds"):
            lines.append(f"{c['system']}, {c['label']}: the pooled jobs' runs of seeds "
                         f"{_seed_ranges(c['mismatched_seeds'])} differ (the first job's are used).")
    for name, labels in (answer.get("non_finite") or {}).items():
        for label, seeds in labels.items():
            lines.append(f"{name}, {label}: seeds {_seed_ranges(seeds)} left out (final utility not finite).")
    bootstrap = p["bootstrap"]
    lines += [f"Final utility: {p['final']}.", f"Score: {p['score']}.", f"Intervals: {p['interval']}.",
              f"Bootstrap: {bootstrap['repetitions']:,} repetitions, seed {bootstrap['seed']}, {bootstrap['method']} "
              f"method, resampling {bootstrap['resampling']}.", f"Test: {p['test']}."]
    return lines


def _rows(answer: Mapping[str, Any]) -> list[tuple[str, str, Mapping[str, Any]]]:
    return [(system, label, s) for system, configs in answer["systems"].items() for label, s in configs.items()]


def table(answer: Mapping[str, Any]) -> str:
    """Text tables for a terminal: per system, then the aggregates, then the protocol."""
    rows = [[system, label + (" *" if s.get("partial") else ""), str(s["n_runs"]), str(s["n_paired"]),
             _number(s["final_mean"], 3), _interval(s["ci95"], 3), _number(s["pct_from_uniform"], 1),
             _interval(s["pct_ci95"], 1)] for system, label, s in _rows(answer)]
    out = [text_table(["system", "configuration", "runs", "paired", "final mean", "95% CI", "% from uniform",
                       "95% CI"], rows, text_columns=2)]
    if any(s.get("partial") for _, _, s in _rows(answer)):
        out.append("* only some of its seeds pair with uniform: its % from uniform stands on n_paired seeds")
    if answer["aggregate"]:
        aggregate_rows = [[label, *(f"{_number(a[m]['estimate'], 3)} {_interval(a[m]['ci95'], 3)}"
                                    for m in AGGREGATES)] for label, a in answer["aggregate"].items()]
        out += ["", "Aggregates of scores (share of the oracle's gain over uniform), 95% bootstrap intervals",
                text_table(["configuration", *(_TITLES[m] for m in AGGREGATES)], aggregate_rows)]
    excluded = answer["aggregated"].get("excluded") or {}
    out += [f"not aggregated: {label}: {reason}" for label, reason in excluded.items()]
    out += ["", *protocol_lines(answer)]
    return "\n".join(out) + "\n"


CSV_COLUMNS = ("system", "configuration", "n_runs", "n_paired", "final_mean_utility", "final_ci95_low_utility",
               "final_ci95_high_utility", "pct_from_uniform_percent", "pct_ci95_low_percent", "pct_ci95_high_percent",
               "pct_of_max_percent", *(f"{m}_{part}_score" for m in AGGREGATES for part in ("estimate", "ci95_low",
                                                                                              "ci95_high")))
"""The CSV's columns: a row per system and configuration fills the first eleven; a row per configuration with
``system`` ``aggregate`` fills ``configuration`` and the aggregates' (scores: shares of the oracle's gain)."""


def _cell(value: Any) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return ""
    return repr(float(value)) if isinstance(value, float) else str(value)


def csv_text(answer: Mapping[str, Any]) -> str:
    """A numeric CSV: ``#`` lines of protocol, a header, a row per system and configuration, a row per aggregate."""
    buffer = io.StringIO()
    for line in protocol_lines(answer):
        buffer.write(f"# {line}\n")
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    for system, label, s in _rows(answer):
        ci = s["ci95"] or [None, None]
        pct = s["pct_ci95"] or [None, None]
        writer.writerow([system, label, s["n_runs"], s["n_paired"], *map(_cell, (s["final_mean"], *ci,
                         s["pct_from_uniform"], *pct, s["pct_of_max"])), *([""] * (3 * len(AGGREGATES)))])
    for label, a in answer["aggregate"].items():
        cells = [_cell(v) for m in AGGREGATES for v in (a[m]["estimate"], *a[m]["ci95"])]
        writer.writerow(["aggregate", label, "", "", *([""] * 7), *cells])
    return buffer.getvalue()


_LATEX_SPECIALS = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_",
                   "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}", "^": r"\textasciicircum{}",
                   "<": r"\textless{}", ">": r"\textgreater{}"}


def latex_escape(text: str) -> str:
    """``text`` with LaTeX's special characters escaped."""
    return "".join(_LATEX_SPECIALS.get(ch, ch) for ch in str(text))


def _latex_interval(value: float | None, pair: Sequence[float | None] | None, digits: int) -> str:
    if value is None:
        return "--"
    if not pair or any(v is None for v in pair):
        return _fixed(value, digits)
    return f"{_fixed(value, digits)} {_interval(pair, digits)}"


def latex(answer: Mapping[str, Any]) -> str:
    """A LaTeX ``table``: the protocol as its caption, a ``tabular`` per system and configuration, one of aggregates.

    The caption is the protocol's sentences, each on a line of its own in the source (a world's episodes and seeds
    one sentence per world), which LaTeX sets as one paragraph.
    """
    caption = "\n".join(latex_escape(line) for line in protocol_lines(answer))
    lines = ["% needs \\usepackage{booktabs}", "\\begin{table}", "\\centering",
             f"\\caption{{{caption}}}", "\\begin{tabular}{llrrll}", "\\toprule",
             "System & Configuration & Runs & Paired & Final mean [95\\% CI] & \\% from uniform [95\\% CI] \\\\",
             "\\midrule"]
    previous = None
    for system, label, s in _rows(answer):
        if previous is not None and system != previous:
            lines.append("\\midrule")
        mark = "$^{*}$" if s.get("partial") else ""
        lines.append(f"{latex_escape(system) if system != previous else ''} & {latex_escape(label)}{mark} & "
                     f"{s['n_runs']} & {s['n_paired']} & {_latex_interval(s['final_mean'], s['ci95'], 3)} & "
                     f"{_latex_interval(s['pct_from_uniform'], s['pct_ci95'], 1)} \\\\")
        previous = system
    lines += ["\\bottomrule", "\\end{tabular}"]
    if any(s.get("partial") for _, _, s in _rows(answer)):
        lines += ["", "$^{*}$ only some of its seeds pair with uniform: its \\% from uniform stands on the paired "
                      "seeds."]
    if answer["aggregate"]:
        lines += ["", "\\medskip", "", "\\begin{tabular}{l" + "l" * len(AGGREGATES) + "}", "\\toprule",
                  "Configuration & " + " & ".join(_TITLES[m] for m in AGGREGATES) + " \\\\", "\\midrule"]
        for label, a in answer["aggregate"].items():
            cells = " & ".join(_latex_interval(a[m]["estimate"], a[m]["ci95"], 3) for m in AGGREGATES)
            lines.append(f"{latex_escape(label)} & {cells} \\\\")
        lines += ["\\bottomrule", "\\end{tabular}"]
    lines.append("\\end{table}")
    return "\n".join(lines) + "\n"


def render(answer: Mapping[str, Any], fmt: str) -> str:
    """The answer as ``table``, ``csv`` or ``latex`` text."""
    return {"table": table, "csv": csv_text, "latex": latex}[fmt](answer)
