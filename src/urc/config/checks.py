"""The checks that need more than one field, or the rotator profile: a known profile,
limits inside the profile's range, park inside the limits and outside every keep-out
zone, served addresses, control overrides the profile allows.

What a key means to a package above urc.config is checked by that package, registered
with :mod:`.owners`: the backend's name and each backend's own section beside its
builder (:mod:`urc.hardware.factory`: :mod:`urc.hardware.gpio.checks`,
:mod:`urc.hardware.bridge.checks`), the front panel's in :mod:`urc.frontpanel.checks`,
MQTT's in :mod:`urc.mqtt.config`, a served protocol's name in :mod:`urc.protocols.registry`."""

from __future__ import annotations

from ..caps import RotatorCaps
from ..profiles import PROFILES
from .issues import Issue, fmt, suggest
from .owners import owner_issues, register_cross_check
from .schema import Config
from .values import parse_host_port

#: elevation range any keep-out zone must lie in (degrees; > 90 is "over the top").
_KEEPOUT_EL_RANGE = (-90.0, 180.0)


def cross_check(cfg: Config) -> list[Issue]:
    issues: list[Issue] = []
    caps = PROFILES.get(cfg.rotator.profile)
    if caps is None:
        valid = ", ".join(sorted(PROFILES))
        hint = suggest(cfg.rotator.profile, sorted(PROFILES))
        return [("rotator.profile", f"one of {valid}", cfg.rotator.profile, hint)]

    issues += _menu_issues(cfg, caps)
    caps = cfg.rotator.variant(caps)
    issues += _single_axis_issues(cfg, caps)
    if cfg.rotator.flip is True and not caps.can_flip and caps.has_el:
        issues.append(("rotator.flip", f"false (profile {caps.name!r} elevation stops at "
                       f"{fmt(caps.el.max_deg)} deg, flip needs 180), or \"auto\"", True, ""))

    # the backend and its section, the panel, MQTT, the protocols: checked by their owners
    issues += owner_issues(cfg, caps)

    for name in ("az", "el"):
        axis = caps.axis(name)
        start = getattr(cfg.hardware.sim, f"start_{name}_deg")
        if start is not None and not axis.min_deg <= start <= axis.max_deg:
            issues.append((f"hardware.sim.start_{name}_deg",
                           f"a number (degrees) in {fmt(axis.min_deg)}..{fmt(axis.max_deg)} "
                           f"(profile {caps.name!r} {name} range)", start, ""))

    # user limits inside the profile's range, min < max
    limits_ok = True
    for name in ("az", "el"):
        axis = caps.axis(name)
        lim = getattr(cfg.limits, name)
        rng = f"profile {caps.name!r} {name} range {fmt(axis.min_deg)}..{fmt(axis.max_deg)}"
        for end in ("min_deg", "max_deg"):
            v = getattr(lim, end)
            if v is not None and not axis.min_deg <= v <= axis.max_deg:
                limits_ok = False
                issues.append((f"limits.{name}.{end}",
                               f"a number (degrees) in {fmt(axis.min_deg)}..{fmt(axis.max_deg)}"
                               f" (the {rng})", v, ""))
        lo = axis.min_deg if lim.min_deg is None else lim.min_deg
        hi = axis.max_deg if lim.max_deg is None else lim.max_deg
        if lo >= hi:
            limits_ok = False
            key = f"limits.{name}.max_deg" if lim.max_deg is not None else f"limits.{name}.min_deg"
            found = hi if lim.max_deg is not None else lo
            issues.append((key, f"limits.{name}.min_deg < limits.{name}.max_deg "
                           f"(min is {fmt(lo)}, max is {fmt(hi)})", found, ""))

    # park inside the limits
    if limits_ok:
        eff = cfg.effective_limits(caps)
        park = cfg.park_position(caps)
        for i, name in enumerate(("az", "el")[:len(caps.axes)]):
            lo, hi = eff[name]
            v = park[i]
            user = getattr(cfg.park, f"{name}_deg")
            if not lo <= v <= hi:
                hint = "" if user is not None else (
                    f"the profile's park {name} is outside limits.{name}; set park.{name}_deg")
                issues.append((f"park.{name}_deg",
                               f"a number (degrees) inside the {name} limits "
                               f"{fmt(lo)}..{fmt(hi)}", v, hint))

    # keep-out zones
    az_lo, az_hi = min(caps.az.min_deg, 0.0), max(caps.az.max_deg, 360.0)
    el_lo, el_hi = _KEEPOUT_EL_RANGE
    for i, z in enumerate(cfg.keepout):
        pre = f"keepout[{i}]"
        zone_ok = True
        for end in ("az_min_deg", "az_max_deg"):
            v = getattr(z, end)
            if not az_lo <= v <= az_hi:
                zone_ok = False
                issues.append((f"{pre}.{end}", f"a number (degrees) in {fmt(az_lo)}.."
                               f"{fmt(az_hi)} (compass, or profile {caps.name!r} wrap range)",
                               v, ""))
        for end in ("el_min_deg", "el_max_deg"):
            v = getattr(z, end)
            if not el_lo <= v <= el_hi:
                zone_ok = False
                issues.append((f"{pre}.{end}", f"a number (degrees) in {fmt(el_lo)}.."
                               f"{fmt(el_hi)}", v, ""))
        if z.az_min_deg == z.az_max_deg:
            zone_ok = False
            issues.append((f"{pre}.az_max_deg", f"a number different from az_min_deg "
                           f"({fmt(z.az_min_deg)}); a sector across north is written "
                           f"az_min_deg = 350, az_max_deg = 10", z.az_max_deg, ""))
        elif z.az_max_deg - z.az_min_deg > 360.0:
            zone_ok = False
            issues.append((f"{pre}.az_max_deg", f"at most 360 degrees past az_min_deg "
                           f"({fmt(z.az_min_deg)})", z.az_max_deg, ""))
        if z.el_min_deg >= z.el_max_deg:
            zone_ok = False
            issues.append((f"{pre}.el_max_deg", f"a number greater than el_min_deg "
                           f"({fmt(z.el_min_deg)})", z.el_max_deg, ""))
        if zone_ok and limits_ok:
            paz, pel = cfg.park_position(caps)
            if z.keep_out(i).contains(paz, pel):
                user = cfg.park.az_deg is not None or cfg.park.el_deg is not None
                key = "park.az_deg" if user else pre
                issues.append((key, f"a park position outside keep-out zone {z.label(i)!r}",
                               (paz, pel), "" if user else
                               "the profile's park position is inside this zone; set [park]"))

    issues += _serve_issues(cfg)
    issues += _control_issues(cfg, caps)
    if cfg.api.read_token and cfg.api.read_token == cfg.api.token:
        issues.append(("api.read_token", "a token other than api.token (the read-only token must not "
                       "also control)", "the control token", ""))
    return issues


