// Charts of pointing, setpoint and pointing error over time (canvas). The history comes
// from /api/history once, then grows with every live frame.
import { get } from "./api.js";
import { utcTime } from "./dom.js";

const WINDOW_S = 600;
const COLORS = { pos: "#ffd24a", set: "#4eff9a", err: "#ff7a6e", grid: "#26313c", text: "#8795a3" };

export class Charts {
  constructor(canvases, select, labelEl) {
    this.c = canvases;
    this.select = select;
    this.labelEl = labelEl;
    this.data = empty();
    this.dirty = true;
    this.which = select.value;
    select.addEventListener("change", () => this.load(select.value));
    setInterval(() => { if (this.dirty && !document.hidden) this.draw(); }, 500);
  }

  async load(which) {
    this.which = which;
    const q = which === "recent" ? `?which=recent&seconds=${WINDOW_S}` : `?which=${which}`;
    const r = await get(`/api/history${q}&max_points=3000`, { quiet: true });
    this.data = r.ok ? r.data : empty();
    this.labelEl.textContent = which === "recent" ? "" : (this.data.label ? `(${this.data.label})` : "(none yet)");
    this.dirty = true;
  }

  push(frame) {
    if (this.which === "last") return;
    const st = frame.status;
    const tracking = st.tracking;
    if (this.which === "current" && !tracking) return;
    const sp = [st.target_az_deg, st.target_el_deg];
    const d = this.data;
    d.t_wall_s.push(frame.t_wall_s);
    d.az_deg.push(st.az_deg);
    d.el_deg.push(st.el_deg);
    d.target_az_deg.push(sp[0]);
    d.target_el_deg.push(sp[1]);
    d.error_deg.push(frame.error_deg);
    if (this.which === "recent") {
      const t0 = frame.t_wall_s - WINDOW_S;
      let n = 0;
      while (n < d.t_wall_s.length && d.t_wall_s[n] < t0) n++;
      if (n > 0) for (const k of Object.keys(d)) if (Array.isArray(d[k])) d[k].splice(0, n);
    }
    this.dirty = true;
  }

  draw() {
    this.dirty = false;
    const d = this.data;
    plot(this.c.az, d.t_wall_s, [[d.target_az_deg, COLORS.set, true], [d.az_deg, COLORS.pos, true]], "az ° (setpoint green)", 5);
    plot(this.c.el, d.t_wall_s, [[d.target_el_deg, COLORS.set, false], [d.el_deg, COLORS.pos, false]], "el °", 5);
    plot(this.c.err, d.t_wall_s, [[d.error_deg, COLORS.err, false]], "pointing error °", 0.5, true);
  }
}

function empty() {
  return { t_wall_s: [], az_deg: [], el_deg: [], target_az_deg: [], target_el_deg: [], error_deg: [] };
}

// (24-hour UTC, as every time on the page)
function clock(tWallS) {
  return utcTime(tWallS * 1000);
}

// series: [[values, color, wraps360]]; a wrapping series breaks its line at 0/360.

// minSpan: the smallest value range shown, so sensor noise does not fill the chart
function plot(canvas, t, series, label, minSpan, fromZero = false) {
  const ctx = canvas.getContext("2d");
  const W = canvas.width, H = canvas.height, L = 46, B = 18, T = 6, Rm = 8;
  ctx.clearRect(0, 0, W, H);
  ctx.font = "11px system-ui, sans-serif";
  let lo = Infinity, hi = -Infinity;
  for (const [vals] of series) for (const v of vals) if (v !== null && v !== undefined) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  if (!Number.isFinite(lo)) { lo = 0; hi = 1; }
  if (fromZero) lo = 0;
  if (hi - lo < minSpan) {
    const mid = (hi + lo) / 2;
    lo = fromZero ? 0 : mid - minSpan / 2;
    hi = fromZero ? Math.max(hi, minSpan) : mid + minSpan / 2;
  }
  const pad = (hi - lo) * 0.08;
  hi += pad; if (!fromZero) lo -= pad;
  const t0 = t.length ? t[0] : 0, t1 = t.length ? t[t.length - 1] : 1;
  const span = Math.max(t1 - t0, 1);
  const X = (x) => L + ((x - t0) / span) * (W - L - Rm);
  const Y = (y) => T + (1 - (y - lo) / (hi - lo)) * (H - T - B);
  ctx.strokeStyle = COLORS.grid;
  ctx.fillStyle = COLORS.text;
  ctx.lineWidth = 1;
  for (let i = 0; i <= 4; i++) {
    const v = lo + ((hi - lo) * i) / 4, y = Y(v);
    ctx.beginPath(); ctx.moveTo(L, y); ctx.lineTo(W - Rm, y); ctx.stroke();
    ctx.fillText(Math.abs(hi - lo) < 2 ? v.toFixed(2) : v.toFixed(0), 4, y + 4);
  }
  if (t.length) {
    for (let i = 0; i <= 4; i++) {
      const x = t0 + (span * i) / 4;
      const label = clock(x);
      const w = ctx.measureText(label).width;
      ctx.fillText(label, Math.max(L, Math.min(X(x) - w / 2, W - Rm - w)), H - 4);
    }
  }
  ctx.fillText(label, L + 4, T + 10);
  for (const [vals, color, wraps] of series) {
    ctx.strokeStyle = color;
    ctx.lineWidth = 1.4;
    ctx.beginPath();
    let pen = false, prev = null;
    for (let i = 0; i < t.length; i++) {
      const v = vals[i];
      if (v === null || v === undefined || (wraps && prev !== null && Math.abs(v - prev) > 180)) { pen = false; }
      if (v === null || v === undefined) { prev = null; continue; }
      if (pen) ctx.lineTo(X(t[i]), Y(v)); else ctx.moveTo(X(t[i]), Y(v));
      pen = true;
      prev = v;
    }
    ctx.stroke();
  }
}
