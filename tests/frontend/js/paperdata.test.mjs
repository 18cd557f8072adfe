import { test } from 'node:test';
import assert from 'node:assert/strict';
import { paperRows, agreement, choosePaperJob, seedPercentile, fmtSeedPercentile } from '../../../frontend/js/paperdata.js';

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

const sys = { name: 'single', paper: { 'mgrao-max': 28.0, 'mgrao-1:1': 23.4 }, paper_config_hash: 'h' };
const job = (id, seeds, extra = {}) => ({ id, system: 'single', status: 'succeeded', episodes: 100, config_hash: 'h',
  algorithms: ['uniform', 'mgrao-1:1', 'mgrao-max'], seeds: Array.from({ length: seeds }, (_, i) => i),
  created_at: `2026-01-${String(id).padStart(2, '0')}T00:00:00.000Z`, tags: [], ...extra });

test('choosePaperJob: the most seeds, then the newest; never a job that is not the paper experiment', () => {
  const hundred = job(1, 100);
  const cloneOfTen = job(5, 10, { tags: ['paper'] });  // newer, tagged: a clone must not replace the 100 seeds
  assert.equal(choosePaperJob(sys, [cloneOfTen, hundred]).id, 1);
  assert.equal(choosePaperJob(sys, [hundred, job(3, 100)]).id, 3);  // equal seeds: the newest
  assert.equal(choosePaperJob(sys, [job(9, 200, { status: 'failed' }), job(8, 200, { episodes: 50 }),
    job(7, 200, { config_hash: 'other' }), job(6, 200, { algorithms: ['uniform', 'mgrao-max'] }),
    job(4, 200, { system: 'multi' }), hundred]).id, 1);
  assert.equal(choosePaperJob(sys, []), null);
  // a system that is no paper experiment (drift, bursty: paper_config_hash null) has no paper job at all
  const drift = { name: 'drift', paper: {}, paper_config_hash: null };
  assert.equal(choosePaperJob(drift, [job(2, 100, { system: 'drift', config_hash: 'd' })]), null);
});

test('seedPercentile: the share of our seeds below the paper, ties counting half', () => {
  const p = seedPercentile([10, 20, 30, 40], 25);
  assert.deepEqual([p.percentile, p.below, p.above, p.n, p.min, p.max], [50, 2, 2, 4, 10, 40]);
  assert.equal(seedPercentile([10, 20, 30, 40], 20).percentile, 37.5);
  assert.equal(seedPercentile([10, null, 30], 5).percentile, 0);
  assert.equal(seedPercentile([], 5), null);
  assert.equal(seedPercentile([1, 2], null), null);
});

test('fmtSeedPercentile says below or above all, else an ordinal percentile', () => {
  assert.equal(fmtSeedPercentile(seedPercentile([10, 20], 5)), 'below all 2');
  assert.equal(fmtSeedPercentile(seedPercentile([10, 20], 25)), 'above all 2');
  assert.deepEqual([1, 2, 3, 4, 11, 12, 13, 21, 22, 42, 50].map((n) => fmtSeedPercentile({ percentile: n, below: 1, above: 1, n: 9 })),
    ['1st percentile', '2nd percentile', '3rd percentile', '4th percentile', '11th percentile', '12th percentile',
      '13th percentile', '21st percentile', '22nd percentile', '42nd percentile', '50th percentile']);
  assert.equal(fmtSeedPercentile(null), '–');
});

test('paperRows: where the paper falls among our seeds, from the results\' pct_by_seed', () => {
  const withSeeds = { job: { id: 4 }, configurations: [
    { algorithm: 'mgrao-max', summary: { n_runs: 4, pct_from_uniform: 25, pct_ci95: [20, 30], pct_of_max: 100 },
      pct_by_seed: [15, 22, 29, 34].map((v, seed) => ({ seed, pct_from_uniform: v })) },
  ] };
  const rows = paperRows(schema, { single: withSeeds });
  const max = rows.find((r) => r.algorithm === 'mgrao-max' && r.system === 'single');
  assert.deepEqual([max.amongSeeds.below, max.amongSeeds.n, max.amongSeeds.percentile], [2, 4, 50]);
  assert.equal(rows.find((r) => r.algorithm === 'mgrao-1:1').amongSeeds, null);
});

test('decidingDigits: one decimal unless rounding hides which side of the interval the paper lies', async () => {
  const { decidingDigits } = await import('../../../frontend/js/stats.js');
  assert.equal(decidingDigits([23.31, 27.99], 28.0), 2); // outside by 0.01: +27.99% against +28.00%
  assert.equal(decidingDigits([23.31, 27.2], 28.0), 1); // plainly outside
  assert.equal(decidingDigits([23.31, 28.04], 28.0), 1); // within, and reads within
  assert.equal(decidingDigits([23.31, 27.9999], 28.0), 4); // at most four
  assert.equal(decidingDigits(null, 28.0), 1);
});
