// The live feed: one WebSocket, reconnecting with backoff; counts messages per second.
// Offline (closed, or no frame for STALE_MS) the page says so and dims the last values:
// nothing old is ever shown as live.
import { $, setText, utcTime } from "./dom.js";
import { wsProtocols } from "./api.js";

const STALE_MS = 2500;


export class Live {
  constructor(onFrame, onOpen = () => {}) {
    this.onFrame = onFrame;
    this.onOpen = onOpen;
    this.ws = null;
    this.delayMs = 250;
    this.count = 0;
    this.total = 0;
    this.rate = 0;
    this.firstFrameMs = null;
    this.lastFrameWallMs = null;
    this.lastFrameMs = 0;
    // parts the server sends only when they change (plan and ground track, event log)
    this.parts = {};
    setInterval(() => this.tick(), 1000);
  }

  connect() {
    const proto = location.protocol === "https:" ? "wss:" : "ws:";
    const ws = new WebSocket(`${proto}//${location.host}/api/ws`, wsProtocols());
    this.ws = ws;
    ws.onopen = () => { this.delayMs = 250; this.parts = {}; this.onOpen(); };
    ws.onmessage = (ev) => {
      this.count += 1;
      this.total += 1;
      $("conn").dataset.frames = String(this.total);
      let frame;
      try { frame = JSON.parse(ev.data); } catch { return; }
      if (frame.type !== "status") { this.parts[frame.type] = frame.data; return; }
      this.merge(frame.status);
      if (this.firstFrameMs === null) {
        this.firstFrameMs = performance.now();
        document.body.dataset.firstFrameMs = String(Math.round(this.firstFrameMs));
      }
      this.lastFrameMs = performance.now();
      this.lastFrameWallMs = Date.now();
      this.setState(true);
      this.onFrame(frame);
    };
    ws.onclose = () => {
      this.setState(false);
      setTimeout(() => this.connect(), this.delayMs);
      this.delayMs = Math.min(this.delayMs * 2, 5000);
    };
    ws.onerror = () => ws.close();
  }

  // put the seldom-sent parts back where the page reads them (status.events, tracking.plan...)
  merge(st) {
    Object.assign(st, this.parts.events || {});
    if (st.tracking) Object.assign(st.tracking, this.parts.plan || {}, this.parts.ground || {});
  }

  tick() {
    this.rate = this.count;
    this.count = 0;
    const el = $("conn");
    el.dataset.rate = String(this.rate);
    if (el.classList.contains("live") && performance.now() - this.lastFrameMs > STALE_MS) this.setState(false);
    if (el.classList.contains("live")) setText(el, `live ${this.rate}/s`);
  }

  setState(live) {
    const el = $("conn");
    const was = el.classList.contains("live");
    el.classList.toggle("live", live);
    el.classList.toggle("offline", !live);
    document.body.classList.toggle("offline", !live);
    $("stale-banner").hidden = live;
    if (!live) {
      setText(el, "offline");
      setText($("stale-text"), this.lastFrameWallMs === null ? "waiting for the live feed: nothing shown is live."
        : `no live data since ${utcTime(this.lastFrameWallMs)} UTC: the values shown are from then, not live.`);
    } else if (!was) setText(el, "live");
  }
}
