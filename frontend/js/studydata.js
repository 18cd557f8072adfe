// Pure helpers of the study views: sorting and paging trials, prefilled sweep ranges, the study's
// JSON from the form's rows, and the Plotly traces of the server's aggregated plots.
// No DOM access here, so that node's test runner can import this module directly.

import { isFiniteNumber } from './stats.js';

// ---- trials -----------------------------------------------------------------------------

/** The value a trials-table column sorts by: 'number', 'value', 'status' or 'param:<name>'. */
function sortValue(trial, key) {
  if (key.startsWith('param:')) return trial.params ? trial.params[key.slice(6)] : undefined;
  return trial[key];
}

/**
 * Trials sorted by `key` ('number', 'value', 'status' or 'param:<name>'), ascending or not;
 * missing values (a failed trial's objective) last either way, ties by trial number.
 */
export function sortTrials(trials, key, ascending = true) {
  const sign = ascending ? 1 : -1;
  return trials.slice().sort((a, b) => {
    const x = sortValue(a, key);
    const y = sortValue(b, key);
    const xm = x === null || x === undefined || (typeof x === 'number' && !Number.isFinite(x));
    const ym = y === null || y === undefined || (typeof y === 'number' && !Number.isFinite(y));
    if (xm !== ym) return xm ? 1 : -1;
    if (!xm && x !== y) {
      if (typeof x === 'number' && typeof y === 'number') return sign * (x - y);
      return sign * String(x).localeCompare(String(y));
    }
    return a.number - b.number;
  });
}

/** Rows `page * size` .. of `items`, with the page count (page clamped into range). */
export function pageOf(items, page, size) {
  const pages = Math.max(1, Math.ceil(items.length / size));
  const p = Math.min(Math.max(0, Math.floor(page) || 0), pages - 1);
  return { rows: items.slice(p * size, (p + 1) * size), page: p, pages };
}

/** A parameter value as shown: floats to 4 significant digits, the rest as text. */
export function fmtParam(v) {
  if (typeof v === 'number' && !Number.isInteger(v)) return String(Number(v.toPrecision(4)));
  if (typeof v === 'boolean') return v ? 'on' : 'off';
  if (v !== null && typeof v === 'object') return JSON.stringify(v); // a list or event list
  return v === null || v === undefined ? '–' : String(v);
}

/** The ended trials (succeeded, failed, cancelled) out of the per-status counts. */
export function endedTrials(counts) {
  return ['succeeded', 'failed', 'cancelled'].reduce((n, s) => n + ((counts || {})[s] || 0), 0);
}

// ---- the new-study form ------------------------------------------------------------------

const LOG_SCALE = /rate|temperature|epsilon|probability|noise/;

/**
 * A sweep's first range for parameter `p` (a schema entry) around the preset's value `v`: half to
 * twice the value within the schema's limits, 3 steps; log-scaled for rates, temperatures and
 * probabilities. Choices and switches sweep all their values.
 */
export function defaultSweep(p, v) {
  if (p.kind === 'choice') return { values: p.choices.slice() };
  if (p.kind === 'bool') return { values: [false, true] };
  const min = isFiniteNumber(p.minimum) ? p.minimum : -Infinity;
  const max = isFiniteNumber(p.maximum) ? p.maximum : Infinity;
  const clamp = (x) => Math.min(max, Math.max(min, x));
  const centre = isFiniteNumber(v) ? v : isFiniteNumber(p.default) ? p.default : (isFiniteNumber(min) ? min : 1);
  let low = clamp(centre > 0 ? centre / 2 : centre - 1);
  let high = clamp(centre > 0 ? centre * 2 : centre + 1);
  if (p.kind === 'int') {
    low = Math.ceil(low);
    high = Math.floor(high);
    if (low >= high) high = Math.min(max, low + 2);
    if (low >= high) low = Math.max(min, high - 2);
  } else {
    low = Number(low.toPrecision(4));
    high = Number(high.toPrecision(4));
  }
  if (low === 0 && p.exclusive_minimum) low = Number((high / 10).toPrecision(4));
  const log = LOG_SCALE.test(p.name) && low > 0;
  return { low, high, steps: 3, log };
}

