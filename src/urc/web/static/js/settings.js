// The settings page: edits the configuration document, checks it with the server's own
// rules (Config.from_dict) and shows each problem next to its field.
import { $, h, clear, setText, toast } from "./dom.js";
import { get, post } from "./api.js";

let doc = null;      // the document as loaded (config without the token)
let revision = null; // its ETag: a save sends it in If-Match (412 when someone saved meanwhile)
let info = null;
let serveDirty = false;

const NUM = "number";

function field(key, label, value, { type = NUM, step = "any", placeholder = "", options = null } = {}) {
  let input;
  if (options) {
    input = h("select", { "data-key": key, id: `f-${key}` });
    for (const o of options) input.append(h("option", { value: o, text: o, selected: o === value }));
  } else if (type === "checkbox") {
    input = h("input", { type: "checkbox", "data-key": key, id: `f-${key}`, checked: !!value });
  } else {
    input = h("input", { type, step: type === NUM ? step : undefined, "data-key": key, id: `f-${key}`,
      value: value === undefined || value === null ? "" : value, placeholder });
  }
  const text = placeholder !== "" && type === NUM ? `${label} (profile ${placeholder})` : label;
  return h("div", { class: "field" }, h("label", { for: `f-${key}`, text }), input,
    h("div", { class: "field-error", "data-error-for": key }));
}

function get_(obj, path, dflt = undefined) {
  let o = obj;
  for (const p of path.split(".")) { if (o === null || typeof o !== "object" || !(p in o)) return dflt; o = o[p]; }
  return o;
}

function capsHint(axis, what) {
  const c = info && info.caps[axis];
  return c ? String(Number(c[what].toFixed(3))) : "";
}

const ZONE_COLUMNS = { name: "name", az_min_deg: "az min", az_max_deg: "az max", el_min_deg: "el min", el_max_deg: "el max" };

// each input is labelled ("zone 2 az min"): the column header alone names no row; on a
// phone the rows stack and each cell shows its column name (data-label)
function zoneRow(z = {}, i) {
  const k = (name) => `keepout[${i}].${name}`;
  const cell = (name, type = NUM) => h("td", { "data-label": ZONE_COLUMNS[name] }, h("input", { type, step: type === NUM ? "any" : undefined, "data-key": k(name),
    value: z[name] === undefined ? "" : z[name], size: type === NUM ? undefined : 10, "aria-label": `zone ${i + 1} ${ZONE_COLUMNS[name]}` }),
    h("div", { class: "field-error", "data-error-for": k(name) }));
  const remove = h("button", { type: "button", text: "remove", "aria-label": `remove zone ${i + 1}` });
  const row = h("tr", { class: "zone-row", "data-key": `keepout[${i}]` }, cell("name", "text"), cell("az_min_deg"), cell("az_max_deg"),
    cell("el_min_deg"), cell("el_max_deg"), h("td", {}, remove));
  remove.addEventListener("click", () => { row.remove(); renumber("zone-row", "keepout"); });
  return row;
}

function serveRow(e = {}, i) {
  const k = (name) => `serve[${i}].${name}`;
  const kinds = ["tcp", "udp", "pty", "serial"];
  const kind = kinds.find((t) => e[t] !== undefined) || "tcp";
  const n = i + 1;
  const proto = h("select", { "data-key": k("protocol"), "aria-label": `port ${n} protocol` });
  for (const p of (info && info.protocols) || [e.protocol]) proto.append(h("option", { value: p, text: p, selected: p === e.protocol }));
  const transport = h("select", { class: "serve-kind", "aria-label": `port ${n} transport` });
  for (const t of kinds) transport.append(h("option", { value: t, text: t, selected: t === kind }));
  const where = h("input", { type: "text", class: "serve-where", "data-key": k(kind), value: e[kind] || "", size: 18,
    placeholder: "127.0.0.1:4533 or /dev/ttyUSB0", "aria-label": `port ${n} address or device` });
  transport.addEventListener("change", () => { where.dataset.key = k(transport.value); });
  const baud = h("input", { type: NUM, step: 1, "data-key": k("baud"), value: e.baud === undefined ? "" : e.baud, placeholder: "9600",
    "aria-label": `port ${n} baud` });
  const remove = h("button", { type: "button", text: "remove", "aria-label": `remove port ${n}` });
  const errs = h("div", { class: "field-error", "data-error-for": `serve[${i}]` });
  const row = h("tr", { class: "serve-row", "data-key": `serve[${i}]` }, h("td", { "data-label": "protocol" }, proto),
    h("td", { "data-label": "transport" }, transport),
    h("td", { "data-label": "address / device" }, where, h("div", { class: "field-error", "data-error-for": k(kind) })),
    h("td", { "data-label": "baud" }, baud), h("td", {}, remove, errs));
  remove.addEventListener("click", () => { row.remove(); serveDirty = true; renumber("serve-row", "serve"); });
  for (const el of [proto, transport, where, baud]) el.addEventListener("change", () => { serveDirty = true; });
  return row;
}

