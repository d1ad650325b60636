// Small geometry helpers shared by the plots (degrees at every boundary).
export const RAD = Math.PI / 180;

// Polar sky plot: azimuth clockwise from north (up), elevation inward (zenith at the centre).
export function skyXY(azDeg, elDeg, radius = 100) {
  const el = Math.max(-8, Math.min(90, elDeg));
  const r = radius * (90 - el) / 90;
  return [r * Math.sin(azDeg * RAD), -r * Math.cos(azDeg * RAD)];
}

export function wrap360(deg) {
  return ((deg % 360) + 360) % 360;
}

// Points of the small circle of angular radius rhoDeg around (lat, lon): the footprint.
export function smallCircle(latDeg, lonDeg, rhoDeg, n = 90) {
  const p = latDeg * RAD, l = lonDeg * RAD, rho = rhoDeg * RAD;
  const out = [];
  for (let i = 0; i <= n; i++) {
    const b = (i / n) * 2 * Math.PI;
    const lat2 = Math.asin(Math.sin(p) * Math.cos(rho) + Math.cos(p) * Math.sin(rho) * Math.cos(b));
    const lon2 = l + Math.atan2(Math.sin(b) * Math.sin(rho) * Math.cos(p), Math.cos(rho) - Math.sin(p) * Math.sin(lat2));
    out.push([lat2 / RAD, ((lon2 / RAD + 540) % 360) - 180]);
  }
  return out;
}

// Split a [[lat, lon], ...] line where it jumps across the antimeridian.
export function splitAntimeridian(points) {
  const parts = [];
  let cur = [];
  for (const pt of points) {
    if (cur.length && Math.abs(pt[1] - cur[cur.length - 1][1]) > 180) {
      parts.push(cur);
      cur = [];
    }
    cur.push(pt);
  }
  if (cur.length) parts.push(cur);
  return parts;
}

export const EARTH_RADIUS_KM = 6371.0;

// A land ring ([[lon, lat], ...]) ready for a plate carrée map: longitudes made continuous
// (Natural Earth's rings cross the antimeridian: drawn as they are, they streak across
// the whole map), a ring round a pole (Antarctica) closed along the map's edge, and the
// copies shifted by 360° that still show between -180 and 180.
export function landRingCopies(ring) {
  const out = [];
  let prev = null;
  for (const [lon, lat] of ring) {
    let x = lon;
    if (prev !== null) x += 360 * Math.round((prev - x) / 360);
    out.push([x, lat]);
    prev = x;
  }
  if (out.length < 2) return [];
  const turn = out[out.length - 1][0] - out[0][0];
  if (Math.abs(turn) > 180) {  // goes once round the globe: it encloses a pole
    const poleLat = out.reduce((a, p) => a + p[1], 0) < 0 ? -90 : 90;
    out.push([out[out.length - 1][0], poleLat], [out[0][0], poleLat]);
  }
  const xs = out.map((p) => p[0]);
  const lo = Math.min(...xs), hi = Math.max(...xs);
  const copies = [];
  for (const shift of [-360, 0, 360]) {
    if (hi + shift > -180 && lo + shift < 180) copies.push(out.map(([x, y]) => [x + shift, y]));
  }
  return copies;
}
