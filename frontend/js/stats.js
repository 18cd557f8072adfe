// Pure helpers: smoothing, series handling, formatting and URL/query parsing.
// No DOM access here, so that node's test runner can import this module directly.

/**
 * Centred moving average over episodes: each point becomes the mean of the finite values whose
 * episode lies within (window - 1) / 2 episodes of its own, on both sides, so the smoothed curve
 * neither lags nor steps. `x` are the points' episodes (ascending; a downsampled series has one point
 * per several episodes, and the window stays in episodes); near the ends the window is cut short.
 */
export function centredAverage(x, values, window) {
  const w = Math.max(1, Math.floor(Number(window) || 1));
  const n = values.length;
  const out = new Array(n);
  if (w === 1) {
    for (let i = 0; i < n; i++) out[i] = isFiniteNumber(values[i]) ? values[i] : null;
    return out;
  }
  const half = (w - 1) / 2;
  let lo = 0;
  let hi = 0; // the window is [lo, hi)
  let sum = 0;
  let count = 0;
  for (let i = 0; i < n; i++) {
    while (hi < n && x[hi] <= x[i] + half) {
      if (isFiniteNumber(values[hi])) { sum += values[hi]; count += 1; }
      hi += 1;
    }
    while (x[lo] < x[i] - half) {
      if (isFiniteNumber(values[lo])) { sum -= values[lo]; count -= 1; }
      lo += 1;
    }
    out[i] = count > 0 ? sum / count : null;
  }
  return out;
}

/** Episodes one plotted point stands for (1 unless the server downsampled the series). */
export function episodesPerPoint(episodes) {
  if (!episodes || episodes.length < 2) return 1;
  return Math.max(1, Math.round((episodes[episodes.length - 1] - episodes[0]) / (episodes.length - 1)));
}

/**
 * One line saying what the chart draws and its smoothing, in episodes, whatever the downsampling. `seeds`
 * (`{drawn, of}`: individual seeds drawn per configuration, of how many) when they are shown.
 */
export function smoothingNote(window, perPoint, bands = true, seeds = null) {
  const w = Math.max(1, Math.floor(Number(window) || 1));
  const points = perPoint > 1 ? ` Each plotted point is already the mean of ${perPoint} consecutive episodes.` : '';
  const mean = seeds ? 'Thick lines: mean over seeds' : 'Lines: mean over seeds';
  let lines = bands ? `${mean}; bands: its 95% interval.` : `${mean} (95% bands hidden).`;
  if (seeds) {
    lines += seeds.drawn < seeds.of
      ? ` Faint lines beneath: ${seeds.drawn} of each configuration’s ${seeds.of} seeds, spread evenly over them.`
      : ` Faint lines beneath: each of its ${seeds.of} ${seeds.of === 1 ? 'seed' : 'seeds'}.`;
  }
  if (w === 1) return `${lines} Not smoothed.${points}`;
  return `${lines} Smoothed with a centred mean over ${w} episodes ` +
    `(${(w - 1) / 2} before and after each${bands ? '; the band likewise' : ''}).${points}`;
}

export function isFiniteNumber(v) {
  return typeof v === 'number' && Number.isFinite(v);
}

/** Smooth a `{episode, mean, low, high}` series; the episode axis is kept as is. */
export function smoothSeries(series, window) {
  if (!series) return series;
  return {
    episode: series.episode.slice(),
    mean: centredAverage(series.episode, series.mean, window),
    low: centredAverage(series.episode, series.low, window),
    high: centredAverage(series.episode, series.high, window),
  };
}

/** x/y arrays of a closed band polygon (upper edge forwards, lower edge backwards) for Plotly fill. */
export function bandPolygon(x, low, high) {
  const xs = [];
  const ys = [];
  for (let i = 0; i < x.length; i++) { xs.push(x[i]); ys.push(high[i]); }
  for (let i = x.length - 1; i >= 0; i--) { xs.push(x[i]); ys.push(low[i]); }
  return { x: xs, y: ys };
}

