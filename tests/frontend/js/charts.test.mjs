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
