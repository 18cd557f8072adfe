import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import {
  remember, forget, describe, compareLabels, sortLabels, colourKey, roleLabel, literalLabels, argumentForms, labelFor,
  argumentOf, readArguments, argumentProblem, memoryPerChild, fmtBytes, compareArguments, validText,
} from '../../../frontend/js/algorithms.js';

// What GET /api/algorithms answers (tests/frontend/test_js_units.py checks it is the core's own).
const FIXTURE = JSON.parse(readFileSync(new URL('./algorithms.fixture.json', import.meta.url)));

test('labels described by the server: order by sort key, undescribed last by spelling', () => {
  forget();
  remember(FIXTURE.descriptions, null, FIXTURE.roles);
  assert.deepEqual(sortLabels(['oracle', 'zzz', 'mgrao-max', 'mgrao-10:1', 'mgrao-2:1', 'uniform', 'mgrao-1:1', 'aaa']),
    ['uniform', 'mgrao-1:1', 'mgrao-2:1', 'mgrao-10:1', 'mgrao-max', 'oracle', 'aaa', 'zzz']);
  assert.equal(describe('mgrao-5:1').groups, 5);
  assert.equal(describe('nothing'), null);
  assert.ok(compareLabels('uniform', 'oracle') < 0);
  assert.equal(colourKey('uniform'), 0);
  assert.equal(colourKey('nothing'), null);
  assert.equal(roleLabel('best_fixed'), 'oracle');
  // a label as asked (another spelling) is remembered under that spelling too
  remember([FIXTURE.descriptions[4]], [' MGRAO-05:1']);
  assert.equal(describe(' MGRAO-05:1').label, 'mgrao-5:1');
});

test('the pickers come from the label forms: literal labels and forms with an argument', () => {
  assert.deepEqual(literalLabels(FIXTURE.families).sort(), ['bandit', 'independent-q', 'mgrao-balance', 'mgrao-max', 'oracle', 'uniform']);
  const [{ form }] = argumentForms(FIXTURE.families);
  assert.equal(labelFor(form, 5), 'mgrao-5:1');
  assert.equal(argumentOf(form, 'MGRAO-05:1'), 5);
  assert.equal(argumentOf(form, 'mgrao-max'), null);
  assert.deepEqual(readArguments('2, 5:1 mgrao-10:1; 2', form), { values: [2, 10], invalid: ['5:1'] });
  assert.deepEqual(readArguments('0, abc, 1.5, mgrao-3:1', form), { values: [3], invalid: ['0', 'abc', '1.5'] });
  assert.deepEqual(readArguments('', form), { values: [], invalid: [] });
  assert.equal(argumentProblem(form, 7), null); // without a system every whole number is left to the server
});

test('a value the system does not allow is refused with the form\'s own words and valid values', () => {
  const [{ form }] = argumentForms(FIXTURE.families_single_12);
  assert.deepEqual(form.valid, [1, 2, 3, 4, 6, 12]);
  assert.equal(argumentProblem(form, 4), null);
  const message = argumentProblem(form, 5);
  assert.ok(message.startsWith('mgrao-5:1 is not valid here'), message);
  assert.ok(message.includes(form.argument_help) && message.includes('(valid: 1, 2, 3, 4, 6, 12)'), message);
});

test('a form of two arguments (mgrao-{x}:{y}) takes pairs x:y, each checked against its valid values', () => {
  const shared = argumentForms(FIXTURE.families).map(({ form }) => form).find((f) => f.second_argument);
  assert.equal(shared.template, 'mgrao-{x}:{y}');
  assert.equal(labelFor(shared, '5:2'), 'mgrao-5:2');
  assert.equal(argumentOf(shared, 'MGRAO-05:02'), '5:2');
  assert.equal(argumentOf(shared, 'mgrao-5:1'), null); // y = 1 is the x:1 form's
  const [{ form: ratio }] = argumentForms(FIXTURE.families);
  assert.equal(argumentOf(ratio, 'mgrao-5:2'), null); // and y > 1 is not the x:1 form's
  assert.deepEqual(readArguments('5:2, mgrao-10:3 5:2; 5, 0:2, 5:0', shared),
    { values: ['5:2', '10:3'], invalid: ['5', '0:2', '5:0'] });
  assert.deepEqual(['10:3', '5:2', '5:1', '1:4'].sort(compareArguments), ['1:4', '5:1', '5:2', '10:3']);
  assert.deepEqual([10, 2, 5].sort(compareArguments), [2, 5, 10]);
  assert.equal(argumentProblem(shared, '7:3'), null); // without a system every pair is left to the server
  const here = { ...shared, valid: [1, 2, 5, 10], second_valid: [3] };
  assert.equal(argumentProblem(here, '5:3'), null);
  const message = argumentProblem(here, '4:2');
  assert.ok(message.startsWith('mgrao-4:2 is not valid here: x is the'), message);
  assert.ok(message.includes('(valid: 1, 2, 5, 10)') && message.includes('y is the') && message.includes('(valid: 3)'), message);
  assert.equal(validText(here), 'Valid x here: 1, 2, 5, 10. Valid y here: 3.');
  const single12 = argumentForms(FIXTURE.families_single_12).map(({ form }) => form).find((f) => f.second_argument);
  assert.deepEqual(single12.second_valid, []); // one child: no team of two
  assert.ok(argumentProblem(single12, '2:2').includes('y is the') && argumentProblem(single12, '2:2').includes('(valid: none)'));
});

test('memory per child: shown when the registry gives it, nothing when it does not (yet)', () => {
  assert.deepEqual(memoryPerChild(FIXTURE.families), {});
  const withMemory = FIXTURE.families.map((f, i) => ({ ...f, memory_per_child: i ? { [f.examples[0]]: 1000 * i } : null }));
  const expected = Object.fromEntries(FIXTURE.families.slice(1).map((f, i) => [f.examples[0], 1000 * (i + 1)]));
  assert.deepEqual(memoryPerChild(withMemory), expected);
  assert.equal(fmtBytes(512), '512 B');
  assert.equal(fmtBytes(2048), '2.0 kB');
  assert.equal(fmtBytes(3_400_000), '3.4 MB');
  assert.equal(fmtBytes(null), '');
});
