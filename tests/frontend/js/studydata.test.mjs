import { test } from 'node:test';
import assert from 'node:assert/strict';
import {
  sortTrials, pageOf, fmtParam, endedTrials, defaultSweep, gridPoints, parseValues, studyBody,
  studyFieldKey, historyTraces, importanceTrace, sliceTraces, studyHeatmapTrace, parallelPlot,
} from '../../../frontend/js/studydata.js';

const trials = [
  { number: 0, status: 'succeeded', value: 3, params: { lr: 0.1, routing: 'per-task' } },
  { number: 1, status: 'failed', value: null, params: { lr: 0.05, routing: 'per-composite' } },
  { number: 2, status: 'succeeded', value: 7, params: { lr: 0.2, routing: 'per-task' } },
  { number: 3, status: 'succeeded', value: 3, params: { lr: 0.05, routing: 'per-composite' } },
];

test('sortTrials: by objective either way, missing values last, ties by number', () => {
  assert.deepEqual(sortTrials(trials, 'value', true).map((t) => t.number), [0, 3, 2, 1]);
  assert.deepEqual(sortTrials(trials, 'value', false).map((t) => t.number), [2, 0, 3, 1]);
  assert.deepEqual(sortTrials(trials, 'param:lr').map((t) => t.number), [1, 3, 0, 2]);
  assert.deepEqual(sortTrials(trials, 'param:routing', false).map((t) => t.number), [0, 2, 1, 3]);
  assert.deepEqual(sortTrials(trials, 'status').map((t) => t.number), [1, 0, 2, 3]);
  assert.deepEqual(trials.map((t) => t.number), [0, 1, 2, 3]); // not in place
});

test('pageOf clamps the page and counts pages', () => {
  const items = Array.from({ length: 120 }, (_, i) => i);
  assert.deepEqual(pageOf(items, 1, 50).rows, items.slice(50, 100));
  assert.equal(pageOf(items, 9, 50).page, 2);
  assert.equal(pageOf(items, -3, 50).page, 0);
  assert.equal(pageOf([], 0, 50).pages, 1);
});

test('fmtParam and endedTrials', () => {
  assert.equal(fmtParam(0.0353553390593), '0.03536');
  assert.equal(fmtParam(20), '20');
  assert.equal(fmtParam(true), 'on');
  assert.equal(fmtParam(null), '–');
  assert.equal(endedTrials({ succeeded: 3, failed: 1, queued: 2, cancelled: 1 }), 5);
  assert.equal(endedTrials(undefined), 0);
});

test('defaultSweep: half to twice within the limits, log for rates, all values for choices', () => {
  const lr = { name: 'learning_rate', kind: 'float', minimum: 0, maximum: 1, default: 0.1 };
  assert.deepEqual(defaultSweep(lr, 0.1), { low: 0.05, high: 0.2, steps: 3, log: true });
  assert.deepEqual(defaultSweep(lr, 0.8), { low: 0.4, high: 1, steps: 3, log: true });
  const td = { name: 'trace_decay', kind: 'float', minimum: 0.001, maximum: 0.999, default: 0.9 };
  assert.deepEqual(defaultSweep(td, 0.9), { low: 0.45, high: 0.999, steps: 3, log: false });
  const parents = { name: 'n_parents', kind: 'int', minimum: 1, maximum: 1000, default: 10 };
  assert.deepEqual(defaultSweep(parents, 10), { low: 5, high: 20, steps: 3, log: false });
  assert.deepEqual(defaultSweep(parents, 1), { low: 1, high: 2, steps: 3, log: false });
  const leave = { name: 'leave_probability', kind: 'float', minimum: 0, maximum: 1, default: 0 };
  const zero = defaultSweep(leave, 0);
  assert.ok(zero.low === 0 && zero.high === 1 && zero.log === false);
  assert.deepEqual(defaultSweep({ name: 'routing', kind: 'choice', choices: ['a', 'b'] }, 'a'), { values: ['a', 'b'] });
  assert.deepEqual(defaultSweep({ name: 'load_sharing', kind: 'bool' }, false), { values: [false, true] });
});