// rows were removed: keep keys serve[0..n] / keepout[0..n] in order
function renumber(cls, name) {
  document.querySelectorAll(`.${cls}`).forEach((row, i) => {
    for (const el of row.querySelectorAll("[data-key],[data-error-for]")) {
      for (const attr of ["data-key", "data-error-for"]) {
        const v = el.getAttribute(attr);
        if (v) el.setAttribute(attr, v.replace(new RegExp(`^${name}\\[\\d+\\]`), `${name}[${i}]`));
      }
    }
    for (const el of row.querySelectorAll("[aria-label]")) {
      el.setAttribute("aria-label", el.getAttribute("aria-label").replace(/\b(zone|port) \d+/, `$1 ${i + 1}`));
    }
    row.setAttribute("data-key", `${name}[${i}]`);
  });
}

function build(c = doc.config) {
  const form = $("settings-form");
  clear(form);
  const profiles = Object.keys(info.profiles);
  form.append(h("fieldset", {}, h("legend", { text: "Rotator (restart needed)" }),
    field("rotator.profile", "profile", get_(c, "rotator.profile"), { options: profiles }),
    field("rotator.flip", "fly over the top (flip)", String(get_(c, "rotator.flip", "auto")), { options: ["auto", "true", "false"] }),
    // BIG-RAS "Elevation: ON/OFF": false = a single-axis rotator, azimuth only
    field("rotator.elevation", "elevation axis", String(get_(c, "rotator.elevation", true)), { options: ["true", "false"] }),
    // the rest of the BIG-RAS menu: "Max. elevation", "Pulse/degree", "Zero point"
    field("rotator.max_el_deg", "max elevation (90 or 180)", get_(c, "rotator.max_el_deg"), { placeholder: capsHint("el", "max_deg") }),
    field("rotator.pulses_per_deg", "pulses per degree (pulse sensors)", get_(c, "rotator.pulses_per_deg"), { step: 1 }),
    field("rotator.zero", "zero point", get_(c, "rotator.zero", "north"), { options: ["north", "south"] }),
    field("rotator.loop_hz", "control loop Hz", get_(c, "rotator.loop_hz"))));
  form.append(h("fieldset", {}, h("legend", { text: "Limits (degrees; empty = the profile's)" }),
    field("limits.az.min_deg", "az min", get_(c, "limits.az.min_deg"), { placeholder: capsHint("az", "min_deg") }),
    field("limits.az.max_deg", "az max", get_(c, "limits.az.max_deg"), { placeholder: capsHint("az", "max_deg") }),
    field("limits.el.min_deg", "el min", get_(c, "limits.el.min_deg"), { placeholder: capsHint("el", "min_deg") }),
    field("limits.el.max_deg", "el max", get_(c, "limits.el.max_deg"), { placeholder: capsHint("el", "max_deg") })));
  form.append(h("fieldset", {}, h("legend", { text: "Offsets (mount misalignment, degrees)" }),
    field("offsets.az_deg", "az offset", get_(c, "offsets.az_deg")),
    field("offsets.el_deg", "el offset", get_(c, "offsets.el_deg"))));
  form.append(h("fieldset", {}, h("legend", { text: "Speeds (empty = the profile's)" }),
    field("control.az.max_rate_deg_per_s", "az max °/s", get_(c, "control.az.max_rate_deg_per_s"), { placeholder: capsHint("az", "max_rate_deg_per_s") }),
    field("control.az.min_rate_deg_per_s", "az minimal turn °/s", get_(c, "control.az.min_rate_deg_per_s"), { placeholder: capsHint("az", "min_rate_deg_per_s") }),
    field("control.az.accel_deg_per_s2", "az accel °/s²", get_(c, "control.az.accel_deg_per_s2")),
    field("control.el.max_rate_deg_per_s", "el max °/s", get_(c, "control.el.max_rate_deg_per_s"), { placeholder: capsHint("el", "max_rate_deg_per_s") }),
    field("control.el.min_rate_deg_per_s", "el minimal turn °/s", get_(c, "control.el.min_rate_deg_per_s"), { placeholder: capsHint("el", "min_rate_deg_per_s") }),
    field("control.el.accel_deg_per_s2", "el accel °/s²", get_(c, "control.el.accel_deg_per_s2"))));
  form.append(h("fieldset", {}, h("legend", { text: "Park" }),
    field("park.az_deg", "park az", get_(c, "park.az_deg"), { placeholder: capsHint("az", "park_deg") }),
    field("park.el_deg", "park el", get_(c, "park.el_deg"), { placeholder: capsHint("el", "park_deg") }),
    field("park.idle_park_s", "auto-park after idle s (0 = never)", get_(c, "park.idle_park_s"))));

  const zones = h("tbody", { id: "zones-body" });
  (c.keepout || []).forEach((z, i) => zones.append(zoneRow(z, i)));
  const addZone = h("button", { type: "button", id: "add-zone", text: "add zone" });
  addZone.addEventListener("click", () => zones.append(zoneRow({}, zones.children.length)));
  form.append(h("fieldset", {}, h("legend", { text: "Keep-out zones (compass az sector, may cross north; el range)" }),
    h("table", { class: "rows" }, h("thead", {}, h("tr", {}, ...["name", "az min", "az max", "el min", "el max"].map((t) => h("th", { text: t })),
      h("th", {}, h("span", { class: "sr-only", text: "remove" })))), zones),
    addZone));

  const usingDefault = c.serve === undefined;
  const serve = h("tbody", { id: "serve-body" });
  (usingDefault ? doc.default_serve : c.serve).forEach((e, i) => serve.append(serveRow(e, i)));
  serveDirty = false;
  const addServe = h("button", { type: "button", id: "add-serve", text: "add port" });
  addServe.addEventListener("click", () => { serve.append(serveRow({ protocol: "rotctld" }, serve.children.length)); serveDirty = true; });
  form.append(h("fieldset", {}, h("legend", { text: "Protocol ports, [[serve]] (restart needed)" }),
    usingDefault ? h("p", { class: "muted small", text: "No [[serve]] in the configuration: the default below is served." }) : null,
    !usingDefault && c.serve.length === 0 ? h("p", { class: "muted small", text: "serve = []: no protocol is served (only this API)." }) : null,
    h("table", { class: "rows" }, h("thead", {}, h("tr", {}, ...["protocol", "transport", "address / device", "baud"].map((t) => h("th", { text: t })),
      h("th", {}, h("span", { class: "sr-only", text: "remove" })))), serve),
    addServe));

  form.append(h("fieldset", {}, h("legend", { text: "Control API (restart needed)" }),
    field("api.host", "listen on", get_(c, "api.host"), { type: "text" }),
    field("api.port", "port", get_(c, "api.port")),
    field("api.token", doc.token_set ? "token (set; empty = keep)" : "token (none set)", "", { type: "password" })));
}

