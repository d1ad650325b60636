"""The catalog held compactly (issue 33: 100 000 imported sets grew urc run's I/O process
from 76 to 579 MB): its sets are kept as their records' text and built, with their sgp4
Satrec, only when asked for, the last few kept. Judged by how many Satrecs are built
(not by RSS, which bench/loop_lag.py measures), and by the sets it gives back: the same,
field for field and position for position, as the old load built them."""

from __future__ import annotations

import json

import numpy as np
import pytest
from sgp4.api import Satrec, jday

from urc.tracking import elements
from urc.tracking.elements import Catalog, ElementSet, import_file
from urc.tracking.errors import CatalogError

from .conftest import FIXTURES, synthetic_tle

#: (read where used: the test must run, and fail, on a catalog without it)
CACHED_SETS = getattr(elements, "CACHED_SETS", 64)
FIXTURE_FILES = ("leo.tle", "deep.tle", "omm.json", "omm.csv")


class CountingSatrec:
    """Stands in for sgp4's Satrec in urc.tracking.elements: counts the ones built."""

    def __init__(self):
        self.made = 0

    def __call__(self) -> Satrec:
        self.made += 1
        return Satrec()

    def twoline2rv(self, *args) -> Satrec:
        self.made += 1
        return Satrec.twoline2rv(*args)


@pytest.fixture
def counting(monkeypatch) -> CountingSatrec:
    c = CountingSatrec()
    monkeypatch.setattr(elements, "Satrec", c)
    return c