/** How many points a grid dimension has (values, or steps of a range); 0 when unreadable. */
export function gridPoints(dimension) {
  if (Array.isArray(dimension.values)) return dimension.values.length;
  return Number.isInteger(dimension.steps) ? dimension.steps : 0;
}

/** Parse a comma-separated list of values for parameter kind `kind`; {values, invalid}. */
export function parseValues(text, kind) {
  const values = [];
  const invalid = [];
  for (const raw of String(text || '').split(',').map((t) => t.trim()).filter(Boolean)) {
    if (kind === 'choice') values.push(raw);
    else if (kind === 'bool') {
      if (/^(on|true|1)$/i.test(raw)) values.push(true);
      else if (/^(off|false|0)$/i.test(raw)) values.push(false);
      else invalid.push(raw);
    } else {
      const n = Number(raw);
      if (raw === '' || !Number.isFinite(n) || (kind === 'int' && !Number.isInteger(n))) invalid.push(raw);
      else values.push(n);
    }
  }
  return { values, invalid };
}

/**
 * The study's JSON from the form: the base experiment (js/experimentfields.js read()), the
 * sweep rows {name, mode: 'range'|'values', low, high, steps, log, values} and the settings.
 * A swept parameter is left out of the base's params (the space sets it).
 */
export function studyBody(base, rows, settings) {
  const params = { ...(base.params || {}) };
  const space = {};
  for (const row of rows) {
    delete params[row.name];
    if (row.mode === 'values') space[row.name] = { values: row.values };
    else {
      space[row.name] = { low: row.low, high: row.high, log: !!row.log };
      if (settings.method === 'grid') space[row.name].steps = row.steps;
    }
  }
  const objective = { metric: settings.metric, direction: settings.direction };
  if (settings.metric !== 'paper_deviation') objective.configuration = settings.configuration;
  const body = {
    name: settings.name, method: settings.method,
    base: { system: base.system, algorithms: base.algorithms, seeds: base.seeds, episodes: base.episodes, params },
    space, objective, max_trials: settings.max_trials, max_in_flight: settings.max_in_flight,
  };
  if (settings.seed !== undefined && settings.seed !== '') body.seed = settings.seed;
  return body;
}

/** Map an API error path (space.learning_rate.low, base.params.x, base.seeds) to the form's field keys. */
export function studyFieldKey(path) {
  const space = /^space\.([A-Za-z_]\w*)/.exec(path);
  if (space) return `space.${space[1]}`;
  if (path.startsWith('base.params.')) return `params.${path.slice(12)}`;
  if (path.startsWith('base.')) return path.slice(5).replace(/\[\d+\]$/, '');
  if (path.startsWith('objective.')) return path;
  return path;
}

// ---- plots -------------------------------------------------------------------------------

const BLUE = '#0072B2';
const ORANGE = '#D55E00';
const GREY = 'rgba(90, 100, 115, 0.55)';

/** Best so far (a step line) over every trial's objective (dots). */
export function historyTraces(history, objectiveName) {
  return [
    { type: 'scatter', mode: 'markers', x: history.trial, y: history.value, name: objectiveName,
      marker: { size: 5, color: GREY }, meta: { kind: 'trial' },
      hovertemplate: 'trial %{x}: %{y:.4g}<extra></extra>' },
    { type: 'scatter', mode: 'lines', x: history.trial, y: history.best, name: 'best so far',
      line: { shape: 'hv', width: 2.5, color: BLUE }, meta: { kind: 'best' },
      hovertemplate: 'best after trial %{x}: %{y:.4g}<extra></extra>' },
  ];
}

