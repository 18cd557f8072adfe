import { test } from 'node:test';
import assert from 'node:assert/strict';
import { paperRows, agreement } from '../../../frontend/js/paperdata.js';

const schema = { systems: [
  { name: 'single', paper: { 'mgrao-max': 28.0, 'mgrao-1:1': 23.4 }, paper_pct_of_max: { 'mgrao-max': 100, 'mgrao-1:1': 83.7 } },
  { name: 'large', paper: { 'mgrao-max': 10.0 }, paper_pct_of_max: {} },
] };
const single = { job: { id: 4 }, configurations: [
  { algorithm: 'mgrao-max', summary: { n_runs: 30, pct_from_uniform: 25.6, pct_ci95: [22.0, 29.1], pct_of_max: 100 } },
  { algorithm: 'mgrao-1:1', summary: { n_runs: 30, pct_from_uniform: 19.1, pct_ci95: [16.0, 22.0], pct_of_max: 74.6 } },
] };

test('paperRows: ours beside the paper, flagged where the paper lies outside our interval', () => {
  const rows = paperRows(schema, { single });
  assert.equal(rows.length, 3);
  const max = rows.find((r) => r.algorithm === 'mgrao-max' && r.system === 'single');
  assert.deepEqual([max.ours, max.ci, max.paper, max.outside, max.oursOfMax, max.paperOfMax, max.jobId],
    [25.6, [22.0, 29.1], 28.0, false, 100, 100, 4]);
  const one = rows.find((r) => r.algorithm === 'mgrao-1:1');
  assert.equal(one.outside, true);  // 23.4 is above [16, 22]
  const large = rows.find((r) => r.system === 'large');
  assert.deepEqual([large.ours, large.outside, large.paperOfMax, large.jobId], [null, null, null, null]);
});

test('agreement counts the judged figures and says what has not run', () => {
  assert.equal(agreement(paperRows(schema, { single })),
    "1 of 2 figures hold the paper's value within our 95% interval (1 not run yet).");
});
