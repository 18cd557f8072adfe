// One fixed colour per algorithm everywhere (job page, compare, studies): colour-blind safe
// (Okabe-Ito and Tol's muted scheme), readable on white and in print. No DOM access here.

const FIXED = {
  uniform: '#5a6473', // grey: the baseline
  'mgrao-1:1': '#0072B2',
  'mgrao-max': '#D55E00',
  oracle: '#009E73',
};
// mgrao-x:1 by x: the paper's ratios first, then further x by their place in this list
const RATIOS = [2, 5, 10, 25, 50, 20, 4, 100, 3, 250, 125];
const RATIO_COLOURS = ['#CC79A7', '#E69F00', '#56B4E9', '#882255', '#44AA99', '#999933', '#AA4499', '#117733',
  '#332288', '#DDCC77', '#661100'];

/** The colour of an algorithm label (uniform, mgrao-1:1, mgrao-x:1, mgrao-max, oracle). */
export function algorithmColour(label) {
  if (label in FIXED) return FIXED[label];
  const m = /^mgrao-(\d+):1$/.exec(String(label));
  if (m) {
    const x = Number(m[1]);
    const i = RATIOS.indexOf(x);
    return RATIO_COLOURS[(i >= 0 ? i : x) % RATIO_COLOURS.length];
  }
  return '#000000';
}
