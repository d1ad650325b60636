"""PstRotator's UDP protocol (Hamlib model 3; protocols.md §5.2).

One ``receive(datagram)`` per UDP datagram; every returned reply is one datagram, which
the UDP adapter sends to the client's host on port 12001 (not to the source port).

===============================================  ==========================================
``<PST><AZIMUTH>123.4</AZIMUTH></PST>``          go to azimuth, elevation keeps its target
``<PST><ELEVATION>45.6</ELEVATION></PST>``       go to elevation, azimuth keeps its target
``<PST><AZIMUTH>..</AZIMUTH><ELEVATION>..``      both in one datagram: one goto
``<PST><PARK>1</PARK></PST>``                    park (``0`` is ignored)
``<PST><STOP>1</STOP></PST>``                    stop both axes
``<PST><TRACK>0|1</TRACK></PST>``                accepted and ignored (tracking is the client's)
``<PST>AZ?</PST>`` / ``<PST>EL?</PST>``          ``AZ:123.4\\r`` / ``EL:45.6\\r``
``<PST>TGA?</PST>`` / ``<PST>TGE?</PST>``        target: ``TGA:130.0\\r`` (the position when none)
===============================================  ==========================================

Angles are sky azimuth 0..360 and elevation (a set azimuth outside 0..360 names a
cable-wrap pose, as everywhere in urc). There is no error reply: garbage, bad numbers and
refused commands are logged and otherwise ignored (PstRotator and Hamlib expect nothing).
Items of one datagram run in order; a bad item does not stop the well-formed ones.
"""

from __future__ import annotations

from ..errors import CommandRejected, UrcError
from ..model.messages import Park, Stop
from ..model.effects import Effects
from .base import (MAX_PENDING_BYTES, RotatorPort, bad_input_log, internal_error,
                   protocol_logger)
from . import pstrotator_codec as codec
from .numbers import compass_tenths
from .poses import goto_named_axes, require_known
from .pstrotator_codec import PstItem
from .single_axis import wire_el_deg

log = protocol_logger("pstrotator")
bad_input = bad_input_log("pstrotator")


class PstRotatorSession:
    """One UDP peer speaking PstRotator's protocol. No options."""

    def __init__(self, rotator: RotatorPort):
        self.rotator = rotator
        self.closed = False

    def receive(self, data: bytes) -> Effects[list[bytes]]:
        if len(data) > MAX_PENDING_BYTES:
            bad_input.warning("datagram of %d bytes dropped (limit %d)", len(data), MAX_PENDING_BYTES)
            return []
        out: list[bytes] = []
        items = codec.parse_datagram(data)
        if not items:
            bad_input.warning("datagram ignored: expected <PST>...</PST>, got %r", data[:80])
        pending_az: float | None = None
        pending_el: float | None = None
        for item in items + [PstItem("end")]:
            # consecutive AZIMUTH/ELEVATION elements make one goto
            if item.kind == "set" and item.name in ("AZIMUTH", "ELEVATION"):
                try:
                    value = codec.parse_number(item.value)
                except ValueError as exc:
                    bad_input.warning("<%s> ignored: %s", item.name, exc)
                    continue
                if item.name == "AZIMUTH":
                    pending_az = value
                else:
                    pending_el = value
                continue
            if pending_az is not None or pending_el is not None:
                yield from self._goto(pending_az, pending_el)
                pending_az = pending_el = None
            try:
                out.extend((yield from self._execute(item)))
            except CommandRejected as exc:
                bad_input.warning("%s refused (%s): %s", item.name, exc.reason, exc)
            except UrcError as exc:     # a hardware failure: PstRotator has no error reply
                log.warning("%s failed: %s", item.name, exc)
            except Exception:           # a bug: logged and counted
                internal_error(log, "pstrotator", "item %r failed", item)
        return out

    def tick(self, now_s: float) -> list[bytes]:
        return []

    def _goto(self, az: float | None, el: float | None) -> Effects[None]:
        """One axis alone: the other keeps its target (or where it is, after a stop)."""
        try:
            yield from goto_named_axes(az, el)
        except CommandRejected as exc:
            given = " ".join(f"{n} {v:.2f}" for n, v in (("az", az), ("el", el)) if v is not None)
            bad_input.warning("goto %s refused (%s): %s", given, exc.reason, exc)

    def _execute(self, item: PstItem) -> Effects[list[bytes]]:
        if item.kind == "end":
            return []
        if item.kind == "garbage":
            bad_input.warning("garbage ignored: %r", item.raw[:80])
            return []
        if item.kind == "query":
            return self._query(item.name)
        name, value = item.name, item.value.strip()
        if name == "PARK":
            if value == "1":
                yield Park()
            elif value != "0":
                bad_input.warning("<PARK> ignored: expected 1, got %r", value[:40])
        elif name == "STOP":
            if value == "1":
                yield Stop()
            elif value != "0":
                bad_input.warning("<STOP> ignored: expected 1, got %r", value[:40])
        elif name == "TRACK":
            if value not in ("0", "1"):
                bad_input.warning("<TRACK> ignored: expected 0 or 1, got %r", value[:40])
        else:
            bad_input.warning("unknown element <%s> ignored (expected one of %s)", name,
                        ", ".join(codec.SET_ELEMENTS))
        return []

    def _query(self, name: str) -> list[bytes]:
        st = require_known(self.rotator.status())
        if name == "AZ":
            return [codec.format_reply("AZ", compass_tenths(st.az_deg))]
        if name == "EL":
            return [codec.format_reply("EL", wire_el_deg(st))]
        if name == "TGA":
            return [codec.format_reply("TGA", compass_tenths(st.az_deg if st.target_az_deg is None
                                                              else st.target_az_deg))]
        if name == "TGE":
            return [codec.format_reply("TGE", wire_el_deg(st) if st.target_el_deg is None
                                       else st.target_el_deg)]
        bad_input.warning("unknown query %s? ignored (expected one of %s)", name,
                    ", ".join(q + "?" for q in codec.QUERIES))
        return []
