// Calibration page: sensors and constants, zero/re-reference, two-point pot, magnetometer
// and limit-switch homing (progress arrives with every live frame).
import { $, h, clear, setText, fmt, toast } from "./dom.js";
import { get, post } from "./api.js";
import { showScan } from "./scanplot.js";

const pot = { p1: null, p2: null };

function num(id) {
  const v = $(id).value.trim();
  return v === "" ? null : Number(v);
}

function options(select, axes) {
  clear(select);
  for (const a of axes) select.append(h("option", { value: a, text: a }));
}

export async function loadCalibration() {
  const r = await get("/api/calibration", { quiet: true });
  if (!r.ok) return;
  const axes = r.data.axes;
  const table = $("cal-sensors");
  clear(table);
  for (const [axis, d] of Object.entries(axes)) {
    // numbers to 6 digits; vectors and matrices (the SARCNET 3-D calibration) to 4 each
    const show = (v) => typeof v === "number" ? Number(v.toPrecision(6))
      : Array.isArray(v) ? `[${v.map((x) => Number(Number(x).toPrecision(4))).join(" ")}]` : v;
    const consts = Object.entries(d.calibration).map(([k, v]) => `${k} = ${show(v)}`).join(", ");
    // (the axis name heads its row: a th, never broken the way a cell's long words may be)
    table.append(h("tr", {}, h("th", { scope: "row", text: axis }), h("td", { text: `${d.kind}${d.absolute ? " (absolute)" : " (incremental)"}, ${fmt(d.resolution_deg, 3)}°/count` }),
      h("td", { class: "muted small", text: consts || "no constants" })));
  }
  const withProc = (p) => Object.keys(axes).filter((a) => axes[a].procedures.includes(p));
  $("pot-card").hidden = withProc("pot").length === 0;
  options($("pot-axis"), withProc("pot"));
  $("mag-card").hidden = withProc("magnetometer").length === 0;
  $("home-card").hidden = withProc("homing").length === 0;
  options($("home-axis"), withProc("homing"));
  showProcedure(r.data.procedure);
  const st = await get("/api/status", { quiet: true });
  if (st.ok) followPosition(st.data);
}

// where the antenna reads now (mechanical + offset: beyond 0..360 names the wrap side)
function reading(st) {
  // (a single-axis rotator has no elevation reading: null)
  return { az: st.az.pos_deg + (st.offsets.az || 0), el: st.el ? st.el.pos_deg + (st.offsets.el || 0) : null };
}

let pendingZero = null;

function zeroQuestion(now) {
  const p = pendingZero;
  const parts = [];
  if (p.az_deg !== null) parts.push(`az ${fmt(p.az_deg, 2)}°`);
  if (p.el_deg !== null) parts.push(`el ${fmt(p.el_deg, 2)}°`);
  setText($("zero-question"), `The antenna reads az ${fmt(now.az, 2)}°, el ${fmt(now.el, 2)}° now. ` +
    `Declare that it points at ${parts.join(", ")}? Every later move is measured from this.`);
}

let lastReading = null;

// every live frame while the calibration page is shown: the reading, and the fields
// follow it until the user edits them (a stale field must not re-reference the antenna)
export function followPosition(st) {
  const now = reading(st);
  lastReading = now;
  setText($("zero-now"), `az ${fmt(now.az, 2)}°, el ${fmt(now.el, 2)}°`);
  for (const [id, v] of [["zero-az", now.az], ["zero-el", now.el]]) {
    const field = $(id);
    if (!field.dataset.edited && document.activeElement !== field) field.value = v === null ? "" : v.toFixed(2);
  }
  if (pendingZero) zeroQuestion(now);
}

function endZero() {
  const wasOpen = !$("zero-confirm").hidden;
  pendingZero = null;
  $("zero-confirm").hidden = true;
  for (const id of ["zero-az", "zero-el"]) delete $(id).dataset.edited;
  if (wasOpen && $("zero-confirm").contains(document.activeElement)) $("zero-submit").focus();
}

