// The dashboard's one light poll of the jobs: `GET /api/jobs/changes?since=<token>` every second
// while the tab is visible. It answers `{"changed": false}` (17 bytes) until a job is submitted
// (from anywhere: API, CLI, a study), deleted, changes state or progresses; then the new token and
// the queue's counts, fired on window as 'jobs-live' (detail {token, queued, running}). The header
// keeps its counts from it and the runs view reloads the rows it shows. Hidden tab: no requests.

import { api } from './api.js';

export const POLL_MS = 1000;

let token = '';
let timer = null;
let asking = false;

async function tick() {
  timer = null;
  if (typeof document !== 'undefined' && document.hidden) return;
  asking = true;
  let answer = null;
  try { answer = await api.jobChanges(token); } catch { /* unreachable: the banner says so; try again */ }
  asking = false;
  if (answer && answer.changed) {
    token = answer.token;
    window.dispatchEvent(new CustomEvent('jobs-live', { detail: answer }));
  }
  if (!document.hidden && !timer) timer = setTimeout(tick, POLL_MS);
}

/** Start polling (once, from app.js); it pauses while the tab is hidden and asks at once on return. */
export function startJobsPoll() {
  document.addEventListener('visibilitychange', () => {
    if (document.hidden) { clearTimeout(timer); timer = null; } else if (!timer && !asking) tick();
  });
  if (!timer && !asking) tick(); // pollJobsSoon may have started it already
}

/** Ask now rather than at the next tick (after a change made by this page). */
export function pollJobsSoon() {
  if (asking || document.hidden) return;
  clearTimeout(timer);
  timer = setTimeout(tick, 50);
}
