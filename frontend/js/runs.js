// Runs view: filterable, sortable, cursor-paginated table of jobs with compare/edit/cancel/delete.

import { api } from './api.js';
import { h, statusCell, confirmDialog, promptDialog, cancelConsequence, keepLabel, editJobDialog, notice, debounce, nextId, downloadText } from './ui.js';
import { fmtDate, fmtDuration, seedCount, parseTags, csvOf, systemName, systemDescription } from './stats.js';
import { outsideRegistry, ready, sortLabels } from './algorithms.js';
import { columnsFromQuery, sortKey, nextSort, sortState, cellText, cellInterval, refreshLimit, sameJob, progressOnly, exportRows } from './runcolumns.js';

const STATUSES = ['queued', 'running', 'succeeded', 'failed', 'cancelled', 'open'];
const SORTS = [
  ['-created_at', 'Newest first'], ['created_at', 'Oldest first'], ['name', 'Name A–Z'],
  ['-name', 'Name Z–A'], ['status', 'Status A–Z'], ['-status', 'Status Z–A'],
];
const PAGE = 50;
const FIXED_SORTS = { Name: 'name', Status: 'status', Created: 'created_at' };

export async function mount(root, params, ctx) {
  const t0 = performance.now();
  const filters = {
    status: params.status || '', system: params.system || '', tag: params.tag || '',
    q: params.q || '', sort: params.sort || '-created_at', result: params.result || '', cols: params.cols || '',
  };
  let schema = null;
  try { schema = await api.systems(); } catch { /* the banner reports an unreachable server */ }
  const knownParams = new Set(schema ? schema.parameters.map((p) => p.name) : []);
  const reference = schema ? schema.algorithms.reference : null; // % of max's yardstick (mgrao-max)
  let columns = columnsFromQuery(filters.result, filters.cols, knownParams, reference);
  const selected = new Set();
  const rows = new Map(); // id -> {job, tr}
  let cursor = null;
  let loadToken = 0;
  let localEdits = 0; // rows this page changed itself (cancel, edit, tag, delete): newer than an answer on its way
  let refreshing = false;
  let refreshAgain = false;
  let stopped = false;

  const live = h('p', { class: 'visually-hidden', 'aria-live': 'polite' });
  const errorBox = h('div', { 'aria-live': 'assertive' });
  const countEl = h('p', { class: 'count', 'aria-live': 'polite' });

  const field = (label, control) => {
    const id = nextId('f');
    control.id = id;
    return h('div', { class: 'field' }, h('label', { for: id }, label), control);
  };
  const statusSel = h('select', { name: 'status' }, h('option', { value: '' }, 'Any'),
    STATUSES.map((s) => h('option', { value: s, selected: s === filters.status }, s)));
  const systemSel = h('select', { name: 'system' }, h('option', { value: '' }, 'Any'));
  const tagIn = h('input', { type: 'text', name: 'tag', value: filters.tag, placeholder: 'e.g. paper' });
  const qIn = h('input', { type: 'search', name: 'q', value: filters.q, placeholder: 'name, notes, tags', 'data-shortcut': 'search' });
  const sortSel = h('select', { name: 'sort' });
  function fillSorts() {
    const options = SORTS.map(([v, l]) => h('option', { value: v, selected: v === filters.sort }, l));
    if (!SORTS.some(([v]) => v === filters.sort)) {
      const key = filters.sort.replace(/^-/, '');
      const col = columns.find((c) => sortKey(c) === key);
      const what = col ? (col.kind === 'result' ? `${col.title} of ${col.configuration}` : col.name) : key;
      options.push(h('option', { value: filters.sort, selected: true }, `${what}, ${filters.sort.startsWith('-') ? 'highest' : 'lowest'} first`));
    }
    sortSel.replaceChildren(...options);
  }
  fillSorts();
  // every configuration a system of the form runs (mgrao-2:1 ... of large, a saved system's), then those of the
  // jobs listed as they load
  const resultLabels = new Set([...(schema ? schema.algorithms.fixed : []),
    ...(schema ? [...schema.systems, ...(schema.saved || [])].flatMap((s) => s.algorithms || []) : []),
    ...(filters.result ? [filters.result] : [])]);
  const resultSel = h('select', { name: 'result' }, h('option', { value: '' }, 'none'),
    [...resultLabels].map((c) => h('option', { value: c, selected: c === filters.result }, c)));
  function offerResults(labels) {
    for (const label of labels) {
      if (resultLabels.has(label)) continue;
      resultLabels.add(label);
      resultSel.append(h('option', { value: label }, label));
    }
  }
  const paramBoxes = schema ? schema.parameters.map((p) => h('label', { class: 'check', title: p.help },
    h('input', { type: 'checkbox', value: p.name, checked: columns.some((c) => c.kind === 'param' && c.name === p.name),
      onchange: () => { readFilters(); renderHead(); load(true); } }), ` ${p.name}`)) : [];
  const columnsBox = h('details', { class: 'columns-picker' }, h('summary', {}, 'Parameter columns'),
    h('div', { class: 'param-boxes' }, paramBoxes));

  const compareBtn = h('button', { type: 'button', class: 'primary', disabled: true, 'data-shortcut': 'compare', onclick: () => {
    ctx.navigate('/compare', { jobs: [...selected].sort((a, b) => a - b).join(',') });
  } }, 'Compare selected');
  const clearBtn = h('button', { type: 'button', class: 'secondary', disabled: true, onclick: () => {
    selected.clear();
    for (const cb of tbody.querySelectorAll('input[type=checkbox]')) cb.checked = false;
    updateSelection();
  } }, 'Clear selection');

  // Bulk actions on the selected jobs: one request per job, then a line saying what each did.
  const bulkStatus = h('p', { class: 'help bulk-status', id: 'bulk-status', 'aria-live': 'polite' });
  async function bulk(what, eligible, act) {
    const chosen = [...selected].map((id) => rows.get(id)?.job).filter(Boolean);
    const doing = chosen.filter(eligible);
    let done = 0;
    const failed = [];
    for (const job of doing) {
      try { await act(job); done += 1; } catch (e) { failed.push(`job ${job.id}: ${e.message}`); }
    }
    const skipped = chosen.length - doing.length;
    bulkStatus.textContent = `${what}: ${done} of ${chosen.length} selected job${chosen.length === 1 ? '' : 's'}` +
      (skipped ? `; ${skipped} skipped (${what === 'Cancelled' ? 'not queued or running' : 'running: cancel first'})` : '') +
      (failed.length ? `; failed: ${failed.join('; ')}` : '') + '.';
  }
  const tagBtn = h('button', { type: 'button', class: 'secondary', disabled: true, onclick: async () => {
    // Comma separated like every other tag field: `quicklook, single` adds two tags.
    const tags = parseTags(await promptDialog('Tag the selected jobs',
      `Tags to add to ${selected.size} job${selected.size === 1 ? '' : 's'} (comma separated)`, 'Add tags', { maxlength: 500 }));
    if (!tags.length) return;
    await bulk('Tagged', () => true, async (job) => {
      const missing = tags.filter((t) => !(job.tags || []).includes(t));
      if (missing.length) replaceRow(await api.patchJob(job.id, { tags: [...(job.tags || []), ...missing] }));
    });
  } }, 'Tag selected');
  const cancelSelBtn = h('button', { type: 'button', class: 'secondary', disabled: true, onclick: async () => {
    if (!(await confirmDialog('Cancel the selected jobs?', `Cancel the queued and running jobs among the ${selected.size} selected? ` +
      'The runs they completed are kept.', 'Cancel them', true, 'Keep them'))) return;
    await bulk('Cancelled', (job) => job.status === 'queued' || job.status === 'running', async (job) => replaceRow(await api.cancelJob(job.id)));
  } }, 'Cancel selected');
  const deleteSelBtn = h('button', { type: 'button', class: 'danger', disabled: true, onclick: async () => {
    if (!(await confirmDialog('Delete the selected jobs?', `Delete the ${selected.size} selected jobs that are not running, with all their results? ` +
      'This cannot be undone.', 'Delete them', true, 'Keep them'))) return;
    await bulk('Deleted', (job) => job.status !== 'running', async (job) => {
      await api.deleteJob(job.id);
      localEdits += 1;
      rows.get(job.id)?.tr.remove();
      rows.delete(job.id);
      selected.delete(job.id);
    });
    updateSelection();
  } }, 'Delete selected');

  // The listed jobs (every page, under the filters and sort shown) as a file: CSV of numbers, or the API's JSON.
  const exportStatus = h('span', { class: 'help', 'aria-live': 'polite' });
  async function exportList(format) {
    exportStatus.textContent = 'Reading every listed job…';
    const jobs = [];
    let next;
    try {
      do {
        const page = await api.listJobs({ status: filters.status, system: filters.system, tag: filters.tag, q: filters.q,
          sort: filters.sort, limit: 200, cursor: next });
        jobs.push(...page.data);
        next = page.next_cursor;
      } while (next && !stopped);
    } catch (e) {
      exportStatus.textContent = `Export failed: ${e.message}`;
      return;
    }
    if (format === 'csv') downloadText('runs.csv', 'text/csv', csvOf(exportRows(jobs, columns)));
    else downloadText('runs.json', 'application/json', JSON.stringify(jobs, null, 1));
    exportStatus.textContent = `${jobs.length.toLocaleString('en-US')} job${jobs.length === 1 ? '' : 's'} exported.`;
  }
  const exportBox = h('p', { class: 'exports' }, 'Export the listed jobs: ',
    h('button', { type: 'button', class: 'small secondary', id: 'export-csv', onclick: () => exportList('csv') }, 'CSV'), ' ',
    h('button', { type: 'button', class: 'small secondary', id: 'export-json', onclick: () => exportList('json') }, 'JSON'),
    ' ', exportStatus);

  const filterForm = h('form', { class: 'filters', role: 'search', 'aria-label': 'Filter jobs', onsubmit: (e) => { e.preventDefault(); reload(); } },
    field('Status', statusSel), field('System', systemSel), field('Tag', tagIn), field('Search', qIn), field('Sort', sortSel),
    field('Result columns of', resultSel), columnsBox);

  const tbody = h('tbody');
  const thead = h('thead');
  const table = h('table', { class: 'runs' }, h('caption', { class: 'visually-hidden' }, 'Jobs'), thead, tbody);

  /** A header that sorts the listing on the server when clicked (again: the other direction). */
  function sortableHeader(title, key, firstDescending, help) {
    return h('th', { scope: 'col', 'aria-sort': sortState(filters.sort, key), title: help || null },
      h('button', { type: 'button', class: 'sort-header', 'data-sort': key, onclick: () => {
        filters.sort = nextSort(filters.sort, key, firstDescending);
        fillSorts();
        readFilters();
        renderHead();
        load(true);
      } }, title, h('span', { class: 'sort-mark', 'aria-hidden': 'true' },
        { ascending: ' ▲', descending: ' ▼', none: '' }[sortState(filters.sort, key)])));
  }

  /** A parameter's name that may break after its underscores (learning_ rate), for a narrow header. */
  function breakable(name) {
    return String(name).split('_').flatMap((part, i) => (i ? ['_', h('wbr'), part] : [part]));
  }

  function renderHead() {
    // with optional columns the table tightens (padding, type, dates on two lines) to fit 1280 px
    table.classList.toggle('with-extra', columns.length > 0);
    const head = (c) => (FIXED_SORTS[c] ? sortableHeader(c, FIXED_SORTS[c], c === 'Created') : h('th', { scope: 'col' }, c));
    thead.replaceChildren(h('tr', {},
      h('th', { scope: 'col' }, h('span', { class: 'visually-hidden' }, 'Select')),
      ['Id', 'Name', 'Status', 'System', 'Configurations', 'Seeds', 'Episodes'].map(head),
      columns.map((c) => sortableHeader(c.kind === 'result'
        ? [c.title, ' ', h('span', { class: 'of-config' }, `(${c.configuration})`)] : breakable(c.name), sortKey(c),
      c.kind === 'result', c.help)),
      ['Tags', 'Created', 'Duration', 'Actions'].map(head)));
  }
  renderHead();
  const moreBtn = h('button', { type: 'button', class: 'secondary', hidden: true, onclick: () => load(false) }, 'Load more');
  const tableWrap = h('div', { class: 'table-wrap' }, table);
  const emptyBox = h('div');

  root.append(
    h('div', { class: 'view-head' }, h('h1', {}, 'Runs'),
      h('div', { class: 'toolbar' }, compareBtn, tagBtn, cancelSelBtn, deleteSelBtn, clearBtn,
        h('a', { class: 'button primary', href: '#/new' }, 'New experiment'))),
    bulkStatus,
    filterForm, exportBox, errorBox, countEl, tableWrap, emptyBox, h('div', { class: 'more' }, moreBtn), live);

  api.systems().then((s) => {
    for (const sys of s.systems) systemSel.append(h('option', { value: sys.name, selected: sys.name === filters.system }, sys.name));
    if ((s.saved || []).length) {
      systemSel.append(h('optgroup', { label: 'Saved systems' }, s.saved.map((sys) =>
        h('option', { value: sys.name, selected: sys.name === filters.system }, `${sys.name} (${sys.base})`))));
    }
  }).catch(() => { /* the banner reports an unreachable server */ });

  function readFilters() {
    filters.status = statusSel.value;
    filters.system = systemSel.value;
    filters.tag = tagIn.value.trim();
    filters.q = qIn.value.trim();
    filters.sort = sortSel.value;
    filters.result = resultSel.value;
    filters.cols = paramBoxes.map((l) => l.querySelector('input')).filter((cb) => cb.checked).map((cb) => cb.value).join(',');
    const before = columns.map(sortKey).join();
    columns = columnsFromQuery(filters.result, filters.cols, knownParams, reference);
    const sortKeyNow = filters.sort.replace(/^-/, '');
    const builtIn = SORTS.some(([v]) => v === filters.sort);
    if (!builtIn && !columns.some((c) => sortKey(c) === sortKeyNow)) { filters.sort = '-created_at'; fillSorts(); }
    if (before !== columns.map(sortKey).join()) renderHead();
    ctx.setQuery({ ...filters, sort: filters.sort === '-created_at' ? '' : filters.sort });
  }
  const reload = () => { readFilters(); load(true); };
  const reloadSoon = debounce(reload, 300);
  statusSel.addEventListener('change', reload);
  systemSel.addEventListener('change', reload);
  sortSel.addEventListener('change', () => { reload(); renderHead(); });
  resultSel.addEventListener('change', reload);
  tagIn.addEventListener('input', reloadSoon);
  qIn.addEventListener('input', reloadSoon);

  function updateSelection() {
    compareBtn.disabled = selected.size === 0;
    clearBtn.disabled = selected.size === 0;
    for (const b of [tagBtn, cancelSelBtn, deleteSelBtn]) b.disabled = selected.size === 0;
    compareBtn.textContent = selected.size ? `Compare selected (${selected.size})` : 'Compare selected';
  }

  function row(job) {
    const cb = h('input', { type: 'checkbox', checked: selected.has(job.id), 'aria-label': `Select job ${job.id} for comparison`,
      onchange: (e) => { if (e.target.checked) selected.add(job.id); else selected.delete(job.id); updateSelection(); } });
    const actions = h('div', { class: 'row-actions' },
      h('button', { type: 'button', class: 'small secondary', 'aria-label': `Edit name, tags and notes of job ${job.id}`, onclick: async () => {
        const updated = await editJobDialog(job);
        if (updated) { replaceRow(updated); live.textContent = `Job ${job.id} saved.`; }
      } }, 'Edit'),
      (job.status === 'queued' || job.status === 'running')
        ? h('button', { type: 'button', class: 'small secondary', 'aria-label': `Cancel job ${job.id}`, onclick: async () => {
          if (!(await confirmDialog('Cancel job?', `Cancel job ${job.id} “${job.name || ''}”? ${cancelConsequence(job)}`, 'Cancel job', true, keepLabel(job)))) return;
          try { replaceRow(await api.cancelJob(job.id)); live.textContent = `Job ${job.id} cancelled.`; } catch (e) { showError(e); }
        } }, 'Cancel')
        : null,
      job.status !== 'running'
        ? h('button', { type: 'button', class: 'small danger', 'aria-label': `Delete job ${job.id}`, onclick: async () => {
          if (!(await confirmDialog('Delete job?', `Delete job ${job.id} “${job.name || ''}” and all its results? This cannot be undone.`, 'Delete', true, 'Keep the job'))) return;
          try {
            await api.deleteJob(job.id);
            localEdits += 1;
            const r = rows.get(job.id);
            if (r) r.tr.remove();
            rows.delete(job.id);
            selected.delete(job.id);
            updateSelection();
            live.textContent = `Job ${job.id} deleted.`;
          } catch (e) { showError(e); }
        } }, 'Delete')
        : null);
    const tr = h('tr', { dataset: { id: job.id, status: job.status } },
      h('td', {}, cb),
      h('td', { class: 'num' }, job.id),
      h('td', { class: 'job-name' }, h('a', { href: `#/jobs/${job.id}` }, job.name || `job ${job.id}`),
        job.notes ? h('div', { class: 'note', title: job.notes }, job.notes) : null),
      h('td', { class: 'status' }, statusCell(job)),
      h('td', { class: 'system', title: job.saved_system ? systemDescription(job) : null }, systemName(job)),
      h('td', { class: 'algos' }, sortLabels(job.algorithms || []).flatMap((label, i) => [i ? ', ' : '',
        h('span', { class: 'label' }, label)])),
      h('td', { class: 'num' }, seedCount(job)),
      h('td', { class: 'num' }, job.episodes),
      columns.map((c) => h('td', { class: `num extra ${c.kind}`, title: cellInterval(job, c) || null, 'data-column': sortKey(c) },
        cellText(job, c))),
      h('td', {}, (job.tags || []).map((t) => h('button', { type: 'button', class: 'tag', title: t, 'aria-label': `Filter by tag ${t}`,
        onclick: () => { tagIn.value = t; reload(); } }, h('span', {}, t)))),
      h('td', { class: 'nowrap' }, h('time', { datetime: job.created_at || '' },
        fmtDate(job.created_at).split(' ').flatMap((part, i) => [i ? ' ' : '', h('span', { class: 'nowrap' }, part)]))),
      h('td', { class: 'num nowrap' }, fmtDuration(job.duration_s)),
      h('td', {}, actions));
    return tr;
  }

  function replaceRow(job) {
    const old = rows.get(job.id);
    if (!job.summaries && old) job.summaries = old.job.summaries; // PATCH and cancel answer without them
    const tr = row(job);
    if (old) old.tr.replaceWith(tr);
    rows.set(job.id, { job, tr });
    localEdits += 1;
  }

  function showError(e) {
    errorBox.replaceChildren(notice('error', e.message));
  }

  async function load(reset) {
    const token = ++loadToken;
    errorBox.replaceChildren();
    if (reset) cursor = null;
    moreBtn.disabled = true;
    root.setAttribute('aria-busy', 'true');
    let page;
    try {
      page = await api.listJobs({ status: filters.status, system: filters.system, tag: filters.tag, q: filters.q,
        sort: filters.sort, limit: PAGE, cursor: reset ? undefined : cursor });
      outsideRegistry(page.data.filter((job) => job.kind === 'external').flatMap((job) => job.algorithms || []));
      offerResults(page.data.filter((job) => job.kind !== 'external').flatMap((job) => job.algorithms || []));
      await ready(page.data.flatMap((job) => job.algorithms || [])); // the configurations' order in each row
    } catch (e) {
      if (token === loadToken) { showError(e); root.removeAttribute('aria-busy'); moreBtn.disabled = false; }
      return;
    }
    if (token !== loadToken || stopped) return;
    root.removeAttribute('aria-busy');
    if (reset) { tbody.replaceChildren(); rows.clear(); }
    const frag = document.createDocumentFragment();
    for (const job of page.data) {
      if (rows.has(job.id)) continue;
      const tr = row(job);
      rows.set(job.id, { job, tr });
      frag.append(tr);
    }
    tbody.append(frag);
    cursor = page.next_cursor;
    moreBtn.hidden = !cursor;
    moreBtn.disabled = false;
    showCount(page.count);
  }

  function showCount(count) {
    const shown = rows.size;
    countEl.textContent = `${count} job${count === 1 ? '' : 's'}${count > shown ? `, ${shown} shown` : ''}`;
    const filtered = filters.status || filters.system || filters.tag || filters.q;
    tableWrap.hidden = shown === 0;
    emptyBox.replaceChildren(shown === 0
      ? (filtered
        ? notice('empty', 'No jobs match these filters.', h('button', { type: 'button', class: 'secondary', onclick: () => {
          statusSel.value = ''; systemSel.value = ''; tagIn.value = ''; qIn.value = ''; reload();
        } }, 'Clear filters'))
        : notice('empty', 'No experiments yet.', h('a', { class: 'button primary', href: '#/new' }, 'Start a new experiment')))
      : '');
  }

  // Live rows: when the jobs poll (livejobs.js) says something changed, the rows shown are read again
  // in one request under the current filters and sort: new jobs appear, states and progress move,
  // jobs that left the filters go. Rows keep their place in the DOM when unchanged (focus stays).
  async function refresh() {
    if (stopped) return;
    if (refreshing) { refreshAgain = true; return; }
    refreshing = true;
    const edits = localEdits;
    const token = loadToken;
    const limit = refreshLimit(rows.size, PAGE);
    let page = null;
    try {
      page = await api.listJobs({ status: filters.status, system: filters.system, tag: filters.tag, q: filters.q,
        sort: filters.sort, limit });
      outsideRegistry(page.data.filter((job) => job.kind === 'external').flatMap((job) => job.algorithms || []));
      await ready(page.data.flatMap((job) => job.algorithms || []));
    } catch { /* unreachable or refused: the next change tries again */ }
    refreshing = false;
    if (stopped) return;
    if (page && token === loadToken) {
      if (edits === localEdits) applyRefresh(page, limit);
      else refreshAgain = true; // this page changed a row meanwhile: the answer may predate it
    }
    if (refreshAgain) { refreshAgain = false; refresh(); }
  }

  function applyRefresh(page, limit) {
    const whole = rows.size <= limit; // the answer covers every row shown
    const wanted = [];
    for (const job of page.data) {
      const old = rows.get(job.id);
      if (old && sameJob(old.job, job)) { wanted.push(old.tr); continue; }
      if (old && progressOnly(old.job, job)) { // the bar moves; the row and its buttons stay
        old.tr.querySelector('td.status').replaceChildren(statusCell(job));
        old.job = job;
        wanted.push(old.tr);
        continue;
      }
      if (old && old.tr.contains(document.activeElement)) { old.job = job; wanted.push(old.tr); continue; }
      if (old && old.job.status !== job.status && job.status !== 'queued' && job.status !== 'running') {
        live.textContent = `Job ${job.id} ${job.status}.`;
      }
      const tr = row(job);
      if (old) old.tr.replaceWith(tr);
      rows.set(job.id, { job, tr });
      wanted.push(tr);
    }
    let ref = tbody.firstElementChild;
    for (const tr of wanted) {
      if (tr === ref) ref = ref.nextElementSibling;
      else tbody.insertBefore(tr, ref);
    }
    if (whole) {
      const keep = new Set(page.data.map((job) => job.id));
      for (const [id, r] of rows) {
        if (keep.has(id)) continue;
        r.tr.remove();
        rows.delete(id);
        selected.delete(id);
      }
      cursor = page.next_cursor;
      moreBtn.hidden = !cursor;
      updateSelection();
    }
    showCount(page.count);
  }

  const onLive = () => refresh();
  window.addEventListener('jobs-live', onLive);

  await load(true);
  root.dataset.renderMs = (performance.now() - t0).toFixed(1);
  performance.mark('runs-rendered');
  return () => { stopped = true; window.removeEventListener('jobs-live', onLive); };
}
