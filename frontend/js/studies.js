// Studies view: the studies (filter, sort, cursor pages) with their progress and best objective.

import { api } from './api.js';
import { h, notice, nextId } from './ui.js';
import { fmtDate, fmtNumber } from './stats.js';
import { endedTrials } from './studydata.js';

const SORTS = [['-created_at', 'Newest first'], ['created_at', 'Oldest first'], ['name', 'Name A–Z'],
  ['-name', 'Name Z–A'], ['status', 'Status A–Z'], ['-status', 'Status Z–A']];
const PAGE = 50;

export function objectiveText(objective) {
  const what = objective.configuration ? `${objective.metric} of ${objective.configuration}` : objective.metric;
  return `${objective.direction} ${what}`;
}

/** A study's progress: a bar of ended trials over planned, and the counts per status. */
export function studyProgress(study) {
  const ended = endedTrials(study.trials);
  const counts = Object.entries(study.trials || {}).map(([s, n]) => `${n} ${s}`).join(', ');
  return h('div', { class: 'status-progress' },
    h('span', { class: `badge status-${study.status === 'finished' ? 'succeeded' : study.status}` }, study.status),
    h('progress', { max: study.planned, value: ended, 'aria-label': `Study ${study.id}: ${ended} of ${study.planned} trials ended` }),
    h('span', { class: 'pct' }, `${ended}/${study.planned}`),
    counts ? h('span', { class: 'help' }, counts) : null);
}

export async function mount(root, params, ctx) {
  const filters = { status: params.status || '', method: params.method || '', q: params.q || '', sort: params.sort || '-created_at' };
  let cursor = null;
  let token = 0;
  let timer = null;
  let stopped = false;

  const field = (label, control) => {
    control.id = nextId('f');
    return h('div', { class: 'field' }, h('label', { for: control.id }, label), control);
  };
  const statusSel = h('select', { name: 'status' }, h('option', { value: '' }, 'Any'),
    ['running', 'finished', 'cancelled'].map((s) => h('option', { value: s, selected: s === filters.status }, s)));
  const methodSel = h('select', { name: 'method' }, h('option', { value: '' }, 'Any'),
    ['grid', 'random', 'tpe'].map((m) => h('option', { value: m, selected: m === filters.method }, m)));
  const qIn = h('input', { type: 'search', name: 'q', value: filters.q, placeholder: 'name', 'data-shortcut': 'search' });
  const sortSel = h('select', { name: 'sort' }, SORTS.map(([v, l]) => h('option', { value: v, selected: v === filters.sort }, l)));
  const form = h('form', { class: 'filters', role: 'search', 'aria-label': 'Filter studies', onsubmit: (e) => { e.preventDefault(); reload(); } },
    field('Status', statusSel), field('Method', methodSel), field('Search', qIn), field('Sort', sortSel));
  for (const el of [statusSel, methodSel, sortSel]) el.addEventListener('change', reload);
  qIn.addEventListener('change', reload);

  const tbody = h('tbody');
  const table = h('table', { class: 'runs studies' },
    h('caption', { class: 'visually-hidden' }, 'Studies'),
    h('thead', {}, h('tr', {}, ['Id', 'Name', 'Method', 'Progress', 'Objective', 'Best', 'Created']
      .map((c) => h('th', { scope: 'col', class: c === 'Best' ? 'num' : null }, c)))),
    tbody);
  const countEl = h('p', { class: 'count', 'aria-live': 'polite' });
  const errorBox = h('div', { 'aria-live': 'assertive' });
  const emptyBox = h('div');
  const moreBtn = h('button', { type: 'button', class: 'secondary', hidden: true, onclick: () => load(false) }, 'Load more');
  root.append(
    h('div', { class: 'view-head' }, h('h1', {}, 'Studies'),
      h('div', { class: 'toolbar' }, h('a', { class: 'button primary', href: '#/studies/new' }, 'New study'))),
    form, errorBox, countEl, h('div', { class: 'table-wrap' }, table), emptyBox, h('div', { class: 'more' }, moreBtn));

  function row(s) {
    return h('tr', { dataset: { id: s.id } },
      h('td', { class: 'num' }, h('a', { href: `#/studies/${s.id}` }, s.id)),
      h('td', {}, h('a', { href: `#/studies/${s.id}` }, s.name || `study ${s.id}`)),
      h('td', {}, s.method),
      h('td', {}, studyProgress(s)),
      h('td', {}, objectiveText(s.objective)),
      h('td', { class: 'num' }, s.best_value === null ? '–' : `${fmtNumber(s.best_value, 3)} (#${s.best_trial})`),
      h('td', { class: 'nowrap' }, fmtDate(s.created_at)));
  }

  function reload() {
    filters.status = statusSel.value;
    filters.method = methodSel.value;
    filters.q = qIn.value.trim();
    filters.sort = sortSel.value;
    ctx.setQuery(filters);
    cursor = null;
    load(true);
  }

  async function load(fresh) {
    const mine = ++token;
    try {
      const page = await api.listStudies({ ...filters, limit: PAGE, cursor: fresh ? undefined : cursor });
      if (stopped || mine !== token) return;
      if (fresh) tbody.replaceChildren();
      tbody.append(...page.data.map(row));
      cursor = page.next_cursor;
      moreBtn.hidden = !cursor;
      countEl.textContent = `${page.count} ${page.count === 1 ? 'study' : 'studies'}`;
      errorBox.replaceChildren();
      emptyBox.replaceChildren(page.count === 0
        ? notice('empty', 'No studies yet.', h('a', { class: 'button primary', href: '#/studies/new' }, 'Start a study'))
        : '');
      if (fresh && page.data.some((s) => s.status === 'running')) {
        clearTimeout(timer);
        timer = setTimeout(() => { if (!stopped) load(true); }, 3000);
      }
    } catch (e) {
      if (!stopped) errorBox.replaceChildren(notice('error', `Cannot load the studies: ${e.message}`));
    }
  }

  await load(true);
  return () => { stopped = true; clearTimeout(timer); };
}
