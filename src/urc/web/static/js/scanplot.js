// The calibration scan (issue 38) drawn as received power against offset from the target:
// the azimuth leg (across elevation, dx) and the elevation leg (dy), each sample a dot,
// with the fitted peak of each leg once the scan is done. Its own card on the
// calibration page, made here: the page's markup is not touched.
import { $, s, h, clear, setText, fmt } from "./dom.js";
import { get } from "./api.js";

const W = 520, H = 220, L = 48, R = 24, T = 10, B = 34;
const LEGS = [{ leg: "az", key: "dx_deg", fit: "dx_deg", cls: "scan-az", label: "az (across el)" },
  { leg: "el", key: "dy_deg", fit: "dy_deg", cls: "scan-el", label: "el" }];

function card() {
  let c = $("scan-card");
  if (c) return c;
  const grid = document.querySelector("#view-calibration .grid");
  if (!grid) return null;
  c = h("div", { class: "card wide", id: "scan-card" },
    h("h2", {}, "Scan ", h("span", { id: "scan-title", class: "muted small" })),
    h("div", { id: "scan-plot" }),
    h("p", { id: "scan-note", class: "small" }));
  grid.append(c);
  return c;
}

// the SVG of a scan report (GET /api/calibration/scan's "scan"): pure, for the page and tests
export function scanSvg(report) {
  const samples = (report && report.samples) || [];
  const svg = s("svg", { viewBox: `0 0 ${W} ${H}`, width: "100%", role: "img",
    "aria-label": "received power against offset from the target" });
  if (!samples.length) return svg;
  const xs = [], ys = samples.map((p) => p.value);
  for (const p of samples) for (const l of LEGS) if (p.leg === l.leg) xs.push(p[l.key]);
  const xMax = Math.max(1e-6, ...xs.map(Math.abs));
  const yMin = Math.min(...ys), yMax = Math.max(yMin + 1e-6, ...ys);
  const X = (v) => L + ((v + xMax) / (2 * xMax)) * (W - L - R);
  const Y = (v) => T + (1 - (v - yMin) / (yMax - yMin)) * (H - T - B);
  svg.append(s("line", { x1: L, y1: H - B, x2: W - R, y2: H - B, class: "scan-axis", stroke: "currentColor" }),
    s("line", { x1: L, y1: T, x2: L, y2: H - B, class: "scan-axis", stroke: "currentColor" }),
    s("line", { x1: X(0), y1: T, x2: X(0), y2: H - B, stroke: "currentColor", "stroke-dasharray": "2 3", opacity: 0.5 }));
  for (const v of [-xMax, 0, xMax]) {
    svg.append(s("text", { x: X(v), y: H - B + 14, "text-anchor": "middle", "font-size": 11, fill: "currentColor" }, fmt(v, 2)));
  }
  svg.append(s("text", { x: (L + W - R) / 2, y: H - 4, "text-anchor": "middle", "font-size": 11, fill: "currentColor" },
    "offset from the target (°)"));
  for (const v of [yMin, yMax]) {
    svg.append(s("text", { x: L - 4, y: Y(v) + 4, "text-anchor": "end", "font-size": 11, fill: "currentColor" }, fmt(v, 1)));
  }
  svg.append(s("text", { x: 12, y: (T + H - B) / 2, "font-size": 11, fill: "currentColor",
    transform: `rotate(-90 12 ${(T + H - B) / 2})`, "text-anchor": "middle" }, samples[0].unit || "power"));
  const colors = { az: "#1f77b4", el: "#d62728" };
  const result = report.result || {};
  LEGS.forEach((l, i) => {
    const pts = samples.filter((p) => p.leg === l.leg).sort((a, b) => a[l.key] - b[l.key]);
    const g = s("g", { class: l.cls, "data-leg": l.leg, fill: colors[l.leg], stroke: colors[l.leg] });
    for (const p of pts) g.append(s("circle", { cx: X(p[l.key]), cy: Y(p.value), r: 2.5 }));
    if (report.state === "done" && Number.isFinite(result[l.fit])) {
      g.append(s("line", { class: "scan-peak", "data-offset": result[l.fit], x1: X(result[l.fit]), y1: T,
        x2: X(result[l.fit]), y2: H - B, "stroke-width": 1.5 }));
    }
    g.append(s("text", { x: W - R - 4, y: T + 12 + 14 * i, "text-anchor": "end", "font-size": 11, stroke: "none" },
      `${l.label} (${pts.length})`));
    svg.append(g);
  });
  return svg;
}

// the last scan's plot, fetched again (a procedure frame of kind "scan" calls this)
export async function showScan() {
  const c = card();
  if (!c) return;
  const r = await get("/api/calibration/scan", { quiet: true });
  const scan = r.ok && r.data ? r.data.scan : null;
  if (!scan) { c.hidden = true; return; }
  c.hidden = false;
  setText($("scan-title"), `${scan.target || ""} · ${scan.state}`);
  clear($("scan-plot"));
  $("scan-plot").append(scanSvg(scan));
  const res = scan.result || {};
  setText($("scan-note"), scan.state === "done"
    ? `peak at ${fmt(res.dx_deg, 3)}° across, ${fmt(res.dy_deg, 3)}° up: the beam is ${fmt(res.az_offset_deg, 3)}° in az, ` +
      `${fmt(res.el_offset_deg, 3)}° in el from where urc reports it`
    : (scan.error || scan.step || ""));
}
