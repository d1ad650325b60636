"""Element sets: TLE/3LE, OMM JSON/CSV, corrupt input, the catalog and its lookups."""

from __future__ import annotations

import json
from datetime import datetime, timezone

import numpy as np
import pytest
from sgp4.api import Satrec
from hypothesis import given, settings
from hypothesis import strategies as st
from sgp4.io import compute_checksum, fix_checksum

from urc.errors import UrcError
from urc.tracking.elements import Catalog, import_file, load_elements, parse_elements, tle_checksum, \
    parse_omm_csv, parse_omm_json, parse_tle
from urc.tracking.errors import AmbiguousSatellite, CatalogError, ChecksumError, \
    ElementsError, SatelliteNotFound

from .conftest import FIXTURES, T0

#: OMM carries the same elements as the TLE fixture, rounded differently: positions agree
#: to well under a metre half a day after epoch.
OMM_VS_TLE_TOL_KM = 1e-3

ISS_L1 = "1 25544U 98067A   24001.25000000  .00016717  00000-0  10270-3 0  9999"
ISS_L2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.50103472432400"


def tle_lines():
    return (FIXTURES / "leo.tle").read_text().splitlines()


def _position_km(es, when=T0):
    jd = 2440587.5 + when.timestamp() / 86400.0
    e, r, v = es.satrec.sgp4(jd, 0.0)
    assert e == 0
    return np.array(r)


# --------------------------------------------------------------------------- reading


def test_three_line_fixture(leo_sets):
    assert [es.name for es in leo_sets][:3] == ["ISS (ZARYA)", "NOAA 19", "NOAA 18"]
    iss = leo_sets[0]
    assert iss.norad_id == 25544
    assert iss.epoch == datetime(2024, 1, 1, 6, 0, tzinfo=timezone.utc)
    assert iss.tle == (ISS_L1, ISS_L2)
    assert iss.sgp4_error is None
    assert iss.mean_motion_rev_per_day == pytest.approx(15.50103472, abs=1e-8)
    assert iss.period_s == pytest.approx(86400 / 15.50103472, rel=1e-9)
    # the same satrec sgp4 itself builds from the lines
    ref = Satrec.twoline2rv(ISS_L1, ISS_L2)
    ref_km = np.array(ref.sgp4(2440587.5 + T0.timestamp() / 86400, 0.0)[1])
    assert np.array_equal(_position_km(iss), ref_km)


def test_two_line_and_spacetrack_zero_prefix():
    two = parse_tle(f"{ISS_L1}\n{ISS_L2}\n")
    assert two[0].name == "" and two[0].label == "NORAD 25544"
    three = parse_tle(f"0 ISS (ZARYA)\r\n{ISS_L1}\r\n{ISS_L2}\r\n\r\n# comment\n")
    assert three[0].name == "ISS (ZARYA)"


def test_omm_json_and_csv_match_the_tle(leo_sets):
    by_id = {es.norad_id: es for es in leo_sets}
    for sets in (load_elements(FIXTURES / "omm.json"), load_elements(FIXTURES / "omm.csv")):
        assert [es.norad_id for es in sets] == [25544, 33591, 28654, 38771]
        for es in sets:
            tle = by_id[es.norad_id]
            assert es.name == tle.name
            assert es.epoch == tle.epoch
            assert es.omm is not None and es.tle is None
            assert np.linalg.norm(_position_km(es) - _position_km(tle)) < OMM_VS_TLE_TOL_KM


def test_omm_json_single_object_and_epoch_without_fraction():
    rec = json.loads((FIXTURES / "omm.json").read_text())[0]
    rec["EPOCH"] = "2024-01-01T06:00:00Z"
    (es,) = parse_omm_json(json.dumps(rec))
    assert es.epoch == datetime(2024, 1, 1, 6, 0, tzinfo=timezone.utc)


def test_format_sniffing():
    assert parse_elements((FIXTURES / "omm.json").read_text())[0].omm is not None
    assert parse_elements((FIXTURES / "omm.csv").read_text())[0].omm is not None
    assert parse_elements((FIXTURES / "leo.tle").read_text())[0].tle is not None


