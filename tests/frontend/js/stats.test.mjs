import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  centredAverage, episodesPerPoint, smoothingNote, smoothSeries, bandPolygon, parseTags, parseIds,
  parseHash, buildHash, fieldErrors, fmtNumber, fmtPct, fmtCI, fmtDuration, fmtDate, pctProgress,
  pctErrorBars, groupKey, seedCount, changedParams, showsTaskRates, fmtRate,
} from '../../../frontend/js/stats.js';

test('centredAverage: window 1 copies; a centred window in episodes, cut short at the ends', () => {
  const x = [0, 1, 2, 3, 4];
  assert.deepEqual(centredAverage(x, [1, 2, 3], 1), [1, 2, 3]);
  assert.deepEqual(centredAverage(x, [1, 2, 3, 4, 5], 3), [1.5, 2, 3, 4, 4.5]);
  assert.deepEqual(centredAverage(x, [0, 0, 9, 0, 0], 3), [0, 3, 3, 3, 0]);  // no lag: the peak stays centred
  assert.deepEqual(centredAverage([], [], 5), []);
});

test('centredAverage: the window is in episodes whatever the spacing of the points', () => {
  // points 10 episodes apart: an 11-episode window holds one point on each side
  const x = [0, 10, 20, 30];
  assert.deepEqual(centredAverage(x, [0, 3, 6, 9], 21), [1.5, 3, 6, 7.5]);
  assert.deepEqual(centredAverage(x, [0, 3, 6, 9], 5), [0, 3, 6, 9]);  // narrower than a point: unchanged
});

test('centredAverage: skips nulls/NaN and handles bad windows', () => {
  const x = [0, 1, 2];
  assert.deepEqual(centredAverage(x, [1, null, 3], 3), [1, 2, 3]);
  assert.deepEqual(centredAverage([0, 1], [null, null], 3), [null, null]);
  assert.deepEqual(centredAverage(x, [1, NaN, 5], 3), [1, 3, 5]);
  assert.deepEqual(centredAverage([0, 1], [1, 2], 0), [1, 2]);
  assert.deepEqual(centredAverage([0, 1], [1, 2], 'x'), [1, 2]);
});

test('centredAverage: large input stays exact enough', () => {
  const xs = Array.from({ length: 100000 }, (_, i) => i % 7);
  const out = centredAverage(xs.map((_, i) => i), xs, 7);
  assert.equal(out.length, xs.length);
  assert.ok(Math.abs(out[50000] - 3) < 1e-9);
});

