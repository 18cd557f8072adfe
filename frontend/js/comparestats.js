// The compare view's statistics across systems (GET /api/compare/statistics, docs/statistics.md) as rows,
// matrices and traces: aggregates with their intervals, performance profiles, sample-efficiency curves, the
// probability of improvement and the paired differences. Pure functions (no DOM), checked by node's test runner;
// every figure is the server's, none is computed here.

import { fmtNumber, isFiniteNumber } from './stats.js';

/** The aggregate metrics in the order views show them, with their titles. */
export const METRICS = [['iqm', 'IQM'], ['mean', 'Mean'], ['median', 'Median'], ['optimality_gap', 'Optimality gap']];

/** "0.503 [0.428, 0.582]": an estimate and its interval. */
export function fmtEstimate(e, digits = 3) {
  if (!e || !isFiniteNumber(e.estimate)) return '–';
  const f = (x) => (Math.abs(x) < 0.5 * 10 ** -digits ? (0).toFixed(digits) : fmtNumber(x, digits)); // 1e-16 is 0
  const ci = Array.isArray(e.ci95) && isFiniteNumber(e.ci95[0]) && isFiniteNumber(e.ci95[1])
    ? ` [${f(e.ci95[0])}, ${f(e.ci95[1])}]` : '';
  return `${f(e.estimate)}${ci}`;
}

/** The aggregated configurations' labels, in the answer's order. */
export function aggregatedLabels(answer) {
  return Object.keys((answer && answer.aggregate) || {});
}

/** CSV rows (header first) of the aggregates: numbers, the unit (score) in the column names. */
export function aggregateCsv(answer) {
  const head = ['configuration', ...METRICS.flatMap(([m]) => [`${m}_score`, `${m}_ci95_low_score`, `${m}_ci95_high_score`])];
  return [head, ...aggregatedLabels(answer).map((label) => [label, ...METRICS.flatMap(([m]) => {
    const e = answer.aggregate[label][m] || {};
    return [e.estimate ?? null, ...(Array.isArray(e.ci95) ? e.ci95 : [null, null])];
  })])];
}

/**
 * rliable's interval plot: one panel per metric (x: the metric, y: the configurations), each configuration a
 * point at its estimate with its 95% interval as an error bar. `colours[label]` colours it.
 */
export function intervalTraces(answer, colours = {}) {
  const labels = aggregatedLabels(answer);
  return METRICS.map(([metric, title], k) => {
    const est = labels.map((l) => answer.aggregate[l][metric].estimate);
    const ci = labels.map((l) => answer.aggregate[l][metric].ci95 || [null, null]);
    return {
      type: 'scatter', mode: 'markers', name: title, showlegend: false, y: labels, x: est,
      xaxis: k ? `x${k + 1}` : 'x', yaxis: 'y',
      marker: { size: 9, color: labels.map((l) => colours[l] || '#1d2430'), symbol: 'line-ns-open', line: { width: 3 } },
      error_x: { type: 'data', symmetric: false, thickness: 10, width: 0,
        array: ci.map((c, i) => (isFiniteNumber(c[1]) ? c[1] - est[i] : 0)),
        arrayminus: ci.map((c, i) => (isFiniteNumber(c[0]) ? est[i] - c[0] : 0)),
        color: 'rgba(29, 36, 48, 0.35)' },
      customdata: ci,
      hovertemplate: `%{y}<br>${title} %{x:.3f} [%{customdata[0]:.3f}, %{customdata[1]:.3f}]<extra></extra>`,
    };
  });
}

/** The interval plot's layout: the panels side by side, the configurations top to bottom in answer order. */
export function intervalLayout(answer) {
  const n = aggregatedLabels(answer).length;
  const gap = 0.04;
  const width = (1 - gap * (METRICS.length - 1)) / METRICS.length;
  const layout = {
    height: 90 + 28 * Math.max(2, n), margin: { l: 150, r: 16, t: 36, b: 40 }, hovermode: 'closest',
    yaxis: { autorange: 'reversed', automargin: true, type: 'category' },
    annotations: [],
  };
  METRICS.forEach(([, title], k) => {
    const axis = k ? `xaxis${k + 1}` : 'xaxis';
    layout[axis] = { domain: [k * (width + gap), k * (width + gap) + width], zeroline: false,
      title: { text: 'score', font: { size: 11 } } };
    layout.annotations.push({ text: `<b>${title}</b>`, showarrow: false, xref: 'paper', yref: 'paper',
      x: k * (width + gap) + width / 2, y: 1, yanchor: 'bottom', xanchor: 'center' });
  });
  return layout;
}

/** A performance profile as the `{episode, mean, low, high}` series the band traces take (x: tau). */
export function profileSeries(answer, label) {
  const p = answer.performance_profiles.profiles[label];
  return { episode: answer.performance_profiles.tau, mean: p.share, low: p.low, high: p.high };
}

