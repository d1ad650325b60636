// The pass list (needs the tracker: when /api/passes is missing the tracking UI hides).
import { $, h, clear, setText, fmt, toast } from "./dom.js";
import { get, post } from "./api.js";

const REFRESH_MS = 60_000;
const HOURS = 24;
// AOS/LOS are where a pass crosses this elevation: the one the tracker flies passes from
// (tracking.min_el_deg), so the list and a pass's plan give the same AOS
let minElDeg = null;

export function setPassOptions(info) {
  const changed = info.tracking_min_el_deg !== minElDeg;
  minElDeg = info.tracking_min_el_deg ?? 0;
  setText($("passes-note"), `(next ${HOURS} h, above ${fmt(minElDeg, 0)}°; times in ${zoneName()})`);
  if (changed && started) loadPasses();
}

// the browser's time zone, named and as an offset: "Europe/Tallinn, UTC+02:00"
export function zoneName() {
  const zone = Intl.DateTimeFormat().resolvedOptions().timeZone || "local time";
  const off = -new Date().getTimezoneOffset();
  const hh = String(Math.floor(Math.abs(off) / 60)).padStart(2, "0"), mm = String(Math.abs(off) % 60).padStart(2, "0");
  return `${zone}, UTC${off < 0 ? "−" : "+"}${hh}:${mm}`;
}

function hhmm(iso) {
  const d = new Date(iso);
  return Number.isNaN(d.getTime()) ? String(iso) : d.toLocaleTimeString([], { hour: "2-digit", minute: "2-digit" });
}

function day(iso) {
  const d = new Date(iso);
  return Number.isNaN(d.getTime()) ? "" : d.toLocaleDateString([], { month: "short", day: "numeric" });
}

export function setTrackingAvailable(available) {
  document.body.classList.toggle("no-tracking", !available);
  for (const el of document.querySelectorAll(".track-only")) el.hidden = !available;
}

export async function loadPasses() {
  const r = await get(`/api/passes?hours=${HOURS}` + (minElDeg === null ? "" : `&min_el=${minElDeg}`), { quiet: true });
  if (r.status === 404) {
    setTrackingAvailable(false);
    return false;
  }
  setTrackingAvailable(true);
  const body = $("passes-body");
  clear(body);
  if (!r.ok) {
    setText($("passes-status"), r.message || "pass search failed");
    return true;
  }
  const passes = Array.isArray(r.data) ? r.data : [];
  setText($("passes-status"), passes.length ? "" : "no passes in the next 24 hours");
  for (const p of passes) {
    const btn = h("button", { type: "button", class: "track-pass", text: "Track this pass" });
    btn.addEventListener("click", async () => {
      const res = await post("/api/track/pass", { norad: p.norad, aos: p.aos });
      if (res.ok) toast(`pass of ${p.name} planned`);
    });
    body.append(h("tr", { "data-norad": p.norad },
      h("td", { text: p.name, title: `NORAD ${p.norad}` }),
      h("td", { text: `${day(p.aos)} ${hhmm(p.aos)}` }),
      h("td", { text: hhmm(p.los) }),
      h("td", { class: "num", text: `${fmt(p.max_el_deg, 0)}°` }),
      h("td", { class: "num", text: `${fmt(p.aos_az_deg, 0)}→${fmt(p.los_az_deg, 0)}` }),
      h("td", {}, btn)));
  }
  return true;
}

let started = false;

export function startPasses() {
  started = true;
  loadPasses().then((available) => { if (available) setInterval(loadPasses, REFRESH_MS); });
}
