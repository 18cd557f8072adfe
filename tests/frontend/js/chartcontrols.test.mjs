import { test } from 'node:test';
import assert from 'node:assert/strict';
import { withAxis, axisProblem } from '../../../frontend/js/chartcontrols.js';
import { csvOf } from '../../../frontend/js/stats.js';

test('withAxis: log scale and a y range (in log10 on a log axis); automatic otherwise', () => {
  const base = { yaxis: { title: { text: 'System utility' } } };
  assert.deepEqual(withAxis(base, { log: false, low: null, high: null }).yaxis,
    { title: { text: 'System utility' }, type: 'linear', autorange: true });
  assert.deepEqual(withAxis(base, { log: false, low: 1, high: 5 }).yaxis.range, [1, 5]);
  const log = withAxis(base, { log: true, low: 1, high: 100 }).yaxis;
  assert.equal(log.type, 'log');
  assert.deepEqual(log.range, [0, 2]);
  assert.equal(withAxis(base, { log: true, low: 0, high: 100 }).yaxis.autorange, true);  // not usable: automatic
});

test('axisProblem names what is wrong with a range', () => {
  assert.equal(axisProblem({ log: false, low: null, high: null }), '');
  assert.match(axisProblem({ log: false, low: 1, high: null }), /both ends/);
  assert.match(axisProblem({ log: false, low: 3, high: 1 }), /below the upper/);
  assert.match(axisProblem({ log: true, low: 0, high: 1 }), /above 0/);
});

test('csvOf quotes what needs it', () => {
  assert.equal(csvOf([['a', 'b,c'], ['"x"', null]]), 'a,"b,c"\n"""x""",\n');
});
