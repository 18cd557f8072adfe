// "Ours against the paper": for each system the job that is the paper's experiment (its preset
// unchanged, 100 episodes, the paper's configurations; the most seeds, then the newest) beside the
// paper's published tables, % from uniform and % of max.

import { api } from './api.js';
import { h, notice } from './ui.js';
import { fmtPct, fmtCI, decidingDigits } from './stats.js';
import { compareLabels, ready, rememberAnswer } from './algorithms.js';
import { algorithmStyles } from './colours.js';
import { paperRows, agreement, choosePaperJob, fmtSeedPercentile } from './paperdata.js';
import { tableCsvButton } from './chartcontrols.js';

const DOC_URL = '/project-docs/reproduction.html';
const MAX_PAGES = 10;  // of 200 jobs of one configuration: far more than anyone runs the paper

/** Every succeeded job of `sys`'s paper configuration (`config_hash`), whatever its tags. */
async function paperJobs(sys) {
  const jobs = [];
  let cursor = null;
  for (let page = 0; page < MAX_PAGES; page += 1) {
    const answer = await api.listJobs({ config_hash: sys.paper_config_hash, status: 'succeeded', limit: 200,
      ...(cursor ? { cursor } : {}) });
    jobs.push(...answer.data);
    cursor = answer.next_cursor;
    if (!cursor) break;
  }
  return jobs;
}

function percentileTitle(r) {
  const p = r.amongSeeds;
  if (!p) return null;
  return `${p.below} of our ${p.n} seeds lie below the paper's ${fmtPct(r.paper)} and ${p.above} above ` +
    `(our seeds range from ${fmtPct(p.min)} to ${fmtPct(p.max)})`;
}

export async function mount(root, params, ctx) {
  let stopped = false;
  const body = h('div', { 'aria-live': 'polite' }, h('p', { class: 'loading' }, 'Loading the paper runs…'));
  root.append(h('div', { class: 'view-head' }, h('h1', {}, 'Ours against the paper')),
    h('p', { class: 'help' }, 'The paper’s Tables (% from uniform, % of max, after 100 episodes) beside, for each ',
      'system, the succeeded job that runs its preset unchanged for 100 episodes with all the paper’s ',
      'configurations: the one with the most seeds, then the newest (tags play no part; the Job column links ',
      'to it). New experiment → “Reproduce the paper” queues them. How the figures are made and why some differ: ',
      h('a', { href: DOC_URL, id: 'reproduction-doc' }, 'Reproducing the paper'), '.'),
    h('p', { class: 'help', id: 'paper-seeds-help' }, 'The paper does not say how many runs its figures average. ',
      'Our 95% interval is for our mean over seeds; “Paper among our seeds” says where the paper’s figure falls ',
      'among our individual seeds’ % from uniform, so a figure outside our interval but well inside our seeds’ ',
      'spread is one a single run like ours could give.'),
    body);

  let schema;
  const results = {};
  try {
    schema = await api.systems();
    await Promise.all(schema.systems.filter((s) => s.paper_config_hash && Object.keys(s.paper || {}).length)
      .map(async (sys) => {
        const job = choosePaperJob(sys, await paperJobs(sys));
        if (job) results[sys.name] = await api.results(job.id, { points: 10, pct_by_seed: true });
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
  for (const r of Object.values(results)) rememberAnswer(r.algorithms, r.configurations.map((c) => c.algorithm));
  await ready(Object.values(results).flatMap((r) => r.configurations.map((c) => c.algorithm))); // order, colours
  if (stopped) return null;
  const rows = paperRows(schema, results);
  // each system's configurations in the colours of its job's page
  const colours = Object.fromEntries(Object.entries(results).map(([system, r]) =>
    [system, algorithmStyles(r.configurations.map((c) => c.algorithm))]));
  rows.sort((a, b) => schema.systems.findIndex((s) => s.name === a.system) - schema.systems.findIndex((s) => s.name === b.system)
    || compareLabels(a.algorithm, b.algorithm));
  const table = h('table', { class: 'summary paper-table', id: 'paper-table' },
      h('caption', {}, 'A flag marks a figure whose published value lies outside our 95% interval.'),
      h('thead', {}, h('tr', {}, ['System', 'Configuration', 'Job', 'Seeds', 'Ours: % from uniform', '95% CI', 'Paper',
        'Paper within our CI?', 'Paper among our seeds', 'Ours: % of max', 'Paper: % of max']
        .map((c) => h('th', { scope: 'col' }, c)))),
      h('tbody', {}, rows.map((r) => h('tr', { class: r.outside ? 'outside' : null, 'data-system': r.system, 'data-algorithm': r.algorithm },
        h('th', { scope: 'row' }, r.system),
        h('td', {}, h('span', { class: 'dot', style: `background: ${colours[r.system]?.[r.algorithm]?.color || 'transparent'}`, 'aria-hidden': 'true' }), r.algorithm),
        h('td', {}, r.jobId ? h('a', { href: `#/jobs/${r.jobId}`, class: 'paper-job' }, `#${r.jobId}`) : '–'),
        h('td', { class: 'num' }, r.runs || '–'),
        h('td', { class: 'num' }, fmtPct(r.ours)),
        h('td', { class: 'num ci' }, r.ci ? fmtCI(r.ci, decidingDigits(r.ci, r.paper), true) : '–'),
        h('td', { class: 'num paper' }, fmtPct(r.paper, decidingDigits(r.ci, r.paper))),
        h('td', { class: 'flag' }, r.outside === null ? 'not run' : (r.outside ? '⚑ outside' : 'within')),
        h('td', { class: 'num seed-rank', title: percentileTitle(r) }, fmtSeedPercentile(r.amongSeeds)),
        h('td', { class: 'num' }, fmtPct(r.oursOfMax, 1, false)),
        h('td', { class: 'num paper' }, r.paperOfMax === null ? '–' : fmtPct(r.paperOfMax, 1, false))))));
  body.replaceChildren(
    h('p', { id: 'paper-agreement' }, agreement(rows), ' ', tableCsvButton('ours-against-the-paper.csv', () => [
      ['system', 'configuration', 'job_id', 'seeds', 'ours_pct_from_uniform_percent', 'ours_pct_ci95_low_percent',
        'ours_pct_ci95_high_percent', 'paper_pct_from_uniform_percent', 'paper_within_ours_ci95',
        'paper_among_our_seeds_percentile', 'ours_pct_of_max_percent', 'paper_pct_of_max_percent'],
      ...rows.map((r) => [r.system, r.algorithm, r.jobId ?? null, r.runs || null, r.ours ?? null, r.ci ? r.ci[0] : null,
        r.ci ? r.ci[1] : null, r.paper ?? null, r.outside === null ? null : !r.outside, r.amongSeeds ? r.amongSeeds.percentile : null,
        r.oursOfMax ?? null, r.paperOfMax ?? null])])),
    h('div', { class: 'table-wrap' }, table));
  return () => { stopped = true; };
}
