// The dashboard: wires the live feed to the plots, readouts, banners and pages.
import { $, h, clear, setText, setData, fmt, utcTime } from "./dom.js";
import { get, setToken, token } from "./api.js";
import { Live } from "./live.js";
import { SkyPlot } from "./sky.js";
import { AzDial } from "./dial.js";
import { GroundMap } from "./map.js";
import { Charts } from "./charts.js";
import { setupControls } from "./controls.js";
import { startPasses, setPassOptions } from "./passes.js";
import { load as loadSettings, setupSettings } from "./settings.js";
import { loadCalibration, setupCalibration, showProcedure, followPosition } from "./calibration.js";
import { setupPointing } from "./point.js";

let info = null;
let infoRev = null;
let sky, dial, map, charts;
let lastEventsKey = "";
let lastProcState = "";
let lastTrackWarnings = "";
let lastStateLine = "";

// the setpoint is the rotator's target, updated every control tick (also while
// tracking); the tracked object itself is drawn apart (it may be below the horizon,
// waiting for its pass)
function setpointOf(st) {
  if (st.target_az_deg !== null && st.target_az_deg !== undefined) return [st.target_az_deg, st.target_el_deg];
  return null;
}

function timeOf(iso) {
  return `${utcTime(iso)} UTC`;
}

// ---------------------------------------------------------------- banners
// A banner folds to its title line (its toggle) and opens again by itself when what it
// says changes: new news is never hidden by an old "hide".
const bannerKeys = new Map();

function setBannerOpen(banner, open) {
  const toggle = banner.querySelector(".banner-toggle");
  if (!toggle) return;
  toggle.setAttribute("aria-expanded", String(open));
  setText(toggle, open ? "hide" : "show");
  $(toggle.getAttribute("aria-controls")).hidden = !open;
  banner.classList.toggle("folded", !open);
}

function bannerNews(banner, key) {
  if (bannerKeys.get(banner.id) === key) return;
  bannerKeys.set(banner.id, key);
  setBannerOpen(banner, true);
}

function setupBanners() {
  for (const toggle of document.querySelectorAll(".banner-toggle")) {
    const banner = toggle.closest(".banner");
    toggle.addEventListener("click", () => setBannerOpen(banner, toggle.getAttribute("aria-expanded") !== "true"));
  }
}

// ---------------------------------------------------------------- is the position confirmed?
// kinds of fault after which a reading itself is not to be trusted until cleared
const MISREAD_FAULTS = new Set(["sensor_stuck", "sensor_jump", "sensor_range"]);

function axesOf(st) {
  return ["az", "el"].filter((a) => st[a]);
}

// why the position shown is not confirmed now: a sensor (or the bridged controller) that
// does not answer, a position not referenced, a reading distrusted by a fault, or a
// control process that is silent (the status is its last). {reasons, axes}: no reasons
// = confirmed; axes = the axes whose numbers are not to be trusted
export function unconfirmed(st) {
  const reasons = [];
  const axes = new Set();
  const all = axesOf(st);
  const unreadable = all.filter((a) => st[a].sensor_ok === false);
  // (why it does not read is the fault banner's to say, once)
  if (unreadable.length) reasons.push(`${both(unreadable)} unreadable now: the last reading is shown`);
  for (const a of all) {
    if (st[a].sensor_ok !== false && st[a].uncertainty_deg > 0) reasons.push(`${a} not referenced (±${fmt(st[a].uncertainty_deg, 1)}°)`);
    else if (st[a].sensor_ok !== false) continue;
    axes.add(a);
  }
  for (const f of st.faults || []) {
    if (f.kind === "control") {
      reasons.push("the control process does not answer: its last status is shown");
      all.forEach((a) => axes.add(a));
    } else if (MISREAD_FAULTS.has(f.kind)) {
      reasons.push(`${f.axis || "a"} sensor misread (${f.kind}): not trusted until the fault is cleared`);
      if (f.axis) axes.add(f.axis); else all.forEach((a) => axes.add(a));
    }
  }
  if (!st.position_known && reasons.length === 0) {
    reasons.push("the position is not referenced");
    all.forEach((a) => axes.add(a));
  }
  return { reasons, axes };
}

