import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  movingAverage, smoothSeries, bandPolygon, sortAlgorithms, parseRatios, parseTags, parseIds,
  parseHash, buildHash, fieldErrors, fmtNumber, fmtPct, fmtCI, fmtDuration, fmtDate, pctProgress,
  pctErrorBars, groupKey, groupLabels, seedCount, changedParams,
} from '../../../frontend/js/stats.js';

test('movingAverage: window 1 copies, trailing window averages, shorter at the start', () => {
  assert.deepEqual(movingAverage([1, 2, 3], 1), [1, 2, 3]);
  assert.deepEqual(movingAverage([1, 2, 3, 4, 5], 2), [1, 1.5, 2.5, 3.5, 4.5]);
  assert.deepEqual(movingAverage([3, 3, 3, 9], 3), [3, 3, 3, 5]);
  assert.deepEqual(movingAverage([], 5), []);
});

test('movingAverage: skips nulls/NaN and handles bad windows', () => {
  assert.deepEqual(movingAverage([1, null, 3], 2), [1, 1, 3]);
  assert.deepEqual(movingAverage([null, null], 2), [null, null]);
  assert.deepEqual(movingAverage([1, NaN, 5], 3), [1, 1, 3]);
  assert.deepEqual(movingAverage([1, 2], 0), [1, 2]);
  assert.deepEqual(movingAverage([1, 2], 'x'), [1, 2]);
  assert.deepEqual(movingAverage([2, 4], 2.7), [2, 3]);
});

test('movingAverage: window longer than the series is the running mean', () => {
  assert.deepEqual(movingAverage([2, 4, 6], 10), [2, 3, 4]);
});

test('movingAverage: large input stays exact enough and fast', () => {
  const xs = Array.from({ length: 100000 }, (_, i) => i % 7);
  const out = movingAverage(xs, 7);
  assert.equal(out.length, xs.length);
  assert.ok(Math.abs(out[99999] - 3) < 1e-9);
});

test('smoothSeries smooths mean and band, keeps episodes', () => {
  const s = smoothSeries({ episode: [0, 1, 2], mean: [1, 3, 5], low: [0, 2, 4], high: [2, 4, 6] }, 2);
  assert.deepEqual(s, { episode: [0, 1, 2], mean: [1, 2, 4], low: [0, 1, 3], high: [2, 3, 5] });
});

test('bandPolygon goes forward along high and back along low', () => {
  assert.deepEqual(bandPolygon([0, 1, 2], [0, 1, 2], [5, 6, 7]), { x: [0, 1, 2, 2, 1, 0], y: [5, 6, 7, 2, 1, 0] });
});

test('sortAlgorithms orders uniform, 1:1, x:1 ascending, max, oracle', () => {
  assert.deepEqual(sortAlgorithms(['oracle', 'mgrao-max', 'mgrao-10:1', 'mgrao-2:1', 'uniform', 'mgrao-1:1']),
    ['uniform', 'mgrao-1:1', 'mgrao-2:1', 'mgrao-10:1', 'mgrao-max', 'oracle']);
});

test('parseRatios accepts x, x:1 and mgrao-x:1, rejects others', () => {
  assert.deepEqual(parseRatios('2, 5:1 mgrao-10:1; 2'), { algorithms: ['mgrao-2:1', 'mgrao-5:1', 'mgrao-10:1'], invalid: [] });
  assert.deepEqual(parseRatios('0, abc, 1.5'), { algorithms: [], invalid: ['0', 'abc', '1.5'] });
  assert.deepEqual(parseRatios(''), { algorithms: [], invalid: [] });
});

test('parseTags and parseIds', () => {
  assert.deepEqual(parseTags(' paper, a ,, paper,b'), ['paper', 'a', 'b']);
  assert.deepEqual(parseIds('3, 1,x, 3 -2 0 7'), [3, 1, 7]);
  assert.deepEqual(parseIds(['4', 4, '5']), [4, 5]);
  assert.deepEqual(parseIds(undefined), []);
});

test('parseHash / buildHash round trip', () => {
  assert.deepEqual(parseHash('#/compare?jobs=1,2&smooth=5'), { path: '/compare', params: { jobs: '1,2', smooth: '5' } });
  assert.deepEqual(parseHash(''), { path: '/', params: {} });
  assert.deepEqual(parseHash('#/jobs/7/'), { path: '/jobs/7', params: {} });
  const hash = buildHash('/compare', { jobs: [1, 2], smooth: 5, groups: 'ab12cd34:mgrao-2:1', empty: '', nothing: null });
  assert.equal(hash, '#/compare?jobs=1,2&smooth=5&groups=ab12cd34:mgrao-2:1');
  assert.deepEqual(parseHash(hash).params, { jobs: '1,2', smooth: '5', groups: 'ab12cd34:mgrao-2:1' });
  assert.equal(buildHash('/runs', {}), '#/runs');
  assert.equal(parseHash(buildHash('/runs', { q: 'a b&c' })).params.q, 'a b&c');
});