def _serve_issues(cfg: Config) -> list[Issue]:
    """[[serve]]: exactly one well-formed transport each, each once (a known protocol:
    urc.protocols.registry's check)."""
    issues: list[Issue] = []
    seen: dict[tuple[str, str], int] = {}
    for i, entry in enumerate(cfg.serve or ()):
        pre = f"serve[{i}]"
        given = [k for k in ("tcp", "pty", "serial", "udp") if getattr(entry, k) is not None]
        if len(given) != 1:
            issues.append((pre, "exactly one of tcp, pty, serial, udp", given or "none", ""))
            continue
        kind, where = entry.transport
        if kind in ("tcp", "udp"):
            try:
                parse_host_port(where)
            except ValueError:
                issues.append((f"{pre}.{kind}", '"host:port", e.g. "127.0.0.1:4533"', where, ""))
        if (kind, where) in seen:
            issues.append((f"{pre}.{kind}", f"an address not already used by serve[{seen[kind, where]}]",
                           where, ""))
        seen[(kind, where)] = i

    return issues


def _control_issues(cfg: Config, caps: RotatorCaps) -> list[Issue]:
    """[control]: overrides within what the profile can do, consistent with each other."""
    issues: list[Issue] = []
    eff_ctl = cfg.effective_control(caps)
    for name in ("az", "el"):
        axis = caps.axis(name)
        c = getattr(cfg.control, name)
        for fld, cap, unit in (("max_rate_deg_per_s", axis.max_rate_deg_per_s, "deg/s"),
                               ("accel_deg_per_s2", axis.accel_deg_per_s2, "deg/s^2")):
            v = getattr(c, fld)
            if v is not None and v > cap:
                issues.append((f"control.{name}.{fld}",
                               f"a number <= {fmt(cap)} {unit} (profile {caps.name!r} "
                               f"{name} maximum)", v, ""))
        e = eff_ctl[name]
        if c.min_rate_deg_per_s is not None and c.min_rate_deg_per_s > e["max_rate_deg_per_s"]:
            issues.append((f"control.{name}.min_rate_deg_per_s", f"a number <= the {name} top speed "
                           f"{fmt(e['max_rate_deg_per_s'])} deg/s", c.min_rate_deg_per_s, ""))
        if e["restart_deg"] < e["tolerance_deg"]:
            key = f"control.{name}.restart_deg" if c.restart_deg is not None \
                else f"control.{name}.tolerance_deg"
            found = c.restart_deg if c.restart_deg is not None else c.tolerance_deg
            issues.append((key, f"restart_deg >= tolerance_deg (restart "
                           f"{fmt(e['restart_deg'])}, tolerance {fmt(e['tolerance_deg'])})",
                           found, ""))
    return issues


