// "Ours against the paper": one row per (system, configuration) with our % from uniform and its
// 95% interval beside the paper's, flagged where the paper's value lies outside our interval, where
// the paper's figure falls among our seeds, and % of max beside the paper's. Which job a system's
// rows come from is chosen here too. Pure functions (no DOM), checked by node's test runner.

/**
 * The job whose results stand for `system` (an entry of GET /api/systems) among `jobs` (listed with
 * `config_hash=system.paper_config_hash`, i.e. the preset's parameters unchanged, 100 episodes): a
 * succeeded one of `episodes` 100 that runs every configuration the paper has a figure for, the one
 * with the most seeds, then the newest. Tags play no part: a clone inherits them. Null if none fits,
 * and always for a system that is no paper experiment (its `paper_config_hash` is null).
 */
export function choosePaperJob(system, jobs) {
  if (!system.paper_config_hash) return null;
  const wanted = Object.keys(system.paper || {});
  let best = null;
  for (const j of jobs) {
    if (j.status !== 'succeeded' || j.episodes !== 100 || j.system !== system.name) continue;
    if (j.config_hash !== system.paper_config_hash) continue;
    if (!wanted.every((a) => j.algorithms.includes(a))) continue;
    if (!best || better(j, best)) best = j;
  }
  return best;
}

function better(a, b) {
  if (a.seeds.length !== b.seeds.length) return a.seeds.length > b.seeds.length;
  if (a.created_at !== b.created_at) return a.created_at > b.created_at;  // ISO 8601 UTC: text order is time order
  return a.id > b.id;
}

/**
 * Where `value` falls among `samples` (our seeds' % from uniform): the mid-rank percentile (the share
 * below plus half the share equal, in %), how many lie below and above, and the count. Null without
 * samples or value.
 */
export function seedPercentile(samples, value) {
  const xs = (samples || []).filter((x) => x !== null && Number.isFinite(x));
  if (!xs.length || value === null || value === undefined) return null;
  const below = xs.filter((x) => x < value).length;
  const above = xs.filter((x) => x > value).length;
  const equal = xs.length - below - above;
  return { percentile: 100 * (below + equal / 2) / xs.length, below, above, n: xs.length,
    min: Math.min(...xs), max: Math.max(...xs) };
}

/** "42nd", "below all 100", "above all 100": a seed percentile as the paper view's cell shows it. */
export function fmtSeedPercentile(p) {
  if (!p) return '–';
  if (p.below === 0 && p.above > 0) return `below all ${p.n}`;
  if (p.above === 0 && p.below > 0) return `above all ${p.n}`;
  const n = Math.round(p.percentile);
  const tens = n % 100;
  const suffix = tens >= 11 && tens <= 13 ? 'th' : ({ 1: 'st', 2: 'nd', 3: 'rd' }[n % 10] || 'th');
  return `${n}${suffix} percentile`;
}

/**
 * Rows for the systems of `schema` in its order. `results[system]` is a job's results answer (its
 * configurations' summaries, `pct_by_seed` (asked for with `?pct_by_seed=true`) and `paper`), or absent. A row's `outside` is true when
 * the paper's % from uniform is outside our 95% interval, null when either is missing;
 * `amongSeeds` is where the paper's figure falls among our seeds' own % from uniform
 * (:func:`seedPercentile`), null without them.
 */
export function paperRows(schema, results) {
  const rows = [];
  for (const sys of schema.systems) {
    const r = results[sys.name];
    const figures = sys.paper || {};
    const ofMax = sys.paper_pct_of_max || {};
    for (const algorithm of Object.keys(figures)) {
      const c = r ? r.configurations.find((x) => x.algorithm === algorithm) : null;
      const s = c ? c.summary : null;
      const ci = s && s.pct_ci95 ? s.pct_ci95 : null;
      const paper = figures[algorithm];
      const known = ci && ci[0] !== null && ci[1] !== null;
      const perSeed = c && c.pct_by_seed ? c.pct_by_seed.map((x) => x.pct_from_uniform) : [];
      rows.push({
        system: sys.name, algorithm, jobId: r ? r.job.id : null,
        ours: s ? s.pct_from_uniform : null, ci: known ? ci : null, paper,
        outside: known ? paper < ci[0] || paper > ci[1] : null,
        oursOfMax: s ? s.pct_of_max : null, paperOfMax: algorithm in ofMax ? ofMax[algorithm] : null,
        runs: s ? s.n_runs : 0, amongSeeds: seedPercentile(perSeed, paper),
      });
    }
  }
  return rows;
}

/** "7 of 10 figures hold the paper's value within our 95% interval." */
export function agreement(rows) {
  const judged = rows.filter((r) => r.outside !== null);
  const inside = judged.filter((r) => !r.outside).length;
  return `${inside} of ${judged.length} figures hold the paper's value within our 95% interval` +
    (judged.length < rows.length ? ` (${rows.length - judged.length} not run yet).` : '.');
}
