// A job's full resolved configuration against its system's preset, and the summary CSV that carries
// it. Pure functions (no DOM), so that node's test runner checks them.

import { fmtParam } from './studydata.js';
import { csvOf, sameValue, systemName } from './stats.js';


/**
 * A parameter group's heading: its title from GET /api/systems (``group_titles``), else the group's name
 * with a capital ("Template" for "template").
 */
export function groupTitle(group, titles = {}) {
  return titles[group] || (group ? group.charAt(0).toUpperCase() + group.slice(1).replace(/[-_]/g, ' ') : 'Other');
}

/**
 * The configuration as rows in the schema's order, grouped: one per parameter with the job's
 * value, the preset's and whether they differ. A parameter the schema does not know (a job stored
 * by another version) is listed last, under "Other".
 */
export function configRows(job, schema) {
  const preset = (schema.systems.find((s) => s.name === job.system) || { params: {} }).params;
  const params = job.params || {};
  const known = new Set();
  const rows = schema.parameters.filter((p) => p.name in params).map((p) => {
    known.add(p.name);
    return {
      group: groupTitle(p.group, schema.group_titles), name: p.name, help: p.help,
      value: params[p.name], preset: preset[p.name], differs: !sameValue(params[p.name], preset[p.name]),
    };
  });
  for (const name of Object.keys(params).sort()) {
    if (!known.has(name)) rows.push({ group: 'Other', name, help: '', value: params[name], preset: preset[name], differs: !sameValue(params[name], preset[name]) });
  }
  // each group once, where it first comes (the schema lists a system parameter after the dynamics too)
  const firstAt = new Map();
  rows.forEach((r, i) => { if (!firstAt.has(r.group)) firstAt.set(r.group, i); });
  return rows.map((r, i) => [r, i]).sort((a, b) => firstAt.get(a[0].group) - firstAt.get(b[0].group) || a[1] - b[1])
    .map(([r]) => r);
}

/**
 * A list or event-list value, one line per item: a scheduled event as "episode 50: new-profiles,
 * fraction 0.3" (its episode first, then its change, then its other fields), a plain item as itself.
 * An empty list reads "none".
 */
export function listLines(value) {
  if (!value.length) return ['none'];
  return value.map((item) => {
    if (item === null || typeof item !== 'object' || Array.isArray(item)) return fmtParam(item);
    const { episode, change, ...rest } = item;
    const head = [episode === undefined ? null : `episode ${episode}:`, change].filter((x) => x !== undefined && x !== null).join(' ');
    const tail = Object.entries(rest).map(([k, v]) => `${k} ${fmtParam(v)}`);
    return [head, ...tail].filter(Boolean).join(', ').replace(':,', ':');
  });
}

/**
 * "3 of 27 parameters differ from the single preset: learning_rate 0.05, ..." (or that none does); a saved
 * system's job says it is that system, whose base is the preset compared with.
 */
export function differenceSummary(job, rows) {
  const differ = rows.filter((r) => r.differs);
  const preset = job.saved_system ? `${job.saved_system}'s base, the ${job.system} preset` : `the ${job.system} preset`;
  if (!differ.length) return `Every parameter is ${preset}'s.`;
  return `${differ.length} of ${rows.length} parameters differ from ${preset}: ` +
    differ.map((r) => `${r.name} ${Array.isArray(r.value) ? `[${listLines(r.value).join('; ')}]` : fmtParam(r.value)}`).join(', ') + '.';
}

/**
 * The final-utility table as CSV, one row per configuration, with the job's identity and every
 * resolved parameter as columns, so that a row read alone says what was run.
 */
export function summaryCsv(job, configurations) {
  const names = Object.keys(job.params || {}).sort();
  const head = ['job_id', 'system', 'saved_system', 'config_hash', 'algorithm', 'seeds_stored', 'seeds', 'episodes', 'final_mean',
    'ci95_low', 'ci95_high', 'pct_from_uniform', 'pct_ci95_low', 'pct_ci95_high', 'pct_of_max', ...names];
  const lines = [head];
  for (const c of configurations) {
    const s = c.summary || {};
    const ci = s.ci95 || [null, null];
    const pci = s.pct_ci95 || [null, null];
    const row = [job.id, job.system, job.saved_system ?? null, job.config_hash, c.algorithm, c.seeds_done ?? s.n_runs, job.seeds.length, job.episodes,
      s.final_mean, ci[0], ci[1], s.pct_from_uniform, pci[0], pci[1], s.pct_of_max, ...names.map((n) => job.params[n])];
    lines.push(row);
  }
  return csvOf(lines);
}

/** The job's configuration as one JSON document: what re-running it needs, and where it came from. */
export function configJson(job) {
  return JSON.stringify({
    id: job.id, name: job.name, system: systemName(job), base: job.system, algorithms: job.algorithms, seeds: job.seeds,
    episodes: job.episodes, params: job.params, config_hash: job.config_hash, version: job.version,
  }, null, 2);
}