/** Tags from a comma separated string, trimmed, de-duplicated, empty ones dropped. */
export function parseTags(text) {
  const tags = [];
  for (const t of String(text || '').split(',')) {
    const tag = t.trim();
    if (tag && !tags.includes(tag)) tags.push(tag);
  }
  return tags;
}

/** Positive integer ids from "1, 2,3" (or an array), unique, in the given order. */
/** The parts of a job-id list that are not job ids (`abc` in `1,abc`), to say so. */
export function badIds(value) {
  return String(value || '').split(/[\s,]+/).filter(Boolean).filter((p) => !/^[1-9]\d*$/.test(p.trim()));
}

/** One-line definitions of the summary columns, shown under every table that has them. */
export const DEFINITIONS = 'Final mean: system utility averaged over the last 10 episodes, then over seeds (95% t-interval). ' +
  '% from uniform: gain over uniform, paired seed by seed (same worlds), over the seeds shared with uniform (Paired). ' +
  '% of max: this configuration’s gain over uniform as a share of mgrao-max’s, on the seeds all three share.';

/**
 * What a reader of "% of max" should know where `reference` (the registry's reference configuration, mgrao-max) is
 * not the yardstick they assume ('' where it is): configurations that gain more over uniform than it (above 100%),
 * or none at all where it gained nothing (the column is empty). `configurations`: `{algorithm, summary}` of one world.
 */
export function maxNote(configurations, reference) {
  const rows = (configurations || []).filter((c) => c && c.summary);
  const max = reference ? rows.find((c) => c.algorithm === reference) : null;
  if (!max) return '';
  if (!isFiniteNumber(max.summary.pct_of_max)) {
    return `% of max is not given: ${reference} gained nothing over uniform here, so no share of its gain means anything.`;
  }
  const above = rows.filter((c) => c.algorithm !== reference && isFiniteNumber(c.summary.pct_of_max) &&
    c.summary.pct_of_max > 100);
  if (!above.length) return '';
  const named = above.map((c) => `${c.algorithm} (${fmtPct(c.summary.pct_of_max, 1, false)})`);
  const list = named.length > 1 ? `${named.slice(0, -1).join(', ')} and ${named[named.length - 1]}` : named[0];
  return `${reference} is not the best here: ${list} ${above.length > 1 ? 'gain' : 'gains'} more over uniform than it ` +
    `does. % of max is a share of ${reference}’s gain, not of the best configuration’s: rank them by % from uniform.`;
}

/**
 * A learner's parent groups at the end (`learning` of a results configuration): "1" where every child has one
 * count, else each count with its children, "5 groups: 4 of 6 children; 10 groups: 2 of 6". '–' without groups.
 */
export function groupsText(learning) {
  const groups = learning && learning.groups;
  if (!groups) return '–';
  const counts = Object.entries(groups).map(([g, n]) => [Number(g), n]).sort((a, b) => a[0] - b[0]);
  if (counts.length === 1 && !learning.groups_change) return String(counts[0][0]);
  const of = learning.children;
  return counts.map(([g, n]) => `${g} ${g === 1 ? 'group' : 'groups'}: ${n} of ${of} ${of === 1 ? 'child' : 'children'}`)
    .join('; ');
}

/** The share of a child's resources learning took (`learning.taken`): "12.5%", or "8.0% (5.0–12.5%)" where it varies. */
export function takenText(learning) {
  const t = learning && learning.taken;
  if (!t || !isFiniteNumber(t.mean)) return '–';
  const pct = (x) => (100 * x).toFixed(1);
  return t.high - t.low > 5e-4 ? `${pct(t.mean)}% (${pct(t.low)}–${pct(t.high)}%)` : `${pct(t.mean)}%`;
}

