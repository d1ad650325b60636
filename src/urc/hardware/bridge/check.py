"""``urc hw check`` for a bridge: is the controller there, who is it, where does it
point, and how slow is the link. Read-only: it never sends a target or a stop."""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass, field

from .client import BridgeClient, ClientOptions
from .dialects import ReplyError, make_dialect
from .link import LinkError, SyncLink, Timeout, port_url


@dataclass
class BridgeCheck:
    ok: bool
    lines: list[str] = field(default_factory=list)
    az_deg: float | None = None
    el_deg: float | None = None
    identity: str | None = None
    round_trip_ms: list[float] = field(default_factory=list)


def check_bridge(section, polls: int = 5) -> BridgeCheck:
    """``section``: a ``[hardware.bridge]`` (urc.config.BridgeSection)."""
    dialect = make_dialect(section.protocol)
    client = BridgeClient(dialect, ClientOptions(timeout_s=section.timeout_s))
    url = port_url(section.serial, section.tcp)
    baud = section.baud or dialect.default_baud
    out = BridgeCheck(ok=False)
    out.lines.append(f"bridge: {section.protocol} on {url}" + ("" if section.tcp else f" at {baud} baud"))
    try:
        link = SyncLink(url, baud, client.timeout_s)
    except LinkError as exc:
        out.lines.append(f"  FAIL: {exc}")
        return out
    try:
        ident = dialect.identify()
        if ident is None:
            out.lines.append("  identity: the protocol has no identification command")
        else:
            try:
                out.identity = ident.parse(link.exchange(ident))
                out.lines.append(f"  identity: {out.identity}")
            except (Timeout, ReplyError, ValueError) as exc:
                out.lines.append(f"  identity: no answer ({type(exc).__name__}); the controller may not support it")
        errors = []
        for _ in range(polls):
            ex = dialect.poll()
            t0 = time.monotonic()
            try:
                data = link.exchange(ex)
                az, el = ex.parse(data)
            except Timeout as exc:
                errors.append(f"no answer within {client.timeout_s:g} s" + (f" (got {exc.partial!r})" if exc.partial else ""))
                continue
            except ReplyError as exc:
                errors.append(f"unreadable answer: {exc}")
                continue
            out.round_trip_ms.append(1000.0 * (time.monotonic() - t0))
            out.az_deg, out.el_deg = az, el
            if ex.settle_s:
                time.sleep(ex.settle_s)
        if out.az_deg is not None:
            el = "-" if not dialect.has_el else f"{out.el_deg:.2f}"
            out.lines.append(f"  position: az {out.az_deg:.2f} deg, el {el} deg (the controller's own frame)")
            rt = out.round_trip_ms
            out.lines.append(f"  link latency: round trip {statistics.median(rt):.1f} ms median, "
                             f"{max(rt):.1f} ms max over {len(rt)} polls"
                             + (f"; plus {dialect.poll().settle_s * 1000:.0f} ms post-write delay"
                                if dialect.poll().settle_s else ""))
        for e in errors:
            out.lines.append(f"  FAIL: {e}")
        out.ok = not errors and out.az_deg is not None
        out.lines.append("  OK" if out.ok else "  FAIL: the controller did not answer every position poll")
    except LinkError as exc:
        out.lines.append(f"  FAIL: link lost: {exc}")
    finally:
        link.close()
    return out
