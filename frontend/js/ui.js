// Small DOM helpers shared by the views: element builder, status badges, dialogs.

import { fmtDate, fmtDuration, jobTimes, pctProgress, seedsText, systemDescription } from './stats.js';
import { api, authorizedFetch, getToken } from './api.js';

/** h('button', {class: 'x', onclick: f}, 'text', child) -> element. Attributes starting with "on" are listeners. */
export function h(tag, attrs = {}, ...children) {
  const el = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (v === undefined || v === null || v === false) continue;
    if (k.startsWith('on') && typeof v === 'function') el.addEventListener(k.slice(2), v);
    else if (k === 'class') el.className = v;
    else if (k === 'dataset') Object.assign(el.dataset, v);
    else if (k === 'value' && 'value' in el) el.value = v;
    else if (k === 'checked' || k === 'selected' || k === 'disabled' || k === 'open') el[k] = !!v;
    else if (v === true) el.setAttribute(k, '');
    else el.setAttribute(k, String(v));
  }
  append(el, children);
  return el;
}

function append(el, children) {
  for (const c of children) {
    if (c === null || c === undefined || c === false) continue;
    if (Array.isArray(c)) append(el, c);
    else el.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
}

let uid = 0;
export function nextId(prefix = 'id') {
  uid += 1;
  return `${prefix}-${uid}`;
}

/** Status badge, with a progress bar and spinner for running/queued jobs and open external runs. */
export function statusCell(job) {
  const badge = h('span', { class: `badge status-${job.status}` },
    job.status === 'running' ? h('span', { class: 'spinner', 'aria-hidden': 'true' }) : null,
    job.status);
  const kind = kindBadge(job);
  if (job.status !== 'running' && job.status !== 'queued' && job.status !== 'open') {
    return kind ? h('span', { class: 'status-progress' }, badge, kind) : badge;
  }
  const pct = pctProgress(job.progress);
  return h('div', { class: 'status-progress' }, badge, kind,
    h('progress', { max: 100, value: pct, 'aria-label': `Job ${job.id} progress` }),
    job.compiling ? h('span', { class: 'pct compiling', title: job.compiling.message }, 'compiling')
      : h('span', { class: 'pct' }, `${pct}%`));
}

/** The mark of a run logged from outside (docs/platform.md), or null for a job the service simulated. */
export function kindBadge(job) {
  return job.kind === 'external'
    ? h('span', { class: 'badge kind-external', title: 'Logged from outside (POST /api/external-runs), not simulated here' }, 'external')
    : null;
}

export function jobMeta(job) {
  return [
    ['System', systemDescription(job)],
    ['Configurations', (job.algorithms || []).join(', ')],
    ['Seeds', seedsText(job)],
    ['Episodes', job.episodes],
    ['Tags', (job.tags || []).join(', ') || '–'],
    ['Created', fmtDate(job.created_at)],
    ...jobTimes(job),
    ['Attempts', job.attempts ?? '–'],
    ['Config hash', job.config_hash ? String(job.config_hash).slice(0, 12) : '–'],
    ['Version', job.version || '–'],
  ];
}

function dialogShell(titleText) {
  const titleId = nextId('dlg-title');
  const dlg = h('dialog', { class: 'dialog', 'aria-labelledby': titleId });
  dlg.append(h('h2', { id: titleId }, titleText));
  document.body.append(dlg);
  dlg.addEventListener('close', () => setTimeout(() => dlg.remove(), 0));
  return dlg;
}

/** Save `text` as a file named `name` (a download the browser starts at once). */
export function downloadText(name, type, text) {
  const url = URL.createObjectURL(new Blob([text], { type }));
  const a = h('a', { href: url, download: name });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 1000);
}

/**
 * Click handler of a download link under /api: with a known API token, fetch the file with it and save
 * it (a plain link cannot send the token); without one the link downloads by itself. An error is shown
 * after the link.
 */
export async function downloadWithToken(ev) {
  if (!getToken()) return;
  ev.preventDefault();
  const link = ev.currentTarget;
  const said = link.nextElementSibling && link.nextElementSibling.classList.contains('download-error')
    ? link.nextElementSibling : null;
  if (said) said.remove();
  link.setAttribute('aria-busy', 'true');
  try {
    const response = await authorizedFetch(link.href, { headers: { Accept: '*/*' } });
    if (!response.ok) throw new Error(`the server answered ${response.status}`);
    const url = URL.createObjectURL(await response.blob());
    const a = h('a', { href: url, download: link.getAttribute('download') || '' });
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 1000);
  } catch (e) {
    link.after(h('span', { class: 'field-error download-error', role: 'alert' }, ` Download failed: ${e.message}.`));
  } finally {
    link.removeAttribute('aria-busy');
  }
}

