// The compare view's panel of statistics across systems (docs/statistics.md): each system's score anchors, the
// aggregates (IQM, mean, median, optimality gap) with stratified bootstrap intervals, performance profiles,
// the probability of improvement and the paired differences as matrices, sample-efficiency curves on demand,
// and the same tables as LaTeX and numeric CSV. It asks the server once the charts above are drawn.

import { api, url } from './api.js';
import { h, notice, downloadWithToken, nextId } from './ui.js';
import { draw, drawWhenSeen, meanBandTraces, bandsBelow, bandAlpha } from './charts.js';
import { fmtNumber } from './stats.js';
import { tableCsvButton } from './chartcontrols.js';
import {
  METRICS, fmtEstimate, aggregatedLabels, aggregateCsv, intervalTraces, intervalLayout, profileSeries,
  efficiencySeries, improvementMatrix, differenceMatrix, pairRows, pairsCsv, anchorRows, significant, tableRepetitions,
} from './comparestats.js';

/** Repetitions of the downloads (a paper's table), as `mgrao compare` prints them. */
export const TABLE_REPETITIONS = 10000;

const DIVERGING = [[0, '#b2182b'], [0.5, '#f7f7f7'], [1, '#2166ac']];

/**
 * The panel for the compared `jobs`: `{element, load}`. `colourOf(label)` is a configuration's colour in the
 * charts above; `load()` asks for the statistics (call it once the charts on screen are drawn).
 */
export function statisticsPanel(jobs, colourOf, { open = true, onToggle = () => {}, signal } = {}) {
  const ids = jobs.join(',');
  const body = h('div', { id: 'stats-body', 'aria-live': 'polite' }, h('p', { class: 'loading' }, 'Statistics load after the charts…'));
  const linksNote = h('span', {}, 'Paper-ready tables (10,000 bootstrap repetitions): ');
  const downloads = [download('LaTeX', 'latex', 'compare.tex'), download('CSV (numbers)', 'csv', 'compare-statistics.csv'),
    download('JSON', 'json', 'compare-statistics.json')];
  const links = h('p', { class: 'stats-downloads' }, linksNote, downloads[0], ' · ', downloads[1], ' · ', downloads[2]);
  const details = h('details', { id: 'stats-panel', open },
    h('summary', {}, h('h2', { id: 'h-stats', class: 'inline' }, 'Statistics across systems')),
    h('p', { class: 'help' }, 'A run’s score is its final utility as the share of the oracle’s gain over uniform on ' +
      'its system (0: uniform, 1: the oracle). Aggregates over systems and seeds as rliable defines them, with 95% ' +
      'stratified bootstrap intervals (seeds resampled within each system). ',
    h('a', { href: '/project-docs/statistics.html' }, 'How each figure is made')), links, body);
  let started = null;
  let armed = false; // the view asked for the statistics (its charts are drawn): opening the panel asks too
  let aggregate = []; // jobs whose worlds stand for their systems, where a system has several worlds

  function aggregateQuery() {
    return aggregate.length ? aggregate.join(',') : undefined;
  }

  function download(text, format, filename, reps = TABLE_REPETITIONS) {
    return h('a', { href: url('/compare/statistics', { jobs: ids, reps, format }), download: filename,
      class: `stats-download stats-${format}`, 'data-format': format, onclick: downloadWithToken }, text);
  }

  function choose(chosen) {
    aggregate = chosen;
    started = null;
    load();
  }

  function load() {
    armed = true;
    if (!details.open) return Promise.resolve(null);
    if (!started) {
      body.replaceChildren(h('p', { class: 'loading' }, 'Computing the statistics…'));
      started = api.compareStatistics(jobs, { aggregate }, { signal }).then(render).catch((e) => {
        if (e.name === 'AbortError') return;
        started = null;
        body.replaceChildren(notice('error', `Cannot compute the statistics: ${e.message}`));
      });
    }
    return started;
  }
  details.addEventListener('toggle', () => { onToggle(details.open); if (details.open && armed) load(); });

  function render(answer) {
    const reps = tableRepetitions(answer, TABLE_REPETITIONS);
    for (const link of downloads) {
      link.href = url('/compare/statistics', { jobs: ids, reps, format: link.dataset.format, aggregate: aggregateQuery() });
    }
    linksNote.textContent = `Paper-ready tables (${reps.toLocaleString('en')} bootstrap repetitions${reps < TABLE_REPETITIONS
      ? ': the most this comparison allows' : ''}): `;
    const labels = aggregatedLabels(answer);
    const colours = Object.fromEntries(Object.values(answer.systems).flatMap((c) => Object.keys(c))
      .map((label) => [label, colourOf(label)]));
    const parts = [anchorsSection(answer), worldChooser(answer, aggregate, choose)];
    if (!labels.length) {
      parts.push(notice('empty', `No aggregates: ${answer.aggregated.reason || 'nothing to aggregate'}.`));
    } else {
      parts.push(aggregatesSection(answer, colours), profilesSection(answer, labels, colours),
        efficiencySection(jobs, labels, colours, signal, aggregate));
    }
    parts.push(headToHeadSection(answer, labels));
    body.replaceChildren(...parts);
    body.dataset.loaded = String(Date.now());
  }
  return { element: details, load };
}

