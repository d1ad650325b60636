// The pass list (needs the tracker: when /api/passes is missing the tracking UI hides).
import { $, h, clear, setText, fmt, toast, utcTime, utcDay } from "./dom.js";
import { get, post } from "./api.js";

const REFRESH_MS = 60_000;
const HOURS = 24;
// AOS/LOS are where a pass crosses this elevation: the one the tracker flies passes from
// (tracking.min_el_deg), so the list and a pass's plan give the same AOS
let minElDeg = null;

export function setPassOptions(info) {
  const changed = info.tracking_min_el_deg !== minElDeg;
  minElDeg = info.tracking_min_el_deg ?? 0;
  setText($("passes-note"), `(next ${HOURS} h, above ${fmt(minElDeg, 0)}°; times in UTC)`);
  if (changed && started) loadPasses();
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
      h("td", { class: "num", text: `${utcDay(p.aos)} ${utcTime(p.aos, false)}` }),
      h("td", { class: "num", text: utcTime(p.los, false) }),
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