function both(axes) {
  return axes.join(" and ");
}

// the numbers of an axis not confirmed now are dimmed, and say so to a screen reader
const AXIS_CELLS = { az: ["now-az", "ro-az", "ro-maz"], el: ["now-el", "ro-el", "ro-mel"] };

// what the causes of the latched faults do now: will "Clear fault" work? (axes that
// fail the same way are named together: a bridged controller's two axes share a link)
function faultNow(st) {
  const out = [];
  if ((st.faults || []).some((f) => f.kind === "control")) out.push("The control process still does not answer: clearing waits for it.");
  const sensorAxes = [...new Set((st.faults || []).filter((f) => f.kind.startsWith("sensor") && f.axis && st[f.axis]).map((f) => f.axis))];
  const byError = new Map();
  for (const a of sensorAxes.filter((a) => st[a].sensor_ok === false)) {
    const err = st[a].sensor_error || "no reading";
    byError.set(err, [...(byError.get(err) || []), a]);
  }
  for (const [err, axes] of byError) {
    out.push(`Now: ${both(axes)} still unreadable (${err}): clearing cannot help until ${axes.length > 1 ? "they read" : "it reads"}.`);
  }
  const back = sensorAxes.filter((a) => st[a].sensor_ok !== false);
  if (back.length) out.push(`Now: ${both(back)} ${back.length > 1 ? "read" : "reads"} again: Clear fault re-arms ${back.length > 1 ? "them" : "it"}.`);
  // a stall: nothing here tells whether its cause is gone; a runaway: whether it still turns
  const ofKind = (kind) => [...new Set((st.faults || []).filter((f) => f.kind === kind && f.axis && st[f.axis]).map((f) => f.axis))];
  for (const [kind, what] of [["stall", "stalled (driven, did not turn)"], ["overcurrent", "drew too much current (jammed or overloaded)"]]) {
    const axes = ofKind(kind);
    if (!axes.length) continue;
    out.push(`Now: ${both(axes)} ${what}. Clearing helps only if the cause is gone (ice, a jammed gear, ` +
      "a cable, an end stop): Clear fault lets the next move try again, and it stops again if still stuck.");
  }
  const running = ofKind("runaway");
  const turning = running.filter((a) => Math.abs(st[a].rate_deg_per_s) > 0.2);
  if (turning.length) out.push(`Now: ${both(turning)} still ${turning.length > 1 ? "turn" : "turns"} with the motor off: clearing cannot help until ${turning.length > 1 ? "they stop" : "it stops"}.`);
  const still = running.filter((a) => !turning.includes(a));
  if (still.length) out.push(`Now: ${both(still)} ${still.length > 1 ? "stand" : "stands"} still: Clear fault re-arms ${still.length > 1 ? "them" : "it"}.`);
  return out.join(" ");
}

function ago(seconds) {
  const s = Math.max(0, Math.round(seconds));
  return s < 120 ? `${s} s ago` : s < 7200 ? `${Math.round(s / 60)} min ago` : `${Math.round(s / 3600)} h ago`;
}

// what the rotator does and why, in a line (the first phone screen shows it)
function whyNow(st, frame, sp) {
  const faults = st.faults || [];
  const trk = st.tracking;
  if (faults.length) {
    const kinds = [...new Set(faults.map((f) => (f.axis ? `${f.axis} ${f.kind}` : f.kind)))];
    return `Stopped by a fault (${kinds.join(", ")}): the banner above says why; clear it to move again.`;
  }
  if ((st.local_control || []).length) return `Held at the rotator (${st.local_control.join(", ")}): moves from here are refused.`;
  if ((frame.jogs || []).length) return `Jogging ${frame.jogs.join(" and ")} from a page (while the button is held).`;
  if (trk) {
    if (trk.stopped) return `Not tracking ${trk.target}: ${trk.stopped}`;
    if (trk.error) return `Tracking ${trk.target}: ${trk.error}`;
    return `Tracking ${trk.target}: ${st.cycle ? st.cycle.why : "following"}.`;
  }
  if (!st.position_known) return "Position not referenced: automatic moves are refused until it is (Calibration).";
  const where = sp ? `az ${fmt(sp[0], 1)}°` + (sp[1] === null || sp[1] === undefined || !st.el ? "" : `, el ${fmt(sp[1], 1)}°`) : "";
  if (st.parked) return "Parked.";
  if (st.moving) return sp ? `Going to ${where}.` : "Moving (a manual move).";
  return sp ? `Holding at ${where}.` : "Standing: no target.";
}