/** The export columns of a configuration's summary: numbers, units in the names (`summaryCells`). */
export const SUMMARY_COLUMNS = ['n_runs', 'n_paired', 'final_mean_utility', 'final_ci95_low_utility',
  'final_ci95_high_utility', 'pct_from_uniform_percent', 'pct_ci95_low_percent', 'pct_ci95_high_percent',
  'pct_of_max_percent'];

/** A summary's cells under SUMMARY_COLUMNS: numbers as the API gave them, empty where it gave none. */
export function summaryCells(s) {
  const v = (x) => (isFiniteNumber(x) ? x : null);
  const ci = Array.isArray(s?.ci95) ? s.ci95 : [null, null];
  const pci = Array.isArray(s?.pct_ci95) ? s.pct_ci95 : [null, null];
  return [s?.n_runs ?? null, s?.n_paired ?? null, v(s?.final_mean), v(ci[0]), v(ci[1]), v(s?.pct_from_uniform),
    v(pci[0]), v(pci[1]), v(s?.pct_of_max)];
}

/** Fewest points per curve worth drawing individual seeds with (fewer: too coarse to read a seed's course). */
export const MIN_SEED_POINTS = 20;

/**
 * The points per curve that a results answer with every seed's curve can hold: `curves` = three per configuration
 * (mean, low, high) and one per stored run, within `maxValues` numbers (`max_response_values` of GET /api/systems),
 * at most `wanted` and the episodes. Null when fewer than MIN_SEED_POINTS would fit (too many runs to draw apart).
 */
export function seedPoints(wanted, episodes, configurations, runs, maxValues) {
  const fitting = Math.floor(maxValues / Math.max(1, configurations * 3 + runs));
  const points = Math.min(wanted, episodes, fitting);
  return points >= Math.min(MIN_SEED_POINTS, episodes) ? points : null;
}

/**
 * Whether a view shows what became of the atomic tasks (a summary's `failure_rate` and `handover_rate`): some
 * configuration has a nonzero rate, or some job lets tasks fail (its params' `task_need` > 0).
 */
export function showsTaskRates(summaries, paramsList = []) {
  const rated = (summaries || []).some((s) => s && ((s.failure_rate || 0) > 0 || (s.handover_rate || 0) > 0));
  return rated || (paramsList || []).some((p) => Number((p || {}).task_need) > 0);
}

/** A share in [0, 1] as a percentage, one decimal ('12.3%'); '<0.1%' for a share too small to show; '–' for none. */
export function fmtRate(x) {
  if (!isFiniteNumber(x)) return '–';
  if (x > 0 && x < 0.0005) return '<0.1%';
  return `${(100 * x).toFixed(1)}%`;
}

/** What the two rates are, in a line under a table or chart of them. */
export const TASK_RATE_DEFINITIONS = 'Failed: share of the atomic tasks allocated to children that failed, their ' +
  'value lost (short of task_need, and not completed through a neighbour). By a neighbour: share a neighbouring child ' +
  'completed (hierarchy: a borrowed share of its resource, or the task handed over to it). Both pooled over the seeds.';

/** "10 of 20 paired": the paired count of a summary whose seeds only partly pair with uniform, else the count. */
export function pairedText(s) {
  if (!s || s.n_paired === undefined || s.n_paired === null) return '–';
  return s.partial ? `${s.n_paired} of ${s.n_runs}` : String(s.n_paired);
}

export function parseIds(value) {
  const parts = Array.isArray(value) ? value : String(value || '').split(/[\s,]+/);
  const ids = [];
  for (const p of parts) {
    const n = Number(String(p).trim());
    if (Number.isInteger(n) && n > 0 && !ids.includes(n)) ids.push(n);
  }
  return ids;
}