test('parseValues and gridPoints', () => {
  assert.deepEqual(parseValues('0.5, 0.7,0.9', 'float'), { values: [0.5, 0.7, 0.9], invalid: [] });
  assert.deepEqual(parseValues('2, 2.5, x', 'int'), { values: [2], invalid: ['2.5', 'x'] });
  assert.deepEqual(parseValues('on, off, maybe', 'bool'), { values: [true, false], invalid: ['maybe'] });
  assert.deepEqual(parseValues('a, b', 'choice'), { values: ['a', 'b'], invalid: [] });
  assert.equal(gridPoints({ values: [1, 2] }), 2);
  assert.equal(gridPoints({ low: 0, high: 1, steps: 4 }), 4);
  assert.equal(gridPoints({ low: 0, high: 1, steps: '' }), 0);
});

test('studyBody: the issue’s shape; swept parameters leave the base; steps only for a grid', () => {
  const base = { system: 'single', algorithms: ['uniform', 'mgrao-max'], seeds: 10, episodes: 100,
    params: { learning_rate: 0.3, n_parents: 20 } };
  const rows = [
    { name: 'learning_rate', mode: 'values', values: [0.05, 0.1, 0.2] },
    { name: 'trace_decay', mode: 'range', low: 0.5, high: 0.95, steps: 4, log: false },
  ];
  const settings = { name: 'lr by decay', method: 'grid', metric: 'pct_from_uniform', direction: 'maximize',
    configuration: 'mgrao-max', max_trials: 100, max_in_flight: 4, seed: 0 };
  assert.deepEqual(studyBody(base, rows, settings), {
    name: 'lr by decay', method: 'grid',
    base: { system: 'single', algorithms: ['uniform', 'mgrao-max'], seeds: 10, episodes: 100, params: { n_parents: 20 } },
    space: { learning_rate: { values: [0.05, 0.1, 0.2] }, trace_decay: { low: 0.5, high: 0.95, log: false, steps: 4 } },
    objective: { metric: 'pct_from_uniform', direction: 'maximize', configuration: 'mgrao-max' },
    max_trials: 100, max_in_flight: 4, seed: 0,
  });
  const tpe = studyBody(base, rows, { ...settings, method: 'tpe', metric: 'paper_deviation', direction: 'minimize' });
  assert.deepEqual(tpe.space.trace_decay, { low: 0.5, high: 0.95, log: false });
  assert.equal(tpe.objective.configuration, undefined);
});

test('studyFieldKey maps the API’s paths to the form’s fields', () => {
  assert.equal(studyFieldKey('space.learning_rate.low'), 'space.learning_rate');
  assert.equal(studyFieldKey('space.groups.values[1]'), 'space.groups');
  assert.equal(studyFieldKey('base.params.n_parents'), 'params.n_parents');
  assert.equal(studyFieldKey('base.seeds'), 'seeds');
  assert.equal(studyFieldKey('base.algorithms[2]'), 'algorithms');
  assert.equal(studyFieldKey('objective.configuration'), 'objective.configuration');
  assert.equal(studyFieldKey('max_trials'), 'max_trials');
});

test('plot traces carry the server’s aggregates', () => {
  const history = historyTraces({ trial: [0, 1, 2], best: [1, 3, 3], value: [1, 3, 2] }, 'obj');
  assert.deepEqual(history.map((t) => t.meta.kind), ['trial', 'best']);
  assert.deepEqual(history[1].y, [1, 3, 3]);
  const importance = importanceTrace({ a: { eta_squared: 0.7, share: 0.7 }, b: { eta_squared: 0.1, share: 0.1 } });
  assert.deepEqual(importance.y, ['b', 'a']); // largest on top
  const slice = sliceTraces({ x: [1, 2], value: [5, 6], low: [4, null], high: [7, null], number: [0, 1],
    bins: { x: [1, 2], mean: [5, 6], low: [null, null], high: [null, null], count: [1, 1] } }, 'a');
  assert.deepEqual(slice[0].error_y.array, [2, 0]);
  assert.deepEqual(slice[0].error_y.arrayminus, [1, 0]);
  const heat = studyHeatmapTrace({ x: 'a', y: 'b', x_values: [0.1, 0.2], y_values: ['p', 'q'], mean: [[1, null], [3, 4]], count: [[1, 0], [1, 1]] }, true);
  assert.deepEqual(heat.x, ['0.1', '0.2']);
  assert.equal(heat.reversescale, true);
});

