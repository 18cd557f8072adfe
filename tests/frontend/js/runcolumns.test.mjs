import { test } from 'node:test';
import assert from 'node:assert/strict';
import { sortKey, nextSort, sortState, cellText, cellInterval, columnsFromQuery, refreshLimit, sameJob, progressOnly } from '../../../frontend/js/runcolumns.js';

const known = new Set(['learning_rate', 'load_sharing']);

test('columnsFromQuery: three result columns for a configuration, then known parameters once each', () => {
  const cols = columnsFromQuery('mgrao-1:1', 'learning_rate, nope,learning_rate,load_sharing', known);
  assert.deepEqual(cols.map(sortKey), ['final_mean:mgrao-1:1', 'pct_from_uniform:mgrao-1:1', 'pct_of_max:mgrao-1:1',
    'param.learning_rate', 'param.load_sharing']);
  assert.deepEqual(columnsFromQuery('', '', known), []);
});

test('columnsFromQuery: mgrao-max has no "% of max" column (a share of its own gain, 100% in every job)', () => {
  assert.deepEqual(columnsFromQuery('mgrao-max', '', known, 'mgrao-max').map(sortKey),
    ['final_mean:mgrao-max', 'pct_from_uniform:mgrao-max']);
});

test('nextSort toggles the direction of the current key, else starts with the column default', () => {
  assert.equal(nextSort('-created_at', 'param.learning_rate', false), 'param.learning_rate');
  assert.equal(nextSort('param.learning_rate', 'param.learning_rate', false), '-param.learning_rate');
  assert.equal(nextSort('-param.learning_rate', 'param.learning_rate', false), 'param.learning_rate');
  assert.equal(nextSort('name', 'final_mean:mgrao-max', true), '-final_mean:mgrao-max');
  assert.equal(sortState('-final_mean:mgrao-max', 'final_mean:mgrao-max'), 'descending');
  assert.equal(sortState('final_mean:mgrao-max', 'final_mean:mgrao-max'), 'ascending');
  assert.equal(sortState('name', 'final_mean:mgrao-max'), 'none');
});

test('cells: results with their interval, parameters as shown, dashes where a job has no value', () => {
  const [mean, pct, ofMax, rate, sharing] = columnsFromQuery('mgrao-1:1', 'learning_rate,load_sharing', known);
  const job = {
    params: { learning_rate: 0.05, load_sharing: false },
    summaries: { 'mgrao-1:1': { n_runs: 3, final_mean: 1.23456, ci95: [1.1, 1.4], pct_from_uniform: 12.345, pct_ci95: [2, 20.5], pct_of_max: 100 } },
  };
  assert.equal(cellText(job, mean), '1.235');
  assert.equal(cellText(job, pct), '+12.3%');
  assert.equal(cellText(job, ofMax), '100.0%');
  assert.equal(cellText(job, rate), '0.05');
  assert.equal(cellText(job, sharing), 'off');
  assert.equal(cellInterval(job, mean), '95% CI [1.100, 1.400] over 3 seeds');
  assert.equal(cellInterval(job, pct), '95% CI [2.0%, 20.5%] over 3 seeds');
  assert.equal(cellInterval(job, ofMax), '');
  const queued = { params: {}, summaries: {} };
  assert.equal(cellText(queued, mean), '–');
  assert.equal(cellText(queued, rate), '–');
  assert.equal(cellInterval(queued, mean), '');
});

test('refreshLimit reads every shown row again in one request, at least a page, at most the API limit', () => {
  assert.equal(refreshLimit(3, 50), 50);
  assert.equal(refreshLimit(150, 50), 150);
  assert.equal(refreshLimit(400, 50), 200);
});

test('sameJob: a row is redrawn only when the job read again differs', () => {
  const job = { id: 4, status: 'running', progress: 0.25, tags: ['a'], summaries: {} };
  assert.equal(sameJob(job, { ...job, tags: ['a'] }), true);
  assert.equal(sameJob(job, { ...job, progress: 0.5 }), false);
  assert.equal(sameJob(job, { ...job, status: 'succeeded' }), false);
});

test('progressOnly: a moved progress bar alone is patched in place; any other change redraws the row', () => {
  const job = { id: 4, status: 'running', progress: 0.25, tags: ['a'] };
  assert.equal(progressOnly(job, { ...job, progress: 0.5 }), true);
  assert.equal(progressOnly(job, { ...job }), false);
  assert.equal(progressOnly(job, { ...job, progress: 1, status: 'succeeded' }), false);
});

test('exportRows: numbers and plain text, the result configuration and parameter columns', async () => {
  const { exportRows, columnsFromQuery } = await import('../../../frontend/js/runcolumns.js');
  const job = { id: 7, name: 'a, b', status: 'succeeded', kind: 'simulation', system: 'large', saved_system: 'walk-p30',
    algorithms: ['uniform', 'mgrao-2:1'], seeds: [0, 1, 2], episodes: 100, tags: ['x', 'system:walk-p30'],
    created_at: 't0', finished_at: 't1', duration_s: 1.5, params: { learning_rate: 0.1, schedule: [{ episode: 5 }] },
    summaries: { 'mgrao-2:1': { n_runs: 3, n_paired: 3, final_mean: 6.5, ci95: [6, 7], pct_from_uniform: 17.6,
      pct_ci95: [15, 20], pct_of_max: 80 } } };
  const columns = columnsFromQuery('mgrao-2:1', 'learning_rate,schedule', new Set(['learning_rate', 'schedule']));
  const [head, row] = exportRows([job], columns);
  assert.deepEqual(head.slice(-12), ['configuration', 'n_runs', 'n_paired', 'final_mean_utility', 'final_ci95_low_utility',
    'final_ci95_high_utility', 'pct_from_uniform_percent', 'pct_ci95_low_percent', 'pct_ci95_high_percent',
    'pct_of_max_percent', 'learning_rate', 'schedule']);
  assert.deepEqual(row.slice(4, 8), ['large', 'walk-p30', 'uniform mgrao-2:1', 3]);
  assert.deepEqual(row.slice(-12), ['mgrao-2:1', 3, 3, 6.5, 6, 7, 17.6, 15, 20, 80, 0.1, '[{"episode":5}]']);
  assert.equal(exportRows([job], [])[0].length, 13); // without columns: the job's own fields only
});