/** What cancelling a job does to its results, in one sentence for the confirmation. */
export function cancelConsequence(job) {
  if (job.status === 'queued' && !(job.progress > 0)) return 'It has not started: nothing is lost.';
  return 'The runs it has completed are kept (its results will be partial); the rest is not computed.';
}

/** The label of the button that does not cancel a job. */
export function keepLabel(job) {
  return job.status === 'queued' ? 'Keep it queued' : 'Keep it running';
}

/** Modal confirmation; resolves true when confirmed. The other button says what not confirming means. */
export function confirmDialog(title, message, confirmLabel = 'Confirm', danger = false, backLabel = 'Back') {
  return new Promise((resolve) => {
    const dlg = dialogShell(title);
    const form = h('form', { method: 'dialog' },
      h('p', {}, message),
      h('div', { class: 'actions' },
        h('button', { type: 'submit', value: 'cancel', class: 'secondary' }, backLabel),
        h('button', { type: 'submit', value: 'ok', class: danger ? 'danger' : 'primary' }, confirmLabel)));
    dlg.append(form);
    dlg.addEventListener('close', () => resolve(dlg.returnValue === 'ok'));
    dlg.showModal();
    form.querySelector('button.secondary').focus();
  });
}

/** Modal asking for one line of text; resolves to the trimmed text, or null when dismissed. */
export function promptDialog(title, label, confirmLabel, { maxlength = 50 } = {}) {
  return new Promise((resolve) => {
    const dlg = dialogShell(title);
    const id = nextId('prompt');
    const input = h('input', { type: 'text', id, maxlength, required: true });
    const form = h('form', { method: 'dialog' },
      h('div', { class: 'field' }, h('label', { for: id }, label), input),
      h('div', { class: 'actions' },
        h('button', { type: 'submit', value: 'cancel', class: 'secondary', formnovalidate: true }, 'Back'),
        h('button', { type: 'submit', value: 'ok', class: 'primary' }, confirmLabel)));
    dlg.append(form);
    dlg.addEventListener('close', () => resolve(dlg.returnValue === 'ok' && input.value.trim() ? input.value.trim() : null));
    dlg.showModal();
    input.focus();
  });
}

/** Dialog editing a job's name, tags and notes (PATCH). Resolves to the updated job or null. */
export function editJobDialog(job) {
  return new Promise((resolve) => {
    const dlg = dialogShell(`Edit job ${job.id}`);
    const nameId = nextId('name');
    const tagsId = nextId('tags');
    const notesId = nextId('notes');
    const errId = nextId('err');
    const name = h('input', { id: nameId, name: 'name', type: 'text', value: job.name || '', maxlength: 200 });
    const tags = h('input', { id: tagsId, name: 'tags', type: 'text', value: (job.tags || []).join(', '), 'aria-describedby': `${tagsId}-help` });
    const notes = h('textarea', { id: notesId, name: 'notes', rows: 4 });
    notes.value = job.notes || '';
    const err = h('p', { id: errId, class: 'error', role: 'alert' });
    let result = null;
    const form = h('form', { class: 'stack' },
      h('label', { for: nameId }, 'Name'), name,
      h('label', { for: tagsId }, 'Tags'), tags,
      h('small', { id: `${tagsId}-help`, class: 'help' }, 'Comma separated, e.g. paper, sweep-3'),
      h('label', { for: notesId }, 'Notes'), notes,
      err,
      h('div', { class: 'actions' },
        h('button', { type: 'button', class: 'secondary', onclick: () => dlg.close() }, 'Cancel'),
        h('button', { type: 'submit', class: 'primary' }, 'Save')));
    form.addEventListener('submit', async (ev) => {
      ev.preventDefault();
      err.textContent = '';
      const tagList = tags.value.split(',').map((t) => t.trim()).filter(Boolean);
      try {
        result = await api.patchJob(job.id, { name: name.value.trim(), tags: [...new Set(tagList)], notes: notes.value });
        dlg.close();
      } catch (e) {
        err.textContent = e.message;
      }
    });
    dlg.append(form);
    dlg.addEventListener('close', () => resolve(result));
    dlg.showModal();
    name.focus();
  });
}

/** A message block for empty states and errors. */
export function notice(kind, text, ...extra) {
  return h('div', { class: `notice ${kind}`, role: kind === 'error' ? 'alert' : null }, h('p', {}, text), ...extra);
}

/** Debounce a function by `ms`. */
export function debounce(fn, ms) {
  let t = null;
  return (...args) => {
    clearTimeout(t);
    t = setTimeout(() => fn(...args), ms);
  };
}
