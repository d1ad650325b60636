// Click (or tap) the sky plot or the dial to point the antenna there. A goto like the
// form's: the API refuses what the limits or keep-out zones forbid. On a touch or narrow
// screen a tap only proposes the move: nothing turns until "Go there" is pressed.
import { $, setText, fmt, toast } from "./dom.js";
import { post } from "./api.js";
import { wrap360 } from "./geo.js";

const SKY_R = 100;
let pending = null;

function confirmFirst() {
  return window.matchMedia("(pointer: coarse), (max-width: 700px)").matches;
}

// the click in the SVG's own coordinates (its viewBox is centred on 0,0)
function svgXY(svg, ev) {
  const p = new DOMPoint(ev.clientX, ev.clientY).matrixTransform(svg.getScreenCTM().inverse());
  return [p.x, p.y];
}

function azOf(x, y) {
  return wrap360(Math.atan2(x, -y) / (Math.PI / 180));
}

function elNow() {
  const v = Number($("ro-el").textContent);
  return Number.isFinite(v) ? v : 0;
}

async function go(target) {
  const azOnly = document.body.classList.contains("az-only");
  const r = await post("/api/goto", { az_deg: target.az, el_deg: azOnly ? 0 : target.el });
  if (r.ok) toast(`going to az ${fmt(target.az, 1)}°` + (azOnly ? "" : `, el ${fmt(target.el, 1)}°`));
}

function propose(target) {
  if (!confirmFirst()) { go(target); return; }
  pending = target;
  const azOnly = document.body.classList.contains("az-only");
  setText($("point-question"), `Point the antenna at az ${fmt(target.az, 1)}°` +
    (azOnly ? "?" : `, el ${fmt(target.el, 1)}°?`));
  $("point-confirm").hidden = false;
}

function end() {
  pending = null;
  $("point-confirm").hidden = true;
}

export function setupPointing() {
  $("sky").addEventListener("click", (ev) => {
    const [x, y] = svgXY($("sky"), ev);
    const r = Math.hypot(x, y);
    if (r > SKY_R) return;   // (outside the horizon: not a direction)
    propose({ az: Math.round(azOf(x, y) * 10) / 10, el: Math.round(90 * (1 - r / SKY_R) * 10) / 10 });
  });
  $("dial").addEventListener("click", (ev) => {
    const [x, y] = svgXY($("dial"), ev);
    if (Math.hypot(x, y) < 10) return;   // (the centre names no azimuth)
    propose({ az: Math.round(azOf(x, y) * 10) / 10, el: elNow() });
  });
  $("point-yes").addEventListener("click", () => { const t = pending; end(); if (t) go(t); });
  $("point-no").addEventListener("click", end);
}