test('fieldErrors maps loc and field to input paths', () => {
  const known = new Set(['n_parents']);
  const detail = [
    { loc: ['body', 'params', 'n_parents'], field: 'n_parents', msg: 'n_parents: must be in [1, 1000] (got 5000)' },
    { loc: ['body', 'seeds'], field: 'seeds', msg: 'too many' },
    { field: 'params.epsilon', msg: 'bad eps' },
    { loc: ['body', 'algorithms', 0], msg: 'unknown algorithm' },
    { field: 'n_parents', msg: 'second' },
    { msg: 'general' },
  ];
  assert.deepEqual(fieldErrors(detail, known), {
    'params.n_parents': 'n_parents: must be in [1, 1000] (got 5000); second',
    seeds: 'too many',
    'params.epsilon': 'bad eps',
    algorithms: 'unknown algorithm',
    _form: 'general',
  });
  assert.deepEqual(fieldErrors('not a list'), {});
});

test('formatting helpers', () => {
  assert.equal(fmtNumber(4.05123), '4.051');
  assert.equal(fmtNumber(null), '–');
  assert.equal(fmtNumber(1.5e-5), '1.50e-5');
  assert.equal(fmtPct(34.94), '+34.9%');
  assert.equal(fmtPct(-2), '-2.0%');
  assert.equal(fmtPct(100, 1, false), '100.0%');
  assert.equal(fmtCI([4, 4.1]), '[4.000, 4.100]');
  assert.equal(fmtCI([33.1, 36.7], 1, true), '[+33.1%, +36.7%]');
  assert.equal(fmtCI(null), '');
  assert.equal(fmtDuration(0.25), '250 ms');
  assert.equal(fmtDuration(1.84), '1.8 s');
  assert.equal(fmtDuration(125), '2 min 5 s');
  assert.equal(fmtDuration(7260), '2 h 1 min');
  assert.equal(fmtDuration(undefined), '–');
  assert.equal(fmtDate(null), '–');
  assert.equal(fmtDate('garbage'), '–');
  assert.match(fmtDate('2026-01-02T03:04:05Z'), /^2026-01-0[12] \d\d:\d\d$/);
  assert.equal(pctProgress(0.424), 42);
  assert.equal(pctProgress(2), 100);
  assert.equal(pctProgress(null), 0);
});

test('pctErrorBars turns CIs into asymmetric error bars', () => {
  const bars = pctErrorBars([
    { pct_from_uniform: 34.9, pct_ci95: [33.1, 36.7] },
    { pct_from_uniform: null, pct_ci95: null },
    { pct_from_uniform: 10, pct_ci95: null },
  ]);
  assert.deepEqual(bars.y, [34.9, null, 10]);
  assert.ok(Math.abs(bars.plus[0] - 1.8) < 1e-9 && Math.abs(bars.minus[0] - 1.8) < 1e-9);
  assert.deepEqual(bars.plus.slice(1), [0, 0]);
});

test('group keys and labels disambiguate equal system/algorithm pairs', () => {
  const groups = [
    { config_hash: 'aaaaaaaaaaaa', algorithm: 'mgrao-max', system: 'single' },
    { config_hash: 'bbbbbbbbbbbb', algorithm: 'mgrao-max', system: 'single' },
    { config_hash: 'aaaaaaaaaaaa', algorithm: 'uniform', system: 'single' },
  ];
  assert.equal(groupKey(groups[0]), 'aaaaaaaa:mgrao-max');
  assert.deepEqual(groupLabels(groups), ['single · mgrao-max (aaaaaa)', 'single · mgrao-max (bbbbbb)', 'single · uniform']);
});

test('seedCount and changedParams', () => {
  assert.equal(seedCount({ seeds: [0, 1, 2] }), 3);
  assert.equal(seedCount({ seeds: 5 }), 5);
  assert.equal(seedCount(null), 0);
  assert.deepEqual(changedParams({ a: 1, b: 0.1 + 0.2, c: null, d: 'x' }, { a: 1, b: 0.3, c: 0.5, d: 'x' }), { c: null });
  assert.deepEqual(changedParams({ n: 5000 }, { n: 10 }), { n: 5000 });
});
