"""What the front-panel display shows, as text rows (pure: a Status and the time in,
rows out; the LCD and OLED drivers only put them on glass).

The Tartu controller (seed 000) shows both axes on its 20x2 LCD as ``xxx.x`` degrees;
urc's rows are the ones its LCDC command prints (:func:`tartu_codec.lcd_rows`):
``AZ 123.4>130.0   RUN`` / ``EL 045.0         HLD`` — position, setpoint, state.

Where the document is silent, urc's choice: a 4-row display adds the fault (with its
LED blink code) or the local control held, and a one-line summary (parked, tracking,
position unknown). A 2-row display alternates its second row every 2 s between the
elevation and that message while there is one. A rotator without elevation shows no
elevation row at all (no fake 0): that row carries the summary instead. During the G4JNT zero-setting procedure
the display shows Z and how to change and store it.

The clock (BIG-RAS: the time in the screen's lower section, UTC or local by its time
zone setting): the OLED's fifth row always, a 4-row LCD's third row with ``clock`` on
while no fault or hold needs that row. While SW10 is held the BIG-RAS shows the preset
knobs' direction instead of the position (:func:`preset_rows`).
"""

from __future__ import annotations

import datetime
from zoneinfo import ZoneInfo

from ..protocols.tartu_codec import lcd_rows
from ..model.snapshot import Status
from .indicators import fault_code

ALTERNATE_S = 2.0


def message(st: Status) -> str:
    """The most important thing besides the two axes, or ''."""
    if st.faults:
        f = st.faults[0]
        return f"E{fault_code(f.kind)} {f.kind}" + (f" {f.axis}" if f.axis else "")
    if st.local_control:
        return "LOCAL " + ", ".join(st.local_control)
    if getattr(st, "procedures", None):     # the BIG-RAS homing: a search frame
        return "HOMING " + " ".join(st.procedures)
    if not st.position_known:
        return "POSITION UNKNOWN"
    return ""


def summary(st: Status) -> str:
    if st.parked:
        return "PARKED"
    if st.target_az_deg is not None and st.el is None:
        return f"TGT {st.target_az_deg:05.1f}"
    if st.target_az_deg is not None and st.target_el_deg is not None:
        return f"TGT {st.target_az_deg:05.1f} {st.target_el_deg:+05.1f}"
    return "MOVING" if st.moving else "READY"


def clock_text(utc_unix_s: float, timezone: str = "UTC") -> str:
    """``UTC 14:03:27``, or the local time with its zone's abbreviation (``CEST 16:03:27``:
    summer time by the zone's own rules)."""
    local = datetime.datetime.fromtimestamp(utc_unix_s, ZoneInfo(timezone))
    return f"{local.tzname()} {local:%H:%M:%S}"


def status_rows(st: Status, t_s: float, cols: int = 20, rows: int = 2,
                utc_unix_s: float | None = None, timezone: str = "UTC", clock: bool = False) -> list[str]:
    """The display's rows, each exactly ``cols`` characters. A fifth row (the OLED's)
    shows the time, as the Berkeley rotor's OLED does beside encoder and target; with
    ``clock`` a 4-row display shows it on its third row while that row has no message."""
    out = lcd_rows(st)
    msg = message(st)
    extra = [msg, summary(st)]
    if st.el is None:  # the (blank) elevation row shows the summary instead
        out[1] = extra.pop()
    if rows == 4 and clock and not msg and utc_unix_s is not None:
        extra[0] = clock_text(utc_unix_s, timezone)
    if rows >= 4:
        out += extra
    if rows >= 5 and utc_unix_s is not None:
        out.append(clock_text(utc_unix_s, timezone))
    elif msg and int(t_s // ALTERNATE_S) % 2 == 1:
        out[1] = msg
    return fit(out[:rows], cols, rows)


def preset_rows(az_deg: float | None, el_deg: float | None, has_el: bool, cols: int = 20,
                rows: int = 2, why: str = "") -> list[str]:
    """SW10 held: where SW7 / SW8 would turn the antenna (None: the knob cannot be read,
    ``why``)."""
    def deg(v: float | None) -> str:
        return "---" if v is None else f"{v:03.0f}"
    out = [f"PRESET AZ {deg(az_deg)}"]
    out.append(f"PRESET EL {deg(el_deg)}" if has_el else "SW7 turns there")
    if why:
        out.append(why)
    return fit(out, cols, rows)


def zero_rows(label: str, value_deg: float, cols: int = 20, rows: int = 2) -> list[str]:
    """The G4JNT zero-setting screen: Z (the bearing of the reference end stop), or
    the azimuth now where the sensor has no Z constant."""
    out = [f"ZERO SET {label:>3} {value_deg:6.1f}", "L/R change SLOW=save"]
    return fit(out, cols, rows)


def fit(lines: list[str], cols: int, rows: int) -> list[str]:
    lines = (lines + [""] * rows)[:rows]
    return [ln[:cols].ljust(cols) for ln in lines]
