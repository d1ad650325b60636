// The azimuth dial: the mechanical azimuth range drawn as a spiral, one turn per 360°,
// so positions in the cable-wrap overlap (beyond 360° or below 0°) sit on their own
// lap, with the soft limits at its ends and the needle on the lap the antenna is on.
import { s, clear, setText, fmt, setAttr, setData } from "./dom.js";
import { RAD } from "./geo.js";

const R_IN = 40, R_OUT = 92;

export class AzDial {
  constructor(svg, textEl) {
    this.svg = svg;
    this.textEl = textEl;
    this.key = "";
  }

  // lo/hi: mechanical limits; off: mount offset (pointing = mechanical + offset)
  setRange(lo, hi, off) {
    const key = `${lo}:${hi}:${off}`;
    if (key === this.key) return;
    this.key = key;
    this.lo = lo; this.hi = hi; this.off = off;
    const svg = this.svg;
    clear(svg);
    svg.append(s("circle", { r: R_OUT + 8, class: "dial-ring" }));
    for (let a = 0; a < 360; a += 10) {
      const long = a % 30 === 0;
      const r1 = R_OUT + 8, r2 = r1 - (long ? 5 : 2.5);
      svg.append(s("line", { x1: r1 * Math.sin(a * RAD), y1: -r1 * Math.cos(a * RAD),
        x2: r2 * Math.sin(a * RAD), y2: -r2 * Math.cos(a * RAD), class: "dial-ring" }));
    }
    for (const [label, a] of [["N", 0], ["E", 90], ["S", 180], ["W", 270]]) {
      svg.append(s("text", { x: (R_OUT + 15) * Math.sin(a * RAD), y: -(R_OUT + 15) * Math.cos(a * RAD), text: label }));
    }
    // the range, in pointing degrees; the overlap (reachable on two laps) highlighted
    const pLo = lo + off, pHi = hi + off;
    svg.append(s("polyline", { id: "dial-range", class: "wrap-range", points: this.arc(pLo, pHi) }));
    if (pHi - pLo > 360) {
      svg.append(s("polyline", { class: "wrap-overlap", points: this.arc(pLo, pHi - 360) }));
      svg.append(s("polyline", { class: "wrap-overlap", points: this.arc(pLo + 360, pHi) }));
    }
    for (const p of [pLo, pHi]) {
      const [x, y] = this.xy(p);
      const [ux, uy] = [Math.sin(p * RAD), -Math.cos(p * RAD)];
      svg.append(s("line", { x1: x - 6 * ux, y1: y - 6 * uy, x2: x + 6 * ux, y2: y + 6 * uy, class: "limit-tick" }));
    }
    this.targetNeedle = s("line", { id: "dial-target", class: "needle-target", x1: 0, y1: 0, x2: 0, y2: 0, visibility: "hidden" });
    this.needle = s("line", { id: "dial-needle", class: "needle", x1: 0, y1: 0, x2: 0, y2: 0 });
    this.dot = s("circle", { id: "dial-antenna", r: 4, class: "antenna-dot" });
    svg.append(this.targetNeedle, this.needle, s("circle", { r: 3, class: "dial-center" }), this.dot);
    // the reading in the top-left corner, outside the rings: the needle (which turns
    // round the centre) never crosses it
    svg.append(s("text", { x: -108, y: -102, class: "corner", text: "mech az" }));
    this.label = s("text", { id: "dial-value", x: -108, y: -91, class: "corner value", text: "" });
    svg.append(this.label);
  }

  radius(pointingDeg) {
    const span = Math.max(this.hi - this.lo, 1);
    const f = (pointingDeg - (this.lo + this.off)) / span;
    return R_IN + (R_OUT - R_IN) * Math.max(-0.05, Math.min(1.05, f));
  }

  xy(pointingDeg) {
    const r = this.radius(pointingDeg);
    return [r * Math.sin(pointingDeg * RAD), -r * Math.cos(pointingDeg * RAD)];
  }

  arc(from, to) {
    const pts = [];
    const n = Math.max(2, Math.ceil(Math.abs(to - from) / 3));
    for (let i = 0; i <= n; i++) {
      const [x, y] = this.xy(from + ((to - from) * i) / n);
      pts.push(`${x.toFixed(2)},${y.toFixed(2)}`);
    }
    return pts.join(" ");
  }

  update(status) {
    const mech = status.az.pos_deg;
    const p = mech + this.off;
    const [x, y] = this.xy(p);
    for (const [k, v] of [["x2", x], ["y2", y]]) setAttr(this.needle, k, v.toFixed(2));
    setAttr(this.dot, "cx", x.toFixed(2));
    setAttr(this.dot, "cy", y.toFixed(2));
    setData(this.dot, "mechAzDeg", mech.toFixed(3));
    setText(this.label, `${fmt(p, 1)}°`);
    const t = status.az.target_deg;
    if (t !== null && t !== undefined) {
      const [tx, ty] = this.xy(t + this.off);
      setAttr(this.targetNeedle, "x2", tx.toFixed(2));
      setAttr(this.targetNeedle, "y2", ty.toFixed(2));
      setAttr(this.targetNeedle, "visibility", "visible");
    } else {
      setAttr(this.targetNeedle, "visibility", "hidden");
    }
    const cw = this.hi - mech, ccw = mech - this.lo;
    const turn = status.wrap_turns;
    const lap = turn === 0 ? "first lap" : `lap ${turn > 0 ? "+" : ""}${turn}${turn > 0 ? " (overlap)" : ""}`;
    setText(this.textEl, `mechanical az ${fmt(p, 1)}° on the ${lap}; limits ${fmt(this.lo + this.off, 0)}…${fmt(this.hi + this.off, 0)}°; ` +
      `${fmt(cw, 0)}° of cable left clockwise, ${fmt(ccw, 0)}° counter-clockwise`);
  }
}
