import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { configurationStyles, algorithmStyles, slotStyles, labelSlot, PALETTE } from '../../../frontend/js/colours.js';
import { remember, forget } from '../../../frontend/js/algorithms.js';

const FIXTURE = JSON.parse(readFileSync(new URL('./algorithms.fixture.json', import.meta.url)));

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

test('slotStyles: each its preferred slot when free, else the next free one, then another round', () => {
  const colour = (s) => PALETTE.indexOf(s.color);
  assert.deepEqual(slotStyles([2, 0, 4]).map(colour), [2, 0, 4]);
  // a later one preferring the same slot takes the next free one; an earlier one never loses its own
  assert.deepEqual(slotStyles([4, 4, 5]).map(colour), [4, 6, 5]);
  assert.deepEqual(slotStyles([null, 0]).map(colour), [1, 0]);
  const nine = slotStyles(Array(9).fill(3));
  assert.equal(new Set(nine.slice(0, 8).map((s) => s.color)).size, 8);
  assert.ok(nine.slice(0, 8).every((s) => s.dash === 'solid'));
  assert.notEqual(nine[8].dash, 'solid');
});

test('algorithmStyles: the job page order and the registry colours, the same wherever drawn', () => {
  forget();
  remember(FIXTURE.descriptions);
  const s = algorithmStyles(['mgrao-max', 'mgrao-10:1', 'uniform', 'mgrao-5:1', 'mgrao-1:1']);
  assert.deepEqual(Object.keys(s), ['uniform', 'mgrao-1:1', 'mgrao-5:1', 'mgrao-10:1', 'mgrao-max']);
  assert.equal(new Set(Object.values(s).map((x) => x.color)).size, 5);
  const key = Object.fromEntries(FIXTURE.descriptions.map((d) => [d.label, d.colour_key]));
  for (const [label, style] of Object.entries(s)) assert.equal(style.color, PALETTE[key[label]], label);
  // the same configuration keeps its colour in a smaller set
  assert.equal(algorithmStyles(['mgrao-max', 'uniform']).uniform.color, s.uniform.color);
  assert.equal(algorithmStyles(['mgrao-max', 'uniform'])['mgrao-max'].color, s['mgrao-max'].color);
  // large's seven configurations: seven colours, none of them dashed
  const large = algorithmStyles(['uniform', 'mgrao-1:1', 'mgrao-2:1', 'mgrao-5:1', 'mgrao-10:1', 'mgrao-25:1', 'mgrao-max']);
  assert.equal(new Set(Object.values(large).map((x) => x.color)).size, 7);
  assert.ok(Object.values(large).every((x) => x.dash === 'solid'));
  assert.deepEqual(algorithmStyles(['uniform', 'mgrao-1:1', 'mgrao-5:1', 'mgrao-10:1', 'mgrao-max']), s);
});

test('labelSlot: the registry colour key, and for a label outside the registry a slot of its spelling', () => {
  forget();
  remember(FIXTURE.descriptions);
  assert.equal(labelSlot('uniform'), 0);
  const slot = labelSlot('my-learner');
  assert.ok(Number.isInteger(slot) && slot >= 0 && slot < PALETTE.length);
  assert.equal(labelSlot('my-learner'), slot); // the same in every view
  assert.notEqual(labelSlot('my-learner'), labelSlot('other-learner'));
  const styles = algorithmStyles(['uniform', 'my-learner']);
  assert.equal(styles.uniform.color, PALETTE[0]); // a built-in keeps its slot beside it
  forget();
});

test('the anchors keep their colour whatever comes first: the oracle is sky blue beside adaptive groups', async () => {
  const { slotStyles, PALETTE } = await import('../../../frontend/js/colours.js');
  // mgrao-adaptive:2 prefers slot 6 too and comes before the oracle in a job's order
  const plain = slotStyles([0, 6, 6]);
  assert.equal(plain[2].color, PALETTE[7]); // without anchors the oracle lost its colour (the bug)
  const anchored = slotStyles([0, 6, 6], [true, false, true]);
  assert.equal(anchored[2].color, PALETTE[6]);
  assert.equal(anchored[0].color, PALETTE[0]);
  assert.notEqual(anchored[1].color, PALETTE[6]);
});