# --------------------------------------------------------------------------- corrupt TLE


def corrupt(lineno: int, new: str) -> str:
    lines = tle_lines()
    lines[lineno - 1] = new
    return "\n".join(lines) + "\n"


def raises(text: str, cls=ElementsError, source="sats.tle", **kw) -> ElementsError:
    with pytest.raises(cls) as info:
        parse_tle(text, source, **kw)
    assert isinstance(info.value, UrcError)
    return info.value


def test_bad_checksum_names_file_line_and_column():
    bad = ISS_L2[:-1] + str((int(ISS_L2[-1]) + 1) % 10)
    err = raises(corrupt(3, bad), ChecksumError)
    assert (err.path, err.line, err.column) == ("sats.tle", 3, 69)
    assert str(err).startswith("sats.tle:3: TLE line 2, column 69 (checksum): expected 0")
    assert parse_tle(corrupt(3, bad), checksum=False)[0].norad_id == 25544


def test_truncated_line():
    err = raises(corrupt(2, ISS_L1[:61]))
    assert err.line == 2 and "truncated line: 61 characters, expected 69" in str(err)


def test_letter_in_a_number_field():
    line = fix_checksum(ISS_L2[:8] + " 5x.6416" + ISS_L2[16:68])
    err = raises(corrupt(3, line))
    assert (err.line, err.column) == (3, 9)
    assert "columns 9-16 (inclination (degrees)): expected something like ' 51.6416', " \
           "found ' 5x.6416'" in str(err)


def test_shifted_columns():
    line = fix_checksum(ISS_L1[:17] + ISS_L1[18:33] + "  " + ISS_L1[33:67])
    err = raises(corrupt(2, line))
    assert err.line == 2 and "column" in str(err) and "expected" in str(err)


def test_line_two_of_another_satellite():
    other = fix_checksum("2 25545" + ISS_L2[7:68])
    err = raises(corrupt(3, other))
    assert "columns 3-7 (satellite number): expected '25544' as on line 1, found '25545'" \
        in str(err)


def test_out_of_range_value():
    line = fix_checksum(ISS_L2[:8] + "191.6416" + ISS_L2[16:68])
    assert "expected 0..180 degrees, found 191.642" in str(raises(corrupt(3, line)))


def test_structure_errors():
    lines = tle_lines()
    err = raises("\n".join(lines[:2]) + "\n")
    assert "truncated file: TLE line 1 of 'ISS (ZARYA)' is not followed by its line 2" in str(err)
    err = raises("\n".join(lines[:1] + lines[2:3]) + "\n")
    assert err.line == 2 and "line 2 without a line 1" in str(err)
    err = raises("ISS\nNOAA 19\n" + "\n".join(lines[1:3]))
    assert err.line == 2 and "expected TLE line 1 (starting '1 ') after the name line 1 'ISS'" \
        in str(err)
    err = raises("\n".join(lines[:4]) + "\n")
    assert "name line 'NOAA 19' is not followed by its two element lines" in str(err)
    err = raises(f"ISS\n{ISS_L1[:30]}\n{ISS_L2}\n")
    assert str(err) == "sats.tle:2: TLE line 1: truncated line: 30 characters, expected 69"
    err = raises(f"{ISS_L1[:20]}\n{ISS_L2}\n")  # too short to tell from a name
    assert "looks like a truncated line 1 (20 characters, expected 69)" in str(err)


def test_file_errors(tmp_path):
    with pytest.raises(ElementsError, match="no such file"):
        load_elements(tmp_path / "nope.tle")
    (tmp_path / "bin.tle").write_bytes(b"ISS\n\xff\xfe\x00garbage")
    with pytest.raises(ElementsError, match=r"bin.tle:2: expected text .* byte 0xff"):
        load_elements(tmp_path / "bin.tle")
    (tmp_path / "page.tle").write_text("<html><body>503 Service Unavailable</body></html>")
    with pytest.raises(ElementsError, match="markup"):
        load_elements(tmp_path / "page.tle")
    (tmp_path / "empty.tle").write_text("\n\n")
    with pytest.raises(ElementsError, match="expected at least one element set, found none"):
        load_elements(tmp_path / "empty.tle")