def _menu_issues(cfg: Config, caps: RotatorCaps) -> list[Issue]:
    """The BIG-RAS menu settings in [rotator]: values the controller offers, on a profile
    that has what they set."""
    r, issues = cfg.rotator, []
    if r.max_el_deg is not None and r.max_el_deg not in (90.0, 180.0):
        issues.append(("rotator.max_el_deg", "90 or 180 (degrees)", r.max_el_deg, ""))
    if r.max_el_deg is not None and not r.elevation:
        issues.append(("rotator.max_el_deg", "no max_el_deg (rotator.elevation = false: azimuth only)",
                       r.max_el_deg, ""))
    if r.pulses_per_deg is not None and not any(caps.axis(n).sensor.kind == "pulse" for n in ("az", "el")):
        issues.append(("rotator.pulses_per_deg", f"no pulses_per_deg (profile {caps.name!r} has no pulse "
                       f"sensor: its sensor is {caps.az.sensor.kind})", r.pulses_per_deg, ""))
    return issues


def _single_axis_issues(cfg: Config, caps: RotatorCaps) -> list[Issue]:
    """``rotator.elevation = false``: no setting may give the absent axis a value."""
    if caps.has_el:
        return []
    expected = "no elevation setting (rotator.elevation = false: azimuth only)"
    issues: list[Issue] = []
    given = [("limits.el.min_deg", cfg.limits.el.min_deg), ("limits.el.max_deg", cfg.limits.el.max_deg),
             ("park.el_deg", cfg.park.el_deg), ("hardware.sim.start_el_deg", cfg.hardware.sim.start_el_deg),
             ("hardware.gpio.el", None if cfg.hardware.gpio is None or cfg.hardware.gpio.el is None else "[...]")]
    if cfg.offsets.el_deg:
        given.append(("offsets.el_deg", cfg.offsets.el_deg))
    for key, v in given:
        if v is not None:
            issues.append((key, expected, v, "remove it, or set rotator.elevation = true"))
    if cfg.rotator.flip is True:
        issues.append(("rotator.flip", 'false or "auto" (a single-axis rotator cannot fly over the top)',
                       True, ""))
    return issues



# the schema's validator runs these through .owners (urc/config/__init__.py imports this
# module, so they are registered before the package can build a Config)
register_cross_check(cross_check)
