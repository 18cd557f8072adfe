// The runs table's optional columns: a configuration's results and any parameter, and the server
// sort each header click asks for. Pure functions (no DOM), checked by node's test runner.

import { fmtParam } from './studydata.js';

export const RESULT_COLUMNS = [
  { field: 'final_mean', title: 'Final mean', help: 'Mean system utility of the last 10 episodes, over seeds (95% interval on hover).' },
  { field: 'pct_from_uniform', title: '% from uniform', help: 'Gain over uniform, paired seed by seed (95% interval on hover).' },
  { field: 'pct_of_max', title: '% of max', help: 'Share of mgrao-max’s gain over uniform that this configuration reaches.' },
];

/** The sort key of a column: `final_mean:mgrao-max`, `param.learning_rate`, or a plain column. */
export function sortKey(column) {
  if (column.kind === 'result') return `${column.field}:${column.configuration}`;
  if (column.kind === 'param') return `param.${column.name}`;
  return column.key;
}

/** What a click on a header sorts by: the other direction if it already sorts by it, else its first one. */
export function nextSort(current, key, firstDescending) {
  if (current === key) return `-${key}`;
  if (current === `-${key}`) return key;
  return firstDescending ? `-${key}` : key;
}

/** `ascending`, `descending` or `none`: how a column's header says it sorts (aria-sort). */
export function sortState(current, key) {
  if (current === key) return 'ascending';
  if (current === `-${key}`) return 'descending';
  return 'none';
}

/** The optional columns chosen, as cells' text: a result (with its interval) or a parameter. */
export function cellText(job, column) {
  if (column.kind === 'param') {
    const params = job.params || {};
    return column.name in params ? fmtParam(params[column.name]) : '–';
  }
  const s = (job.summaries || {})[column.configuration];
  const v = s ? s[column.field] : null;
  if (v === null || v === undefined || !Number.isFinite(v)) return '–';
  if (column.field === 'final_mean') return v.toFixed(3);
  return `${v >= 0 && column.field === 'pct_from_uniform' ? '+' : ''}${v.toFixed(1)}%`;
}

/** The 95% interval behind a result cell, for its tooltip, or ''. */
export function cellInterval(job, column) {
  if (column.kind !== 'result' || column.field === 'pct_of_max') return '';
  const s = (job.summaries || {})[column.configuration];
  const ci = s ? (column.field === 'final_mean' ? s.ci95 : s.pct_ci95) : null;
  if (!ci || ci[0] === null || ci[1] === null) return '';
  const digits = column.field === 'final_mean' ? 3 : 1;
  const unit = column.field === 'final_mean' ? '' : '%';
  return `95% CI [${ci[0].toFixed(digits)}${unit}, ${ci[1].toFixed(digits)}${unit}] over ${s.n_runs} seeds`;
}

/**
 * The optional columns from the view's query: `result=mgrao-max` and `cols=learning_rate,trace_decay`; `reference`
 * is the registry's reference configuration (% of max is a share of its gain: its own column would be 100%).
 */
export function columnsFromQuery(result, cols, knownParams, reference = null) {
  const out = [];
  for (const r of result ? RESULT_COLUMNS : []) {
    if (r.field === 'pct_of_max' && result === reference) continue; // its own gain's share: 100% by definition
    out.push({ kind: 'result', configuration: result, ...r });
  }
  for (const name of (cols || '').split(',').map((s) => s.trim()).filter(Boolean)) {
    if (knownParams.has(name) && !out.some((c) => c.kind === 'param' && c.name === name)) {
      out.push({ kind: 'param', name, title: name });
    }
  }
  return out;
}

/** The page size that reads every row shown again in one request (the API's limit is 200). */
export function refreshLimit(shown, page, max = 200) {
  return Math.min(max, Math.max(page, shown));
}

/** Whether a row needs no redraw: the job as read again equals the one shown (state, progress, labels, summaries). */
export function sameJob(shown, read) {
  return JSON.stringify(shown) === JSON.stringify(read);
}

/** Whether only the progress of the job moved (its row's progress bar is updated in place, not redrawn). */
export function progressOnly(shown, read) {
  return shown.progress !== read.progress && sameJob({ ...shown, progress: 0 }, { ...read, progress: 0 });
}

/**
 * The run list as CSV rows (header first): each job's identity and configuration, then, with result `columns`,
 * that configuration's figures with their intervals and seeds, then the parameter columns. Numbers as the API
 * gave them (units in the column names), lists joined by spaces, never the cells as shown.
 */
export function exportRows(jobs, columns) {
  const results = columns.filter((c) => c.kind === 'result');
  const params = columns.filter((c) => c.kind === 'param');
  const configuration = results.length ? results[0].configuration : null;
  const head = ['id', 'name', 'status', 'kind', 'system', 'saved_system', 'algorithms', 'seeds', 'episodes', 'tags',
    'created_at', 'finished_at', 'duration_s'];
  if (configuration) {
    head.push('configuration', 'n_runs', 'n_paired', 'final_mean_utility', 'final_ci95_low_utility',
      'final_ci95_high_utility', 'pct_from_uniform_percent', 'pct_ci95_low_percent', 'pct_ci95_high_percent',
      'pct_of_max_percent');
  }
  head.push(...params.map((c) => c.name));
  const value = (v) => (v === undefined ? null : v);
  const rows = jobs.map((job) => {
    const row = [job.id, job.name, job.status, job.kind, job.system, value(job.saved_system), (job.algorithms || []).join(' '),
      Array.isArray(job.seeds) ? job.seeds.length : job.seeds, job.episodes, (job.tags || []).join(' '),
      value(job.created_at), value(job.finished_at), value(job.duration_s)];
    if (configuration) {
      const s = (job.summaries || {})[configuration] || {};
      const ci = s.ci95 || [null, null];
      const pci = s.pct_ci95 || [null, null];
      row.push(configuration, value(s.n_runs), value(s.n_paired), value(s.final_mean), ci[0], ci[1],
        value(s.pct_from_uniform), pci[0], pci[1], value(s.pct_of_max));
    }
    row.push(...params.map((c) => {
      const v = (job.params || {})[c.name];
      return v !== null && typeof v === 'object' ? JSON.stringify(v) : value(v);
    }));
    return row;
  });
  return [head, ...rows];
}
