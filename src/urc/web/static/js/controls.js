// Commands: go to, press-and-hold jog (renewed while held, so a lost page stops the
// antenna), STOP (button, Space, Escape), park, clear fault, tracking, simulator faults.
// Space stops also while a button has the focus (the page says so; Enter presses the
// button): after "Go to" or "Park" the focus stays on that button, and a Space meant as
// a stop must not send the move again.
import { $, toast } from "./dom.js";
import { post } from "./api.js";

const RENEW_MS = 200;
const KEYS = { ArrowLeft: ["az", -1], ArrowRight: ["az", 1], ArrowUp: ["el", 1], ArrowDown: ["el", -1] };
const held = new Map(); // axis -> {dir, timer, source}

function speed() {
  return Number($("jog-speed").value) / 100;
}

function button(axis, dir) {
  return document.querySelector(`.jog-btn[data-axis="${axis}"][data-dir="${dir}"]`);
}

async function startJog(axis, dir, source) {
  const cur = held.get(axis);
  if (cur && cur.dir === dir) return;
  if (cur) stopJog(axis, false);
  const body = { axis, direction: dir, speed: speed() };
  const state = { dir, source, timer: null };
  held.set(axis, state);
  button(axis, dir)?.classList.add("held");
  const r = await post("/api/jog", body);
  if (!r.ok || held.get(axis) !== state) { if (held.get(axis) === state) stopJog(axis); return; }
  state.timer = setInterval(() => post("/api/jog", { axis, direction: dir, speed: speed() }, { quiet: true }), RENEW_MS);
}

function stopJog(axis, send = true) {
  const cur = held.get(axis);
  if (!cur) return;
  clearInterval(cur.timer);
  held.delete(axis);
  button(axis, cur.dir)?.classList.remove("held");
  if (send) post("/api/jog/release", { axis }, { quiet: true });
}

export function stopAll() {
  for (const axis of [...held.keys()]) stopJog(axis, false);
  post("/api/stop", {}).then((r) => { if (r.ok) toast("stopped"); });
}

function typing(target) {
  const tag = target && target.tagName;
  return tag === "INPUT" || tag === "SELECT" || tag === "TEXTAREA" || (target && target.isContentEditable);
}

export function setupControls() {
  $("stop-btn").addEventListener("click", stopAll);
  $("jog-speed").addEventListener("input", () => { $("jog-speed-out").value = `${$("jog-speed").value}%`; });

  for (const btn of document.querySelectorAll(".jog-btn")) {
    const axis = btn.dataset.axis, dir = Number(btn.dataset.dir);
    btn.addEventListener("pointerdown", (ev) => {
      ev.preventDefault();
      btn.setPointerCapture?.(ev.pointerId);
      startJog(axis, dir, "pointer");
    });
    for (const evName of ["pointerup", "pointercancel", "lostpointercapture"]) {
      btn.addEventListener(evName, () => { if (held.get(axis)?.source === "pointer") stopJog(axis); });
    }
    btn.addEventListener("contextmenu", (ev) => ev.preventDefault());
  }

  document.addEventListener("keydown", (ev) => {
    if (ev.key === "Escape" || (ev.key === " " && !typing(ev.target))) {
      ev.preventDefault();
      stopAll();
      return;
    }
    const jog = KEYS[ev.key];
    if (jog && jog[0] === "el" && document.body.classList.contains("az-only")) return;  // no elevation
    if (!jog || typing(ev.target) || location.hash.replace("#", "") !== "dashboard" && location.hash !== "") return;
    ev.preventDefault();
    if (!ev.repeat) startJog(jog[0], jog[1], "key");
  });
  document.addEventListener("keyup", (ev) => {
    // (a browser presses a focused button when Space is released: that key was a stop)
    if (ev.key === " " && !typing(ev.target)) ev.preventDefault();
    const jog = KEYS[ev.key];
    if (jog && held.get(jog[0])?.source === "key") stopJog(jog[0]);
  });
  window.addEventListener("blur", () => { for (const axis of [...held.keys()]) stopJog(axis); });

  $("goto-form").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const azOnly = document.body.classList.contains("az-only");
    // (a single-axis rotator leaves the elevation of a goto aside: 0 is sent)
    const az = Number($("goto-az").value), el = azOnly ? 0 : Number($("goto-el").value);
    const r = await post("/api/goto", { az_deg: az, el_deg: el });
    if (r.ok) toast(azOnly ? `going to az ${az}` : `going to az ${az}, el ${el}`);
  });
  $("park-btn").addEventListener("click", async () => { if ((await post("/api/park")).ok) toast("parking"); });
  $("clear-fault-btn").addEventListener("click", async () => { if ((await post("/api/clear-faults")).ok) toast("faults cleared"); });

  $("track-sun").addEventListener("click", () => track({ kind: "sun" }, "the Sun"));
  $("track-moon").addEventListener("click", () => track({ kind: "moon" }, "the Moon"));
  $("track-stop").addEventListener("click", async () => { if ((await post("/api/track/stop")).ok) toast("tracking stopped"); });
  $("track-sat-form").addEventListener("submit", (ev) => {
    ev.preventDefault();
    const v = $("track-sat").value.trim();
    if (!v) return;
    const body = /^\d+$/.test(v) ? { kind: "satellite", norad: Number(v) } : { kind: "satellite", name: v };
    track(body, v);
  });

  $("sim-form").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const body = { axis: $("sim-axis").value, kind: $("sim-kind").value };
    if ((await post("/api/sim/fault", body)).ok) toast(`simulated ${body.kind} on ${body.axis}`);
  });
  $("sim-repair").addEventListener("click", async () => {
    for (const axis of ["az", "el"]) await post("/api/sim/clear", { axis });
    toast("simulated hardware repaired (clear the latched fault to move again)");
  });
}

async function track(body, what) {
  const r = await post("/api/track", body);
  if (r.ok) toast(`tracking ${what}`);
}
