// The polar sky plot (SVG): horizon rings, keep-out zones, the planned pass, the
// setpoint and the antenna (whose position the tests read from data-az-deg/data-el-deg).
import { s, clear, setAttr, setData } from "./dom.js";
import { skyXY, wrap360 } from "./geo.js";

const R = 100;
const TRAIL_S = 60;

function polyPoints(pts) {
  return pts.map(([x, y]) => `${x.toFixed(2)},${y.toFixed(2)}`).join(" ");
}

export class SkyPlot {
  constructor(svg) {
    this.svg = svg;
    this.trail = [];
    this.planKey = "";
    this.zonesKey = "";
    clear(svg);
    svg.append(s("circle", { r: R, class: "sky-horizon" }));
    this.zoneLayer = s("g", { id: "sky-zones" });
    svg.append(this.zoneLayer);
    for (const el of [30, 60]) svg.append(s("circle", { r: R * (90 - el) / 90, class: "sky-grid" }));
    for (let az = 0; az < 360; az += 30) {
      const [x, y] = skyXY(az, 0, R);
      svg.append(s("line", { x1: 0, y1: 0, x2: x, y2: y, class: "sky-grid" }));
    }
    for (const [label, az] of [["N", 0], ["E", 90], ["S", 180], ["W", 270]]) {
      const [x, y] = skyXY(az, -7, R);
      svg.append(s("text", { x, y, text: label }));
    }
    for (const el of [30, 60]) svg.append(s("text", { x: 4, y: -R * (90 - el) / 90 + 5, text: `${el}°` }));
    this.planLine = s("polyline", { id: "sky-plan", class: "plan-line", points: "" });
    this.aos = s("circle", { id: "sky-aos", r: 2.5, class: "aos-dot", visibility: "hidden" });
    this.trailLine = s("polyline", { id: "sky-trail", class: "trail-line", points: "" });
    this.target = s("g", { id: "sky-target", visibility: "hidden" },
      s("circle", { r: 5, class: "target-mark" }),
      s("line", { x1: -8, y1: 0, x2: 8, y2: 0, class: "target-mark" }),
      s("line", { x1: 0, y1: -8, x2: 0, y2: 8, class: "target-mark" }));
    this.object = s("circle", { id: "sky-object", r: 3.5, class: "object-mark", visibility: "hidden" });
    this.antenna = s("circle", { id: "sky-antenna", r: 4.5, class: "antenna-dot" });
    svg.append(this.planLine, this.aos, this.trailLine, this.object, this.target, this.antenna);
  }

  // zones: [{name, az_min_deg, az_max_deg, el_min_deg, el_max_deg}] in compass degrees
  setZones(zones) {
    const key = JSON.stringify(zones || []);
    if (key === this.zonesKey) return;
    this.zonesKey = key;
    clear(this.zoneLayer);
    for (const z of zones || []) {
      let span = z.az_max_deg - z.az_min_deg;
      if (span <= 0) span += 360;
      span = Math.min(span, 360);
      const elLo = Math.max(0, Math.min(90, z.el_min_deg));
      const elHi = Math.max(0, Math.min(90, z.el_max_deg));
      if (elHi <= elLo) continue;
      const n = Math.max(2, Math.ceil(span / 2));
      const outer = [], inner = [];
      for (let i = 0; i <= n; i++) {
        const az = z.az_min_deg + (span * i) / n;
        outer.push(skyXY(az, elLo, R));
        inner.push(skyXY(az, elHi, R));
      }
      const pts = outer.concat(inner.reverse());
      const shape = s("polygon", { class: "zone-shape", points: polyPoints(pts), "data-zone": z.name || "" });
      shape.append(s("title", { text: `keep-out ${z.name || ""}: az ${z.az_min_deg}…${z.az_max_deg}°, el ${z.el_min_deg}…${z.el_max_deg}°` }));
      this.zoneLayer.append(shape);
    }
  }

  // track: [[iso, az, el], ...] of the planned pass (sky frame)
  setPlan(track) {
    const key = track && track.length ? `${track.length}:${track[0][0]}:${track[track.length - 1][0]}` : "";
    if (key === this.planKey) return;
    this.planKey = key;
    if (!key) {
      this.planLine.setAttribute("points", "");
      this.aos.setAttribute("visibility", "hidden");
      return;
    }
    const pts = track.filter((p) => p[2] >= -1).map((p) => skyXY(p[1], p[2], R));
    this.planLine.setAttribute("points", polyPoints(pts));
    if (pts.length) {
      this.aos.setAttribute("cx", pts[0][0].toFixed(2));
      this.aos.setAttribute("cy", pts[0][1].toFixed(2));
      this.aos.setAttribute("visibility", "visible");
    }
  }

  // the tracked object where it is now (only when above the horizon)
  setObject(tracking) {
    const ok = tracking && tracking.az_deg !== null && tracking.az_deg !== undefined && tracking.el_deg >= -0.5;
    setAttr(this.object, "visibility", ok ? "visible" : "hidden");
    if (!ok) return;
    const [x, y] = skyXY(wrap360(tracking.az_deg), tracking.el_deg, R);
    setAttr(this.object, "cx", x.toFixed(2));
    setAttr(this.object, "cy", y.toFixed(2));
  }

  update(status, setpoint, tWallS) {
    // a single-axis rotator (el null): its beam stands at the horizon, drawn on the ring
    const az = wrap360(status.az_deg), el = status.el_deg;
    const [x, y] = skyXY(az, el ?? 0, R);
    setAttr(this.antenna, "cx", x.toFixed(2));
    setAttr(this.antenna, "cy", y.toFixed(2));
    setData(this.antenna, "azDeg", az.toFixed(3));
    setData(this.antenna, "elDeg", el === null || el === undefined ? undefined : el.toFixed(3));
    if (setpoint) {
      const [tx, ty] = skyXY(wrap360(setpoint[0]), setpoint[1] ?? 0, R);
      setAttr(this.target, "transform", `translate(${tx.toFixed(2)} ${ty.toFixed(2)})`);
      setAttr(this.target, "visibility", "visible");
      setData(this.target, "azDeg", wrap360(setpoint[0]).toFixed(3));
      setData(this.target, "elDeg", setpoint[1] === null ? "" : setpoint[1].toFixed(3));
    } else {
      setAttr(this.target, "visibility", "hidden");
      setData(this.target, "azDeg", undefined);
    }
    const last = this.trail[this.trail.length - 1];
    if (!last || tWallS - last[2] >= 0.5) {
      // standing still (to the line's 0.01 precision: a sensor's jitter below it too):
      // the last point's time moves on instead of a copy of it being added (the line, and
      // so the page, stays unchanged)
      if (last && last[0].toFixed(2) === x.toFixed(2) && last[1].toFixed(2) === y.toFixed(2)) last[2] = tWallS;
      else this.trail.push([x, y, tWallS]);
      while (this.trail.length && tWallS - this.trail[0][2] > TRAIL_S) this.trail.shift();
      setAttr(this.trailLine, "points", polyPoints(this.trail));
    }
  }
}