// the confirmation is a modal dialog: Tab and Shift+Tab go round its buttons, and focus
// that leaves it (a click elsewhere) comes back; STOP alone may take it
function trapZeroFocus() {
  const dialog = $("zero-confirm");
  const buttons = () => [...dialog.querySelectorAll("button")];
  dialog.addEventListener("keydown", (ev) => {
    if (ev.key !== "Tab") return;
    const all = buttons();
    const at = all.indexOf(document.activeElement);
    ev.preventDefault();
    all[(at + (ev.shiftKey ? all.length - 1 : 1)) % all.length].focus();
  });
  document.addEventListener("focusin", (ev) => {
    // (not while another page is shown: the dialog is not on screen then)
    if (dialog.hidden || dialog.offsetParent === null || dialog.contains(ev.target) || ev.target === $("stop-btn")) return;
    buttons()[0].focus();
  });
}

export function showProcedure(proc) {
  const card = $("proc-card");
  if (!proc) { card.hidden = true; return; }
  card.hidden = false;
  setText($("proc-kind"), `${proc.kind} · ${proc.axis} · ${proc.state}`);
  $("proc-progress").value = proc.progress;
  setText($("proc-step"), proc.step);
  $("proc-cancel").hidden = proc.state !== "running";
  card.dataset.state = proc.state;
  if (proc.kind === "scan") showScan();  // the power against offset, as the scan goes
}

async function readPot(which) {
  const axis = $("pot-axis").value;
  const r = await post("/api/calibration/pot/read", { axis });
  if (!r.ok) return;
  pot[which] = r.data.p;
  setText($(`pot-${which}`), `P = ${fmt(r.data.p, 1)} (reads ${fmt(r.data.reading_deg, 1)}°)`);
}

export function setupCalibration() {
  for (const id of ["zero-az", "zero-el"]) $(id).addEventListener("input", () => { $(id).dataset.edited = "1"; });
  $("zero-form").addEventListener("submit", (ev) => {
    ev.preventDefault();
    const body = { az_deg: num("zero-az"), el_deg: num("zero-el") };
    if (body.az_deg === null && body.el_deg === null) { toast("enter az and/or el", true); return; }
    pendingZero = body;   // asked first: re-referencing cannot be undone by moving
    zeroQuestion(lastReading || { az: null, el: null });
    $("zero-confirm").hidden = false;
    $("zero-no").focus();   // (the safe answer first: Enter on it cancels)
  });
  trapZeroFocus();
  $("zero-no").addEventListener("click", endZero);
  $("zero-yes").addEventListener("click", async () => {
    const body = pendingZero;
    if (!body) return;
    if ((await post("/api/calibration/zero", body)).ok) { toast("position set"); endZero(); loadCalibration(); }
  });
  $("pot-read1").addEventListener("click", () => readPot("p1"));
  $("pot-read2").addEventListener("click", () => readPot("p2"));
  $("pot-apply").addEventListener("click", async () => {
    const b1 = num("pot-b1"), b2 = num("pot-b2");
    if (b1 === null || b2 === null || pot.p1 === null || pot.p2 === null) { toast("enter both bearings and read both points", true); return; }
    const r = await post("/api/calibration/pot/apply", { axis: $("pot-axis").value,
      points: [{ bearing_deg: b1, p: pot.p1 }, { bearing_deg: b2, p: pot.p2 }] });
    if (r.ok) { toast(`calibrated: M = ${r.data.result.M.toPrecision(5)}, C = ${fmt(r.data.result.C, 2)}`); loadCalibration(); }
  });
  $("mag-start").addEventListener("click", async () => {
    const r = await post("/api/calibration/magnetometer");
    if (r.ok) showProcedure(r.data.procedure);
  });
  $("home-form").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const body = { axis: $("home-axis").value };
    const sw = num("home-switch");
    if (sw !== null) body.switch_deg = sw;
    const r = await post("/api/calibration/homing", body);
    if (r.ok) showProcedure(r.data.procedure);
  });
  $("proc-cancel").addEventListener("click", () => post("/api/calibration/procedure/cancel"));
}
