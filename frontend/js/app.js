// Hash router: #/runs, #/new, #/jobs/<id>, #/compare?jobs=1,2&smooth=5, #/studies, #/studies/new, #/studies/<id>,
// #/systems, #/systems/<name>. Each view module exports
// mount(container, params, ctx) and may return a cleanup function (stop polling, purge plots).

import { api, savedToken, setToken } from './api.js';
import { ready } from './algorithms.js';
import { parseHash, buildHash, workersWord } from './stats.js';
import * as runs from './runs.js';
import * as newjob from './newjob.js';
import * as job from './job.js';
import * as compare from './compare.js';
import * as studies from './studies.js';
import * as study from './study.js';
import * as newstudy from './newstudy.js';
import * as paper from './paper.js';
import * as systems from './systems.js';
import { installShortcuts } from './shortcuts.js';
import { startJobsPoll, pollJobsSoon } from './livejobs.js';

const main = document.getElementById('main');
const banner = document.getElementById('banner');
let cleanup = null;
let generation = 0;

const routes = [
  { re: /^\/(runs)?$/, view: runs, nav: 'runs', title: 'Runs' },
  { re: /^\/new$/, view: newjob, nav: 'new', title: 'New experiment' },
  { re: /^\/jobs\/(\d+)$/, view: job, nav: 'runs', title: 'Job' },
  { re: /^\/compare$/, view: compare, nav: 'compare', title: 'Compare' },
  { re: /^\/studies$/, view: studies, nav: 'studies', title: 'Studies' },
  { re: /^\/studies\/new$/, view: newstudy, nav: 'studies', title: 'New study' },
  { re: /^\/studies\/(\d+)$/, view: study, nav: 'studies', title: 'Study' },
  { re: /^\/paper$/, view: paper, nav: 'paper', title: 'Ours against the paper' },
  { re: /^\/systems$/, view: systems, nav: 'systems', title: 'Systems' },
  { re: /^\/systems\/([a-z][a-z0-9-]{0,31})$/, view: systems, nav: 'systems', title: 'System' },
];

/** Context handed to views. */
const ctx = {
  navigate(path, params = {}) {
    location.hash = buildHash(path, params);
  },
  /** Update the query part of the current URL without re-mounting the view (shareable settings). */
  setQuery(params) {
    const { path } = parseHash(location.hash);
    history.replaceState(null, '', buildHash(path, params));
  },
  isCurrent(gen) {
    return gen === generation;
  },
};

async function render() {
  const { path, params } = parseHash(location.hash || '#/runs');
  const route = routes.find((r) => r.re.test(path));
  if (typeof cleanup === 'function') {
    try { cleanup(); } catch (e) { console.error(e); }
  }
  cleanup = null;
  generation += 1;
  const gen = generation;
  main.replaceChildren();
  for (const a of document.querySelectorAll('[data-nav]')) {
    if (route && a.dataset.nav === route.nav) a.setAttribute('aria-current', 'page');
    else a.removeAttribute('aria-current');
  }
  if (!route) {
    const h1 = document.createElement('h1');
    h1.textContent = 'Page not found';
    const p = document.createElement('p');
    p.innerHTML = 'Nothing lives at this address. <a href="#/runs">Go to the runs</a>.';
    main.append(h1, p);
    document.title = 'Not found · MG-RAO';
    return;
  }
  document.title = `${route.title} · MG-RAO`;
  const m = route.re.exec(path);
  const routeParams = { ...params };
  if (route.view === job || route.view === study) routeParams.id = Number(m[1]);
  if (route.view === systems && m[1]) routeParams.name = m[1];
  try {
    const c = await route.view.mount(main, routeParams, { ...ctx, generation: gen });
    if (gen === generation) cleanup = c;
    else if (typeof c === 'function') c();
  } catch (e) {
    console.error(e);
    const p = document.createElement('p');
    p.className = 'notice error';
    p.setAttribute('role', 'alert');
    p.textContent = `This view failed: ${e.message}`;
    main.append(p);
  }
  // Move focus to the new view's heading so keyboard and screen-reader users land on it.
  const heading = main.querySelector('h1');
  if (heading && gen === generation && document.activeElement === document.body) {
    heading.setAttribute('tabindex', '-1');
    heading.focus({ preventScroll: true });
  }
  if (gen === generation) window.dispatchEvent(new CustomEvent('view-mounted'));
}