function pill(text, cls = "") {
  return h("span", { class: `pill ${cls}`, text });
}

// everything the tracker says the operator should know, most urgent first: why it is
// not following, its error, its warnings (old elements...), then the plan's notes (a
// keyhole's worst error, a pass wider than the azimuth range, a keep-out zone)
function trackingWarnings(trk) {
  if (!trk) return [];
  return [trk.stopped, trk.error, ...(trk.warnings || []), ...((trk.plan && trk.plan.notes) || [])]
    .filter((w) => w);
}

function showTrackingWarnings(trk) {
  const items = trackingWarnings(trk);
  const key = `${trk ? trk.target : ""}\n${items.join("\n")}`;
  if (key === lastTrackWarnings) return;  // frames come 10 times a second: redraw on change only
  lastTrackWarnings = key;
  $("track-banner").hidden = items.length === 0;
  setText($("track-banner-title"), trk && trk.stopped ? `NOT tracking ${trk.target}` : `Tracking ${trk ? trk.target : ""}`);
  setText($("track-count"), items.length > 1 ? `${items.length} notes` : "");
  const ul = $("track-warnings");
  clear(ul);
  for (const text of items) ul.append(h("li", { text }));
  if (items.length) bannerNews($("track-banner"), key);
}

// the pills under the position, rebuilt only when one of them changed (frames come 10
// times a second: a rebuilt line is a layout and a repaint of the page each time)
function showStateLine(st, frame) {
  const error = frame.error_deg !== null && frame.error_deg !== undefined ? fmt(frame.error_deg, 2) : null;
  const c = st.cycle;
  const key = JSON.stringify([st.moving, st.parked, st.flipped, error, frame.jogs || [],
    c ? [c.document, c.state, c.why] : null]);
  if (key === lastStateLine) return;
  lastStateLine = key;
  const line = $("state-line");
  clear(line);
  line.append(pill(st.moving ? "moving" : "standing", st.moving ? "on" : ""));
  if (st.parked) line.append(pill("parked", "on"));
  if (st.flipped) line.append(pill("flipped (over the top)", "on"));
  if (error !== null) line.append(pill(`error ${error}°`));
  for (const axis of frame.jogs || []) line.append(pill(`jogging ${axis}`, "on"));
  if (c) {
    // the Berkeley state machine's name for what urc does now (urc.tracking.cycle)
    const p = pill(`cycle ${c.document}`, c.state === "track" || c.state === "report" ? "on" : "");
    p.id = "cycle-pill";
    p.dataset.state = c.state;
    p.title = c.why;
    line.append(p);
  }
}

