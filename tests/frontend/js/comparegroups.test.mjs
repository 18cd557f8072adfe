import { test } from 'node:test';
import assert from 'node:assert/strict';
import { configurations, differingParams, groupLabels, diffTable, facets, lineStyles, legendLayout, legendRows, barsLayout, MAX_LEGEND_ROWS } from '../../../frontend/js/comparegroups.js';
import { readFileSync } from 'node:fs';
import { algorithmStyles, PALETTE } from '../../../frontend/js/colours.js';
import { remember } from '../../../frontend/js/algorithms.js';

remember(JSON.parse(readFileSync(new URL('./algorithms.fixture.json', import.meta.url))).descriptions);

const jobs = [
  { config_hash: 'aaaaaaaa1', system: 'single', episodes: 100, params: { learning_rate: 0.1, trace_decay: 0.9 } },
  { config_hash: 'bbbbbbbb2', system: 'single', episodes: 100, params: { learning_rate: 0.09, trace_decay: 0.9 } },
  { config_hash: 'cccccccc3', system: 'large', episodes: 100, params: { learning_rate: 0.1, trace_decay: 0.9 } },
  { config_hash: 'dddddddd4', system: 'single', episodes: 100, params: { learning_rate: 0.1, trace_decay: 0.9 } },
];
const configs = configurations(jobs);
const g = (hash, algorithm) => ({ config_hash: hash, algorithm, system: configs[hash].system });

test('differingParams names what differs, episodes included', () => {
  assert.deepEqual(differingParams(['aaaaaaaa1', 'bbbbbbbb2'], configs), ['learning_rate']);
  assert.deepEqual(differingParams(['aaaaaaaa1'], configs), []);
  const longer = configurations([...jobs, { config_hash: 'e5', system: 'single', episodes: 200, params: jobs[0].params }]);
  assert.deepEqual(differingParams(['aaaaaaaa1', 'e5'], longer), ['episodes']);
});

test('groupLabels: the world and the label the server gave (the algorithm and system of an older answer)', () => {
  const groups = [{ ...g('aaaaaaaa1', 'mgrao-max'), world: 'single', label: 'mgrao-max (learning_rate=0.1)' },
    { ...g('bbbbbbbb2', 'mgrao-max'), world: 'single (episodes=200)', label: 'mgrao-max' }, g('cccccccc3', 'uniform')];
  assert.deepEqual(groupLabels(groups), ['single · mgrao-max (learning_rate=0.1)', 'single (episodes=200) · mgrao-max',
    'large · uniform']);
  assert.deepEqual(facets(groups), ['single', 'single (episodes=200)', 'large']);
});

test('configurations name a saved system as compare\'s groups do, else as the job does (issue 47, item 3)', () => {
  const mine = { config_hash: 'ffffffff6', system: 'large', saved_system: 'large30', episodes: 100,
    params: { n_parents: 30 } };
  const plain = { config_hash: 'ffffffff6', system: 'large', episodes: 100, params: { n_parents: 30 } };
  assert.equal(configurations([mine]).ffffffff6.system, 'large30');  // without groups: the job's saved system
  // the plain job comes first, but its world is the saved system's: the server's name (its groups') holds
  const groups = [{ config_hash: 'ffffffff6', config_hashes: ['ffffffff6'], system: 'large30', base: 'large' }];
  assert.equal(configurations([plain, mine], groups).ffffffff6.system, 'large30');
  const paper = { config_hash: 'cccccccc3', system: 'large', episodes: 100, params: { n_parents: 50 } };
  const both = configurations([mine, paper], groups);
  assert.deepEqual(diffTable(['ffffffff6', 'cccccccc3'], both).rows[0],
    { name: 'system', values: ['large30', 'large'] });
});

test('diffTable: one row per differing parameter, one column per configuration, the system first if mixed', () => {
  const t = diffTable(['aaaaaaaa1', 'bbbbbbbb2', 'aaaaaaaa1', 'cccccccc3'], configs);
  assert.deepEqual(t.hashes, ['aaaaaaaa1', 'bbbbbbbb2', 'cccccccc3']);
  assert.deepEqual(t.rows, [
    { name: 'system', values: ['single', 'single', 'large'] },
    { name: 'learning_rate', values: ['0.1', '0.09', '0.1'] },
  ]);
  assert.deepEqual(diffTable(['aaaaaaaa1'], configs).rows, []);
});

test('facets and line styles: a chart per system, each group of a chart its own colour, job by job', () => {
  const groups = [g('aaaaaaaa1', 'mgrao-max'), g('bbbbbbbb2', 'mgrao-max'), g('cccccccc3', 'mgrao-max'), g('aaaaaaaa1', 'uniform')];
  assert.deepEqual(facets(groups), ['single', 'large']);
  const jobs = [{ config_hash: 'aaaaaaaa1' }, { config_hash: 'bbbbbbbb2' }, { config_hash: 'cccccccc3' }];
  const styles = lineStyles(groups, jobs);
  const single = [0, 1, 3].map((i) => styles[i].color);
  assert.equal(new Set(single).size, 3); // every configuration drawn together its own colour
  // the first job's configurations keep their job page's colours (uniform, then max)
  const page = algorithmStyles(['mgrao-max', 'uniform']);
  assert.equal(styles[3].color, page.uniform.color);
  assert.equal(styles[0].color, page['mgrao-max'].color);
  assert.equal(styles[1].color, PALETTE[3]); // the second job's max: the next free slot after max's own (2)
  assert.equal(styles[2].color, page['mgrao-max'].color); // the large chart starts over: max in its own colour
});

test('legendLayout keeps the plot area and puts the legend below the axis title, a row at a time', () => {
  const few = legendLayout(['a', 'b'], 600);
  const many = legendLayout(Array.from({ length: 14 }, (_, i) => `single · mgrao-max · learning_rate 0.${i}, trace_decay 0.85`), 600);
  for (const fit of [few, many]) {
    assert.equal(fit.height - fit.margin.t - fit.margin.b, 300); // the plot area's height, whatever the legend
    assert.ok(fit.legend.y * 300 <= -68); // below the tick labels and the "Episode" title
    assert.ok(fit.legend.maxheight >= (fit.margin.b - 68 - 8)); // no scroll bar
  }
  assert.equal(legendRows(['a', 'b'], 520), 1);
  assert.equal(legendRows(Array(14).fill('x'.repeat(60)), 520), 14);
  assert.ok(many.height > few.height);
  // seventy configurations: no 2,000 px chart, the legend is left out (the group list is the key)
  const seventy = legendLayout(Array.from({ length: 70 }, (_, i) => `single · mgrao-max · learning_rate 0.${i}`), 600);
  assert.equal(seventy.showlegend, false);
  assert.equal(seventy.height - seventy.margin.t - seventy.margin.b, 300);
  assert.ok(many.showlegend && 14 <= MAX_LEGEND_ROWS); // fourteen long labels, one a row, still shown
});

test('barsLayout: long labels deepen the bottom margin, not squeeze the bars', () => {
  const short = barsLayout(['a', 'b']);
  const long = barsLayout(['single · mgrao-max · episodes 20, learning_rate 0.2, trace_decay 0.85']);
  for (const fit of [short, long]) assert.equal(fit.height - fit.margin.t - fit.margin.b, 260);
  assert.ok(long.margin.b > 200 && long.margin.b > short.margin.b);
});
