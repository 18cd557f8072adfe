// "Ours against the paper": the newest paper run of each system (tag "paper", the preset's
// parameters, 100 episodes) beside the paper's published tables, % from uniform and % of max.

import { api } from './api.js';
import { h, notice } from './ui.js';
import { fmtPct, fmtCI, algorithmRank } from './stats.js';
import { algorithmStyles } from './colours.js';
import { paperRows, agreement } from './paperdata.js';
import { tableCsvButton } from './chartcontrols.js';

const DOC_URL = '/project-docs/reproduction.md';

export async function mount(root, params, ctx) {
  let stopped = false;
  const body = h('div', { 'aria-live': 'polite' }, h('p', { class: 'loading' }, 'Loading the paper runs…'));
  root.append(h('div', { class: 'view-head' }, h('h1', {}, 'Ours against the paper')),
    h('p', { class: 'help' }, 'The paper’s Tables (% from uniform, % of max, after 100 episodes) beside the newest ',
      'succeeded job of each system that runs its preset unchanged for 100 episodes, tagged “paper” ',
      '(New experiment → “Reproduce the paper” queues them). How the figures are made and why some differ: ',
      h('a', { href: DOC_URL, id: 'reproduction-doc' }, 'docs/reproduction.md'), '.'),
    body);

  let schema;
  let results = {};
  try {
    schema = await api.systems();
    const page = await api.listJobs({ tag: 'paper', status: 'succeeded', limit: 200 });
    const candidates = page.data.filter((j) => j.episodes === 100);
    // per system, the newest (the listing is newest first) whose results carry the paper's figures
    const bySystem = {};
    for (const j of candidates) (bySystem[j.system] ||= []).push(j);
    await Promise.all(Object.entries(bySystem).map(async ([system, jobs]) => {
      for (const j of jobs) {
        const r = await api.results(j.id, { points: 10 });
        if (r.paper) { results[system] = r; return; }
      }
    }));
  } catch (e) {
    body.replaceChildren(notice('error', `Cannot load the paper runs: ${e.message}`));
    return () => { stopped = true; };
  }
  if (stopped) return null;
  if (!Object.keys(results).length) {
    body.replaceChildren(notice('empty', 'No paper run has succeeded yet.',
      h('a', { class: 'button primary', href: '#/new' }, 'Reproduce the paper')));
    return () => { stopped = true; };
  }
  const rows = paperRows(schema, results);
  // each system's configurations in the colours of its job's page
  const colours = Object.fromEntries(Object.entries(results).map(([system, r]) =>
    [system, algorithmStyles(r.configurations.map((c) => c.algorithm))]));
  rows.sort((a, b) => schema.systems.findIndex((s) => s.name === a.system) - schema.systems.findIndex((s) => s.name === b.system)
    || algorithmRank(a.algorithm) - algorithmRank(b.algorithm));
  const table = h('table', { class: 'summary paper-table', id: 'paper-table' },
      h('caption', {}, 'A flag marks a figure whose published value lies outside our 95% interval.'),
      h('thead', {}, h('tr', {}, ['System', 'Configuration', 'Job', 'Seeds', 'Ours: % from uniform', '95% CI', 'Paper',
        'Paper within our CI?', 'Ours: % of max', 'Paper: % of max'].map((c) => h('th', { scope: 'col' }, c)))),
      h('tbody', {}, rows.map((r) => h('tr', { class: r.outside ? 'outside' : null, 'data-system': r.system, 'data-algorithm': r.algorithm },
        h('th', { scope: 'row' }, r.system),
        h('td', {}, h('span', { class: 'dot', style: `background: ${colours[r.system]?.[r.algorithm]?.color || 'transparent'}`, 'aria-hidden': 'true' }), r.algorithm),
        h('td', {}, r.jobId ? h('a', { href: `#/jobs/${r.jobId}` }, `#${r.jobId}`) : '–'),
        h('td', { class: 'num' }, r.runs || '–'),
        h('td', { class: 'num' }, fmtPct(r.ours)),
        h('td', { class: 'num ci' }, r.ci ? fmtCI(r.ci, 1, true) : '–'),
        h('td', { class: 'num paper' }, fmtPct(r.paper)),
        h('td', { class: 'flag' }, r.outside === null ? 'not run' : (r.outside ? '⚑ outside' : 'within')),
        h('td', { class: 'num' }, fmtPct(r.oursOfMax, 1, false)),
        h('td', { class: 'num paper' }, r.paperOfMax === null ? '–' : fmtPct(r.paperOfMax, 1, false))))));
  body.replaceChildren(
    h('p', { id: 'paper-agreement' }, agreement(rows), ' ', tableCsvButton(table, 'ours-against-the-paper.csv')),
    h('div', { class: 'table-wrap' }, table));
  return () => { stopped = true; };
}
