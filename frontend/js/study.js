// Study view: state and actions, the trials table (sortable by every parameter and the objective,
// each row opening its job), and the server's aggregated plots: best so far, importance, a heatmap
// of any two dimensions, parallel coordinates and a slice per dimension. While the study runs, a
// light poll (no trials) watches its revision and reloads trials and plots when it moves.

import { api } from './api.js';
import { h, notice, nextId, confirmDialog } from './ui.js';
import { draw, purge, loadPlotly } from './charts.js';
import { fmtDate, fmtNumber } from './stats.js';
import {
  sortTrials, pageOf, fmtParam, historyTraces, importanceTrace, importanceNote, bestText, sliceTraces,
  studyHeatmapTrace, parallelPlot,
} from './studydata.js';
import { objectiveText, studyProgress } from './studies.js';
import { ruleText } from './jobrule.js';

const PAGE = 50;
const POLL_MS = 2000;

export async function mount(root, params, ctx) {
  const id = params.id;
  let stopped = false;
  let timer = null;
  let detail = null;
  let plotsData = null;
  let sortKey = params.sort || 'number';
  let ascending = params.dir !== 'desc';
  let page = Number(params.page) || 0;
  let heatX = params.x || '';
  let heatY = params.y || '';
  let lastFull = 0;
  const charts = [];

  const title = h('h1', {}, `Study ${id}`);
  const actions = h('div', { class: 'toolbar' });
  const stateBox = h('div', { class: 'study-state', 'aria-live': 'polite' });
  const metaBox = h('dl', { class: 'meta' });
  const messages = h('div', { 'aria-live': 'assertive' });
  const tableBox = h('section', { 'aria-labelledby': 'h-trials' });
  const plotsBox = h('section', { 'aria-labelledby': 'h-plots', class: 'study-plots' });
  root.append(h('div', { class: 'view-head' }, title, actions), stateBox, messages, metaBox, plotsBox, tableBox);

  try {
    detail = await api.getStudy(id);
  } catch (e) {
    stateBox.append(notice('error', e.status === 404 ? `There is no study ${id}.` : `Cannot load study ${id}: ${e.message}`,
      h('a', { href: '#/studies' }, 'Back to the studies')));
    return null;
  }

  const study = () => detail.study;
  const dimensions = () => Object.keys(detail.definition.space);
  const objectiveName = () => (study().objective.metric === 'paper_deviation' ? 'worst deviation from the paper'
    : `${study().objective.metric} of ${study().objective.configuration}`);
  const reversed = () => study().objective.direction === 'minimize';

  async function act(button, run) {
    button.disabled = true;
    try {
      await run();
      await refresh(true);
    } catch (e) {
      messages.replaceChildren(notice('error', e.message));
    } finally {
      button.disabled = false;
    }
  }

  function renderHead() {
    const s = study();
    title.textContent = s.name || `Study ${s.id}`;
    document.title = `${title.textContent} · MG-RAO`;
    const counts = s.trials || {};
    const holes = (counts.failed || 0) + (counts.cancelled || 0);
    const buttons = [];
    if (s.status === 'running') {
      const b = h('button', { type: 'button', class: 'danger' }, 'Cancel study');
      b.addEventListener('click', async () => {
        if (!(await confirmDialog('Cancel the study?', `Cancel study ${s.id} with its queued and running trials?`, 'Cancel study', true, 'Keep it running'))) return;
        act(b, () => api.cancelStudy(s.id));
      });
      buttons.push(b);
    }
    if (holes) {
      const b = h('button', { type: 'button', class: 'secondary' }, `Re-run failed (${holes})`);
      b.addEventListener('click', () => act(b, () => api.rerunFailed(s.id)));
      buttons.push(b);
    }
    if (s.status !== 'running') {
      const b = h('button', { type: 'button', class: 'danger' }, 'Delete');
      b.addEventListener('click', async () => {
        if (!(await confirmDialog('Delete the study?', `Delete study ${s.id} with its ${s.planned} trials' jobs and results?`, 'Delete', true, 'Keep the study'))) return;
        try { await api.deleteStudy(s.id); ctx.navigate('/studies'); } catch (e) { messages.replaceChildren(notice('error', e.message)); }
      });
      buttons.push(b);
    }
    buttons.push(h('a', { class: 'button secondary', href: `#/runs?tag=study-${s.id}` }, 'Its jobs'));
    actions.replaceChildren(...buttons);
    stateBox.replaceChildren(studyProgress(s));
    const best = s.best_trial === null ? null : detail.trials.find((t) => t.number === s.best_trial);
    const base = detail.definition.base;
    const pairs = [
      ['Method', `${s.method}${detail.definition.seed ? ` (seed ${detail.definition.seed})` : ''}`],
      ['Objective', objectiveText(s.objective)],
      ['Best', bestText(best, detail.trials, base.until ? null : (base.seeds || []).length, (v) => fmtNumber(v, 4))],
      ['Base', `${[].concat(base.system).map((s) => (typeof s === 'string' ? s : s.name)).join(', ')}; ${base.until
        ? `seeds from ${base.first_seed ?? 0} until the rule answers` : `${base.seeds.length} seeds`} × ${base.episodes} episodes`],
      ...(base.until ? [['Stopping rule', ruleText(base.until)]] : []),
      ['Space', dimensions().map((d) => {
        const dim = detail.definition.space[d];
        return dim.values ? `${d} ∈ {${dim.values.map(fmtParam).join(', ')}}`
          : `${d} ${dim.log ? 'log ' : ''}[${fmtParam(dim.low)}, ${fmtParam(dim.high)}]${dim.steps ? ` in ${dim.steps} steps` : ''}`;
      }).join('; ')],
      ['Trials in flight', `at most ${detail.definition.max_in_flight}`],
      ['Created', fmtDate(s.created_at)],
      ['Finished', fmtDate(s.finished_at)],
    ];
    metaBox.replaceChildren(...pairs.map(([k, v]) => h('div', { class: k === 'Space' || k === 'Best' ? 'wide' : null },
      h('dt', {}, k), h('dd', {}, String(v)))));
  }

  // ---- trials table ----------------------------------------------------------------------
  function renderTable() {
    const dims = dimensions();
    const sorted = sortTrials(detail.trials, sortKey, ascending);
    const shown = pageOf(sorted, page, PAGE);
    page = shown.page;
    const header = (label, key, num = false) => {
      const active = sortKey === key;
      const button = h('button', { type: 'button', class: 'sort', dataset: { key } }, label,
        h('span', { 'aria-hidden': 'true' }, active ? (ascending ? ' ▲' : ' ▼') : ''));
      button.addEventListener('click', () => {
        ascending = active ? !ascending : key !== 'value' || reversed();
        sortKey = key;
        page = 0;
        ctx.setQuery({ sort: sortKey, dir: ascending ? '' : 'desc', x: heatX, y: heatY });
        renderTable();
        tableBox.querySelector(`button.sort[data-key="${CSS.escape(key)}"]`)?.focus();
      });
      return h('th', { scope: 'col', class: num ? 'num' : null, 'aria-sort': active ? (ascending ? 'ascending' : 'descending') : 'none' }, button);
    };
    const rows = shown.rows.map((t) => {
      const jobs = t.job_ids.map((j, i) => [i ? ' ' : '', h('a', { href: `#/jobs/${j}` }, `job ${j}`)]);
      const tr = h('tr', { dataset: { number: t.number }, class: t.number === study().best_trial ? 'best' : null },
        h('td', { class: 'num' }, t.number),
        h('td', {}, h('span', { class: `badge status-${t.status === 'pending' ? 'queued' : t.status}` }, t.status)),
        dims.map((d) => h('td', { class: 'num' }, fmtParam(t.params[d]))),
        h('td', { class: 'num' }, fmtNumber(t.value, 4)),
        h('td', { class: 'num ci' }, t.ci95 ? `[${fmtNumber(t.ci95[0], 3)}, ${fmtNumber(t.ci95[1], 3)}]` : ''),
        h('td', { class: 'nowrap' }, jobs),
        h('td', { class: 'note', title: t.error || '' }, t.error || '',
          (t.max_seeds_jobs || []).length ? h('span', { class: 'max-seeds' }, `${t.error ? ' ' : ''}stopped at max_seeds`) : null));
      if (t.job_ids.length) {
        tr.classList.add('clickable');
        tr.addEventListener('click', (ev) => { if (!ev.target.closest('a, button')) ctx.navigate(`/jobs/${t.job_ids[0]}`); });
      }
      return tr;
    });
    const pager = h('div', { class: 'pager' },
      h('button', { type: 'button', class: 'secondary small', disabled: shown.page === 0, onclick: () => { page -= 1; renderTable(); } }, 'Previous'),
      h('span', { class: 'pct' }, `page ${shown.page + 1} of ${shown.pages} (${detail.trials.length} trials)`),
      h('button', { type: 'button', class: 'secondary small', disabled: shown.page >= shown.pages - 1, onclick: () => { page += 1; renderTable(); } }, 'Next'));
    const atMost = detail.trials.filter((t) => (t.max_seeds_jobs || []).length).length;
    tableBox.replaceChildren(...[ // no "null" where there is no note
      h('h2', { id: 'h-trials' }, 'Trials'),
      h('p', { class: 'help' }, 'Sort by any column; a row opens its job (a study over several systems has a job per system).'),
      atMost ? h('p', { class: 'notice warn', id: 'max-seeds-trials', role: 'status' },
        `${atMost} trial${atMost === 1 ? '' : 's'} stopped at max_seeds before the stopping rule answered: `
        + 'their objective is less precise than the rule asks (marked "stopped at max_seeds").') : null,
      h('div', { class: 'table-wrap' }, h('table', { class: 'trials' },
        h('caption', { class: 'visually-hidden' }, 'Trials of the study'),
        h('thead', {}, h('tr', {}, header('#', 'number', true), header('Status', 'status'),
          dims.map((d) => header(d, `param:${d}`, true)), header(objectiveName(), 'value', true),
          h('th', { scope: 'col', class: 'num' }, '95% CI over seeds'), h('th', { scope: 'col' }, 'Jobs'), h('th', { scope: 'col' }, 'Error'))),
        h('tbody', {}, rows))),
      ...(shown.pages > 1 ? [pager] : [])].filter(Boolean));
  }

  // ---- plots -----------------------------------------------------------------------------
  const chart = (cls, label) => {
    const el = h('div', { class: `chart ${cls}`, role: 'img', 'aria-label': label });
    charts.push(el);
    return el;
  };
  const historyChart = chart('study-history', 'Best objective so far against the trial number');
  const importanceChart = chart('study-importance', 'Share of the objective’s variance each parameter explains');
  const heatmapChart = chart('study-heatmap', 'Mean objective over two parameters');
  const parallelChart = chart('study-parallel', 'Parallel coordinates of the trials');
  const slicesBox = h('div', { class: 'slices' });
  const xSel = h('select', { id: nextId('hx') });
  const ySel = h('select', { id: nextId('hy') });
  const plotsNote = h('p', { class: 'help', 'aria-live': 'polite', id: 'plots-note' });
  const importanceCaution = h('p', { class: 'help warn-text', id: 'importance-note', role: 'status' });
  const plotsGrid = h('div');
  for (const sel of [xSel, ySel]) {
    sel.addEventListener('change', async () => {
      heatX = xSel.value;
      heatY = ySel.value;
      ctx.setQuery({ sort: sortKey, dir: ascending ? '' : 'desc', x: heatX, y: heatY });
      await loadPlots();
    });
  }

  function layoutPlots() {
    const dims = dimensions();
    for (const [sel, value, fallback] of [[xSel, heatX, dims[0]], [ySel, heatY, dims[1] || dims[0]]]) {
      sel.replaceChildren(...dims.map((d) => h('option', { value: d, selected: d === (value || fallback) }, d)));
    }
    plotsGrid.replaceChildren(
      h('div', { class: 'grid2' },
        h('figure', {}, h('figcaption', {}, 'Best so far'), historyChart),
        h('figure', {}, h('figcaption', {}, 'Parameter importance (η²: variance explained by each parameter alone)'),
          importanceChart, importanceCaution)),
      h('div', { class: 'grid2' },
        h('figure', {}, h('figcaption', {}, 'Heatmap: mean objective'),
          h('div', { class: 'controls' }, h('label', { for: xSel.id }, 'x'), xSel, h('label', { for: ySel.id }, 'y'), ySel),
          heatmapChart),
        h('figure', {}, h('figcaption', {}, 'Parallel coordinates'), parallelChart)),
      h('h3', {}, 'Slices: the objective (95% CI over seeds) against each parameter, with the mean per value'),
      slicesBox);
    plotsBox.replaceChildren(h('h2', { id: 'h-plots' }, 'What the trials show'), plotsNote, plotsGrid);
  }

  async function loadPlots() {
    try {
      plotsData = await api.studyPlots(id, { x: xSel.value || undefined, y: ySel.value || undefined });
    } catch (e) {
      plotsNote.textContent = `Cannot load the plots: ${e.message}`;
      return;
    }
    if (stopped) return;
    await drawPlots();
  }

  async function drawPlots() {
    const p = plotsData;
    const name = objectiveName();
    plotsNote.textContent = p.trials ? `${p.trials} trials with an objective; plots of large studies show at most 1,000 trials, the best first.`
      : 'No trial has an objective yet: the plots fill in as trials finish.';
    plotsGrid.hidden = !p.trials; // nothing is known yet: no axes drawn around nothing
    if (!p.trials) { plotsBox.dataset.rendered = String(Date.now()); return; }
    importanceCaution.textContent = importanceNote(p.importance, p.trials);
    const axis = (text, extra = {}) => ({ title: { text }, zeroline: false, ...extra });
    await draw(historyChart, historyTraces(p.history, name), { xaxis: axis('Trial'), yaxis: axis(name), hovermode: 'closest' });
    await draw(importanceChart, [importanceTrace(p.importance)], { xaxis: axis('η²', { range: [0, 1] }), yaxis: { automargin: true }, hovermode: 'closest', showlegend: false, margin: { l: 140, r: 16, t: 24, b: 52 } });
    const hm = p.heatmap;
    // automargin: the margins grow to hold the tick labels, and each title sits clear of them
    await draw(heatmapChart, [studyHeatmapTrace(hm, reversed())], {
      xaxis: axis(hm.x, { type: 'category', automargin: true, title: { text: hm.x, standoff: 8 } }),
      yaxis: axis(hm.y, { type: 'category', automargin: true, title: { text: hm.y, standoff: 8 } }),
      hovermode: 'closest' });
    heatmapChart.dataset.cells = String(hm.count.flat().filter((c) => c > 0).length);
    const logs = Object.fromEntries(p.dimensions.map((d) => [d, !!(detail.definition.space[d] || {}).log]));
    const parallel = parallelPlot(p.parallel, p.dimensions, name, { minimize: reversed(), logs });
    await draw(parallelChart, parallel.traces, parallel.layout);
    const slices = p.dimensions.map((d) => {
      let el = slicesBox.querySelector(`[data-dimension="${CSS.escape(d)}"]`);
      if (!el) {
        el = chart('study-slice', `Objective against ${d}`);
        el.dataset.dimension = d;
        slicesBox.append(el);
      }
      return [d, el];
    });
    for (const [d, el] of slices) {
      const dim = detail.definition.space[d];
      await draw(el, sliceTraces(p.slices[d], d), {
        xaxis: axis(d, dim && dim.log ? { type: 'log' } : {}), yaxis: axis(name), hovermode: 'closest', showlegend: false,
      });
    }
    plotsBox.dataset.rendered = String(Date.now());
  }

  // ---- refresh ---------------------------------------------------------------------------
  async function refresh(full) {
    if (full) {
      detail = await api.getStudy(id);
      lastFull = Date.now();
    }
    if (stopped) return;
    renderHead();
    renderTable();
    await loadPlots();
  }

  async function poll() {
    if (stopped) return;
    try {
      const head = await api.getStudy(id, { query: { trials: 'false' } });
      const moved = head.study.revision !== study().revision;
      const wait = detail.trials.length > 2000 ? 5000 : 0; // big studies reload at most every 5 s
      if (moved && Date.now() - lastFull >= wait) await refresh(true);
    } catch (e) {
      if (e.status === 404) { stopped = true; messages.replaceChildren(notice('error', 'This study was deleted.')); return; }
    }
    if (!stopped && study().status === 'running') timer = setTimeout(poll, POLL_MS);
  }

  renderHead();
  renderTable();
  layoutPlots();
  // the table is usable now; plotly.js (a second or more of main thread on slow machines) loads after
  // the browser has painted it
  await new Promise((resolve) => requestAnimationFrame(() => setTimeout(resolve, 0)));
  tableBox.dataset.ready = String(Date.now());
  loadPlotly();
  await loadPlots();
  if (study().status === 'running') timer = setTimeout(poll, POLL_MS);
  return () => { stopped = true; clearTimeout(timer); for (const c of charts) purge(c); };
}
