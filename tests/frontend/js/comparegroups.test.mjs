import { test } from 'node:test';
import assert from 'node:assert/strict';
import { configurations, differingParams, groupLabels, diffTable, facets, lineStyles } from '../../../frontend/js/comparegroups.js';
import { algorithmColour } from '../../../frontend/js/colours.js';

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

test('groupLabels: by what differs within a system; a hash only when nothing we know differs', () => {
  const groups = [g('aaaaaaaa1', 'mgrao-max'), g('bbbbbbbb2', 'mgrao-max'), g('cccccccc3', 'uniform')];
  assert.deepEqual(groupLabels(groups, configs), [
    'single · mgrao-max · learning_rate 0.1', 'single · mgrao-max · learning_rate 0.09', 'large · uniform']);
  const same = [g('aaaaaaaa1', 'uniform'), g('dddddddd4', 'uniform')];
  assert.deepEqual(groupLabels(same, configs), ['single · uniform (aaaaaa)', 'single · uniform (dddddd)']);
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

test('facets and line styles: a chart per system, a colour per algorithm, a dash per variant', () => {
  const groups = [g('aaaaaaaa1', 'mgrao-max'), g('bbbbbbbb2', 'mgrao-max'), g('cccccccc3', 'mgrao-max'), g('aaaaaaaa1', 'uniform')];
  assert.deepEqual(facets(groups), ['single', 'large']);
  const styles = lineStyles(groups);
  assert.deepEqual(styles.map((s) => s.dash), ['solid', 'dash', 'solid', 'solid']);
  assert.equal(styles[0].color, algorithmColour('mgrao-max'));
  assert.equal(styles[2].color, styles[0].color);  // the same algorithm, the same colour, in every system
  assert.notEqual(styles[3].color, styles[0].color);
});
