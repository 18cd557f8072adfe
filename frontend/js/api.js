// The one REST client of the dashboard. Every request goes to the page's own origin under /api.
// Errors become ApiError with a readable message; 422 bodies keep their per-field details.
// A known bearer token goes with every request. A read refused with 401 means the server protects
// its reads (MGRAO_PROTECT_READS): the page asks for the token once (tokenform.js), keeps it in
// sessionStorage and sends the request again; a refused token is forgotten and asked for again.

import { askForToken } from './tokenform.js';

const TOKEN_KEY = 'mgrao-api-token'; // localStorage: the footer's "Save token"
const SESSION_KEY = 'mgrao-api-token'; // sessionStorage: the token asked for by a refused read

export class ApiError extends Error {
  constructor(status, message, detail = null) {
    super(message);
    this.name = 'ApiError';
    this.status = status; // 0 when the server could not be reached
    this.detail = detail; // the body's `detail` (a list for 422)
  }
}

let pageToken = ''; // the asked-for token when sessionStorage is disabled: it lives for this page only

function sessionToken() {
  try { return sessionStorage.getItem(SESSION_KEY) || ''; } catch { return pageToken; }
}

function setSessionToken(token) {
  pageToken = token;
  try {
    if (token) sessionStorage.setItem(SESSION_KEY, token);
    else sessionStorage.removeItem(SESSION_KEY);
  } catch { /* storage disabled: pageToken holds it */ }
}

/** The token saved with the footer's form (localStorage). */
export function savedToken() {
  try { return localStorage.getItem(TOKEN_KEY) || ''; } catch { return ''; }
}

/** The token requests send: the one asked for in this session, else the saved one ('' for none). */
export function getToken() {
  return sessionToken() || savedToken();
}

/** Save (or with '' clear) the footer's token; it replaces the one asked for in this session. */
export function setToken(token) {
  setSessionToken('');
  try {
    if (token) localStorage.setItem(TOKEN_KEY, token);
    else localStorage.removeItem(TOKEN_KEY);
  } catch { /* storage disabled: the token lives for this page only */ }
}

let readsNeedToken = false; // a read was refused (401): from then on any 401 asks for the token
let asking = null; // the token form's pending answer, shared by every request refused meanwhile

function tokenAsked(refused) {
  if (!asking) asking = askForToken(refused).finally(() => { asking = null; });
  return asking;
}

/**
 * After a 401 to a request sent with `sent`: whether to send it again, once a token is known.
 * Only a server that refused a read asks (MGRAO_PROTECT_READS); a write refused elsewhere is an error.
 */
async function tokenAfter401(method, sent, signal) {
  if (typeof document === 'undefined' || !(method === 'GET' || readsNeedToken)) return false;
  readsNeedToken = true;
  if (getToken() === sent) { // not replaced by an answer to the form while this request was out
    if (sent && sessionToken() === sent) setSessionToken('');
    setSessionToken(await tokenAsked(Boolean(sent)));
  }
  if (signal && signal.aborted) throw new DOMException('The request was aborted.', 'AbortError');
  return true;
}

/** fetch() with the known token, if any; a `url` under /api whose answer is 401 asks for it as `request` does. */
export async function authorizedFetch(address, init = {}) {
  for (;;) {
    const token = getToken();
    const headers = { ...(init.headers || {}) };
    if (token) headers.Authorization = `Bearer ${token}`;
    const response = await fetch(address, { ...init, headers });
    if (response.status !== 401 || !(await tokenAfter401(init.method || 'GET', token, init.signal))) return response;
  }
}

/** Fired on window: 'api-status' with detail {up: bool, message}. The app shows or hides its banner. */
function announce(up, message = '') {
  window.dispatchEvent(new CustomEvent('api-status', { detail: { up, message } }));
}

function messageFrom(status, body, text) {
  const detail = body && typeof body === 'object' ? body.detail : undefined;
  if (typeof detail === 'string') return detail;
  if (Array.isArray(detail)) {
    return detail.map((d) => (d && d.msg) || JSON.stringify(d)).join('; ');
  }
  if (detail && typeof detail === 'object') return detail.msg || JSON.stringify(detail);
  if (status === 401) return 'This server needs an API token for changes: set it under “API token” at the bottom of the page.';
  if (status === 413) return 'The request is too large.';
  if (text) return `${status}: ${text.slice(0, 200)}`;
  return `Request failed with status ${status}.`;
}

export function url(path, query) {
  const q = new URLSearchParams();
  for (const [k, v] of Object.entries(query || {})) {
    if (v === undefined || v === null || v === '') continue;
    q.set(k, Array.isArray(v) ? v.join(',') : String(v));
  }
  const qs = q.toString();
  return `/api${path}${qs ? '?' + qs : ''}`;
}

