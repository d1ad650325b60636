"""Importing element files as a stream (issue 21: 50 MB, 350k sets, peaked at 818 MB
and ran a 1 GB Pi out of memory)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from sgp4.io import compute_checksum

from urc.errors import UrcError
from urc.tracking.elements import Catalog, import_file, iter_elements, load_elements

from .conftest import FIXTURES

_L1 = "1 25544U 98067A   24001.25000000  .00016717  00000-0  10270-3 0  999"
_L2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.5010347243240"


def two_line_file(path, n: int, first_id: int = 1, day: str = "001.25") -> None:
    """``n`` two-line sets (the ISS orbit) with NORAD ids from ``first_id``."""
    with open(path, "w") as fh:
        for norad in range(first_id, first_id + n):
            a = f"1 {norad:5d}" + _L1[7:18] + f"24{day}000000" + _L1[32:]
            b = f"2 {norad:5d}" + _L2[7:]
            fh.write(f"{a}{compute_checksum(a)}\n{b}{compute_checksum(b)}\n")


def test_a_large_file_is_imported_in_bounded_memory(tmp_path):
    """60k sets (9 MB): the import's peak RSS stays near the interpreter's own (the old
    import held every set as an ElementSet: ~2 kB each, 200 MB here)."""
    big = tmp_path / "big.tle"
    two_line_file(big, 60000)
    # (VmHWM, the peak of this process's own memory: getrusage's ru_maxrss carries the
    # peak of the process it was forked from across exec, a long-running test worker's)
    code = ("import sys; from urc.tracking.elements import import_file; "
            "r = import_file(sys.argv[1], sys.argv[2]); "
            "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM:')][0].split()[1]; "
            "print(len(r.added), hwm)")
    out = subprocess.run([sys.executable, "-c", code, str(big), str(tmp_path / "cat")],
                         capture_output=True, text=True, timeout=900, check=True).stdout.split()
    added, peak_kib = int(out[0]), int(out[1])
    assert added == 60000
    assert peak_kib < 120 * 1024, f"peak RSS {peak_kib / 1024:.0f} MiB"
    cat = Catalog.load(tmp_path / "cat")
    assert len(cat) == 60000 and cat.get(59999).label == "NORAD 59999"


def test_merging_into_a_stored_catalog_keeps_the_newest(tmp_path):
    cat_dir = tmp_path / "cat"
    first, second = tmp_path / "a.tle", tmp_path / "b.tle"
    two_line_file(first, 50, day="001.25")
    two_line_file(second, 50, first_id=26, day="002.25")   # 26..50 newer, 51..75 new
    r1 = import_file(first, cat_dir)
    r2 = import_file(second, cat_dir)
    assert len(r1.added) == 50
    assert (len(r2.added), len(r2.updated), len(r2.kept)) == (25, 25, 0)
    cat = Catalog.load(cat_dir)
    assert len(cat) == 75
    assert cat.get(30).epoch > cat.get(10).epoch
    r3 = import_file(first, cat_dir)   # older sets again: the catalog's stay
    assert len(r3.kept) == 50 and Catalog.load(cat_dir).get(30).epoch == cat.get(30).epoch


def test_a_catalog_in_the_older_layout_is_still_merged(tmp_path):
    """Catalogs written before (indented JSON, one value per line) are read whole."""
    cat_dir = tmp_path / "cat"
    sets = load_elements(FIXTURES / "leo.tle")
    data = {"format": "urc-catalog", "version": 1, "sets": [es.to_record() for es in sets]}
    cat_dir.mkdir()
    (cat_dir / "catalog.json").write_text(json.dumps(data, indent=1) + "\n")
    extra = tmp_path / "x.tle"
    two_line_file(extra, 3, first_id=90001)
    import_file(extra, cat_dir)
    assert len(Catalog.load(cat_dir)) == len(sets) + 3


def test_sets_are_read_one_at_a_time(tmp_path):
    """The first set comes before a damaged one later in the file is even read."""
    f = tmp_path / "damaged.tle"
    two_line_file(f, 2)
    f.write_text(f.read_text() + "1 00003U garbage\n")
    sets = iter_elements(f)
    assert next(sets).norad_id == 1 and next(sets).norad_id == 2
    with pytest.raises(UrcError):
        next(sets)
    assert not list((tmp_path).glob("cat*"))