function anchorsSection(answer) {
  const rows = anchorRows(answer);
  const aggregated = answer.aggregated;
  const excluded = Object.entries(aggregated.excluded || {});
  const leftOut = Object.entries(aggregated.left_out || {}).flatMap(([system, labels]) =>
    Object.entries(labels).map(([label, out]) => [system, label, out]));
  return h('section', { id: 'stats-anchors' },
    h('h3', {}, 'Score anchors'),
    h('div', { class: 'table-wrap' }, h('table', { class: 'summary', id: 'anchors-table' },
      h('thead', {}, h('tr', {}, ['System', 'Uniform (mean final)', 'Oracle (mean final)', 'Gain [95% CI]', 'Seeds', 'Scores']
        .map((c) => h('th', { scope: 'col' }, c)))),
      h('tbody', {}, rows.map((r) => h('tr', { class: r.valid ? '' : 'muted' },
        h('th', { scope: 'row' }, r.system),
        h('td', { class: 'num' }, fmtNumber(r.uniform)),
        h('td', { class: 'num' }, fmtNumber(r.oracle)),
        h('td', { class: 'num' }, fmtEstimate({ estimate: r.gain, ci95: r.gain_ci95 })),
        h('td', { class: 'num' }, r.n_seeds),
        h('td', { class: 'anchor-state' }, r.valid ? (r.caveats.length
          ? h('span', { title: r.caveats.join('; ') }, '⚠ oracle no upper bound: ', r.caveats.join('; '))
          : 'yes') : `none: ${r.reason}`)))))),
    aggregated.systems.length ? h('p', { class: 'help', id: 'aggregated-note' },
      `Aggregates over ${aggregated.systems.length} system${aggregated.systems.length > 1 ? 's' : ''}, each on its ` +
      `anchor seeds, those with both a uniform and an oracle run (` +
      `${aggregated.systems.map((s) => `${s}: ${aggregated.n_seeds[s]} seeds, ${seedRange(aggregated.seeds[s])}`).join('; ')}). ` +
      `Each system weighs the same, whatever its seeds.`) : null,
    leftOut.length ? h('ul', { class: 'help', id: 'left-out-list' }, leftOut.map(([system, label, out]) =>
      h('li', {}, `${system}, ${label}: seeds ${seedRange(out.seeds)} not scored (${out.reason}).`))) : null,
    excluded.length ? h('ul', { class: 'help', id: 'excluded-list' }, excluded.map(([label, reason]) =>
      h('li', {}, `${label}: not aggregated (${reason}).`))) : null);
}

/**
 * Where a system has several worlds among the jobs (other episodes or parameters), a choice of the one that stands
 * for it in the aggregates: `choose(jobIds)` asks again with them.
 */