test('episodesPerPoint and smoothingNote say what a line is, in episodes', () => {
  assert.equal(episodesPerPoint([0, 1, 2]), 1);
  assert.equal(episodesPerPoint([0, 17, 34, 51]), 17);
  assert.equal(episodesPerPoint([5]), 1);
  assert.match(smoothingNote(1, 1), /Not smoothed\.$/);
  assert.match(smoothingNote(11, 1), /centred mean over 11 episodes \(5 before and after each/);
  assert.match(smoothingNote(11, 17), /already the mean of 17 consecutive episodes/);
  assert.match(smoothingNote(1, 1, true, { drawn: 20, of: 100 }),
    /^Thick lines: mean over seeds; bands: its 95% interval\. Faint lines beneath: 20 of each configuration’s 100 seeds/);
  assert.match(smoothingNote(1, 1, false, { drawn: 3, of: 3 }), /Faint lines beneath: each of its 3 seeds\./);
});

test('smoothSeries smooths mean and band, keeps episodes', () => {
  const s = smoothSeries({ episode: [0, 1, 2], mean: [1, 3, 5], low: [0, 2, 4], high: [2, 4, 6] }, 3);
  assert.deepEqual(s, { episode: [0, 1, 2], mean: [2, 3, 4], low: [1, 2, 3], high: [3, 4, 5] });
});

test('bandPolygon goes forward along high and back along low', () => {
  assert.deepEqual(bandPolygon([0, 1, 2], [0, 1, 2], [5, 6, 7]), { x: [0, 1, 2, 2, 1, 0], y: [5, 6, 7, 2, 1, 0] });
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

test('group keys', () => {
  assert.equal(groupKey({ config_hash: 'aaaaaaaaaaaa', algorithm: 'mgrao-max', system: 'single' }), 'aaaaaaaa:mgrao-max');
});

test('seedCount and changedParams', () => {
  assert.equal(seedCount({ seeds: [0, 1, 2] }), 3);
  assert.equal(seedCount({ seeds: 5 }), 5);
  assert.equal(seedCount(null), 0);
  assert.deepEqual(changedParams({ a: 1, b: 0.1 + 0.2, c: null, d: 'x' }, { a: 1, b: 0.3, c: 0.5, d: 'x' }), { c: null });
  assert.deepEqual(changedParams({ n: 5000 }, { n: 10 }), { n: 5000 });
});

test('workersWord and waitingMessage say whether workers are warming up, ready or missing', async () => {
  const { workersWord, waitingMessage } = await import('../../../frontend/js/stats.js');
  assert.equal(workersWord(null), '');
  assert.equal(workersWord({ warming: 2, ready: 0 }), '2 workers warming up');
  assert.equal(workersWord({ warming: 0, ready: 1 }), '1 worker');
  assert.equal(workersWord({ warming: 1, ready: 2 }), '2 workers (+1 warming up)');
  assert.equal(workersWord({ warming: 0, ready: 0 }), 'no worker');
  assert.match(waitingMessage({ warming: 2, ready: 0 }, 0), /^Workers are warming up/);
  assert.match(waitingMessage({ warming: 0, ready: 0 }, 0), /No worker is running/);
  assert.match(waitingMessage({ warming: 0, ready: 2 }, 40), /2 workers ready.*\(40% already stored\)/);
  assert.equal(waitingMessage(null, 0), 'Waiting for a worker…');
});

test('waitingMessage says what a queued job really waits for once workers are ready', async () => {
  const { waitingMessage } = await import('../../../frontend/js/stats.js');
  const ready = { warming: 0, ready: 1 };
  assert.match(waitingMessage(ready, 0, { ahead: 3, running: 1 }), /^Waiting in the queue: 3 jobs were queued before this one/);
  assert.match(waitingMessage(ready, 0, { ahead: 0, running: 1 }), /^Next in the queue: the ready worker is busy \(1 job running\)/);
  assert.match(waitingMessage({ warming: 0, ready: 2 }, 0, { ahead: 0, running: 2 }), /all 2 ready workers are busy/);
  assert.match(waitingMessage({ warming: 0, ready: 2 }, 0, { ahead: 0, running: 1 }), /a ready worker takes it within a few seconds/);
  for (const queue of [{ ahead: 0, running: 0 }, { ahead: 0, running: 1 }]) {
    assert.doesNotMatch(waitingMessage(ready, 0, queue), /queued before/);
  }
});

test('bandCaution: too few seeds, or bands wider than the spread of the means, say so; else nothing', async () => {
  const { bandCaution, MIN_BAND_RUNS } = await import('../../../frontend/js/stats.js');
  const series = (mean, half) => ({ mean, low: mean.map((m) => m - half), high: mean.map((m) => m + half) });
  // 3 seeds: uniform's band spans -0.2 to 1.7 around means 0.75 and 0.9
  const wide = bandCaution([{ runs: 3, episodes: series([0.75, 0.75, 0.75], 0.95) },
    { runs: 3, episodes: series([0.9, 0.92, 0.93], 0.95) }]);
  assert.match(wide, /3 seeds per configuration \(fewer than 10\)/);
  assert.match(wide, /median band width of 1\.900, more than the 0\.170/);
  // 100 seeds, narrow bands, means far apart: the bands mean something
  assert.equal(bandCaution([{ runs: 100, episodes: series([1, 1, 1], 0.02) }, { runs: 100, episodes: series([2, 2, 2], 0.02) }]), '');
  // many seeds but bands wider than the gap between the lines
  assert.match(bandCaution([{ runs: 50, episodes: series([1, 1], 0.5) }, { runs: 50, episodes: series([1.1, 1.1], 0.5) }]),
    /^The 95% bands are too wide to mean much: a median band width of 1\.000/);
  // one configuration: only its seeds count
  assert.equal(bandCaution([{ runs: MIN_BAND_RUNS, episodes: series([1, 2], 3) }]), '');
  assert.match(bandCaution([{ runs: 1, episodes: series([1, 2], 0) }]), /one seed per configuration/);
});

test('seedPoints: the points a results answer with every seed can hold, or null when too few', async () => {
  const { seedPoints, MIN_SEED_POINTS } = await import('../../../frontend/js/stats.js');
  assert.equal(seedPoints(600, 100, 3, 30, 1_000_000), 100); // all the episodes
  assert.equal(seedPoints(600, 1000, 4, 2000, 1_000_000), 497); // 1,000,000 / (12 + 2,000)
  assert.equal(seedPoints(600, 1000, 4, 60_000, 1_000_000), null); // 16 points a seed: too coarse
  assert.equal(seedPoints(600, 5, 1, 3, 1_000_000), 5); // a short run: every episode, even below the minimum
  assert.equal(MIN_SEED_POINTS, 20);
});

test('showsTaskRates: a nonzero rate, or a job whose tasks can fail; fmtRate: a share as a percentage', () => {
  const zero = { failure_rate: 0, handover_rate: 0 };
  assert.equal(showsTaskRates([zero, zero], [{ learning_rate: 0.1 }]), false);  // nothing can fail: nothing shown
  assert.equal(showsTaskRates([zero, { failure_rate: 0, handover_rate: 0.2 }], []), true);
  assert.equal(showsTaskRates([zero], [{ task_need: 1.5 }]), true);  // can fail, even where none did
  assert.equal(showsTaskRates([{}, undefined], [undefined, { task_need: 0 }]), false);  // an older answer
  assert.deepEqual([0, 0.1234, 1, 0.0001, null].map(fmtRate), ['0.0%', '12.3%', '100.0%', '<0.1%', '–']);
});

test('maxNote: says so where a configuration gains more than mgrao-max, or mgrao-max gained nothing', async () => {
  const { maxNote } = await import('../../../frontend/js/stats.js');
  const c = (algorithm, pct) => ({ algorithm, summary: { pct_of_max: pct } });
  assert.equal(maxNote([c('uniform', 0), c('mgrao-1:1', 80), c('mgrao-max', 100)], 'mgrao-max'), '');
  const note = maxNote([c('uniform', 0), c('mgrao-1:1', 116.4), c('mgrao-max', 100), c('oracle', 273.7)], 'mgrao-max');
  assert.match(note, /^mgrao-max is not the best here: mgrao-1:1 \(116\.4%\) and oracle \(273\.7%\) gain more/);
  assert.match(maxNote([c('mgrao-max', null), c('mgrao-1:1', null)], 'mgrao-max'), /mgrao-max gained nothing over uniform/);
  assert.equal(maxNote([c('uniform', 0), c('mgrao-1:1', 120)], 'mgrao-max'), ''); // no mgrao-max: the column is empty anyway
});

test('groupsText and takenText: a learner\'s groups at the end and what learning took', async () => {
  const { groupsText, takenText } = await import('../../../frontend/js/stats.js');
  assert.equal(groupsText({ groups: { 5: 6 }, children: 6, groups_change: false }), '5');
  assert.equal(groupsText({ groups: { 10: 2, 5: 4 }, children: 6, groups_change: true }),
    '5 groups: 4 of 6 children; 10 groups: 2 of 6 children');
  assert.equal(groupsText({ groups: null, children: 0 }), '–');
  assert.equal(takenText({ taken: { mean: 0.125, low: 0.125, high: 0.125 } }), '12.5%');
  assert.equal(takenText({ taken: { mean: 0.08, low: 0.05, high: 0.125 } }), '8.0% (5.0–12.5%)');
  assert.equal(takenText({ taken: null }), '–');
});

test('seedsText, jobTimes, compilingText: a header that says how many seeds of how many, and where time went', async () => {
  const { seedsText, jobTimes, compilingText } = await import('../../../frontend/js/stats.js');
  assert.equal(seedsText({ seeds: [0, 1, 2] }), '3');
  const until = { until: { max_seeds: 500 }, seeds: Array.from({ length: 500 }, (_, i) => i), status: 'running' };
  assert.equal(seedsText({ ...until, stopped: { seeds: 20 } }), '20 of at most 500');
  assert.equal(seedsText({ ...until, stopped: { seeds: 0 } }), '0 of at most 500');
  assert.deepEqual(jobTimes({ queued_s: 100.2, compile_s: 279, duration_s: 279.132, started_at: 'x' }),
    [['Queued', '1 min 40 s'], ['Compiling', '4 min 39 s'], ['Running', '132 ms']]);
  assert.deepEqual(jobTimes({ queued_s: 0.5, compile_s: null, duration_s: 2, started_at: 'x' }).map((p) => p[1]),
    ['500 ms', 'none', '2.0 s']);
  const text = compilingText({ message: 'compiling the engine for bandit: first time only, about 20 s',
    since: '2026-11-28T10:00:00Z' }, Date.parse('2026-11-28T10:00:40Z'));
  assert.match(text, /^Compiling the engine for bandit: first time only, about 20 s \(40\.0 s so far\)\. /);
  assert.equal(compilingText(null), '');
});

test('ownWords: a refusal beside its field in the field\'s words, not the API\'s path', async () => {
  const { ownWords } = await import('../../../frontend/js/stats.js');
  assert.equal(ownWords('space.learning_rate', 'space.learning_rate.high: must be at most 1 (got 10)'),
    'learning_rate (to): must be at most 1 (got 10)');
  assert.equal(ownWords('params.n_types', 'base.params.n_types: must be in [2, 200] (got 1)'), 'n_types: must be in [2, 200] (got 1)');
  assert.equal(ownWords('algorithms:mgrao-{x}:1', 'mgrao-25:1: x must be a divisor of n_parents = 30'),
    'mgrao-25:1: x must be a divisor of n_parents = 30');
  assert.equal(ownWords('algorithms', 'algorithms[1]: mgrao-25:1: x must be a divisor'), 'mgrao-25:1: x must be a divisor');
  assert.equal(ownWords('seeds', 'seeds: must be at least 1 (got -5)'), 'seeds: must be at least 1 (got -5)');
  assert.equal(ownWords('space', 'space: a trial with n_parents = 15 is not a valid experiment: ...'),
    'the parameters swept: a trial with n_parents = 15 is not a valid experiment: ...');
});