# --------------------------------------------------------------------------- corrupt OMM


def omm_records():
    return json.loads((FIXTURES / "omm.json").read_text())


def test_omm_json_errors():
    with pytest.raises(ElementsError) as info:
        parse_omm_json('[{"OBJECT_NAME": "X",\n "EPOCH" "2024"}]', "gp.json")
    assert (info.value.line, info.value.column) == (2, 10)
    recs = omm_records()
    del recs[1]["MEAN_MOTION"]
    with pytest.raises(ElementsError, match=r"gp.json: record 2 \(NORAD 33591 'NOAA 19'\): "
                                            r"MEAN_MOTION: expected a value \(required\)"):
        parse_omm_json(json.dumps(recs), "gp.json")
    recs = omm_records()
    recs[0]["ECCENTRICITY"] = "abc"
    with pytest.raises(ElementsError, match="ECCENTRICITY: expected a number, found \"'abc'\""):
        parse_omm_json(json.dumps(recs), "gp.json")
    recs = omm_records()
    recs[0]["EPOCH"] = "01/01/2024"
    with pytest.raises(ElementsError, match="EPOCH: expected a UTC time"):
        parse_omm_json(json.dumps(recs), "gp.json")
    with pytest.raises(ElementsError, match="expected a JSON list of OMM objects, found str"):
        parse_omm_json('"hello"', "gp.json")


def test_omm_csv_errors():
    text = (FIXTURES / "omm.csv").read_text()
    lines = text.splitlines()
    cut = lines[:2] + [",".join(lines[2].split(",")[:12])] + lines[3:]
    with pytest.raises(ElementsError) as info:
        parse_omm_csv("\n".join(cut), "gp.csv")
    assert info.value.line == 3
    assert "truncated row: expected 17 columns as in the header, found 12" in str(info.value)
    with pytest.raises(ElementsError, match="gp.csv:2: expected 17 columns as in the header, "
                                            "found 18"):
        parse_omm_csv("\n".join([lines[0], lines[1] + ",9"]), "gp.csv")
    header = lines[0].replace("MEAN_MOTION,", "MEANMOTION,")
    with pytest.raises(ElementsError, match="gp.csv:1: OMM CSV header: .* missing MEAN_MOTION"):
        parse_omm_csv("\n".join([header] + lines[1:]), "gp.csv")
    bad = lines[1].replace("15.50103472", "15.5O103472")
    with pytest.raises(ElementsError, match=r"gp.csv:2 \(NORAD 25544 'ISS \(ZARYA\)'\): "
                                            "MEAN_MOTION: expected a number"):
        parse_omm_csv("\n".join([lines[0], bad]), "gp.csv")


# --------------------------------------------------------------------------- catalog


def older(es_line1: str, days: float) -> str:
    epoch = float(es_line1[20:32]) - days
    return fix_checksum(es_line1[:20] + f"{epoch:012.8f}" + es_line1[32:68])


def test_catalog_keeps_the_newest_epoch(leo_sets):
    cat = Catalog(leo_sets)
    old = parse_tle(f"ISS OLD\n{older(ISS_L1, 0.5)}\n{ISS_L2}\n")
    r = cat.merge(old)
    assert r.kept == (25544,) and cat.get(25544).name == "ISS (ZARYA)"
    newer = parse_tle(f"ISS NEW\n{older(ISS_L1, -1)}\n{ISS_L2}\n")
    r = cat.merge(newer)
    assert r.updated == (25544,) and cat.get(25544).name == "ISS NEW"
    assert len(cat) == 7 and 25544 in cat