function setPath(obj, key, value) {
  const parts = key.split(".");
  let o = obj;
  for (const p of parts.slice(0, -1)) { if (typeof o[p] !== "object" || o[p] === null) o[p] = {}; o = o[p]; }
  const last = parts[parts.length - 1];
  if (value === undefined) delete o[last]; else o[last] = value;
}

function valueOf(el) {
  if (el.type === "checkbox") return el.checked;
  const raw = el.value.trim();
  if (raw === "") return undefined;
  if (el.tagName === "SELECT" && (raw === "true" || raw === "false")) return raw === "true";
  if (el.type === "number") return Number.isFinite(Number(raw)) ? Number(raw) : raw;
  return raw;
}

function collect() {
  const out = structuredClone(doc.config);
  for (const el of $("settings-form").querySelectorAll("[data-key]")) {
    const key = el.dataset.key;
    if (key.startsWith("keepout[") || key.startsWith("serve[") || el.tagName === "TR") continue;
    setPath(out, key, valueOf(el));
  }
  out.keepout = [...document.querySelectorAll(".zone-row")].map((row) => {
    const z = {};
    for (const el of row.querySelectorAll("input[data-key]")) {
      const name = el.dataset.key.split(".").pop();
      const v = valueOf(el);
      if (v !== undefined) z[name] = v;
    }
    return z;
  });
  if (serveDirty || out.serve !== undefined) {
    out.serve = [...document.querySelectorAll(".serve-row")].map((row) => {
      const e = {};
      for (const el of row.querySelectorAll("[data-key]")) {
        const name = el.dataset.key.split(".").pop();
        const v = valueOf(el);
        if (v !== undefined) e[name] = v;
      }
      return e;
    });
  }
  return out;
}