function worldChooser(answer, chosen, choose) {
  const systems = Object.entries(answer.aggregated.worlds_of_system || {});
  if (!systems.length) return null;
  const jobOf = {};
  for (const c of answer.configurations || []) {
    if (!(c.system in jobOf) && c.job_ids.length) jobOf[c.system] = c.job_ids[0];
  }
  const selects = systems.map(([system, worlds]) => {
    const picked = worlds.find((w) => chosen.includes(jobOf[w]));
    return [system, h('select', { id: `aggregate-${system}`, 'data-system': system },
      h('option', { value: '', selected: !picked }, 'choose a world…'),
      worlds.map((w) => h('option', { value: String(jobOf[w]), selected: w === picked }, w)))];
  });
  const apply = () => choose(selects.map(([, s]) => Number(s.value)).filter((v) => v));
  for (const [, s] of selects) s.addEventListener('change', apply);
  return h('section', { id: 'stats-worlds' },
    h('p', { class: 'help' }, 'Several worlds of one system share their seeds’ draws: they are not separate tasks, so ' +
      'each system is aggregated once. Choose the world that stands for it:'),
    selects.map(([system, s]) => h('label', { class: 'world-choice' }, `${system}: `, s)));
}

/** A matrix chart's height for `n` rows: 44 px a row, room for the slanted labels below. */
function matrixHeight(n) {
  return 140 + 44 * Math.max(2, n);
}

function seedRange(seeds) {
  if (!seeds || !seeds.length) return 'none';
  const contiguous = seeds.every((s, i) => i === 0 || s === seeds[i - 1] + 1);
  return contiguous ? `${seeds[0]}–${seeds[seeds.length - 1]}` : `${seeds.length} seeds from ${seeds[0]}`;
}

function aggregatesSection(answer, colours) {
  const labels = aggregatedLabels(answer);
  const table = h('table', { class: 'summary', id: 'aggregates-table' },
    h('thead', {}, h('tr', {}, h('th', { scope: 'col' }, 'Configuration'),
      METRICS.map(([, title]) => h('th', { scope: 'col' }, `${title} [95% CI]`)))),
    h('tbody', {}, labels.map((label) => h('tr', {},
      h('th', { scope: 'row' }, h('span', { class: 'dot', style: `background: ${colours[label]}`, 'aria-hidden': 'true' }), label),
      METRICS.map(([m]) => h('td', { class: 'num ci' }, fmtEstimate(answer.aggregate[label][m])))))));
  const chart = h('div', { class: 'chart', id: 'stats-intervals', role: 'img',
    'aria-label': 'Aggregate scores with 95% bootstrap intervals, one panel per metric' });
  const layout = intervalLayout(answer);
  chart.style.height = `${layout.height}px`;
  drawWhenSeen(chart, () => draw(chart, intervalTraces(answer, colours), layout))
    .then(() => { chart.dataset.rendered = String(Date.now()); });
  return h('section', { id: 'stats-aggregates' },
    h('h3', {}, 'Aggregate scores ', tableCsvButton('compare-aggregates.csv', () => aggregateCsv(answer))),
    chart, h('div', { class: 'table-wrap' }, table),
    h('p', { class: 'help' }, 'IQM: mean of the middle 50% of all runs’ scores; mean and median: of the systems’ mean ' +
      'scores; optimality gap: how far the scores fall short of 1 (the oracle), on average. Higher is better, but for ' +
      'the optimality gap.'));
}

function profilesSection(answer, labels, colours) {
  const chart = h('div', { class: 'chart', id: 'stats-profiles', role: 'img',
    'aria-label': 'Performance profiles: the share of runs with a score above tau, with 95% bands' });
  chart.style.height = '360px';
  const traces = labels.flatMap((label) => meanBandTraces(label, profileSeries(answer, label), colours[label], 1, label,
    'solid', { fillAlpha: bandAlpha(labels.length) }));
  drawWhenSeen(chart, () => draw(chart, bandsBelow(traces), {
    xaxis: { title: { text: 'score τ (share of the oracle’s gain)' }, zeroline: false },
    yaxis: { title: { text: 'share of runs with score > τ' }, range: [0, 1.02] }, hovermode: 'x unified', height: 360,
    margin: { l: 64, r: 16, t: 16, b: 110 }, legend: { orientation: 'h', y: -0.3, x: 0 },
  })).then(() => { chart.dataset.rendered = String(Date.now()); });
  return h('section', { id: 'stats-profile' }, h('h3', {}, 'Performance profiles'), chart,
    h('p', { class: 'help' }, 'Each curve: the share of all runs (every seed of every system) scoring above τ; a curve ' +
      'above another everywhere dominates it. Bands: 95% stratified bootstrap.'));
}

