// How compared configurations are told apart: labels by the parameters that differ between them,
// the table of those differences, one chart per system, a line style per configuration (each its
// own colour, colours.js) and a legend that never crowds the axes. Pure functions (no DOM), checked
// by node's test runner.

import { isAnchor, labelSlot, slotStyles } from './colours.js';
import { compareLabels } from './algorithms.js';
import { fmtParam } from './studydata.js';
import { sameValue, systemName } from './stats.js';

/**
 * Each configuration's resolved parameters (and its episodes), by config_hash, from the compared jobs; its system
 * named as compare's `groups` name it (a saved system's name where its jobs ran one, the server's rule:
 * docs/statistics.md, "Names"), else as its first job does.
 */
export function configurations(jobs, groups = []) {
  const named = {};
  for (const g of groups || []) {
    for (const hash of g.config_hashes || [g.config_hash]) if (!(hash in named)) named[hash] = g.system;
  }
  const out = {};
  for (const j of jobs || []) {
    if (!(j.config_hash in out)) {
      out[j.config_hash] = { system: named[j.config_hash] ?? systemName(j), episodes: j.episodes, ...(j.params || {}) };
    }
  }
  return out;
}

/** The parameters (and `episodes`) whose values differ between the given configurations, sorted. */
export function differingParams(hashes, configs) {
  const unique = [...new Set(hashes)].filter((h) => configs[h]);
  if (unique.length < 2) return [];
  const names = new Set(unique.flatMap((h) => Object.keys(configs[h])));
  names.delete('system');
  return [...names].filter((n) => unique.some((h) => !sameValue(configs[h][n], configs[unique[0]][n]))).sort();
}

/**
 * Labels for compare groups: "world · label", as the server names them (docs/statistics.md, "Pairing"): the
 * world is its system's name, and where worlds share a system, what differs ("single (episodes=200)"); the label
 * is the algorithm's, and where two configurations of one world share it, what tells them apart
 * ("mgrao-1:1 (learning_rate=0.2)", "hedge (job 12)").
 */
export function groupLabels(groups) {
  return groups.map((g) => `${g.world ?? g.system} · ${g.label ?? g.algorithm}`);
}

/** Rows of the parameter diff table: `{name, values: [...]}` over the configurations in order. */
export function diffTable(hashes, configs) {
  const unique = [...new Set(hashes)].filter((h) => configs[h]);
  const names = differingParams(unique, configs);
  const systems = new Set(unique.map((h) => configs[h].system));
  const rows = names.map((name) => ({ name, values: unique.map((h) => fmtParam(configs[h][name])) }));
  if (systems.size > 1) rows.unshift({ name: 'system', values: unique.map((h) => configs[h].system) });
  return { hashes: unique, rows };
}

/** Worlds (systems) in the order their groups come, for one chart per world. */
export function facets(groups) {
  return [...new Set(groups.map(facetOf))];
}

/** The chart a group is drawn on: its world's. */
export function facetOf(group) {
  return group.world ?? group.system;
}

/**
 * Each group's line `{color, dash, symbol}`: the groups of one system (drawn together on its chart)
 * each their own (`slotStyles`, each preferring its registry colour), handed out job by job in the
 * order of `jobs` (the compared jobs), within a job in the job page's order (the registry's sort
 * keys): a compare of one job draws it in its job page's colours, and the first job of several
 * keeps them. The groups' labels must have been described first (algorithms.js `ready`).
 */
export function lineStyles(groups, jobs = []) {
  const order = (jobs || []).map((j) => j.config_hash);
  const place = (g) => { const i = order.indexOf(g.config_hash); return i < 0 ? order.length : i; };
  const out = new Array(groups.length);
  for (const system of facets(groups)) {
    const ranked = groups.map((_, i) => i).filter((i) => facetOf(groups[i]) === system)
      .sort((a, b) => place(groups[a]) - place(groups[b])
        || compareLabels(groups[a].algorithm, groups[b].algorithm) || a - b);
    const styles = slotStyles(ranked.map((i) => labelSlot(groups[i].algorithm)),
      ranked.map((i) => isAnchor(groups[i].algorithm)));
    ranked.forEach((g, k) => { out[g] = styles[k]; });
  }
  return out;
}

const LEGEND_ROW_PX = 30; // a row of the horizontal legend at 13 px (plotly.js spaces them so)
const LEGEND_CHAR_PX = 7.2; // a character of a legend label, on average, at 13 px
const LEGEND_ITEM_PX = 46; // the line sample and the gaps around an item

/** Rows a horizontal legend of `labels` takes in `width` pixels (items packed left to right). */
export function legendRows(labels, width) {
  let rows = labels.length ? 1 : 0;
  let used = 0;
  for (const label of labels) {
    const item = LEGEND_ITEM_PX + String(label).length * LEGEND_CHAR_PX;
    if (used > 0 && used + item > width) { rows += 1; used = 0; }
    used += item;
  }
  return rows;
}

/** Past this many legend rows a chart leaves its legend out (the "Shown configurations" swatches are the key). */
export const MAX_LEGEND_ROWS = 16;

/**
 * A utility chart's height, bottom margin and legend for `labels` on a chart `width` pixels wide:
 * the plot area keeps `plotHeight` pixels whatever the number of configurations, the legend sits
 * below the "Episode" axis title, and the chart grows by one legend row at a time, up to
 * MAX_LEGEND_ROWS rows; a longer legend is left out (`showlegend` false).
 */
export function legendLayout(labels, width, plotHeight = 300, top = 48) {
  const needed = legendRows(labels, Math.max(100, width - 80));
  const showlegend = needed <= MAX_LEGEND_ROWS;
  const rows = showlegend ? needed : 0;
  const below = 68; // tick labels and the axis title under the plot area, and a gap
  const bottom = below + rows * LEGEND_ROW_PX + 8;
  return {
    height: top + plotHeight + bottom,
    margin: { l: 64, r: 16, t: top, b: bottom },
    showlegend,
    legend: { orientation: 'h', x: 0, xanchor: 'left', y: -below / plotHeight, yanchor: 'top',
      maxheight: rows * LEGEND_ROW_PX + 16 }, // in pixels: no scroll bar, the whole legend shows
  };
}

/**
 * The % from uniform bars' height and margins for `labels` under the bars at -35°: the plot area
 * keeps `plotHeight` pixels however long the labels (the deepest label sets the bottom margin).
 */
export function barsLayout(labels, plotHeight = 260) {
  const longest = Math.max(0, ...labels.map((l) => String(l).length));
  const bottom = Math.ceil(longest * LEGEND_CHAR_PX * Math.sin((35 * Math.PI) / 180)) + 24;
  const left = 64 + Math.ceil(Math.min(longest, 24) * LEGEND_CHAR_PX * 0.82 * 0.5); // the first label reaches left
  return { height: 24 + plotHeight + bottom, margin: { l: left, r: 16, t: 24, b: bottom }, tickangle: -35 };
}
