// The one REST client of the dashboard. Every request goes to the page's own origin under /api.
// Errors become ApiError with a readable message; 422 bodies keep their per-field details.

const TOKEN_KEY = 'mgrao-api-token';

export class ApiError extends Error {
  constructor(status, message, detail = null) {
    super(message);
    this.name = 'ApiError';
    this.status = status; // 0 when the server could not be reached
    this.detail = detail; // the body's `detail` (a list for 422)
  }
}

export function getToken() {
  try { return localStorage.getItem(TOKEN_KEY) || ''; } catch { return ''; }
}

export function setToken(token) {
  try {
    if (token) localStorage.setItem(TOKEN_KEY, token);
    else localStorage.removeItem(TOKEN_KEY);
  } catch { /* storage disabled: the token lives for this page only */ }
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
  const token = getToken();
  if (token && method !== 'GET') headers.Authorization = `Bearer ${token}`;
  let response;
  try {
    response = await fetch(url(path, query), {
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
  weights: (id, seed, opts) => request('GET', `/jobs/${id}/weights`, { query: { seed }, ...opts }),
  compare: (ids, points, opts) => request('GET', '/compare', { query: { jobs: ids.join(','), points }, ...opts }),
  episodesUrl: (id, format) => url(`/jobs/${id}/episodes`, { format }),
  listStudies: (query, opts) => request('GET', '/studies', { query, ...opts }),
  getStudy: (id, opts) => request('GET', `/studies/${id}`, opts),
  studyPlots: (id, query, opts) => request('GET', `/studies/${id}/plots`, { query, ...opts }),
  createStudy: (body) => request('POST', '/studies', { body }),
  cancelStudy: (id) => request('POST', `/studies/${id}/cancel`),
  rerunFailed: (id) => request('POST', `/studies/${id}/rerun-failed`),
  deleteStudy: (id) => request('DELETE', `/studies/${id}`),
};
