// "Ours against the paper": one row per (system, configuration) with our % from uniform and its
// 95% interval beside the paper's, flagged where the paper's value lies outside our interval, and
// % of max beside the paper's. Pure functions (no DOM), checked by node's test runner.

/**
 * Rows for the systems of `schema` in its order. `results[system]` is a job's results answer (its
 * configurations' summaries and `paper`), or absent. A row's `outside` is true when the paper's %
 * from uniform is outside our 95% interval, null when either is missing.
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
      rows.push({
        system: sys.name, algorithm, jobId: r ? r.job.id : null,
        ours: s ? s.pct_from_uniform : null, ci: known ? ci : null, paper,
        outside: known ? paper < ci[0] || paper > ci[1] : null,
        oursOfMax: s ? s.pct_of_max : null, paperOfMax: algorithm in ofMax ? ofMax[algorithm] : null,
        runs: s ? s.n_runs : 0,
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