/** Horizontal bars of each dimension's share of the explained variance, largest on top. */
export function importanceTrace(importance) {
  const names = Object.keys(importance).sort((a, b) => importance[a].eta_squared - importance[b].eta_squared);
  return {
    type: 'bar', orientation: 'h', y: names, x: names.map((n) => importance[n].eta_squared),
    marker: { color: names.map((n) => (noisy(importance[n]) ? GREY : BLUE)) }, meta: { kind: 'importance' },
    customdata: names.map((n) => [importance[n].share, importance[n].p_value ?? null]),
    hovertemplate: '%{y}: η² %{x:.3f} (%{customdata[0]:.0%} of the sum; permutation p %{customdata[1]:.3f})<extra></extra>',
  };
}

/** Significance level under which a parameter's importance is told apart from noise (its permutation test). */
export const IMPORTANCE_LEVEL = 0.05;

function noisy(entry) {
  return !(typeof entry.p_value === 'number' && entry.p_value < IMPORTANCE_LEVEL);
}

/**
 * What the importance plot cannot tell (''): the parameters whose η² shuffled objectives reach as often as
 * IMPORTANCE_LEVEL or more (their permutation test), with the trials behind them.
 */
export function importanceNote(importance, trials) {
  const names = Object.keys(importance || {}).filter((n) => noisy(importance[n]));
  if (!names.length) return '';
  const each = names.map((n) => `${n} (η² ${importance[n].eta_squared.toFixed(2)}, p = ${(importance[n].p_value ?? 1).toFixed(2)})`);
  return `Not told apart from noise with ${trials} ${trials === 1 ? 'trial' : 'trials'}: ${each.join(', ')}. ` +
    'Shuffled over the same values, the trials’ objectives explain as much that often (greyed); more trials per ' +
    'value tell.';
}

/**
 * The best trial as the study's header says it: its objective with the 95% interval over seeds and the seeds, and
 * the trials that cannot be told apart from it (their objective inside that interval), the runner-up first.
 */
export function bestText(best, trials, seeds, fmt) {
  if (!best) return '–';
  const params = Object.entries(best.params).map(([k, v]) => `${k} ${fmtParam(v)}`).join(', ');
  const ci = Array.isArray(best.ci95) && best.ci95.every((x) => typeof x === 'number')
    ? ` [${fmt(best.ci95[0])}, ${fmt(best.ci95[1])}]` : '';
  const over = seeds ? ` over ${seeds} ${seeds === 1 ? 'seed' : 'seeds'}` : '';
  let text = `${fmt(best.value)}${ci}${ci ? ` (95% interval${over})` : over} at trial ${best.number}: ${params}`;
  if (ci) {
    const [low, high] = best.ci95;
    const close = trials.filter((t) => t !== best && typeof t.value === 'number' && t.value >= low && t.value <= high)
      .sort((a, b) => Math.abs(best.value - a.value) - Math.abs(best.value - b.value));
    if (close.length) {
      text += `. Not told apart from ${close.length === 1 ? 'trial' : `${close.length} trials`} whose objective lies ` +
        `in that interval (the nearest: trial ${close[0].number}, ${fmt(close[0].value)})`;
    }
  }
  return text;
}

