import { test } from 'node:test';
import assert from 'node:assert/strict';
import { indexAxis } from '../../../frontend/js/charts.js';

test('indexAxis labels every index while they fit, then every 2nd, 5th, 10th… so labels never overlap', () => {
  assert.deepEqual(indexAxis(10, 300, 16), { tickmode: 'linear', tick0: 0, dtick: 1 });
  assert.equal(indexAxis(20, 300, 16).dtick, 2);    // 18 labels fit in 300 px
  assert.equal(indexAxis(50, 270, 16).dtick, 5);    // the large system's 50 parent groups: 10 labels
  assert.equal(indexAxis(200, 440, 22).dtick, 10);  // 200 task types on a bar chart
  for (const [n, px] of [[3, 40], [50, 100], [999, 300], [5000, 200]]) {
    const { dtick } = indexAxis(n, px, 16);
    assert.ok(Math.ceil(n / dtick) <= Math.max(1, Math.floor(px / 16)), `${n} on ${px} px: ${dtick}`);
  }
});

test('bands: light enough to read the lines through, under every line, and left out on request', async () => {
  const { meanBandTraces, bandsBelow, BAND_FILL_ALPHA, bandAlpha } = await import('../../../frontend/js/charts.js');
  const s = { episode: [0, 1], mean: [1, 2], low: [0, 1], high: [2, 3] };
  const a = meanBandTraces('a', s, '#0072B2');
  const b = meanBandTraces('b', s, '#D55E00');
  assert.ok(BAND_FILL_ALPHA <= 0.1);
  assert.match(a[0].fillcolor, /, 0\.07\)$/);
  assert.equal(bandAlpha(3), 0.07);
  assert.equal(bandAlpha(50), 0.007); // fifty overlapping bands cover about 30%, not a slab
  assert.ok(1 - (1 - bandAlpha(50)) ** 50 < 0.32 && 1 - (1 - bandAlpha(5)) ** 5 < 0.32);
  assert.match(meanBandTraces('a', s, '#0072B2', 1, 'a', 'solid', { fillAlpha: bandAlpha(50) })[0].fillcolor, /, 0\.007\)$/);
  assert.deepEqual(bandsBelow([...a, ...b]).map((t) => `${t.meta.kind} ${t.meta.config}`), ['band a', 'band b', 'mean a', 'mean b']);
  const seed = { meta: { kind: 'seed', config: 'a' } };
  assert.deepEqual(bandsBelow([...a, seed]).map((t) => t.meta.kind), ['seed', 'band', 'mean']); // seeds beneath
  assert.deepEqual(meanBandTraces('a', s, '#0072B2', 1, 'a', 'solid', { bands: false }).map((t) => t.meta.kind), ['mean']);
  const marked = meanBandTraces('a', s, '#0072B2', 1, 'a', 'dash', { symbol: 'square' })[1];
  assert.equal(marked.mode, 'lines+markers');
  assert.equal(marked.marker.symbol, 'square');
});

test('withEvents: a dashed line per scheduled event that fires, labelled with its change', async () => {
  const { withEvents, utilityLayout } = await import('../../../frontend/js/charts.js');
  const plain = utilityLayout();
  assert.equal(withEvents(plain, [], 100), plain);
  assert.equal(withEvents(plain, undefined, 100), plain);
  const schedule = [{ episode: 50, change: 'new-profiles', fraction: 0.3, period: 1 },
    { episode: 60, change: 'frequencies', fraction: 0.5, period: 4 }, { episode: 100, change: 'new-composites', fraction: 1, period: 1 }];
  const marked = withEvents(plain, schedule, 100);
  assert.deepEqual(marked.shapes.map((s) => [s.x0, s.x1, s.yref, s.line.dash]), [[50, 50, 'paper', 'dash'], [60, 60, 'paper', 'dash']]);
  assert.deepEqual(marked.annotations.map((a) => a.text), ['new-profiles 30%', 'frequencies → 4 50%']);
  assert.equal(marked.xaxis, plain.xaxis);
});

test('sampleSeeds: at most SEED_SAMPLE seeds, spread evenly, the first and last among them', async () => {
  const { sampleSeeds, seedTraces, SEED_SAMPLE } = await import('../../../frontend/js/charts.js');
  const seeds = Array.from({ length: 100 }, (_, i) => ({ seed: i, episode: [0, 1], utility: [1, 2] }));
  const sample = sampleSeeds(seeds).map((s) => s.seed);
  assert.equal(sample.length, SEED_SAMPLE);
  assert.equal(sample[0], 0);
  assert.equal(sample[sample.length - 1], 99);
  assert.equal(new Set(sample).size, SEED_SAMPLE);
  assert.deepEqual(sampleSeeds(seeds.slice(0, 3)).map((s) => s.seed), [0, 1, 2]);
  assert.equal(seedTraces('a', seeds, '#123456').length, SEED_SAMPLE);
});