/** Split a location hash "#/compare?jobs=1,2&smooth=5" into {path: "/compare", params: {jobs: "1,2", smooth: "5"}}. */
export function parseHash(hash) {
  let h = String(hash || '').replace(/^#/, '');
  if (!h.startsWith('/')) h = '/' + h;
  const q = h.indexOf('?');
  const path = (q === -1 ? h : h.slice(0, q)).replace(/\/+$/, '') || '/';
  const params = {};
  if (q !== -1) {
    for (const [k, v] of new URLSearchParams(h.slice(q + 1))) params[k] = v;
  }
  return { path, params };
}

/** Inverse of parseHash; empty, null and undefined values are left out. Commas stay readable. */
export function buildHash(path, params = {}) {
  const parts = [];
  for (const [k, v] of Object.entries(params)) {
    if (v === undefined || v === null || v === '' || (Array.isArray(v) && v.length === 0)) continue;
    const value = Array.isArray(v) ? v.join(',') : String(v);
    parts.push(`${encodeURIComponent(k)}=${encodeURIComponent(value).replace(/%2C/gi, ',').replace(/%3A/gi, ':')}`);
  }
  return '#' + path + (parts.length ? '?' + parts.join('&') : '');
}

/**
 * Map a 422 error detail list to {fieldPath: message}. The field path is "params.<name>" for
 * parameters (from `loc` ["body", "params", name]) and the plain field name otherwise.
 * `knownParams` (a Set of parameter names) lets a bare `field` like "n_parents" find its parameter.
 */
export function fieldErrors(detail, knownParams = new Set()) {
  const out = {};
  if (!Array.isArray(detail)) return out;
  for (const item of detail) {
    if (!item || typeof item !== 'object') continue;
    const loc = Array.isArray(item.loc) ? item.loc.filter((p) => p !== 'body') : [];
    let key = null;
    let field = typeof item.field === 'string' ? item.field : null;
    if (field && field.startsWith('params.')) key = field;
    else if (loc[0] === 'params' && loc.length > 1) key = `params.${loc[1]}`;
    else if (field && knownParams.has(field)) key = `params.${field}`;
    else if (field) key = field;
    else if (loc.length) key = String(loc[0]);
    else key = '_form';
    const msg = item.msg || 'invalid value';
    out[key] = out[key] ? `${out[key]}; ${msg}` : msg;
  }
  return out;
}

const RANGE_ENDS = { low: 'from', high: 'to', steps: 'steps', log: 'log scale' };

/** What a form calls the field of an API path: `learning_rate` for `base.params.learning_rate`, '' for a label. */
export function fieldName(path) {
  const p = String(path || '');
  let m;
  if ((m = /^(?:base\.)?params\.(\w+)$/.exec(p))) return m[1];
  if ((m = /^space\.(\w+)\.(low|high|steps|log)$/.exec(p))) return `${m[1]} (${RANGE_ENDS[m[2]]})`;
  if ((m = /^space\.(\w+)\.values\[(\d+)\]$/.exec(p))) return `${m[1]} (value ${Number(m[2]) + 1})`;
  if ((m = /^space\.(\w+)(?:\.values)?$/.exec(p))) return m[1];
  if (/^(?:base\.)?algorithms\[\d+\]$/.test(p)) return '';
  if (p === 'space') return 'the parameters swept';
  if ((m = /^(?:base\.|until\.)(\w+)$/.exec(p))) return m[1];
  return p;
}

/**
 * A refusal as shown beside its field, in the field's own words: the API's path that opens it
 * ("space.learning_rate.high: ...") as the form names that field ("learning_rate (to): ..."); a refused label's
 * path left out (its message names the label).
 */
export function ownWords(path, msg) {
  const text = String(msg || '');
  const m = /^([\w.[\]-]+): /.exec(text);
  if (!m) return text;
  const name = fieldName(m[1]);
  return name ? `${name}: ${text.slice(m[0].length)}` : text.slice(m[0].length);
}

// ---- formatting -------------------------------------------------------------------------

export function fmtNumber(x, digits = 3) {
  if (!isFiniteNumber(x)) return '–';
  const a = Math.abs(x);
  if (a !== 0 && (a >= 1e6 || a < 1e-3)) return x.toExponential(2);
  return x.toFixed(digits);
}

export function fmtPct(x, digits = 1, sign = true) {
  if (!isFiniteNumber(x)) return '–';
  const s = x.toFixed(digits);
  return (sign && x > 0 ? '+' : '') + s + '%';
}

export function fmtCI(ci, digits = 3, pct = false) {
  if (!Array.isArray(ci) || ci.length < 2 || !isFiniteNumber(ci[0]) || !isFiniteNumber(ci[1])) return '';
  const f = pct ? (v) => fmtPct(v, digits) : (v) => fmtNumber(v, digits);
  return `[${f(ci[0])}, ${f(ci[1])}]`;
}

/**
 * The one rounding rule of an interval shown against a figure it is judged by (the paper's % from uniform): the
 * decimals at which both read as on the side of `value` that it is. One (`digits`) unless rounding hides the verdict
 * (the paper's +28.0% outside [+23.28%, +27.99%] would read as its end, [+23.3%, +28.0%]), then as many as tell
 * them apart, at most `most`. Every view that shows the interval beside that figure (the paper view, a job's page)
 * writes both with these decimals; `deciding_digits` of mgrao_core/statistics/report.py is the command line's.
 */
export function decidingDigits(ci, value, digits = 1, most = 4) {
  if (!Array.isArray(ci) || !Number.isFinite(ci[0]) || !Number.isFinite(ci[1]) || !Number.isFinite(value)) return digits;
  const outside = value < ci[0] || value > ci[1];
  for (let d = digits; d < most; d += 1) {
    const at = (x) => Number(x.toFixed(d));
    if ((at(value) < at(ci[0]) || at(value) > at(ci[1])) === outside) return d;
  }
  return most;
}

export function fmtDuration(seconds) {
  if (!isFiniteNumber(seconds)) return '–';
  if (seconds < 1) return `${Math.round(seconds * 1000)} ms`;
  if (seconds < 60) return `${seconds.toFixed(1)} s`;
  const m = Math.floor(seconds / 60);
  const s = Math.round(seconds - m * 60);
  if (m < 60) return `${m} min ${s} s`;
  const h = Math.floor(m / 60);
  return `${h} h ${m - h * 60} min`;
}

/** "2026-11-21 10:05" in the viewer's time zone; '–' for a missing or bad date. */
export function fmtDate(iso) {
  if (!iso) return '–';
  const d = new Date(iso);
  if (Number.isNaN(d.getTime())) return '–';
  const p = (n) => String(n).padStart(2, '0');
  return `${d.getFullYear()}-${p(d.getMonth() + 1)}-${p(d.getDate())} ${p(d.getHours())}:${p(d.getMinutes())}`;
}

/** Progress as a whole percentage clamped into [0, 100]. */
export function pctProgress(progress) {
  if (!isFiniteNumber(progress)) return 0;
  return Math.round(Math.min(1, Math.max(0, progress)) * 100);
}

/** Error bar arrays for Plotly from summaries' pct_from_uniform and pct_ci95. */
export function pctErrorBars(summaries) {
  const y = [];
  const plus = [];
  const minus = [];
  for (const s of summaries) {
    const v = s && isFiniteNumber(s.pct_from_uniform) ? s.pct_from_uniform : null;
    y.push(v);
    const ci = s && Array.isArray(s.pct_ci95) ? s.pct_ci95 : null;
    if (v !== null && ci && isFiniteNumber(ci[0]) && isFiniteNumber(ci[1])) {
      plus.push(Math.max(0, ci[1] - v));
      minus.push(Math.max(0, v - ci[0]));
    } else {
      plus.push(0);
      minus.push(0);
    }
  }
  return { y, plus, minus };
}

/** Stable key of a compare group: first 8 characters of its config hash and its label (commas escaped: keys are a list). */
export function groupKey(group) {
  const label = String(group.label ?? group.algorithm).replace(/%/g, '%25').replace(/,/g, '%2C');
  return `${String(group.config_hash || '').slice(0, 8)}:${label}`;
}

/**
 * A job's system as people name it: the saved system it ran (`saved_system`), else its preset (`system`, which for
 * a saved system's job is the base preset: docs/api.md, "Saved systems").
 */
export function systemName(job) {
  return (job && (job.saved_system || job.system)) || '';
}

/** A job's system with its base where it is a saved system: "large30 (saved system, based on large)". */
export function systemDescription(job) {
  return job && job.saved_system ? `${job.saved_system} (saved system, based on ${job.system})` : systemName(job);
}

/**
 * A job's seeds as its header says them: the count, and for a job run until a question is answered (`until`),
 * "20 of at most 500" (the seeds judged so far, or run, of the rule's most).
 */
export function seedsText(job) {
  if (!job || !job.until) return String(seedCount(job));
  const run = job.stopped && isFiniteNumber(job.stopped.seeds) && job.stopped.seeds > 0 ? job.stopped.seeds
    : (job.status === 'succeeded' ? seedCount(job) : 0);
  return `${run} of at most ${job.until.max_seeds}`;
}

/**
 * Where a job's time went, for its header: [label, text] pairs: queued (from its submission to its start: waiting
 * for a worker, or for one to warm up), compiling the engine for it, and running (the rest of its run).
 */
export function jobTimes(job) {
  const compiling = isFiniteNumber(job.compile_s) ? job.compile_s : 0;
  const running = isFiniteNumber(job.duration_s) ? Math.max(0, job.duration_s - compiling) : null;
  return [
    ['Queued', fmtDuration(job.queued_s)],
    ['Compiling', job.compiling ? 'under way' : (compiling > 0 ? fmtDuration(compiling) : (job.started_at ? 'none' : '–'))],
    ['Running', fmtDuration(running)],
  ];
}

/** A running job's compile (its `compiling`) as the job page says it: the notice and how long so far. */
export function compilingText(compiling, nowMs = Date.now()) {
  if (!compiling || !compiling.message) return '';
  const since = Date.parse(compiling.since || '');
  const so = Number.isFinite(since) ? ` (${fmtDuration(Math.max(0, (nowMs - since) / 1000))} so far)` : '';
  const message = compiling.message.charAt(0).toUpperCase() + compiling.message.slice(1);
  return `${message}${so}. The engine is cached once compiled: later jobs of these families start at once ` +
    '(“mgrao compile” compiles every family ahead).';
}

/** Number of seeds of a job (its `seeds` list, or a count). */
export function seedCount(job) {
  if (!job) return 0;
  if (Array.isArray(job.seeds)) return job.seeds.length;
  return isFiniteNumber(job.seeds) ? job.seeds : 0;
}

/** Two parameter values are the same (floats compared to 1e-12 relative, as the server resolves them). */
export function sameValue(a, b) {
  if (a === b) return true;
  if (Array.isArray(a) || Array.isArray(b)) { // a list or event list: item by item, field by field
    return Array.isArray(a) && Array.isArray(b) && a.length === b.length && a.every((x, i) => sameValue(x, b[i]));
  }
  if (a && b && typeof a === 'object' && typeof b === 'object') {
    const keys = new Set([...Object.keys(a), ...Object.keys(b)]);
    return [...keys].every((k) => sameValue(a[k], b[k]));
  }
  return isFiniteNumber(a) && isFiniteNumber(b) && Math.abs(a - b) <= 1e-12 * Math.max(1, Math.abs(b));
}

/** Parameters in `values` that differ from `base` (numbers compared numerically, null vs value counts). */
export function changedParams(values, base) {
  const out = {};
  for (const [k, v] of Object.entries(values)) {
    if (!sameValue(v, base ? base[k] : undefined)) out[k] = v;
  }
  return out;
}

/** One CSV cell, quoted when it holds a comma, quote or line break. */
function csvCell(v) {
  const text = v === null || v === undefined ? '' : String(v);
  return /[",\n\r]/.test(text) ? `"${text.replace(/"/g, '""')}"` : text;
}

/** Rows of cells as CSV text. */
export function csvOf(rows) {
  return `${rows.map((r) => r.map(csvCell).join(',')).join('\n')}\n`;
}

/** The header's few words on the workers of `/api/health` (`{warming, ready}`; null when unknown). */
export function workersWord(workers) {
  if (!workers) return '';
  const { warming = 0, ready = 0 } = workers;
  if (warming && !ready) return `${warming} ${warming === 1 ? 'worker' : 'workers'} warming up`;
  if (!warming && !ready) return 'no worker';
  return `${ready} ${ready === 1 ? 'worker' : 'workers'}` + (warming ? ` (+${warming} warming up)` : '');
}

/**
 * What a queued job is waiting for, given the workers of `/api/health` and the share already stored.
 * `queue` ({ahead, running} of `GET /api/jobs/{id}/status`) says what is true when workers are ready:
 * jobs queued before this one, every ready worker busy with a running job, or a worker about to take it.
 */
export function waitingMessage(workers, pct, queue = null) {
  const stored = pct > 0 ? ` (${pct}% already stored)` : '';
  if (!workers) return `Waiting for a worker…${stored}`;
  const { warming = 0, ready = 0 } = workers;
  if (!ready && warming) {
    return `Workers are warming up: loading the simulation kernel (compiling it takes about 25 s on a fresh ` +
      `install, a second or two after). The job starts when one is ready.${stored}`;
  }
  if (!ready) {
    return 'No worker is running: start one with “mgrao worker” (or “mgrao serve” with --workers 1 or more); ' +
      `the job waits in the queue.${stored}`;
  }
  const workersText = `${ready} ${ready === 1 ? 'worker' : 'workers'} ready`;
  if (!queue) return `Waiting for a worker: ${workersText}.${stored}`;
  const { ahead = 0, running = 0 } = queue;
  const runningText = `${running} ${running === 1 ? 'job' : 'jobs'} running`;
  if (ahead > 0) {
    return `Waiting in the queue: ${ahead} ${ahead === 1 ? 'job was' : 'jobs were'} queued before this one and ` +
      `${ahead === 1 ? 'runs' : 'run'} first (${workersText}, ${runningText}).${stored}`;
  }
  if (running >= ready) {
    return `Next in the queue: ${ready === 1 ? 'the ready worker is' : `all ${ready} ready workers are`} busy ` +
      `(${runningText}); it starts when one finishes.${stored}`;
  }
  return `Next in the queue: a ready worker takes it within a few seconds (${workersText}, ${runningText}).${stored}`;
}

// ---- the work budget of an experiment ------------------------------------------------------

/** The form's field path of a work factor named by `GET /api/systems` (`limits.work_factors`). */
export function workFieldPath(name) {
  return ['seeds', 'algorithms', 'episodes'].includes(name) ? name : `params.${name}`;
}

/**
 * An experiment's work against the limit, from `GET /api/systems`: the product of
 * `limits.work_factors` (the number of seeds and of configurations, the episodes, parameters from
 * the overrides or else the preset) against `limits.max_work`. {used, max, factors: [{name, value,
 * path}], over}, or null while a factor cannot be read (an empty field).
 */
export function workBudget(experiment, presetParams, limits) {
  if (!limits || !limits.max_work || !Array.isArray(limits.work_factors)) return null;
  const overrides = experiment.params || {};
  const factors = [];
  for (const name of limits.work_factors) {
    let value;
    if (name === 'seeds') value = Array.isArray(experiment.seeds) ? experiment.seeds.length : experiment.seeds;
    else if (name === 'algorithms') value = (experiment.algorithms || []).length;
    else if (name === 'episodes') value = experiment.episodes;
    else value = overrides[name] ?? (presetParams || {})[name];
    if (typeof value !== 'number' || !Number.isFinite(value) || value < 0) return null;
    factors.push({ name, value, path: workFieldPath(name) });
  }
  const used = factors.reduce((product, f) => product * f.value, 1);
  return { used, max: limits.max_work, factors, over: used > limits.max_work };
}

/** The budget line: "3 seeds × 3 configurations × … = 9,000 atomic tasks of 2,000,000,000 allowed (0.00045%)". */
export function workText(budget) {
  const word = (f) => (f.name === 'algorithms' ? 'configurations' : f.name);
  const product = budget.factors.map((f) => `${f.value.toLocaleString('en-US')} ${word(f)}`).join(' × ');
  const used = budget.used.toLocaleString('en-US');
  const max = budget.max.toLocaleString('en-US');
  if (budget.over) {
    return `Work: ${product} = ${used} atomic tasks, over the limit of ${max} per experiment ` +
      `(${(budget.used / budget.max).toPrecision(2)} times it). Lower one of the marked fields.`;
  }
  const pct = (100 * budget.used) / budget.max;
  return `Work: ${product} = ${used} atomic tasks of ${max} allowed (${pct >= 1 ? pct.toFixed(0) : pct.toPrecision(2)}%).`;
}

/** Fewer seeds than this and a 95% t-interval is too wide to mean much (t(0.975, 9) = 2.26; with 3 seeds 4.30). */
export const MIN_BAND_RUNS = 10;

function median(values) {
  const v = values.filter(isFiniteNumber).sort((a, b) => a - b);
  if (!v.length) return null;
  const m = v.length >> 1;
  return v.length % 2 ? v[m] : (v[m - 1] + v[m]) / 2;
}

/**
 * Whether the 95% bands of the configurations drawn together mean much, as a sentence ('' when they
 * do). `series`: one `{runs, episodes: {mean, low, high}}` per configuration. The bands are called
 * too wide when a configuration has fewer than `minRuns` seeds, or when their median width (over
 * configurations and plotted points) exceeds the median spread of the means (the highest mean less
 * the lowest at each point): then every band covers the gaps between the lines.
 */
export function bandCaution(series, minRuns = MIN_BAND_RUNS) {
  const drawn = (series || []).filter((s) => s && s.episodes && s.episodes.mean);
  if (!drawn.length) return '';
  const runs = Math.min(...drawn.map((s) => Number(s.runs) || 0));
  const widths = drawn.flatMap((s) => s.episodes.low.map((low, i) => s.episodes.high[i] - low));
  const width = median(widths);
  let spread = null;
  if (drawn.length > 1) {
    const n = Math.min(...drawn.map((s) => s.episodes.mean.length));
    const gaps = [];
    for (let i = 0; i < n; i++) {
      const means = drawn.map((s) => s.episodes.mean[i]).filter(isFiniteNumber);
      if (means.length > 1) gaps.push(Math.max(...means) - Math.min(...means));
    }
    spread = median(gaps);
  }
  const reasons = [];
  if (runs < minRuns) reasons.push(`${runs === 1 ? 'one seed' : `${runs} seeds`} per configuration (fewer than ${minRuns})`);
  if (width !== null && spread !== null && width > spread) {
    reasons.push(`a median band width of ${fmtNumber(width, 3)}, more than the ${fmtNumber(spread, 3)} between the highest and lowest mean`);
  }
  if (!reasons.length) return '';
  return `The 95% bands are too wide to mean much: ${reasons.join('; ')}. Read the mean lines; ` +
    `run more seeds for intervals that tell the configurations apart.`;
}