/** A slice: each trial (its 95% CI as an error bar) and the mean per value or bin with its CI. */
export function sliceTraces(slice, name) {
  const errors = (ys, lows, highs) => ({
    type: 'data', symmetric: false, thickness: 1, width: 0, color: GREY,
    array: ys.map((y, i) => (isFiniteNumber(highs[i]) && isFiniteNumber(y) ? Math.max(0, highs[i] - y) : 0)),
    arrayminus: ys.map((y, i) => (isFiniteNumber(lows[i]) && isFiniteNumber(y) ? Math.max(0, y - lows[i]) : 0)),
  });
  const bins = slice.bins;
  return [
    { type: 'scatter', mode: 'markers', x: slice.x.map((v) => (typeof v === 'boolean' ? String(v) : v)), y: slice.value,
      name: 'trials', marker: { size: 6, color: GREY }, error_y: errors(slice.value, slice.low, slice.high),
      customdata: slice.number, meta: { kind: 'slice-trials', dimension: name },
      hovertemplate: `trial %{customdata}: ${name} %{x}, %{y:.4g}<extra></extra>` },
    { type: 'scatter', mode: 'lines+markers', x: bins.x.map((v) => (typeof v === 'boolean' ? String(v) : v)), y: bins.mean,
      name: 'mean', line: { color: ORANGE, width: 2 }, marker: { size: 7, color: ORANGE },
      error_y: { ...errors(bins.mean, bins.low, bins.high), color: ORANGE, thickness: 1.5, width: 4 },
      customdata: bins.count, meta: { kind: 'slice-mean', dimension: name },
      hovertemplate: `${name} %{x}: mean %{y:.4g} over %{customdata} trials<extra></extra>` },
  ];
}

/** The mean objective over two dimensions; empty cells stay blank. */
export function studyHeatmapTrace(heatmap, reversed = false) {
  const label = (v) => (typeof v === 'number' ? fmtParam(v) : String(v));
  return {
    type: 'heatmap', z: heatmap.mean, x: heatmap.x_values.map(label), y: heatmap.y_values.map(label),
    customdata: heatmap.count, colorscale: 'Viridis', reversescale: reversed, hoverongaps: false,
    colorbar: { title: { text: 'mean objective' } }, meta: { kind: 'study-heatmap' },
    hovertemplate: `${heatmap.x} %{x}, ${heatmap.y} %{y}: %{z:.4g} (%{customdata} trials)<extra></extra>`,
  };
}

// Where a numeric parallel-coordinates axis is labelled: both ends and three values between
const PARALLEL_TICKS = [0, 0.25, 0.5, 0.75, 1];

/** A tick value to 3 significant digits (0.0316227766 → 0.0316), so that labels stay short. */
function roundTick(v) {
  return Number.isFinite(v) && v !== 0 ? Number(v.toPrecision(3)) : v;
}

const VIRIDIS = ['#440154', '#46327e', '#365c8d', '#277f8e', '#1fa187', '#4ac16d', '#a0da39', '#fde725'];

/**
 * Parallel coordinates drawn as SVG lines (no WebGL, which Plotly's parcoords needs): one axis per
 * dimension and a last one for the objective, each scaled to [0, 1] (log dimensions on a log
 * scale, choices as evenly spaced ticks, numbers labelled at both ends and three points between);
 * the trials in 8 colour bands of the objective (the best
 * band brightest), each band one trace with gaps between trials. Returns {traces, layout}.
 */