def test_a_loaded_catalog_builds_satrecs_only_for_the_sets_used(tmp_path, counting):
    n = 2000
    src = tmp_path / "many.tle"
    src.write_text(synthetic_tle(n))
    import_file(src, tmp_path / "cat")
    counting.made = 0
    cat = Catalog.load(tmp_path / "cat")
    assert len(cat) == n and counting.made == 0   # (the old load built all 2000)
    used = [80000 + i for i in range(0, n, n // 100)]
    for norad_id in used:
        assert cat.get(norad_id).norad_id == norad_id
    assert counting.made == len(used)
    recent = used[-CACHED_SETS // 2:]
    kept = {norad_id: cat.get(norad_id) for norad_id in recent}
    assert counting.made == len(used)            # the recent ones were kept ...
    assert all(cat.get(k) is es for k, es in kept.items())
    cat.get(used[0])
    assert counting.made == len(used) + 1        # ... the oldest were not (bounded)
    assert cat.get(f"synth {n - 1}").norad_id == 80000 + n - 1   # a name, found without building all
    assert counting.made == len(used) + 2


def _old_load(path) -> list[ElementSet]:
    """What Catalog.load built before: every record through ElementSet.from_record."""
    data = json.loads(path.read_text())
    return [ElementSet.from_record(rec, f"{path}: set {i}") for i, rec in enumerate(data["sets"], start=1)]


def _positions_km(es: ElementSet) -> np.ndarray:
    jd, fr = jday(2024, 1, 1, 12, 0, 0)
    offsets_d = np.linspace(-1.0, 3.0, 97)
    err, r, _v = es.satrec.sgp4_array(np.full(97, jd), fr + offsets_d)
    return np.where(err[:, None] == 0, r, np.nan)


@pytest.mark.parametrize("name", FIXTURE_FILES)
def test_sets_and_their_propagation_equal_the_old_load(tmp_path, name):
    import_file(FIXTURES / name, tmp_path)
    old = _old_load(Catalog.path_in(tmp_path))
    cat = Catalog.load(tmp_path)
    assert [es.norad_id for es in cat] == sorted(es.norad_id for es in old)
    for want in old:
        for got in (cat.get(want.norad_id), cat.get(want.name) if want.name else cat.get(want.norad_id)):
            assert (got.name, got.norad_id, got.epoch, got.source, got.tle) == \
                (want.name, want.norad_id, want.epoch, want.source, want.tle)
            assert (dict(got.omm) if got.omm is not None else None) == \
                (dict(want.omm) if want.omm is not None else None)
            assert got.sgp4_error == want.sgp4_error
            np.testing.assert_array_equal(_positions_km(got), _positions_km(want))
    # saved again, the file says the same
    cat.save(tmp_path / "again")
    assert [json.loads(json.dumps(r)) for r in json.loads(Catalog.path_in(tmp_path / "again").read_text())["sets"]] \
        == json.loads(Catalog.path_in(tmp_path).read_text())["sets"]


def test_merged_sets_are_kept_as_given_and_the_newest_wins(leo_sets, counting):
    cat = Catalog(leo_sets)
    iss = next(es for es in leo_sets if es.norad_id == 25544)
    assert cat.get(25544) is iss and counting.made == 0
    again = ElementSet.from_record(iss.to_record(), "x")
    assert cat.merge([again]).kept == (25544,) and cat.get(25544) is iss


def test_alpha5_catalog_numbers_key_the_set_as_sgp4_reads_them(tmp_path):
    l1 = "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9002"
    l2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391 12345"
    lines = []
    for field in ("A0001", "J1234", "Z9999"):
        a, b = l1[:2] + field + l1[7:68], l2[:2] + field + l2[7:68]
        lines += [f"ALPHA {field}", a + str(elements.tle_checksum(a)), b + str(elements.tle_checksum(b))]
    (tmp_path / "a5.tle").write_text("\n".join(lines) + "\n")
    import_file(tmp_path / "a5.tle", tmp_path / "cat")
    cat = Catalog.load(tmp_path / "cat")
    assert [es.norad_id for es in cat] == [100001, 181234, 339999]
    assert [cat.get(n).satrec.satnum for n in (100001, 181234, 339999)] == [100001, 181234, 339999]


def test_a_stored_catalog_is_still_checked_whole_at_load(tmp_path, leo_sets):
    Catalog(leo_sets).save(tmp_path)
    path = Catalog.path_in(tmp_path)
    good = path.read_text()
    lines = good.splitlines()
    rec = json.loads(lines[3].rstrip(","))
    rec["tle"][1] = rec["tle"][1][:-1] + str((int(rec["tle"][1][-1]) + 1) % 10)  # a wrong checksum
    path.write_text("\n".join(lines[:3] + [json.dumps(rec) + ","] + lines[4:]) + "\n")
    with pytest.raises(CatalogError, match="set 3: corrupt record.*checksum"):
        Catalog.load(tmp_path)
    path.write_text("\n".join(good.splitlines()[:-1]) + "\n")   # cut before its closing line
    with pytest.raises(CatalogError, match="corrupt catalog"):
        Catalog.load(tmp_path)
    dup_older = dict(json.loads(lines[1].rstrip(",")), epoch="2000-01-01T00:00:00+00:00", name="OLDER")
    path.write_text("\n".join(lines[:-2] + [lines[-2] + ",", json.dumps(dup_older), "]}"]) + "\n")
    back = Catalog.load(tmp_path)
    assert len(back) == len(leo_sets) and back.get(dup_older["norad_id"]).name != "OLDER"


def test_sets_merged_into_a_loaded_catalog_join_the_ones_read(tmp_path, leo_sets):
    first, rest = leo_sets[:4], leo_sets[4:]
    Catalog(first).save(tmp_path)
    cat = Catalog.load(tmp_path)
    r = cat.merge(leo_sets)
    assert set(r.added) == {es.norad_id for es in rest} and set(r.kept) == {es.norad_id for es in first}
    assert len(cat) == len(leo_sets) and [es.norad_id for es in cat] == sorted(es.norad_id for es in leo_sets)
    iss = next(es for es in leo_sets if es.norad_id == 25544)
    newer = ElementSet.from_record({**iss.to_record(), "name": "ISS NEWER"}, "x")
    newer = ElementSet(newer.name, newer.norad_id, iss.epoch.replace(year=iss.epoch.year + 1), newer.satrec,
                       newer.source, newer.tle)
    assert cat.merge([newer]).updated == (25544,)
    assert cat.get("iss newer") is newer and cat.get(25544) is newer and len(cat) == len(leo_sets)
    for es in leo_sets:   # the ones read and the ones merged, by name as by id
        if es.norad_id != 25544:
            assert cat.get(es.name).norad_id == es.norad_id and es.norad_id in cat
    cat.save(tmp_path / "again")
    back = Catalog.load(tmp_path / "again")
    assert [es.norad_id for es in back] == [es.norad_id for es in cat] and back.get(25544).name == "ISS NEWER"


def test_a_large_catalog_is_read_in_a_process_of_its_own(tmp_path, monkeypatch):
    """Reading 100 000 sets on a thread of urc run's I/O process held the event loop's
    share of Python's lock (its timer ran up to 836 ms late on a loaded machine)."""
    from urc.tracking import catalog_process

    for name in FIXTURE_FILES:
        import_file(FIXTURES / name, tmp_path)
    want = Catalog.load(tmp_path)
    monkeypatch.setattr(catalog_process, "ISOLATED_READ_BYTES", 0)
    here: list[str] = []
    load = Catalog.load
    monkeypatch.setattr(Catalog, "load", staticmethod(lambda d: (here.append(str(d)), load(d))[1]))
    got = catalog_process.read_catalog(tmp_path)
    assert here == []   # read in the other process, sent back whole
    assert got.records() == want.records() and len(got) == len(want)
    for es in want:
        assert got.get(es.name or es.norad_id).norad_id == es.norad_id
        np.testing.assert_array_equal(_positions_km(got.get(es.norad_id)), _positions_km(es))
    Catalog.path_in(tmp_path).write_text(Catalog.path_in(tmp_path).read_text()[:300])
    with pytest.raises(CatalogError, match="corrupt catalog"):
        catalog_process.read_catalog(tmp_path)