function showErrors(errors) {
  for (const el of document.querySelectorAll("#settings-form .invalid")) el.classList.remove("invalid");
  for (const el of document.querySelectorAll("#settings-form .field-error")) setText(el, "");
  const box = $("settings-errors");
  clear(box);
  box.hidden = true;
  for (const e of errors) {
    const input = e.key ? document.querySelector(`#settings-form [data-key="${CSS.escape(e.key)}"]`) : null;
    const slot = e.key ? document.querySelector(`#settings-form [data-error-for="${CSS.escape(e.key)}"]`) : null;
    if (input && input.tagName !== "TR") input.classList.add("invalid");
    if (slot) {
      setText(slot, slot.textContent ? `${slot.textContent}; ${e.message}` : e.message);
    } else {
      box.append(h("div", { text: e.key ? `${e.key}: ${e.message}` : e.message }));
      box.hidden = false;
    }
  }
}

async function check() {
  const r = await post("/api/settings/validate", collect(), { quiet: true });
  showErrors(r.ok ? [] : (r.data && r.data.errors) || [{ key: "", message: r.message }]);
  const res = $("settings-result");
  clear(res);
  if (r.ok) res.append(h("li", { text: r.data.changed.length ? `valid; changes: ${r.data.changed.join(", ")}` : "valid; nothing changed" }));
  return r.ok;
}

// what the person changed (against the document loaded) on top of a newer one: a leaf
// (a number, a list of zones or ports) they changed is theirs, any other is the newer's
function onTop(base, mine, newer) {
  const same = (a, b) => JSON.stringify(a) === JSON.stringify(b);
  const isTable = (v) => v !== null && typeof v === "object" && !Array.isArray(v);
  if (isTable(base) && isTable(mine) && isTable(newer)) {
    const out = {};
    for (const k of new Set([...Object.keys(newer), ...Object.keys(mine), ...Object.keys(base)])) {
      const v = onTop(base[k], mine[k], newer[k]);
      if (v !== undefined) out[k] = v;
    }
    return out;
  }
  return same(base, mine) ? newer : mine;
}

async function reloadKeepingEdits() {
  const mine = collect();
  const base = doc.config;
  const r = await get("/api/settings", { quiet: true });
  if (!r.ok) { toast("cannot load the settings", true); return; }
  doc = r.data;
  revision = r.etag || doc.revision;
  const merged = onTop(base, mine, doc.config);
  build(merged);
  serveDirty = JSON.stringify(merged.serve) !== JSON.stringify(doc.config.serve);
  const res = $("settings-result");
  clear(res);
  res.append(h("li", { text: "Loaded the settings saved meanwhile; your changes are kept on top. Check them and save again." }));
}

async function save() {
  // always conditional: a tab loaded before someone else's save must not undo it
  const r = await post("/api/settings", collect(), { quiet: true, headers: { "If-Match": revision } });
  const res = $("settings-result");
  clear(res);
  if (r.status === 412) {
    showErrors([]);
    const again = h("button", { type: "button", id: "settings-reload", text: "load theirs, keep my changes" });
    again.addEventListener("click", reloadKeepingEdits);
    res.append(h("li", { text: "Not saved: someone else saved the settings since this page loaded them. " }, again));
    toast("settings not saved: they changed meanwhile", true);
    return;
  }
  if (!r.ok) {
    showErrors((r.data && r.data.errors) || [{ key: "", message: r.message }]);
    if (r.status === 401) toast("saving needs the API token", true);
    else toast("settings not saved: see the messages", true);
    return;
  }
  showErrors([]);
  for (const m of r.data.messages) res.append(h("li", { text: m }));
  toast("settings saved");
  await load();
}

export async function load(infoData) {
  if (infoData) info = infoData;
  const r = await get("/api/settings", { quiet: true });
  if (!r.ok) return;
  doc = r.data;
  revision = r.etag || doc.revision;
  setText($("settings-where"), doc.config_path
    ? `Configuration file: ${doc.config_path}`
    : `urc run was started without a configuration file: settings are saved to ${doc.save_path}.`);
  const pending = doc.restart_pending || [];
  $("settings-pending").hidden = pending.length === 0;
  setText($("settings-pending"), `Saved, waiting for a restart of urc run: ${pending.join(", ")}.`);
  build();
}

export function setupSettings() {
  $("settings-validate").addEventListener("click", check);
  $("settings-save").addEventListener("click", save);
}