export function parallelPlot(parallel, dimensions, objectiveName, { minimize = false, logs = {} } = {}) {
  const axes = dimensions.map((name) => ({ name, values: parallel.params[name], log: !!logs[name] }));
  axes.push({ name: 'objective', values: parallel.value, log: false });
  const scaled = axes.map((axis) => {
    const numeric = axis.values.every((v) => typeof v === 'number');
    if (!numeric) {
      const labels = [...new Set(axis.values.map(String))].sort();
      const at = (l) => (labels.length > 1 ? labels.indexOf(l) / (labels.length - 1) : 0.5);
      return { y: axis.values.map((v) => at(String(v))), ticks: labels.map((l) => [at(l), l]) };
    }
    const f = axis.log ? (v) => Math.log10(v) : (v) => v;
    const finite = axis.values.filter((v) => isFiniteNumber(v) && (!axis.log || v > 0)).map(f);
    const lo = finite.length ? Math.min(...finite) : 0;
    const hi = finite.length ? Math.max(...finite) : 1;
    const at = (v) => (hi > lo ? (f(v) - lo) / (hi - lo) : 0.5);
    const inv = (t) => (axis.log ? 10 ** (lo + t * (hi - lo)) : lo + t * (hi - lo));
    const ticks = hi > lo ? PARALLEL_TICKS.map((t) => [t, fmtParam(roundTick(inv(t)))]) : [[0.5, fmtParam(inv(0.5))]];
    return { y: axis.values.map((v) => (isFiniteNumber(v) ? at(v) : null)), ticks };
  });
  const objective = parallel.value;
  const finite = objective.filter(isFiniteNumber);
  const lo = finite.length ? Math.min(...finite) : 0;
  const hi = finite.length ? Math.max(...finite) : 1;
  const band = (v) => {
    const t = hi > lo ? (v - lo) / (hi - lo) : 1;
    const k = Math.min(VIRIDIS.length - 1, Math.floor((minimize ? 1 - t : t) * VIRIDIS.length));
    return k;
  };
  const bands = VIRIDIS.map(() => ({ x: [], y: [], n: 0, lo: Infinity, hi: -Infinity }));
  objective.forEach((v, i) => {
    if (!isFiniteNumber(v)) return;
    const b = bands[band(v)];
    for (let a = 0; a < axes.length; a++) { b.x.push(a); b.y.push(scaled[a].y[i]); }
    b.x.push(null); b.y.push(null);
    b.n += 1; b.lo = Math.min(b.lo, v); b.hi = Math.max(b.hi, v);
  });
  const traces = bands.map((b, k) => ({
    type: 'scatter', mode: 'lines', x: b.x, y: b.y, connectgaps: false, hoverinfo: 'skip',
    line: { width: 1.2, color: VIRIDIS[k] }, opacity: 0.75, meta: { kind: 'parallel', band: k, trials: b.n },
    name: b.n ? bandName(b.lo, b.hi) : '', showlegend: b.n > 0,
  })).filter((t) => t.meta.trials > 0);
  const shapes = axes.map((_, a) => ({ type: 'line', x0: a, x1: a, y0: 0, y1: 1, line: { color: '#1d2430', width: 1 } }));
  const annotations = [];
  axes.forEach((axis, a) => {
    annotations.push({ x: a, y: 1.08, text: `<b>${axis.name}</b>`, showarrow: false, xanchor: 'center' });
    for (const [t, label] of scaled[a].ticks) {
      annotations.push({ x: a, y: t, text: label, showarrow: false, xanchor: 'left', xshift: 4, font: { size: 11, color: '#5a6473' },
        bgcolor: 'rgba(255, 255, 255, 0.85)', borderpad: 1 }); // readable where trials' lines cross it
    }
  });
  const layout = {
    xaxis: { visible: false, range: [-0.2, axes.length - 0.6] }, yaxis: { visible: false, range: [-0.05, 1.12] },
    shapes, annotations, hovermode: false,
    legend: { title: { text: `${objectiveName}:`, side: 'top' }, orientation: 'h', x: 0, y: -0.04, yanchor: 'top',
      font: { size: 11 }, entrywidthmode: 'fraction', entrywidth: 0.24 },
    margin: { l: 16, r: 16, t: 16, b: 80 },
  };
  return { traces: traces.reverse(), layout };
}

/**
 * A colour band's legend entry: its lowest and highest objective, with as many digits as tell them apart ("39.31 …
 * 39.34", not "39.3 … 39.3"), or the one value of a band whose trials share it.
 */
export function bandName(lo, hi) {
  if (fmtParam(lo) !== fmtParam(hi)) return `${fmtParam(lo)} … ${fmtParam(hi)}`;
  for (let digits = 5; digits <= 12 && lo !== hi; digits += 1) {
    const [a, b] = [lo, hi].map((v) => Number(v.toPrecision(digits)));
    if (a !== b) return `${a} … ${b}`;
  }
  return fmtParam(lo); // the band's trials share one value
}

