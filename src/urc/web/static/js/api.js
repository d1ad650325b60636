// REST calls with the control token (when the API needs one). Every refusal is shown.
import { $, toast } from "./dom.js";

const TOKEN_KEY = "urc-token";

export function token() {
  return sessionStorage.getItem(TOKEN_KEY) || "";
}

// an exposed instance's reads need a token too (the read-only one will do): a page that
// was refused a read loads again once one is given, the live feed and all
let readRefused = false;

export function setToken(value) {
  if (value) sessionStorage.setItem(TOKEN_KEY, value);
  else sessionStorage.removeItem(TOKEN_KEY);
  if (readRefused && value) location.reload();
}

function askForToken() {
  $("token-form").hidden = false;
}

// the live feed's subprotocols: a browser's WebSocket sends no Authorization header, so
// the token goes as "urc.bearer.<base64url>" beside "urc" (the one the server picks)
export function wsProtocols() {
  const t = token();
  if (!t) return undefined;
  const b64 = btoa(String.fromCharCode(...new TextEncoder().encode(t)));
  return ["urc", `urc.bearer.${b64.replace(/\+/g, "-").replace(/\//g, "_").replace(/=+$/, "")}`];
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
  if (resp.status === 401) {
    askForToken();
    if (method === "GET") {
      readRefused = true;
      if (!quiet) toast("reading needs the API token (or the read-only one): enter it at the top", true);
    }
  }
  if (!resp.ok && !quiet) {
    if (resp.status === 401) {
      if (method !== "GET") toast("control needs the API token: enter it at the top", true);
    } else {
      toast(describe(resp.status, data), true);
    }
  }
  return { ok: resp.ok, status: resp.status, data, etag: resp.headers.get("ETag"),
    message: resp.ok ? "" : describe(resp.status, data) };
}

export const get = (path, opts) => request("GET", path, undefined, opts);
export const post = (path, body = {}, opts) => request("POST", path, body, opts);
