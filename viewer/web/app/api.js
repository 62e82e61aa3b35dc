// The server's JSON API (relative URLs: the viewer is served by the same HttpApi). With tokens
// on, open the viewer as /#token=TOKEN: the token is kept in sessionStorage and sent as a bearer
// header, never in a URL the server sees.
const TOKEN_KEY = 'loci-token';

export class ApiError extends Error {
  constructor(status, code, message) {
    super(message);
    this.status = status;
    this.code = code;
  }
}

export function takeTokenFromHash() {
  const m = location.hash.match(/token=([^&]+)/);
  if (!m) return;
  sessionStorage.setItem(TOKEN_KEY, decodeURIComponent(m[1]));
  history.replaceState(null, '', location.pathname + location.search);
}

export function authHeaders() {
  const token = sessionStorage.getItem(TOKEN_KEY);
  return token ? { Authorization: 'Bearer ' + token } : {};
}

export async function getJson(path) {
  const res = await fetch(path, { headers: authHeaders(), cache: 'no-store' });
  const body = await res.json().catch(() => ({}));
  if (!res.ok) {
    const e = body.error || {};
    throw new ApiError(res.status, e.code || 'HTTP_' + res.status, e.message || res.statusText);
  }
  return body;
}

// proto3 JSON prints int64 as strings: ids fit a Number, stamps are kept to the millisecond.
export const toId = (s) => Number(s);
export const nsToDate = (ns) => new Date(Number(BigInt(ns) / 1000000n));
