import { test } from 'node:test';
import assert from 'node:assert/strict';
import { configurationStyles, algorithmStyles, PALETTE } from '../../../frontend/js/colours.js';

test('configurationStyles: eight Okabe-Ito colours, one each, then again with dashes and markers', () => {
  assert.equal(new Set(PALETTE).size, 8);
  const styles = configurationStyles(Array.from({ length: 10 }, (_, i) => i));
  assert.deepEqual(styles.slice(0, 8).map((s) => s.color), PALETTE);
  assert.ok(styles.slice(0, 8).every((s) => s.dash === 'solid' && s.symbol === null));
  assert.equal(styles[8].color, PALETTE[0]);
  assert.notEqual(styles[8].dash, 'solid');
  assert.ok(styles[8].symbol);
  const pairs = styles.map((s) => `${s.color}|${s.dash}|${s.symbol}`);
  assert.equal(new Set(pairs).size, 10); // told apart past the palette too
});

test('algorithmStyles: the job page order, so 1:1 and 10:1, 5:1 and max are not the same hue in a small job', () => {
  const s = algorithmStyles(['mgrao-max', 'mgrao-10:1', 'uniform', 'mgrao-5:1', 'mgrao-1:1']);
  assert.deepEqual(Object.keys(s), ['uniform', 'mgrao-1:1', 'mgrao-5:1', 'mgrao-10:1', 'mgrao-max']);
  assert.equal(new Set(Object.values(s).map((x) => x.color)).size, 5);
  // the two blues (#0072B2, #56B4E9) and the two oranges (#D55E00, #E69F00) only meet from the 6th on
  const five = Object.values(s).map((x) => x.color);
  assert.ok(!(five.includes('#0072B2') && five.includes('#56B4E9')));
  assert.ok(!(five.includes('#D55E00') && five.includes('#E69F00')));
  // the same set gives the same colours wherever it is drawn
  assert.deepEqual(algorithmStyles(['uniform', 'mgrao-1:1', 'mgrao-5:1', 'mgrao-10:1', 'mgrao-max']), s);
});