test('parallelPlot: axes scaled to [0, 1], choices as ticks, one trace per colour band', () => {
  const { traces, layout } = parallelPlot(
    { number: [0, 1, 2], value: [1, 2, 3], params: { lr: [0.01, 0.1, 1], routing: ['x', 'y', 'x'] } },
    ['lr', 'routing'], 'obj', { logs: { lr: true } });
  const lines = traces.flatMap((t) => {
    const out = [];
    let line = [];
    t.y.forEach((y) => { if (y === null) { out.push(line); line = []; } else line.push(y); });
    return out.map((l) => [t.meta.band, l]);
  });
  assert.equal(lines.length, 3);
  const byValue = Object.fromEntries(lines.map(([band, l]) => [l[2], [band, l]]));
  assert.deepEqual(byValue[0][1], [0, 0, 0]); // lowest lr (log scale), first choice, lowest objective
  assert.deepEqual(byValue[0.5][1], [0.5, 1, 0.5]);
  assert.deepEqual(byValue[1][1], [1, 0, 1]);
  assert.ok(byValue[1][0] > byValue[0][0]); // the best band is the brightest
  assert.equal(layout.shapes.length, 3);
  // a numeric axis is labelled at both ends and three points between (log: evenly in log), not only its ends
  const lrTicks = layout.annotations.filter((a) => a.x === 0 && !a.text.startsWith('<b>'));
  assert.deepEqual(lrTicks.map((a) => a.y), [0, 0.25, 0.5, 0.75, 1]);
  assert.deepEqual(lrTicks.map((a) => a.text), ['0.01', '0.0316', '0.1', '0.316', '1']);
  const minimized = parallelPlot({ number: [0, 1], value: [1, 2], params: { lr: [1, 2] } }, ['lr'], 'obj', { minimize: true });
  const bands = Object.fromEntries(minimized.traces.map((t) => [t.y[1], t.meta.band]));
  assert.ok(bands[0] > bands[1]); // minimizing: the lowest objective is the brightest
});

test('bandName: digits enough to tell the ends of a band apart, one value when its trials share it', async () => {
  const { bandName } = await import('../../../frontend/js/studydata.js');
  assert.equal(bandName(39.3, 39.30004), '39.3 … 39.30004');
  assert.equal(bandName(39.31, 39.52), '39.31 … 39.52');
  assert.equal(bandName(39.3, 39.3), '39.3');
});

test('importanceNote and bestText: say when importance or the best trial cannot be told apart from noise', async () => {
  const { importanceNote, bestText, fmtParam } = await import('../../../frontend/js/studydata.js');
  const importance = { learning_rate: { eta_squared: 1, share: 0.5, p_value: 1, groups: 4 },
    trace_decay: { eta_squared: 0.9, share: 0.5, p_value: 0.002, groups: 2 } };
  const note = importanceNote(importance, 4);
  assert.match(note, /^Not told apart from noise with 4 trials: learning_rate \(η² 1\.00, p = 1\.00\)\. /);
  assert.doesNotMatch(note, /trace_decay/);
  assert.equal(importanceNote({ a: { eta_squared: 0.5, p_value: 0.01 } }, 40), '');
  const trials = [{ number: 0, value: 10, ci95: [5, 15], params: { x: 1 } }, { number: 1, value: 27.96, ci95: [9.4, 45.8], params: { x: 2 } },
    { number: 2, value: 20, ci95: [10, 30], params: { x: 3 } }, { number: 3, value: 2, ci95: [0, 4], params: { x: 4 } }];
  const fmt = (v) => v.toFixed(1);
  assert.equal(bestText(trials[1], trials, 3, fmt), '28.0 [9.4, 45.8] (95% interval over 3 seeds) at trial 1: x 2. ' +
    'Not told apart from 2 trials whose objective lies in that interval (the nearest: trial 2, 20.0)');
  assert.equal(bestText(null, trials, 3, fmt), '–');
  assert.equal(typeof fmtParam, 'function');
});
