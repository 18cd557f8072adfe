import { test } from 'node:test';
import assert from 'node:assert/strict';
import { configRows, differenceSummary, summaryCsv, configJson, listLines } from '../../../frontend/js/jobconfig.js';
import { sameValue } from '../../../frontend/js/stats.js';

const schema = {
  systems: [{ name: 'single', params: { n_types: 20, learning_rate: 0.1, quality_model: 'hyperbolic' } }],
  parameters: [
    { name: 'n_types', group: 'system', help: 'types' },
    { name: 'quality_model', group: 'quality', help: 'q' },
    { name: 'learning_rate', group: 'mgrao', help: 'alpha' },
  ],
  group_titles: { system: 'System', quality: 'Quality (environment)', mgrao: 'MG-RAO (algorithm)' },  // the API's
};
const job = {
  id: 7, name: 'x', system: 'single', algorithms: ['uniform', 'mgrao-max'], seeds: [0, 1], episodes: 100,
  params: { n_types: 20, learning_rate: 0.05, quality_model: 'hyperbolic', legacy_knob: 3 },
  config_hash: 'abc', version: '0.1.0',
};

test('sameValue: floats to 1e-12 relative, everything else exactly', () => {
  assert.ok(sameValue(0.1, 0.1 + 1e-14));
  assert.ok(!sameValue(0.1, 0.1001));
  assert.ok(sameValue('a', 'a'));
  assert.ok(!sameValue(true, 1));
  assert.ok(!sameValue(null, 0));
});

test('configRows: schema order, groups named, differences against the preset, unknown parameters last', () => {
  const rows = configRows(job, schema);
  assert.deepEqual(rows.map((r) => r.name), ['n_types', 'quality_model', 'learning_rate', 'legacy_knob']);
  assert.deepEqual(rows.map((r) => r.differs), [false, false, true, true]);
  assert.equal(rows[2].group, 'MG-RAO (algorithm)');
  assert.equal(rows[2].preset, 0.1);
  assert.equal(rows[3].group, 'Other');
});

test('differenceSummary names what differs, or says nothing does', () => {
  const rows = configRows(job, schema);
  assert.equal(differenceSummary(job, rows),
    '2 of 4 parameters differ from the single preset: learning_rate 0.05, legacy_knob 3.');
  const plain = { ...job, params: { n_types: 20, learning_rate: 0.1, quality_model: 'hyperbolic' } };
  assert.equal(differenceSummary(plain, configRows(plain, schema)), "Every parameter is the single preset's.");
});

test('summaryCsv: one row per configuration with every parameter as a column, quoted where needed', () => {
  const configs = [
    { algorithm: 'uniform', seeds_done: 2, summary: { final_mean: 1.5, ci95: [1.4, 1.6], pct_from_uniform: 0, pct_ci95: null, pct_of_max: 0 } },
    { algorithm: 'mgrao-max', seeds_done: 1, summary: { final_mean: 2, ci95: [null, null], pct_from_uniform: 33.3, pct_ci95: [10, 50], pct_of_max: 100 } },
  ];
  const lines = summaryCsv({ ...job, params: { ...job.params, quality_model: 'a,"b"' } }, configs).trim().split('\n');
  assert.equal(lines.length, 3);
  assert.equal(lines[0], 'job_id,system,saved_system,config_hash,algorithm,seeds_stored,seeds,episodes,final_mean,ci95_low,ci95_high,' +
    'pct_from_uniform,pct_ci95_low,pct_ci95_high,pct_of_max,learning_rate,legacy_knob,n_types,quality_model');
  assert.equal(lines[1], '7,single,,abc,uniform,2,2,100,1.5,1.4,1.6,0,,,0,0.05,3,20,"a,""b"""');
  assert.equal(lines[2], '7,single,,abc,mgrao-max,1,2,100,2,,,33.3,10,50,100,0.05,3,20,"a,""b"""');
});

test('configJson holds what re-running the job needs', () => {
  const parsed = JSON.parse(configJson(job));
  assert.deepEqual(Object.keys(parsed), ['id', 'name', 'system', 'base', 'algorithms', 'seeds', 'episodes', 'params',
    'config_hash', 'version']);
  assert.equal(parsed.params.learning_rate, 0.05);
  assert.deepEqual([parsed.system, parsed.base], ['single', 'single']);
});

test('a saved system\'s job is named by it: its summary, CSV and configuration (issue 47, item 3)', () => {
  const saved = { ...job, saved_system: 'single12' };
  assert.equal(differenceSummary(saved, configRows(saved, schema)),
    "2 of 4 parameters differ from single12's base, the single preset: learning_rate 0.05, legacy_knob 3.");
  const parsed = JSON.parse(configJson(saved));
  assert.deepEqual([parsed.system, parsed.base], ['single12', 'single']);  // POSTed again: the saved system's job
  const lines = summaryCsv(saved, [{ algorithm: 'uniform', seeds_done: 2, summary: {} }]).trim().split('\n');
  assert.ok(lines[1].startsWith('7,single,single12,abc,uniform,'), lines[1]);
});

test('listLines: an event list one event per line, its episode and change first; a plain list item by item', () => {
  assert.deepEqual(listLines([{ episode: 50, change: 'new-profiles', fraction: 0.3 }, { change: 'frequencies', period: 2, episode: 0 }]),
    ['episode 50: new-profiles, fraction 0.3', 'episode 0: frequencies, period 2']);
  assert.deepEqual(listLines([1, 4, 2.5]), ['1', '4', '2.5']);
  assert.deepEqual(listLines([]), ['none']);
});

test('configRows: each group once, under its title (capability_spread joins System, not a second one)', async () => {
  const { configRows, groupTitle } = await import('../../../frontend/js/jobconfig.js');
  const schema = { systems: [{ name: 'single', params: { n_types: 20, schedule: [], capability_spread: 0 } }],
    parameters: [{ name: 'n_types', group: 'system' }, { name: 'schedule', group: 'dynamics' },
      { name: 'capability_spread', group: 'system' }],
    group_titles: { system: 'System', dynamics: 'Dynamics (environment)' } };
  const rows = configRows({ system: 'single', params: { n_types: 20, schedule: [], capability_spread: 0.5 } }, schema);
  assert.deepEqual(rows.map((r) => [r.group, r.name]), [['System', 'n_types'], ['System', 'capability_spread'],
    ['Dynamics (environment)', 'schedule']]);
  assert.equal(groupTitle('mgrao', { mgrao: 'MG-RAO (algorithm)' }), 'MG-RAO (algorithm)');
  assert.equal(groupTitle('template'), 'Template');  // a group the service gives no title
});