function onFrame(frame) {
  const st = frame.status;
  const sp = setpointOf(st);
  sky.update(st, sp, frame.t_wall_s);
  sky.setObject(st.tracking);
  sky.setPlan(st.tracking && st.tracking.plan ? st.tracking.plan.track : null);
  dial.setRange(st.limits.az[0], st.limits.az[1], st.offsets.az || 0);
  dial.update(st);
  map.update(st.tracking);
  if (frame.revs && frame.revs.info !== infoRev) {
    // the settings changed (limits, keep-out zones...): what /api/info says changed too
    if (infoRev !== null) loadInfo();
    infoRev = frame.revs.info;
  }
  if (!$("view-calibration").hidden) followPosition(st);
  charts.push(frame);

  // where it points (with how sure urc is of it), what it does, why
  const unsure = unconfirmed(st);
  document.body.classList.toggle("unconfirmed", unsure.reasons.length > 0);
  for (const [axis, ids] of Object.entries(AXIS_CELLS)) {
    for (const id of ids) setData($(id), "confirmed", String(!unsure.axes.has(axis)));
  }
  setData($("now-pos"), "unconfirmedAxes", [...unsure.axes].join(" "));
  $("now-badge").hidden = unsure.reasons.length === 0;
  $("confirm-line").hidden = unsure.reasons.length === 0;
  setText($("confirm-line"), unsure.reasons.length ? `Position unconfirmed: ${unsure.reasons.join("; ")}.` : "");
  const unc = (a) => (st[a] && st[a].uncertainty_deg > 0 ? ` ±${fmt(st[a].uncertainty_deg, 1)}` : "");
  setText($("now-az"), `az ${fmt(st.az_deg, 2)}°${unc("az")}`);
  setText($("now-el"), `el ${fmt(st.el_deg, 2)}°${unc("el")}`);
  setText($("why-line"), whyNow(st, frame, sp));

  setText($("ro-az"), fmt(st.az_deg, 2));
  // (a single-axis rotator: st.el is null; its cells are hidden, see loadInfo)
  const el = st.el || {};
  setText($("ro-el"), fmt(st.el_deg, 2));
  setText($("ro-taz"), sp ? fmt(sp[0], 2) : "—");
  setText($("ro-tel"), sp ? fmt(sp[1], 2) : "—");
  setText($("ro-maz"), fmt(st.az.pos_deg, 2));
  setText($("ro-mel"), fmt(el.pos_deg, 2));
  setText($("ro-raz"), fmt(st.az.rate_deg_per_s, 2));
  setText($("ro-rel"), fmt(el.rate_deg_per_s, 2));
  setText($("ro-modeaz"), st.az.mode);
  setText($("ro-modeel"), el.mode || "—");
  showStateLine(st, frame);
  const trk = st.tracking;
  setText($("tracking-line"), trk ? `tracking ${trk.target}` + (trk.plan ? ` · AOS ${timeOf(trk.plan.aos)} · LOS ${timeOf(trk.plan.los)}` +
    `${trk.plan.flip ? " · over the top" : ""}${trk.plan.wrap_turns ? ` · wrap lap ${trk.plan.wrap_turns}` : ""}` : "") : "");
  showTrackingWarnings(trk);
  setText($("map-title"), trk && trk.ground_track ? `(${trk.target})` : "");
  $("map-note").hidden = !!(trk && trk.ground_track);

  // faults: a banner with every reason; an uncertain position: a warning
  const faults = st.faults || [];
  $("fault-banner").hidden = faults.length === 0;
  if (faults.length) bannerNews($("fault-banner"), faults.map((f) => `${f.kind}:${f.reason}`).join("\n"));
  setText($("fault-announce"), faults.length ? `Fault: ${faults.map((f) => f.reason).join("; ")}` : "");
  setText($("fault-count"), faults.length > 1 ? `(${faults.length})` : "");
  // each reason with its age: a latched fault says what happened then, not now
  setText($("fault-text"), faults.map((f) => `${f.kind}: ${f.reason} (${ago(st.t_s - f.t_s)})`).join(" · "));
  setText($("fault-now"), faultNow(st));
  // a front-panel button (or a console procedure) held at the rotator: the local
  // operator wins, so moves from here are refused until it is released
  const local = st.local_control || [];
  $("local-banner").hidden = local.length === 0;
  setText($("local-text"), local.length ? `${local.join(", ")} held at the rotator: moves from here ` +
    "are refused until it is released (STOP still works)." : "");
  // a stop urc made by itself (a late loop, a silent I/O process, a fault): what it
  // cut, why, and whether it goes on by itself; shown for a minute, never a silent idle
  const stop = st.last_stop;
  const stopShown = !!stop && st.t_s - stop.t_s < 60;
  $("stop-banner").hidden = !stopShown;
  if (stopShown) {
    setText($("stop-text"), `${stop.command || "motion"} stopped (${stop.kind}): ${stop.reason} (${ago(st.t_s - stop.t_s)}); ` +
      (stop.resumes ? "it resumes by itself once urc is healthy." : "it does not resume by itself."));
  }
  const uncertain = !st.position_known;
  $("warn-banner").hidden = !uncertain;
  if (uncertain) {
    const parts = ["az", "el"].filter((a) => st[a] && st[a].uncertainty_deg > 0).map((a) => `${a} ±${fmt(st[a].uncertainty_deg, 1)}°`);
    setText($("warn-text"), `${parts.join(", ")}: automatic moves are refused until the position is re-referenced.`);
  }

  const evKey = (st.events || []).join("\n");
  if (evKey !== lastEventsKey) {
    lastEventsKey = evKey;
    const ul = $("events");
    clear(ul);
    for (const e of [...(st.events || [])].reverse()) ul.append(h("li", { text: e }));
  }
  if (!document.body.dataset.firstPositionMs) {
    // page load (navigation start) to the first live position drawn: the benchmark reads it
    document.body.dataset.firstPositionMs = String(Math.round(performance.now()));
  }
  const proc = frame.procedure;
  const procKey = proc ? `${proc.state}:${proc.step}:${proc.progress}` : "";
  if (procKey !== lastProcState) {
    const wasRunning = lastProcState.startsWith("running");
    lastProcState = procKey;
    showProcedure(proc);
    if (wasRunning && proc && proc.state !== "running") loadCalibration();
  }
}