def test_catalog_save_load_round_trip(tmp_path, leo_sets):
    cat = Catalog(leo_sets)
    cat.merge(load_elements(FIXTURES / "omm.csv"))
    cat.merge(parse_omm_json(json.dumps([dict(omm_records()[0], NORAD_CAT_ID=99999,
                                              OBJECT_NAME="OMM ONLY")])))
    path = cat.save(tmp_path)
    assert path.name == "catalog.json"
    back = Catalog.load(tmp_path)
    assert [es.norad_id for es in back] == [es.norad_id for es in cat]
    for a, b in zip(back, cat):
        assert a.name == b.name and a.epoch == b.epoch and a.source == b.source
        assert np.array_equal(_position_km(a), _position_km(b))
    assert back.get(99999).omm is not None
    assert Catalog.load(tmp_path / "missing").__len__() == 0


def test_corrupt_catalog_file(tmp_path, leo_sets):
    Catalog(leo_sets).save(tmp_path)
    path = tmp_path / "catalog.json"
    path.write_text(path.read_text()[:200])
    with pytest.raises(CatalogError, match="corrupt catalog"):
        Catalog.load(tmp_path)
    data = json.loads(json.dumps({"format": "urc-catalog", "version": 1,
                                  "sets": [{"name": "X", "tle": ["1 bad", "2 bad"]}]}))
    path.write_text(json.dumps(data))
    with pytest.raises(CatalogError, match="set 1: corrupt record"):
        Catalog.load(tmp_path)
    path.write_text(json.dumps({"format": "something", "sets": []}))
    with pytest.raises(CatalogError, match="expected a urc catalog"):
        Catalog.load(tmp_path)


def test_lookup_by_id_name_and_prefix(leo_sets):
    cat = Catalog(leo_sets)
    assert cat.get(25544).name == "ISS (ZARYA)"
    assert cat.get("25544").norad_id == 25544
    assert cat.get("iss (zarya)").norad_id == 25544
    assert cat.get("  Iss  ").norad_id == 25544
    assert cat.get("metop").norad_id == 38771
    assert cat.get("NOAA 18").norad_id == 28654  # exact beats prefix
    with pytest.raises(AmbiguousSatellite) as info:
        cat.get("noaa")
    assert {es.norad_id for es in info.value.candidates} == {28654, 33591}
    assert "2 satellites start with 'noaa'" in str(info.value)
    with pytest.raises(SatelliteNotFound, match="did you mean 'HST'"):
        cat.get("HTS")
    with pytest.raises(SatelliteNotFound, match="NORAD id 12345"):
        cat.get(12345)
    assert [es.norad_id for es in cat.select(["iss", 20580])] == [25544, 20580]


def test_duplicate_names_are_ambiguous():
    two = parse_tle(f"OBJECT A\n{ISS_L1}\n{ISS_L2}\n") + parse_tle(
        "OBJECT A\n" + "\n".join(tle_lines()[4:6]) + "\n")
    with pytest.raises(AmbiguousSatellite, match="2 satellites share the name 'object a'"):
        Catalog(two).get("object a")


def test_import_file(tmp_path):
    r = import_file(FIXTURES / "leo.tle", tmp_path)
    assert len(r.added) == 7
    r = import_file(FIXTURES / "omm.json", tmp_path)
    assert len(r.kept) == 4 and not r.added
    assert len(Catalog.load(tmp_path)) == 7


@settings(max_examples=400, deadline=None)
@given(st.one_of(st.text(max_size=75),
                 st.text(alphabet="0123456789 -+.ABCU²٣", min_size=60, max_size=70),
                 st.sampled_from([ln for ln in (FIXTURES / "leo.tle").read_text().splitlines() if ln[:2] in ("1 ", "2 ")])))
def test_tle_checksum_is_sgp4s_on_ascii_and_counts_only_ascii_digits(line):
    """Our C-speed checksum gives sgp4's compute_checksum's value; a non-ASCII digit
    (on which sgp4's raises ValueError or counts a '٣' as 3) counts nothing."""
    ascii_only = "".join(c for c in line[:68] if c.isascii())
    assert tle_checksum(line) == compute_checksum(ascii_only)
