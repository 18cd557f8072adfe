// Keyboard shortcuts: `/` focuses the search, `n` opens a new experiment, `c` compares the selected
// jobs, `?` lists them. Ignored while typing in a field or with a modifier key held.

import { h } from './ui.js';

export const SHORTCUTS = [
  ['/', 'Focus the search (the runs or studies search; from elsewhere, the runs search)'],
  ['n', 'Open a new experiment'],
  ['c', 'Compare the jobs selected in the runs table'],
  ['?', 'Show these shortcuts'],
];

function typing(target) {
  return target instanceof HTMLElement && (target.isContentEditable || ['INPUT', 'TEXTAREA', 'SELECT'].includes(target.tagName));
}

function helpDialog() {
  const open = document.getElementById('shortcuts-dialog');
  if (open) return;
  const dlg = h('dialog', { class: 'dialog', id: 'shortcuts-dialog', 'aria-labelledby': 'shortcuts-title' },
    h('h2', { id: 'shortcuts-title' }, 'Keyboard shortcuts'),
    h('table', { class: 'summary shortcuts' }, h('tbody', {}, SHORTCUTS.map(([key, what]) =>
      h('tr', {}, h('th', { scope: 'row' }, h('kbd', {}, key)), h('td', {}, what))))),
    h('form', { method: 'dialog' }, h('div', { class: 'actions' }, h('button', { type: 'submit', class: 'primary' }, 'Close'))));
  dlg.addEventListener('close', () => dlg.remove());
  document.body.append(dlg);
  dlg.showModal();
}

/** Listen for the shortcuts; `say(text)` announces what happened (e.g. nothing to compare). */
export function installShortcuts(say) {
  document.addEventListener('keydown', (event) => {
    if (event.defaultPrevented || event.ctrlKey || event.metaKey || event.altKey || typing(event.target)) return;
    if (document.querySelector('dialog[open]')) return;
    if (event.key === '/') {
      event.preventDefault();
      const search = document.querySelector('[data-shortcut="search"]');
      if (search) search.focus();
      else {
        location.hash = '#/runs';
        window.addEventListener('view-mounted', () => document.querySelector('[data-shortcut="search"]')?.focus(), { once: true });
      }
    } else if (event.key === 'n') {
      location.hash = '#/new';
    } else if (event.key === 'c') {
      const button = document.querySelector('[data-shortcut="compare"]');
      if (button && !button.disabled) button.click();
      else say(button ? 'Select jobs in the runs table first, then press c to compare them.' : 'c compares the jobs selected on the Runs page.');
    } else if (event.key === '?') {
      helpDialog();
    }
  });
}