function efficiencySection(jobs, labels, colours, signal, aggregate) {
  const chart = h('div', { class: 'chart', id: 'stats-efficiency', role: 'img', hidden: true,
    'aria-label': 'IQM of the scores per bucket of episodes, with 95% bands' });
  chart.style.height = '360px';
  const status = h('p', { class: 'help', 'aria-live': 'polite' });
  const button = h('button', { type: 'button', class: 'secondary', id: 'efficiency-button', onclick: async () => {
    button.disabled = true;
    status.textContent = 'Computing IQM per bucket of episodes (50 buckets, 1,000 repetitions)…';
    try {
      const curves = await api.compareSampleEfficiency(jobs, { aggregate }, { signal });
      const traces = [];
      let byShare = false;
      for (const label of labels.filter((l) => curves.curves[l])) {
        const { series, byShare: share } = efficiencySeries(curves, label);
        byShare = share;
        traces.push(...meanBandTraces(label, series, colours[label], 1, label, 'solid', { fillAlpha: bandAlpha(labels.length) }));
      }
      chart.hidden = false;
      await draw(chart, bandsBelow(traces), {
        xaxis: { title: { text: byShare ? 'share of the run' : 'Episode' }, zeroline: false },
        yaxis: { title: { text: 'IQM score' }, zeroline: true }, height: 360, hovermode: 'x unified',
        margin: { l: 64, r: 16, t: 16, b: 110 }, legend: { orientation: 'h', y: -0.3, x: 0 },
      });
      chart.dataset.rendered = String(Date.now());
      status.textContent = 'Each point: the IQM of all runs’ mean utility over a bucket of episodes, scored with the ' +
        'system’s final anchors; bands: 95% stratified bootstrap.';
    } catch (e) {
      if (e.name === 'AbortError') return;
      status.textContent = `Cannot compute the curves: ${e.message}`;
      button.disabled = false;
    }
  } }, 'Draw IQM per episode');
  return h('section', { id: 'stats-sample-efficiency' }, h('h3', {}, 'Sample efficiency'),
    h('p', { class: 'help' }, 'How fast each configuration learns, on the same scores: asked for on demand (it reads ' +
      'every episode of every run).'), button, status, chart);
}

