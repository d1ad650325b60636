"""While a procedure runs (the BIG-RAS homing: the axis counts in a search frame of its
own, 434 deg here while the antenna stands at about 62) no protocol gives a number as
the position: each answers in its own error form, or as the original does when it has
none (silence). The LCD rows show dashes. Afterwards the numbers come back."""

from __future__ import annotations

import re

import pytest

from urc.frontpanel.screen import status_rows
from urc.protocols import make_session
from urc.wire import spid as spid_codec
from urc.protocols.tartu_codec import lcd_rows
from urc.testing.sessions import fed, ticked

SPID_STATUS = spid_codec.encode_query(spid_codec.K_STATUS)

#: protocol -> (position query, the answer while the azimuth's position is unknown)
QUERIES = {
    "rotctld": (b"p\n", [b"RPRT -9\n"]),
    "easycomm2": (b"AZ EL \n", []),
    "easycomm3": (b"AZ EL \n", []),
    "gs232a": (b"C2\r", [b"?>\r"]),
    "gs232b": (b"C2\r", [b"?>\r\n"]),
    "foxdelta": (b"C2\r", []),
    "rot2prog": (SPID_STATUS, []),
    "md01": (SPID_STATUS, []),
    "urc": (b"RDAZ\r\n", [b"ERR 6 position unknown: az (reference search) running\r\n"]),
    "sarcnet": (b"AZ EL\n", [b"Error: position unknown: az (reference search) running\r\n"]),
    "pstrotator": (b"<PST>AZ?</PST>", []),
}


@pytest.fixture
def homing(bench):
    b = bench("bigras")
    b.rot.set_position(62.0, 10.0)
    b.run(0.2)
    b.rot.search_frame("az", 434.0)          # what the BIG-RAS homing does first
    b.run(0.2)
    st = b.rot.status()
    assert st.position_unknown("az") and st.az.pos_deg == pytest.approx(434.0, abs=0.5)
    return b


@pytest.mark.parametrize("proto", QUERIES)
def test_a_position_query_during_homing_is_answered_unknown_in_the_protocols_own_form(homing, proto):
    query, unknown = QUERIES[proto]
    s = make_session(proto, homing.rot)
    assert fed(s, query) == unknown
    homing.rot.end_search("az")               # the search ends without a find: back to 62
    homing.run(0.2)
    answer = b"".join(fed(s, query))
    assert answer and answer != b"".join(unknown)
    if proto in ("rot2prog", "md01"):
        az, _el, *_ = spid_codec.decode_rot2_position(answer)
        assert az == pytest.approx(62.0, abs=1.0)
    else:
        assert re.search(rb"0*62(\.\d+)?", answer.replace(b"+", b"")), answer


def test_the_g4jnt_stream_says_why_instead_of_a_bearing(homing):
    s = make_session("g4jnt", homing.rot)
    lines = ticked(s, 1.0) + ticked(s, 3.0)
    assert lines[-1] == b"? position unknown: az (reference search) running\r\n"
    assert not any(line.startswith(b"b") for line in lines)
    homing.rot.end_search("az")
    homing.run(0.2)
    assert ticked(s, 5.0)[-1].startswith(b"b")


def test_lcd_and_panel_rows_show_dashes_for_the_axis_in_the_procedure(homing):
    st = homing.rot.status()
    az_row, el_row = lcd_rows(st)
    assert az_row.startswith("AZ ---.-") and "434" not in az_row and az_row.endswith("UNK")
    assert el_row.startswith("EL 010.0")
    rows = status_rows(st, 0.0, 20, 4)
    assert rows[0].startswith("AZ ---.-") and "434" not in "".join(rows)
    assert rows[2].rstrip() == "HOMING az"