export async function request(method, path, { query, body, signal } = {}) {
  const headers = { Accept: 'application/json' };
  // Every change is sent as JSON, with or without a body: the server refuses (415) a write without
  // Content-Type: application/json unless its Origin is the server's own (docs/api.md, "Cross-site requests").
  if (body !== undefined || method !== 'GET') headers['Content-Type'] = 'application/json';
  let response;
  try {
    response = await authorizedFetch(url(path, query), {
      method, headers, signal, body: body === undefined ? undefined : JSON.stringify(body),
    });
  } catch (err) {
    if (err && err.name === 'AbortError') throw err;
    const e = new ApiError(0, 'Cannot reach the MG-RAO server. Is `mgrao serve` running?');
    announce(false, e.message);
    throw e;
  }
  if (response.status >= 502 && response.status <= 504) {
    const e = new ApiError(response.status, `The server is unavailable (${response.status}).`);
    announce(false, e.message);
    throw e;
  }
  announce(true);
  // A change was accepted (submitted, cancelled, deleted...): the header's counts refresh at once.
  if (method !== 'GET' && response.ok && typeof window !== 'undefined') window.dispatchEvent(new CustomEvent('jobs-changed'));
  if (response.status === 204) return null;
  const text = await response.text();
  let data = null;
  if (text) {
    try { data = JSON.parse(text); } catch { data = null; }
  }
  if (!response.ok) {
    throw new ApiError(response.status, messageFrom(response.status, data, data ? '' : text), data ? data.detail : null);
  }
  return data;
}

let systemsCache = null;

export const api = {
  health: () => request('GET', '/health'),
  systems: () => {
    if (!systemsCache) systemsCache = request('GET', '/systems').catch((e) => { systemsCache = null; throw e; });
    return systemsCache;
  },
  /** Save a named system (a base preset and overrides); the systems' cache is read again after. */
  saveSystem: async (body) => {
    const saved = await request('POST', '/systems/saved', { body });
    systemsCache = null;
    return saved;
  },
  listSaved: () => request('GET', '/systems/saved'),
  getSaved: (name) => request('GET', `/systems/saved/${encodeURIComponent(name)}`),
  /** Replace a saved system's definition; the systems' cache is read again after. */
  replaceSaved: async (name, body) => {
    const saved = await request('PUT', `/systems/saved/${encodeURIComponent(name)}`, { body });
    systemsCache = null;
    return saved;
  },
  /** Forget a saved system (its jobs stay); the systems' cache is read again after. */
  deleteSaved: async (name) => {
    await request('DELETE', `/systems/saved/${encodeURIComponent(name)}`);
    systemsCache = null;
  },
  listJobs: (query, opts) => request('GET', '/jobs', { query, ...opts }),
  jobChanges: (since, opts) => request('GET', '/jobs/changes', { query: { since }, ...opts }),
  getJob: (id, opts) => request('GET', `/jobs/${id}`, opts),
  jobStatus: (id, opts) => request('GET', `/jobs/${id}/status`, opts),
  createJob: (body) => request('POST', '/jobs', { body }),
  checkJob: (body) => request('POST', '/jobs/check', { body }),
  patchJob: (id, body) => request('PATCH', `/jobs/${id}`, { body }),
  cancelJob: (id) => request('POST', `/jobs/${id}/cancel`),
  deleteJob: (id) => request('DELETE', `/jobs/${id}`),
  results: (id, query, opts) => request('GET', `/jobs/${id}/results`, { query, ...opts }),
  weights: (id, seed, page, opts) => request('GET', `/jobs/${id}/weights`, { query: { seed, ...page }, ...opts }),
  compare: (ids, points, opts) => request('GET', '/compare', { query: { jobs: ids.join(','), points }, ...opts }),
  compareStatistics: (ids, { reps, seed, aggregate } = {}, opts) => request('GET', '/compare/statistics',
    { query: { jobs: ids.join(','), reps, seed, aggregate: aggregate && aggregate.length ? aggregate.join(',') : undefined }, ...opts }),
  compareSampleEfficiency: (ids, { points, reps, seed, aggregate } = {}, opts) => request('GET', '/compare/sample-efficiency',
    { query: { jobs: ids.join(','), points, reps, seed, aggregate: aggregate && aggregate.length ? aggregate.join(',') : undefined }, ...opts }),
  episodesUrl: (id, format) => url(`/jobs/${id}/episodes`, { format }),
  listStudies: (query, opts) => request('GET', '/studies', { query, ...opts }),
  getStudy: (id, opts) => request('GET', `/studies/${id}`, opts),
  studyPlots: (id, query, opts) => request('GET', `/studies/${id}/plots`, { query, ...opts }),
  createStudy: (body) => request('POST', '/studies', { body }),
  cancelStudy: (id) => request('POST', `/studies/${id}/cancel`),
  rerunFailed: (id) => request('POST', `/studies/${id}/rerun-failed`),
  deleteStudy: (id) => request('DELETE', `/studies/${id}`),
};
