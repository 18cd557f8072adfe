import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  METRICS, fmtEstimate, aggregatedLabels, aggregateCsv, intervalTraces, intervalLayout, profileSeries, efficiencySeries,
  improvementMatrix, differenceMatrix, pairRows, pairsCsv, verdict, anchorRows, tableRepetitions,
} from '../../../frontend/js/comparestats.js';

const e = (estimate, lo, hi) => ({ estimate, ci95: [lo, hi] });
const aggregate = (k) => ({ mean: e(k, k - 0.1, k + 0.1), median: e(k, k - 0.2, k + 0.2), iqm: e(k + 0.01, k - 0.1, k + 0.1),
  optimality_gap: e(1 - k, 0.9 - k, 1.1 - k) });
const answer = {
  systems: { single: { uniform: {}, 'mgrao-max': {}, oracle: {} }, large: { uniform: {}, 'mgrao-max': {}, oracle: {} } },
  normalisation: { single: { uniform: 1, oracle: 1.6, gain: 0.6, gain_ci95: [0.5, 0.7], n_seeds: 10, valid: true, reason: null, caveats: [] } },
  aggregate: { uniform: aggregate(0), 'mgrao-max': aggregate(0.5), oracle: aggregate(1) },
  aggregated: { systems: ['single', 'large'], seeds: { single: [0, 1], large: [0, 1] }, n_seeds: 2, excluded: {}, reason: null },
  performance_profiles: { tau: [0, 0.5, 1], profiles: { oracle: { share: [1, 1, 0.5], low: [1, 0.9, 0.3], high: [1, 1, 0.7] } } },
  probability_of_improvement: {
    'uniform>mgrao-max': e(0.2, 0.1, 0.3), 'mgrao-max>uniform': e(0.8, 0.7, 0.9),
    'uniform>oracle': e(0, 0, 0), 'oracle>uniform': e(1, 1, 1),
    'mgrao-max>oracle': e(0.3, 0.2, 0.4), 'oracle>mgrao-max': e(0.7, 0.6, 0.8),
  },
  head_to_head: { tests: 3, pairs: [
    { system: 'single', x: 'uniform', y: 'mgrao-max', n_paired: 10, difference: -25, ci95: [-28, -22], p_value: 0.001, p_holm: 0.003, favours: 'y' },
    { system: 'single', x: 'uniform', y: 'oracle', n_paired: 10, difference: -60, ci95: [-66, -55], p_value: 0.001, p_holm: 0.003, favours: 'y' },
    { system: 'single', x: 'mgrao-max', y: 'oracle', n_paired: 10, difference: -3, ci95: [-9, 3], p_value: 0.3, p_holm: 0.3, favours: 'y' },
  ] },
};

test('fmtEstimate: the estimate and its interval, a dash without one', () => {
  assert.equal(fmtEstimate(e(0.5, 0.4, 0.6)), '0.500 [0.400, 0.600]');
  assert.equal(fmtEstimate(null), '–');
  assert.equal(fmtEstimate({ estimate: 0.25, ci95: [null, null] }), '0.250');
});

test('aggregates: rows of numbers for CSV, an interval panel per metric in the answer order', () => {
  assert.deepEqual(aggregatedLabels(answer), ['uniform', 'mgrao-max', 'oracle']);
  const csv = aggregateCsv(answer);
  assert.deepEqual(csv[0].slice(0, 4), ['configuration', 'iqm_score', 'iqm_ci95_low_score', 'iqm_ci95_high_score']);
  assert.deepEqual(csv[2].slice(0, 4), ['mgrao-max', 0.51, 0.4, 0.6]);
  const traces = intervalTraces(answer, { oracle: '#56B4E9' });
  assert.equal(traces.length, METRICS.length);
  assert.deepEqual(traces[1].x, [0, 0.5, 1]);
  assert.equal(traces[1].xaxis, 'x2');
  assert.ok(Math.abs(traces[1].error_x.array[1] - 0.1) < 1e-12 && Math.abs(traces[1].error_x.arrayminus[1] - 0.1) < 1e-12);
  assert.equal(traces[0].marker.color[2], '#56B4E9');
  const layout = intervalLayout(answer);
  assert.ok(layout.xaxis4.domain[1] <= 1 && layout.xaxis.domain[0] === 0);
});

test('profiles and curves as band series; curves by share of the run when the systems differ in episodes', () => {
  assert.deepEqual(profileSeries(answer, 'oracle'), { episode: [0, 0.5, 1], mean: [1, 1, 0.5], low: [1, 0.9, 0.3], high: [1, 1, 0.7] });
  const curve = { curves: { oracle: { iqm: [0.5, 1], low: [0.4, 0.9], high: [0.6, 1.1] } } };
  assert.deepEqual(efficiencySeries({ ...curve, episodes: { a: [0, 50], b: [0, 50] } }, 'oracle').series.episode, [0, 50]);
  const mixed = efficiencySeries({ ...curve, episodes: { a: [0, 50], b: [0, 500] } }, 'oracle');
  assert.deepEqual(mixed.series.episode, [0, 0.5]);
  assert.equal(mixed.byShare, true);
});

test('head to head: P(row > column) with a blank diagonal; paired differences antisymmetric, starred by Holm', () => {
  const m = improvementMatrix(answer);
  assert.deepEqual(m.z, [[null, 0.2, 0], [0.8, null, 0.3], [1, 0.7, null]]);
  assert.equal(m.text[1][0], '0.80');
  const d = differenceMatrix(answer, 'single');
  assert.deepEqual(d.labels, ['uniform', 'mgrao-max', 'oracle']);
  assert.deepEqual(d.z[0], [null, -25, -60]);
  assert.deepEqual(d.z[2], [60, 3, null]);
  assert.deepEqual(d.text[1], ['+25.0*', '', '-3.0']);
  assert.deepEqual(differenceMatrix(answer, 'large').labels, []);
  assert.deepEqual(pairRows(answer).map((p) => p.verdict), ['mgrao-max better', 'oracle better', 'no significant difference']);
  assert.equal(verdict({ p_holm: null }), 'too few pairs');
  // the side is the signed-rank test's, even where the mean difference (skewed by one seed) points the other way
  assert.equal(verdict({ x: 'a', y: 'b', difference: 2, p_holm: 0.01, favours: 'y' }), 'b better');
  assert.deepEqual(pairsCsv(answer)[1], ['single', 'uniform', 'mgrao-max', 10, -25, -28, -22, 0.001, 0.003]);
  assert.deepEqual(anchorRows(answer).map((r) => r.system), ['single']);
  assert.equal(tableRepetitions({ protocol: { max_repetitions: 4500 } }), 4500);
  assert.equal(tableRepetitions({ protocol: { max_repetitions: 50000 } }), 10000);
});

test('fmtEstimate: a rounding residue is shown as the zero it is', () => {
  assert.equal(fmtEstimate(e(1.1e-16, -0.27, 0.25)), '0.000 [-0.270, 0.250]');
});
