// The live feed: one WebSocket, reconnecting with backoff; counts messages per second.
import { $, setText } from "./dom.js";

export class Live {
  constructor(onFrame) {
    this.onFrame = onFrame;
    this.ws = null;
    this.delayMs = 250;
    this.count = 0;
    this.total = 0;
    this.rate = 0;
    this.firstFrameMs = null;
    // parts the server sends only when they change (plan and ground track, event log)
    this.parts = {};
    setInterval(() => this.tick(), 1000);
  }

  connect() {
    const proto = location.protocol === "https:" ? "wss:" : "ws:";
    const ws = new WebSocket(`${proto}//${location.host}/api/ws`);
    this.ws = ws;
    ws.onopen = () => { this.delayMs = 250; };
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
    if (st.tracking) Object.assign(st.tracking, this.parts.plan || {});
  }

  tick() {
    this.rate = this.count;
    this.count = 0;
    const el = $("conn");
    el.dataset.rate = String(this.rate);
    if (el.classList.contains("live")) setText(el, `live ${this.rate}/s`);
  }

  setState(live) {
    const el = $("conn");
    const was = el.classList.contains("live");
    el.classList.toggle("live", live);
    el.classList.toggle("offline", !live);
    if (!live) setText(el, "offline");
    else if (!was) setText(el, "live");
  }
}
