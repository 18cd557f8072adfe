// The colours of configurations shown together (job page, compare, paper view, the weights' bars):
// each one its own colour from Okabe-Ito's eight (colour-blind safe, readable on white and in
// print), then, past eight, the colours again with a dash and a marker. A configuration prefers
// the palette slot the algorithm registry gives it (GET /api/algorithms' colour_key, the same in
// every view), and takes the next free one when another shown with it came first. No DOM access here.

import { colourKey, roleLabel, sortLabels } from './algorithms.js';

/** Whether `label` is an anchor of every view: the baseline (uniform) or the best fixed allocation (the oracle). */
export function isAnchor(label) {
  return label === roleLabel('baseline') || label === roleLabel('best_fixed');
}

// Okabe-Ito, ordered so that the first few shown together are furthest apart: the two blues and
// the two oranges only meet from the seventh configuration on. The registry's colour keys are
// slots of this list.
export const PALETTE = ['#000000', '#0072B2', '#D55E00', '#009E73', '#CC79A7', '#E69F00', '#56B4E9', '#F0E442'];
const DASHES = ['solid', 'dash', 'dot', 'dashdot', 'longdash', 'longdashdot'];
const SYMBOLS = ['circle', 'square', 'diamond', 'triangle-up', 'x', 'cross'];

function style(slot, round) {
  return {
    color: PALETTE[slot],
    dash: DASHES[round % DASHES.length],
    symbol: round ? SYMBOLS[(round - 1) % SYMBOLS.length] : null,
  };
}

/**
 * Line styles of configurations shown together, in the order given, each preferring a palette slot
 * (`preferred[i]`, an integer 0-7, or null for none): first the anchors (`anchors[i]` true: uniform and
 * the oracle, which every view draws in their own colour), then every configuration whose slot no earlier
 * one prefers takes it, then the others the next free slot after theirs (the first free for null); past
 * the palette the colours repeat with a dash and a marker of the next round (`symbol` null in the first
 * round). Returns one `{color, dash, symbol}` per entry.
 */
export function slotStyles(preferred, anchors = []) {
  const n = PALETTE.length;
  const wants = (preferred || []).map((p) => (Number.isInteger(p) && p >= 0 ? p % n : null));
  const out = new Array(wants.length).fill(null);
  const taken = new Set();
  const claim = (p, i) => {
    if (p !== null && !out[i] && !taken.has(p)) { taken.add(p); out[i] = style(p, 0); }
  };
  wants.forEach((p, i) => { if (anchors[i]) claim(p, i); });
  wants.forEach(claim);
  let round = 0;
  let used = taken;
  wants.forEach((p, i) => {
    if (out[i]) return;
    if (used.size >= n) { round += 1; used = new Set(); }
    let slot = p === null ? 0 : p;
    while (used.has(slot)) slot = (slot + 1) % n;
    used.add(slot);
    out[i] = style(slot, round);
  });
  return out;
}

/**
 * Line styles of the configurations shown together, in the order given, without preferred slots:
 * the i-th takes PALETTE[i]; past the palette the colours repeat with a dash and a marker of round
 * ⌊i / 8⌋ (`symbol` null in the first round). Returns one `{color, dash, symbol}` per key.
 */
export function configurationStyles(keys) {
  return slotStyles((keys || []).map(() => null));
}

/**
 * The palette slot a configuration prefers: the registry's colour key, or for a label outside the
 * registry (a run logged from outside, docs/platform.md) a slot of its own spelling, so that it keeps
 * its colour from view to view. The one place a label outside the registry is given a colour.
 */
export function labelSlot(label) {
  const key = colourKey(label);
  if (key !== null) return key;
  let hash = 0;
  for (const ch of String(label)) hash = (hash * 31 + ch.codePointAt(0)) >>> 0;
  return hash % PALETTE.length;
}

/**
 * The styles of a job's configurations by algorithm label, in the job page's order (the registry's
 * sort keys), each in its registry colour when free: what the job page, its weights, the paper view
 * and a compare of that job all use, so that a configuration keeps its colour from view to view.
 * The labels must have been described first (algorithms.js `ready`).
 */
export function algorithmStyles(algorithms) {
  const labels = sortLabels([...new Set(algorithms || [])]);
  const styles = slotStyles(labels.map(labelSlot), labels.map(isAnchor));
  return Object.fromEntries(labels.map((label, i) => [label, styles[i]]));
}
