// How compared configurations are told apart: labels by the parameters that differ between them,
// the table of those differences, one chart per system, and a line style per configuration
// (colour by algorithm, dash by variant). Pure functions (no DOM), checked by node's test runner.

import { algorithmColour } from './colours.js';
import { fmtParam } from './studydata.js';
import { sameValue } from './stats.js';

const DASHES = ['solid', 'dash', 'dot', 'dashdot', 'longdash', 'longdashdot'];

/** Each configuration's resolved parameters (and its episodes), by config_hash, from the compared jobs. */
export function configurations(jobs) {
  const out = {};
  for (const j of jobs || []) {
    if (!(j.config_hash in out)) out[j.config_hash] = { system: j.system, episodes: j.episodes, ...(j.params || {}) };
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
 * Labels for compare groups: "system · algorithm", then, where a system holds several
 * configurations, the parameters that differ between them ("single · mgrao-max · learning_rate
 * 0.09"). A short hash is the last resort (configurations that differ in nothing we were sent).
 */
export function groupLabels(groups, configs) {
  const bySystem = {};
  for (const g of groups) (bySystem[g.system] ||= []).push(g.config_hash);
  const differ = Object.fromEntries(Object.entries(bySystem).map(([sys, hashes]) => [sys, differingParams(hashes, configs)]));
  const base = groups.map((g) => {
    const names = differ[g.system] || [];
    const c = configs[g.config_hash];
    const diff = c && names.length ? ` · ${names.map((n) => `${n} ${fmtParam(c[n])}`).join(', ')}` : '';
    return `${g.system} · ${g.algorithm}${diff}`;
  });
  const counts = {};
  for (const b of base) counts[b] = (counts[b] || 0) + 1;
  return groups.map((g, i) => (counts[base[i]] > 1 ? `${base[i]} (${String(g.config_hash || '').slice(0, 6)})` : base[i]));
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

/** Systems in the order their groups come, for one chart per system. */
export function facets(groups) {
  return [...new Set(groups.map((g) => g.system))];
}

/** A group's line: its algorithm's colour, and a dash per configuration of that algorithm and system. */
export function lineStyles(groups) {
  const seen = {};
  return groups.map((g) => {
    const key = `${g.system}|${g.algorithm}`;
    const variants = (seen[key] ||= []);
    if (!variants.includes(g.config_hash)) variants.push(g.config_hash);
    return { color: algorithmColour(g.algorithm), dash: DASHES[variants.indexOf(g.config_hash) % DASHES.length] };
  });
}