window.addEventListener('api-status', (ev) => {
  const { up, message } = ev.detail;
  if (up) {
    banner.hidden = true;
    banner.textContent = '';
  } else {
    banner.hidden = false;
    banner.textContent = `${message} The page retries automatically.`;
  }
});

// The header: version and workers from /api/health (every 10 s), the running and queued counts from
// the jobs poll (livejobs.js: within about a second of any change, wherever it was made).
const header = { version: '', running: null, queued: null, workers: '' };
let healthAt = 0; // when /api/health was last asked
function showHeader() {
  const el = document.getElementById('health');
  el.textContent = `server ${header.version} · ${header.running ?? 0} running · ${header.queued ?? 0} queued` +
    (header.workers ? ` · ${header.workers}` : '');
  el.className = 'health ok';
}

async function checkHealth() {
  const el = document.getElementById('health');
  healthAt = performance.now();
  try {
    const hl = await api.health();
    if (!('version' in hl)) { // a server that protects its reads tells only its status without the token
      el.textContent = hl.status === 'ok' ? 'server up' : 'server error';
      el.className = hl.status === 'ok' ? 'health ok' : 'health down';
      return;
    }
    Object.assign(header, { version: hl.version || '', running: hl.running, queued: hl.queued, workers: workersWord(hl.workers) });
    showHeader();
  } catch {
    el.textContent = 'server unreachable';
    el.className = 'health down';
  }
}

function setupToken() {
  const form = document.getElementById('token-form');
  const input = document.getElementById('api-token');
  const status = document.getElementById('token-status');
  input.value = savedToken();
  form.addEventListener('submit', (ev) => {
    ev.preventDefault();
    setToken(input.value.trim());
    status.textContent = input.value.trim() ? 'Token saved in this browser.' : 'Token cleared.';
  });
}

window.addEventListener('hashchange', () => {
  // Blur whatever had focus so render() moves focus to the new heading.
  if (document.activeElement && document.activeElement !== document.body) document.activeElement.blur();
  render();
});
setupToken();
// What a shortcut could not do (e.g. `c` with nothing selected): shown for a while and announced.
const shortcutStatus = document.createElement('p');
shortcutStatus.className = 'toast';
shortcutStatus.setAttribute('role', 'status');
shortcutStatus.setAttribute('aria-live', 'polite');
shortcutStatus.id = 'shortcut-status';
shortcutStatus.hidden = true;
document.body.append(shortcutStatus);
let shortcutHide = null;
installShortcuts((text) => {
  shortcutStatus.textContent = text;
  shortcutStatus.hidden = false;
  clearTimeout(shortcutHide);
  shortcutHide = setTimeout(() => { shortcutStatus.hidden = true; shortcutStatus.textContent = ''; }, 6000);
});
// The skip link must not touch the hash (the router owns it): move focus to <main> instead.
document.querySelector('.skip-link').addEventListener('click', (ev) => {
  ev.preventDefault();
  main.focus();
});
if (!location.hash) history.replaceState(null, '', '#/runs');
ready(); // the algorithm roles (GET /api/systems), asked for while the first view loads its data
render();
// The header's health and the jobs poll start once the first view has drawn what it shows (or after
// 1.5 s): their requests and answers then do not compete with the view's own on a cold load.
let headerStarted = false;
function startHeader() {
  if (headerStarted) return;
  headerStarted = true;
  checkHealth();
  setInterval(checkHealth, 10000);
  startJobsPoll();
}
window.addEventListener('view-mounted', startHeader, { once: true });
setTimeout(startHeader, 1500);
window.addEventListener('jobs-live', (ev) => {
  header.running = ev.detail.running;
  header.queued = ev.detail.queued;
  if (header.version) showHeader();
  if (performance.now() - healthAt > 3000) checkHealth(); // workers warming up -> ready show with the job they run
});
// After an action of this page, or when a view sees a job change state, the poll asks at once and
// the workers are read again (a worker that took its first job is no longer warming up).
let healthSoon = null;
window.addEventListener('jobs-changed', () => {
  pollJobsSoon();
  clearTimeout(healthSoon);
  healthSoon = setTimeout(checkHealth, 300);
});
