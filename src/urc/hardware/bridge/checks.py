"""``[hardware.bridge]`` checks beside the bridge's builder (registered with the
backend, run whenever a configuration is validated): present for the bridge backend, a
known protocol, exactly one link."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ...caps import RotatorCaps
from ...config.issues import Issue, suggest
from ...config.values import parse_host_port
from .dialects import BRIDGE_PROTOCOLS

if TYPE_CHECKING:
    from ...config import Config


def bridge_issues(cfg: Config, caps: RotatorCaps) -> list[Issue]:
    """[hardware.bridge]: present for the bridge backend, a known protocol, one link."""
    br = cfg.hardware.bridge
    if br is None:
        if cfg.hardware.backend == "bridge":
            return [("hardware.bridge", '[hardware.bridge] with protocol and serial or tcp '
                     '(backend "bridge")', None, "")]
        return []
    issues: list[Issue] = []
    if br.protocol not in BRIDGE_PROTOCOLS:
        issues.append(("hardware.bridge.protocol", "one of " + ", ".join(BRIDGE_PROTOCOLS), br.protocol,
                       suggest(br.protocol, list(BRIDGE_PROTOCOLS))))
    given = [k for k in ("serial", "tcp") if getattr(br, k) is not None]
    if len(given) != 1:
        issues.append(("hardware.bridge", "exactly one of serial, tcp", given or "none", ""))
    elif br.tcp is not None:
        try:
            parse_host_port(br.tcp)
        except ValueError:
            issues.append(("hardware.bridge.tcp", '"host:port", e.g. "127.0.0.1:4533"', br.tcp, ""))
    if br.baud is not None and br.tcp is not None:
        issues.append(("hardware.bridge.baud", "no baud with tcp (only a serial line has one)", br.baud, ""))
    if br.protocol == "rot1prog" and cfg.hardware.backend == "bridge" and caps.has_el and \
            cfg.effective_limits(caps)["el"][1] > 1.0:
        issues.append(("limits.el.max_deg", "at most 1 (a Rot1Prog turns azimuth only)",
                       cfg.limits.el.max_deg, "set rotator.elevation = false (or [limits.el] max_deg = 1)"))
    return issues