function route() {
  const view = (location.hash || "#dashboard").slice(1);
  const known = ["dashboard", "settings", "calibration"].includes(view) ? view : "dashboard";
  for (const v of ["dashboard", "settings", "calibration"]) $(`view-${v}`).hidden = v !== known;
  for (const a of document.querySelectorAll("nav a")) a.classList.toggle("active", a.dataset.view === known);
  if (known === "settings") loadSettings(info);
  if (known === "calibration") loadCalibration();
}

// the rotator's description: read at start, after every reconnection (urc may have been
// restarted with other settings) and when the live frames say the settings changed
async function loadInfo() {
  const r = await get("/api/info", { quiet: true });
  if (!r.ok) return;
  info = r.data;
  setText($("profile-name"), `${info.profile} · ${info.backend}${info.simulator ? " (simulator)" : ""}`);
  $("token-form").hidden = !info.control_requires_token;
  $("sim-card").hidden = !info.simulator;
  sky.setZones(info.keepout);
  map.setStation(info.station);
  setPassOptions(info);
  document.body.dataset.infoProfile = info.profile;
  // a single-axis rotator: every elevation control and readout (.el-only) is hidden
  const azOnly = !(info.axes || ["az", "el"]).includes("el");
  document.body.classList.toggle("az-only", azOnly);
  $("goto-el").required = !azOnly;  // a hidden required field would block the goto form
}

async function start() {
  // the plots and the live feed first (the first position is drawn as soon as it comes),
  // then what needs the rotator's description
  sky = new SkyPlot($("sky"));
  dial = new AzDial($("dial"), $("wrap-text"));
  map = new GroundMap($("map"));
  charts = new Charts({ az: $("chart-az"), el: $("chart-el"), err: $("chart-err") }, $("chart-which"), $("chart-label"));
  let opened = false;
  new Live(onFrame, () => { if (opened) loadInfo(); opened = true; }).connect();
  await loadInfo();
  $("token-input").value = token();
  $("token-input").addEventListener("change", (ev) => setToken(ev.target.value.trim()));
  $("token-form").addEventListener("submit", (ev) => ev.preventDefault());
  setupBanners();

  charts.load("recent");
  setupControls();
  setupSettings();
  setupCalibration();
  setupPointing();
  startPasses();
  window.addEventListener("hashchange", route);
  route();
}

start();