/**
 * A sample-efficiency curve as a band series. x is each bucket's first episode where every system has the same
 * episodes, else the share of the run the bucket starts at (`byShare` true).
 */
export function efficiencySeries(curves, label) {
  const lists = Object.values(curves.episodes || {});
  const same = lists.every((l) => JSON.stringify(l) === JSON.stringify(lists[0]));
  const c = curves.curves[label];
  const x = same && lists.length ? lists[0] : c.iqm.map((_, k) => k / c.iqm.length);
  return { series: { episode: x, mean: c.iqm, low: c.low, high: c.high }, byShare: !(same && lists.length) };
}

/**
 * The probability-of-improvement matrix: rows X, columns Y, `z[i][j]` = P(X > Y), null on the diagonal;
 * `text` each cell's estimate, `ci` its interval.
 */
export function improvementMatrix(answer) {
  const labels = aggregatedLabels(answer);
  const poi = answer.probability_of_improvement || {};
  const cell = (x, y) => (x === y ? null : poi[`${x}>${y}`] || null);
  return {
    labels,
    z: labels.map((x) => labels.map((y) => (cell(x, y) ? cell(x, y).estimate : null))),
    text: labels.map((x) => labels.map((y) => (cell(x, y) ? cell(x, y).estimate.toFixed(2) : ''))),
    ci: labels.map((x) => labels.map((y) => (cell(x, y) ? cell(x, y).ci95 : [null, null]))),
  };
}

/** Whether a paired difference is significant at 5% after Holm's adjustment. */
export function significant(pair) {
  return pair && isFiniteNumber(pair.p_holm) && pair.p_holm < 0.05;
}

/** One system's configurations that have paired tests, in answer order. */
export function pairedLabels(answer, system) {
  const order = Object.keys((answer.systems || {})[system] || {});
  const seen = new Set();
  for (const p of answer.head_to_head.pairs) if (p.system === system) { seen.add(p.x); seen.add(p.y); }
  return order.filter((l) => seen.has(l));
}

/**
 * One system's paired differences as a matrix: `z[i][j]` = row minus column in % from uniform (antisymmetric),
 * `text` with a `*` where Holm's adjusted p is below 0.05, `pairs[i][j]` the pair as the answer gives it.
 */
export function differenceMatrix(answer, system) {
  const labels = pairedLabels(answer, system);
  const find = {};
  for (const p of answer.head_to_head.pairs) if (p.system === system) find[`${p.x}|${p.y}`] = p;
  const pairs = labels.map((x) => labels.map((y) => find[`${x}|${y}`] || find[`${y}|${x}`] || null));
  const z = labels.map((x, i) => labels.map((y, j) => {
    const p = pairs[i][j];
    if (!p || !isFiniteNumber(p.difference)) return null;
    return p.x === x ? p.difference : -p.difference;
  }));
  const text = z.map((row, i) => row.map((v, j) => (v === null ? '' : `${v > 0 ? '+' : ''}${v.toFixed(1)}${significant(pairs[i][j]) ? '*' : ''}`)));
  return { labels, z, text, pairs };
}

/** The paired tests' rows for a table or CSV: each pair once, as the answer orders them. */
export function pairRows(answer) {
  return answer.head_to_head.pairs.map((p) => ({ ...p, verdict: verdict(p) }));
}

/**
 * "mgrao-max better", "no significant difference", "too few pairs": what the Holm-adjusted signed-rank test
 * says, on the side it leans to (`favours`: its ranks, not the mean difference's sign, which can disagree).
 */
export function verdict(p) {
  if (!p || !isFiniteNumber(p.p_holm)) return 'too few pairs';
  if (p.p_holm >= 0.05 || !p.favours) return 'no significant difference';
  return `${p.favours === 'x' ? p.x : p.y} better`;
}

/** The repetitions of a paper-ready table: 10,000, or the most the comparison allows where that is fewer. */
export function tableRepetitions(answer, wanted = 10000) {
  const most = answer && answer.protocol && answer.protocol.max_repetitions;
  return isFiniteNumber(most) ? Math.max(1, Math.min(wanted, most)) : wanted;
}

/** CSV rows (header first) of the paired tests: numbers, units in the column names. */
export function pairsCsv(answer) {
  const head = ['system', 'x', 'y', 'n_paired', 'difference_pct_points', 'ci95_low_pct_points', 'ci95_high_pct_points',
    'p_value', 'p_holm'];
  return [head, ...answer.head_to_head.pairs.map((p) => [p.system, p.x, p.y, p.n_paired, p.difference,
    ...(Array.isArray(p.ci95) ? p.ci95 : [null, null]), p.p_value, p.p_holm])];
}

/** The systems' score anchors as rows: uniform's and the oracle's means, the gain, whether it scores and why not. */
export function anchorRows(answer) {
  return Object.entries(answer.normalisation || {}).map(([system, a]) => ({ system, ...a }));
}
