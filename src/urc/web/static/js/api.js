// REST calls with the control token (when the API needs one). Every refusal is shown.
import { $, toast } from "./dom.js";

const TOKEN_KEY = "urc-token";

export function token() {
  return sessionStorage.getItem(TOKEN_KEY) || "";
}

export function setToken(value) {
  if (value) sessionStorage.setItem(TOKEN_KEY, value);
  else sessionStorage.removeItem(TOKEN_KEY);
}

function describe(status, data) {
  if (data && typeof data === "object") {
    if (data.error) return data.error;
    if (Array.isArray(data.detail)) return data.detail.map((d) => `${(d.loc || []).slice(1).join(".")}: ${d.msg}`).join("; ");
    if (data.detail) return String(data.detail);
  }
  return `HTTP ${status}`;
}

export async function request(method, path, body, { quiet = false, headers: extra = {} } = {}) {
  const headers = { Accept: "application/json", ...extra };
  if (body !== undefined) headers["Content-Type"] = "application/json";
  const t = token();
  if (t) headers.Authorization = `Bearer ${t}`;
  let resp;
  try {
    resp = await fetch(path, { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
  } catch (err) {
    if (!quiet) toast(`cannot reach urc: ${err.message}`, true);
    return { ok: false, status: 0, data: null };
  }
  let data = null;
  try { data = await resp.json(); } catch { data = null; }
  if (!resp.ok && !quiet) {
    if (resp.status === 401) {
      $("token-form").hidden = false;
      toast("control needs the API token: enter it at the top", true);
    } else {
      toast(describe(resp.status, data), true);
    }
  }
  return { ok: resp.ok, status: resp.status, data, etag: resp.headers.get("ETag"),
    message: resp.ok ? "" : describe(resp.status, data) };
}

export const get = (path, opts) => request("GET", path, undefined, opts);
export const post = (path, body = {}, opts) => request("POST", path, body, opts);
