// The colours of configurations shown together (job page, compare, paper view, the weights' bars):
// each one its own colour from Okabe-Ito's eight (colour-blind safe, readable on white and in
// print) in a fixed order, then, past eight, the colours again with a dash and a marker. The one
// place that assigns them (a later algorithm registry may carry a colour key per configuration and
// take this over). No DOM access here.

import { algorithmRank } from './stats.js';

// Okabe-Ito, ordered so that the first few shown together are furthest apart: the two blues and
// the two oranges only meet from the seventh configuration on.
export const PALETTE = ['#000000', '#0072B2', '#D55E00', '#009E73', '#CC79A7', '#E69F00', '#56B4E9', '#F0E442'];
const DASHES = ['solid', 'dash', 'dot', 'dashdot', 'longdash', 'longdashdot'];
const SYMBOLS = ['circle', 'square', 'diamond', 'triangle-up', 'x', 'cross'];

/**
 * Line styles of the configurations shown together, in the order given: the i-th takes PALETTE[i];
 * past the palette the colours repeat with a dash and a marker of round ⌊i / 8⌋ (`symbol` null in
 * the first round). Returns one `{color, dash, symbol}` per key.
 */
export function configurationStyles(keys) {
  return (keys || []).map((_, i) => {
    const round = Math.floor(i / PALETTE.length);
    return {
      color: PALETTE[i % PALETTE.length],
      dash: DASHES[round % DASHES.length],
      symbol: round ? SYMBOLS[(round - 1) % SYMBOLS.length] : null,
    };
  });
}

/**
 * The styles of a job's configurations by algorithm label, in the job page's order (uniform, x:1
 * by x, max, oracle): what the job page, its weights, the paper view and a compare of that job
 * all use, so that a configuration keeps its colour from view to view.
 */
export function algorithmStyles(algorithms) {
  const labels = [...new Set(algorithms || [])].sort((a, b) => algorithmRank(a) - algorithmRank(b)
    || String(a).localeCompare(String(b)));
  const styles = configurationStyles(labels);
  return Object.fromEntries(labels.map((label, i) => [label, styles[i]]));
}
