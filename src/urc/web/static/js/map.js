// The map (canvas, plate carrée): Natural Earth land shipped with urc, the satellite's
// ground track, where it is now and its footprint (the area that sees it above 0°), and
// the station (from /api/info, drawn whether or not anything is tracked).
import { smallCircle, splitAntimeridian, landRingCopies, EARTH_RADIUS_KM } from "./geo.js";

export class GroundMap {
  constructor(canvas) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.land = null;
    this.key = null;
    fetch("/static/world-110m.geojson")
      .then((r) => r.json())
      .then((g) => { this.land = g; this.key = null; this.draw(this.last); })
      .catch(() => {});
    this.last = null;
    this.station = null;
    this.draw(null);
  }

  setStation(station) {
    const same = JSON.stringify(station || null) === JSON.stringify(this.station);
    if (same) return;
    this.station = station || null;
    if (this.station) {
      const [x, y] = this.px(this.station.lat_deg, this.station.lon_deg);
      this.canvas.dataset.stationX = x.toFixed(1);
      this.canvas.dataset.stationY = y.toFixed(1);
    }
    this.draw(this.last);
  }

  px(lat, lon) {
    const { width, height } = this.canvas;
    return [((lon + 180) / 360) * width, ((90 - lat) / 180) * height];
  }

  update(tracking) {
    const t = tracking && tracking.ground_track ? tracking : null;
    // redraw at most when something visible changed
    const key = t ? `${t.sat_lat_deg?.toFixed(2)}:${t.sat_lon_deg?.toFixed(2)}:${t.ground_track.length}:${t.footprint_km}` : "none";
    if (key === this.key) return;
    this.key = key;
    this.last = t;
    this.draw(t);
  }

  draw(t) {
    const { ctx, canvas } = this;
    ctx.fillStyle = "#0b1a2a";
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    ctx.strokeStyle = "#1b3047";
    ctx.lineWidth = 1;
    for (let lon = -180; lon <= 180; lon += 30) this.line([[90, lon], [-90, lon]]);
    for (let lat = -60; lat <= 60; lat += 30) this.line([[lat, -180], [lat, 180]]);
    if (this.land) {
      ctx.fillStyle = "#2b3d2f";
      ctx.strokeStyle = "#4f6b53";
      for (const f of this.land.features) {
        const g = f.geometry;
        const polys = g.type === "MultiPolygon" ? g.coordinates : [g.coordinates];
        for (const poly of polys) {
          ctx.beginPath();
          for (const ring of poly) {
            for (const copy of landRingCopies(ring)) {
              copy.forEach(([lon, lat], i) => {
                const [x, y] = this.px(lat, lon);
                if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
              });
              ctx.closePath();
            }
          }
          ctx.fill("evenodd");
          ctx.stroke();
        }
      }
    }
    this.drawStation();
    if (!t) return;
    if (t.footprint_km) {
      // footprint_km: ground radius, sub-satellite point to where the satellite sets
      const rhoDeg = (t.footprint_km / EARTH_RADIUS_KM) * (180 / Math.PI);
      ctx.strokeStyle = "#ffd24a";
      ctx.fillStyle = "rgba(255, 210, 74, 0.12)";
      for (const part of splitAntimeridian(smallCircle(t.sat_lat_deg, t.sat_lon_deg, rhoDeg))) {
        this.line(part, true);
      }
    }
    ctx.strokeStyle = "#4ea3ff";
    ctx.lineWidth = 1.5;
    for (const part of splitAntimeridian(t.ground_track)) this.line(part);
    this.drawStation();
    if (t.sat_lat_deg !== undefined && t.sat_lat_deg !== null) {
      const [x, y] = this.px(t.sat_lat_deg, t.sat_lon_deg);
      ctx.fillStyle = "#ffd24a";
      ctx.beginPath();
      ctx.arc(x, y, 5, 0, 2 * Math.PI);
      ctx.fill();
    }
  }

  // the station: a green square with a dark edge, on top of everything
  drawStation() {
    if (!this.station) return;
    const { ctx } = this;
    const [x, y] = this.px(this.station.lat_deg, this.station.lon_deg);
    ctx.fillStyle = "#000";
    ctx.fillRect(x - 5, y - 5, 10, 10);
    ctx.fillStyle = "#4eff9a";
    ctx.fillRect(x - 4, y - 4, 8, 8);
  }

  line(points, fill = false) {
    const { ctx } = this;
    ctx.beginPath();
    points.forEach(([lat, lon], i) => {
      const [x, y] = this.px(lat, lon);
      if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
    });
    if (fill) ctx.fill();
    ctx.stroke();
  }
}