function headToHeadSection(answer, labels) {
  const parts = [h('h3', {}, 'Head to head')];
  if (labels.length > 1) {
    const m = improvementMatrix(answer);
    const chart = h('div', { class: 'chart', id: 'stats-poi', role: 'img',
      'aria-label': 'Probability of improvement of each row over each column' });
    chart.style.height = `${matrixHeight(m.labels.length)}px`;
    drawWhenSeen(chart, () => draw(chart, [{
      type: 'heatmap', z: m.z, x: m.labels, y: m.labels, text: m.text, texttemplate: '%{text}', customdata: m.ci,
      zmin: 0, zmax: 1, colorscale: DIVERGING, colorbar: { title: { text: 'P(row > col)' } }, xgap: 2, ygap: 2,
      hovertemplate: 'P(%{y} > %{x}) = %{z:.3f} [%{customdata[0]:.3f}, %{customdata[1]:.3f}]<extra></extra>',
    }], { height: matrixHeight(m.labels.length), margin: { l: 150, r: 16, t: 16, b: 120 }, hovermode: 'closest',
      xaxis: { type: 'category', tickangle: -30 }, yaxis: { type: 'category', autorange: 'reversed' } }))
      .then(() => { chart.dataset.rendered = String(Date.now()); });
    parts.push(h('p', { class: 'help' }, 'P(row > column): the chance that a run of the row’s configuration scores above a run of the column’s ' +
      'on the same system, averaged over systems, with its 95% bootstrap interval on hover. Blue: the row tends to win.'),
    chart);
  }
  const systems = Object.keys(answer.systems).filter((s) => differenceMatrix(answer, s).labels.length > 1);
  if (systems.length) {
    const selectId = nextId('h2h-system');
    const select = h('select', { id: selectId }, systems.map((s) => h('option', { value: s }, s)));
    const chart = h('div', { class: 'chart', id: 'stats-differences', role: 'img',
      'aria-label': 'Paired difference in % from uniform of each row minus each column' });
    const drawDifferences = () => {
      const d = differenceMatrix(answer, select.value);
      chart.style.height = `${matrixHeight(d.labels.length)}px`;
      const limit = Math.max(1, ...d.z.flat().filter((v) => v !== null).map(Math.abs));
      const custom = d.pairs.map((row) => row.map((p) => [p ? p.p_holm : null, p ? p.n_paired : null]));
      return draw(chart, [{
        type: 'heatmap', z: d.z, x: d.labels, y: d.labels, text: d.text, texttemplate: '%{text}', customdata: custom,
        zmin: -limit, zmax: limit, colorscale: DIVERGING, colorbar: { title: { text: 'row − col (pts)' } }, xgap: 2, ygap: 2,
        hovertemplate: '%{y} − %{x}: %{z:.2f} points of % from uniform<br>Holm-adjusted p %{customdata[0]:.3g}, ' +
          '%{customdata[1]} paired seeds<extra></extra>',
      }], { height: matrixHeight(d.labels.length), margin: { l: 150, r: 16, t: 16, b: 120 }, hovermode: 'closest',
        xaxis: { type: 'category', tickangle: -30 }, yaxis: { type: 'category', autorange: 'reversed' } })
        .then(() => { chart.dataset.rendered = String(Date.now()); });
    };
    select.addEventListener('change', drawDifferences);
    drawWhenSeen(chart, drawDifferences);
    const rows = pairRows(answer);
    const table = h('table', { class: 'summary', id: 'pairs-table' },
      h('thead', {}, h('tr', {}, ['System', 'X', 'Y', 'Paired seeds', 'X − Y (points)', '95% CI', 'p (Wilcoxon)',
        'p (Holm)', 'Verdict'].map((c) => h('th', { scope: 'col' }, c)))),
      h('tbody', {}, rows.map((p) => h('tr', { class: significant(p) ? 'significant' : '' },
        h('td', {}, p.system), h('td', {}, p.x), h('td', {}, p.y), h('td', { class: 'num' }, p.n_paired),
        h('td', { class: 'num' }, fmtNumber(p.difference, 2)),
        h('td', { class: 'num ci' }, p.ci95 ? `[${fmtNumber(p.ci95[0], 2)}, ${fmtNumber(p.ci95[1], 2)}]` : '–'),
        h('td', { class: 'num' }, p.p_value === null ? '–' : p.p_value.toPrecision(2)),
        h('td', { class: 'num' }, p.p_holm === null ? '–' : p.p_holm.toPrecision(2)),
        h('td', {}, p.verdict)))));
    parts.push(h('p', { class: 'help' }, `Paired difference in % from uniform (row minus column) over the seeds both ` +
      `share with uniform; * marks a two-sided Wilcoxon signed-rank test significant at 5% after Holm’s adjustment over ` +
      `all ${answer.head_to_head.tests} tests.`),
    h('p', { class: 'controls' }, h('label', { for: selectId }, 'System'), select), chart,
    h('details', {}, h('summary', {}, 'Every pair ', tableCsvButton('compare-paired-tests.csv', () => pairsCsv(answer))),
      h('div', { class: 'table-wrap' }, table)));
  }
  return h('section', { id: 'stats-head-to-head' }, ...parts);
}
