"""Orbital element sets: TLE/3LE and CelesTrak OMM (JSON, CSV) into one type, and the
local catalog that keeps the newest set per NORAD id.

sgp4 does the orbit initialisation (``Satrec.twoline2rv``, ``sgp4.omm.initialize``), the
same calls skyfield makes, so propagation here and in skyfield agree exactly. The
column-by-column TLE check below is ours because sgp4's fast C++ parser accepts corrupt
lines silently (``5x.6416`` reads as an inclination of 5 degrees); every error names the
file, the line, the columns and what was expected there.

(Over 600 lines on purpose: the TLE column check, the OMM fields and the catalog's
newest-set rule are one format's rules, read together when a file is refused.)
"""

from __future__ import annotations

import bisect
import csv
import difflib
import io
import json
import math
import mmap
import os
import re
from array import array
from collections import OrderedDict
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import IO, Any, Iterable, Iterator, Mapping, Sequence

from sgp4.api import SGP4_ERRORS, Satrec

from .errors import AmbiguousSatellite, CatalogError, ChecksumError, ElementsError, \
    SatelliteNotFound

__all__ = [
    "Catalog", "ElementSet", "MergeResult", "import_file", "load_elements", "parse_elements",
    "parse_omm_csv", "parse_omm_json", "parse_tle",
]

#: file in the catalog directory holding the element sets.
CATALOG_FILE = "catalog.json"
_CATALOG_FORMAT = "urc-catalog"
_CATALOG_VERSION = 1
_TWO_PI = 2.0 * math.pi


# --------------------------------------------------------------------------- the type


@dataclass(frozen=True, eq=False)
class ElementSet:
    """One satellite's mean elements at one epoch, ready for SGP4.

    ``tle`` or ``omm`` keeps the text it was read from, so the catalog stores exactly
    what was imported (OMM carries more digits than a TLE can).
    """

    name: str
    norad_id: int
    epoch: datetime
    satrec: Satrec = field(repr=False)
    source: str = ""
    tle: tuple[str, str] | None = field(default=None, repr=False)
    omm: Mapping[str, Any] | None = field(default=None, repr=False)

    @property
    def label(self) -> str:
        """The name, or ``NORAD 25544`` for a nameless two-line set."""
        return self.name or f"NORAD {self.norad_id}"

    @property
    def epoch_unix_s(self) -> float:
        return self.epoch.timestamp()

    @property
    def mean_motion_rev_per_day(self) -> float:
        return self.satrec.no_kozai * 1440.0 / _TWO_PI

    @property
    def sgp4_error(self) -> str | None:
        """Why sgp4 cannot propagate these elements even at their epoch (decayed ...), or None.

        Such sets still load (the text is fine); propagation reports the error.
        """
        return SGP4_ERRORS.get(self.satrec.error, f"error {self.satrec.error}") \
            if self.satrec.error else None

    @property
    def period_s(self) -> float:
        return _TWO_PI / self.satrec.no_kozai * 60.0

    def to_record(self) -> dict[str, Any]:
        """A JSON-able record; :meth:`from_record` reads it back."""
        rec: dict[str, Any] = {"name": self.name, "norad_id": self.norad_id,
                               "epoch": self.epoch.isoformat(), "source": self.source}
        if self.omm is not None:
            rec["omm"] = dict(self.omm)
        else:
            rec["tle"] = list(self.tle or ())
        return rec

    @classmethod
    def from_record(cls, rec: Mapping[str, Any], source: str, *, checksum: bool = True) -> ElementSet:
        if "omm" in rec:
            es = _from_omm(dict(rec["omm"]), source, str(rec.get("name", "")))
        elif "tle" in rec and len(rec["tle"]) == 2:
            l1, l2 = rec["tle"]
            es = _from_tle(str(rec.get("name", "")), str(l1), str(l2), source, 0, 0, checksum)
        else:
            raise CatalogError(f"{source}: record for {rec.get('name', '?')!r}: expected a "
                               "'tle' pair or an 'omm' table, found neither")
        return _replace_source(es, str(rec.get("source", "")) or source)


def _replace_source(es: ElementSet, source: str) -> ElementSet:
    return ElementSet(es.name, es.norad_id, es.epoch, es.satrec, source, es.tle, es.omm)


def _epoch_of(sat: Satrec) -> datetime:
    # jdsatepoch + jdsatepochF is the UTC epoch; round to the microsecond datetime holds.
    u = (sat.jdsatepoch - 2440587.5) * 86400.0 + sat.jdsatepochF * 86400.0
    return datetime.fromtimestamp(round(u, 6), tz=timezone.utc)


# --------------------------------------------------------------------------- TLE / 3LE

#: (first column, end column (Python slice), field, pattern, example), per TLE line.
_LINE1_FIELDS = (
    (0, 1, "line number", r"1", "1"),
    (2, 7, "satellite number", r"[A-HJ-NP-Z]\d{4}|[ \d]{4}\d", "25544"),
    (7, 8, "classification", r"[A-Z ]", "U"),
    (9, 17, "international designator", r"[ -~]{8}", "98067A  "),
    (18, 20, "epoch year", r"\d\d", "24"),
    (20, 32, "epoch day of year", r"[ \d]{3}\.\d{8}", "001.50000000"),
    (33, 43, "first derivative of mean motion", r"[ +-]\.\d{8}", " .00016717"),
    (44, 52, "second derivative of mean motion", r"[ +-][ \d]{5}[ +-]\d", " 00000-0"),
    (53, 61, "drag term (BSTAR)", r"[ +-][ \d]{5}[ +-]\d", " 10270-3"),
    (62, 63, "ephemeris type", r"[\d ]", "0"),
    (64, 68, "element set number", r"[ \d]{3}\d|    ", " 999"),
)
_LINE2_FIELDS = (
    (0, 1, "line number", r"2", "2"),
    (2, 7, "satellite number", r"[A-HJ-NP-Z]\d{4}|[ \d]{4}\d", "25544"),
    (8, 16, "inclination (degrees)", r"[ \d]{3}\.[\d ]{4}", " 51.6416"),
    (17, 25, "right ascension of the ascending node (degrees)", r"[ \d]{3}\.[\d ]{4}",
     "247.4627"),
    (26, 33, "eccentricity (decimal point assumed)", r"[ \d]{6}\d", "0006703"),
    (34, 42, "argument of perigee (degrees)", r"[ \d]{3}\.[\d ]{4}", "130.5360"),
    (43, 51, "mean anomaly (degrees)", r"[ \d]{3}\.[\d ]{4}", "325.0288"),
    (52, 63, "mean motion (revolutions per day)", r"[ \d]{2}\.[\d ]{8}", "15.72125391"),
    (63, 68, "revolution number at epoch", r"[ \d]{5}", "12345"),
)
_BLANK_COLUMNS = {1: (1, 8, 17, 32, 43, 52, 61, 63), 2: (1, 7, 16, 25, 33, 42, 51)}
_COMPILED = {n: tuple((a, b, name, re.compile(f"(?:{pat})\\Z"), ex) for a, b, name, pat, ex in fs)
             for n, fs in ((1, _LINE1_FIELDS), (2, _LINE2_FIELDS))}
TLE_LINE_LENGTH = 69


def parse_tle(text: str, source: str = "<string>", *, checksum: bool = True) -> list[ElementSet]:
    """Element sets from TLE text: two-line sets, optionally each after a name line (3LE).

    Name lines may carry space-track's ``0 `` prefix; blank lines and ``#`` comments are
    skipped. ``checksum=False`` accepts lines whose checksum digit is wrong or missing.
    """
    return list(iter_tle(text.splitlines(), source, checksum=checksum))


def iter_tle(raw_lines: Iterable[str], source: str = "<string>", *,
             checksum: bool = True) -> Iterator[ElementSet]:
    """:func:`parse_tle` one set at a time from an iterable of lines (a file read as it
    goes: a 50 MB catalog is never held whole)."""
    def numbered() -> Iterator[tuple[int, str]]:
        for i, raw in enumerate(raw_lines, start=1):
            line = raw.rstrip()
            if line.strip() and not line.lstrip().startswith("#"):
                yield i, line
    lines = numbered()
    name: tuple[int, str] | None = None
    for lineno, line in lines:
        if _looks_like(line, "1"):
            nxt = next(lines, None)
            if nxt is None:
                raise ElementsError(
                    f"{source}:{lineno}: truncated file: TLE line 1 of "
                    f"{_who(name, line)} is not followed by its line 2",
                    path=source, line=lineno, expected="TLE line 2", found="end of file")
            lineno2, line2 = nxt
            if not line2.startswith("2"):
                raise ElementsError(
                    f"{source}:{lineno2}: expected line 2 of {_who(name, line)} "
                    f"(starting '2 '), found {_short(line2)}",
                    path=source, line=lineno2, column=1, expected="TLE line 2", found=line2)
            yield _from_tle(name[1] if name else "", line, line2, source, lineno, lineno2, checksum)
            name = None
            continue
        if line.startswith("2 ") and len(line) > 20:
            hint = ""
            if name and name[1][:2] == "1 ":
                hint = (f"; line {name[0]} looks like a truncated line 1 ({len(name[1])} "
                        f"characters, expected {TLE_LINE_LENGTH})")
            raise ElementsError(f"{source}:{lineno}: found TLE line 2 without a line 1 "
                                f"before it{hint}", path=source, line=lineno,
                                expected="TLE line 1", found=line)
        if name is not None:
            raise ElementsError(
                f"{source}:{lineno}: expected TLE line 1 (starting '1 ') after the name line "
                f"{name[0]} {name[1]!r}, found {_short(line)}",
                path=source, line=lineno, column=1, expected="TLE line 1", found=line)
        name = (lineno, line[2:].strip() if line.startswith("0 ") else line.strip())
    if name is not None:
        raise ElementsError(f"{source}:{name[0]}: truncated file: name line {name[1]!r} is "
                            "not followed by its two element lines", path=source,
                            line=name[0], expected="TLE line 1", found="end of file")


def _looks_like(line: str, number: str) -> bool:
    # A name may start with "1 " too; a line 1 is long enough to hold the epoch.
    return line.startswith(number + " ") and len(line) >= 24


def _who(name: tuple[int, str] | None, line1: str) -> str:
    return repr(name[1]) if name else f"satellite {line1[2:7].strip()!r}"


def _short(text: str, n: int = 40) -> str:
    return repr(text if len(text) <= n else text[: n - 3] + "...")


#: byte -> what it adds to a TLE checksum: a digit its value, a minus sign 1, anything else 0
_CHECKSUM_VALUE = bytes(b - 48 if 48 <= b <= 57 else 1 if b == 45 else 0 for b in range(256))


def tle_checksum(line: str) -> int:
    """The TLE checksum of ``line``: the digits of its first 68 columns plus one per
    minus sign, modulo 10 (sgp4.io.compute_checksum's value on ASCII text). Summed in C
    (bytes.translate) rather than by sgp4's generator over every character (~100x
    slower), since every line of a stored catalog is checked again at each load; other
    characters count nothing, so a non-ASCII digit such as '²', on which sgp4's raises
    ValueError, makes a checksum error, not a crash."""
    return sum(line[:68].encode("latin-1", "replace").translate(_CHECKSUM_VALUE)) % 10


def _check_line(line: str, number: int, source: str, lineno: int, checksum: bool) -> None:
    where = f"{source}:{lineno}: TLE line {number}"
    n = len(line)
    if n < TLE_LINE_LENGTH - 1 or (n == TLE_LINE_LENGTH - 1 and checksum):
        raise ElementsError(f"{where}: truncated line: {n} characters, expected "
                            f"{TLE_LINE_LENGTH}", path=source, line=lineno, column=n + 1,
                            expected=f"{TLE_LINE_LENGTH} characters", found=n)
    if n > TLE_LINE_LENGTH:
        raise ElementsError(f"{where}: unexpected text after column {TLE_LINE_LENGTH}: "
                            f"{_short(line[TLE_LINE_LENGTH:])}", path=source, line=lineno,
                            column=TLE_LINE_LENGTH + 1, expected="end of line",
                            found=line[TLE_LINE_LENGTH:])
    for col in _BLANK_COLUMNS[number]:
        if line[col] != " ":
            raise ElementsError(f"{where}, column {col + 1}: expected a blank, found "
                                f"{line[col]!r}; the columns are shifted or the line is "
                                "corrupt", path=source, line=lineno, column=col + 1,
                                expected="' '", found=line[col])
    for a, b, what, pattern, example in _COMPILED[number]:
        text = line[a:b]
        if not pattern.match(text):
            cols = f"column {a + 1}" if b - a == 1 else f"columns {a + 1}-{b}"
            raise ElementsError(f"{where}, {cols} ({what}): expected something like "
                                f"{example!r}, found {text!r}", path=source, line=lineno,
                                column=a + 1, expected=example, found=text)
    if checksum:
        given, computed = line[68], tle_checksum(line)
        if not given.isdigit() or int(given) != computed:
            raise ChecksumError(
                f"{where}, column 69 (checksum): expected {computed} (digits plus one per "
                f"minus sign, modulo 10), found {given!r}: the line is corrupt",
                path=source, line=lineno, column=69, expected=str(computed), found=given)


def _from_tle(name: str, line1: str, line2: str, source: str, lineno1: int, lineno2: int,
              checksum: bool) -> ElementSet:
    _check_tle(line1, line2, source, lineno1, lineno2, checksum)
    sat = Satrec.twoline2rv(line1, line2)
    return ElementSet(name, int(sat.satnum), _epoch_of(sat), sat, source, (line1, line2), None)


#: Alpha-5 catalog numbers: a letter (I and O left out) for the ten-thousands above 99999
_ALPHA5 = {c: i for i, c in enumerate("ABCDEFGHJKLMNPQRSTUVWXYZ", start=10)}


def _tle_norad_id(line1: str) -> int:
    """The NORAD id of a checked line 1 (Alpha-5 too), as sgp4's ``satnum`` reads it."""
    field = line1[2:7]
    return _ALPHA5[field[0]] * 10000 + int(field[1:]) if field[0] in _ALPHA5 else int(field)


def _check_tle(line1: str, line2: str, source: str, lineno1: int, lineno2: int,
               checksum: bool) -> None:
    """Every check of a TLE pair that needs no Satrec (a catalog is checked at load and its
    Satrecs built only for the sets used)."""
    _check_line(line1, 1, source, lineno1, checksum)
    _check_line(line2, 2, source, lineno2, checksum)
    if line1[2:7] != line2[2:7]:
        raise ElementsError(f"{source}:{lineno2}: TLE line 2, columns 3-7 (satellite number): "
                            f"expected {line1[2:7]!r} as on line 1, found {line2[2:7]!r}",
                            path=source, line=lineno2, column=3, expected=line1[2:7],
                            found=line2[2:7])
    where = f"{source}:{lineno2}: TLE line 2"
    for a, b, what, limit in ((8, 16, "inclination", 180.0), (17, 25, "right ascension", 360.0),
                              (34, 42, "argument of perigee", 360.0),
                              (43, 51, "mean anomaly", 360.0)):
        value = float(line2[a:b])
        if value > limit:
            raise ElementsError(f"{where}, columns {a + 1}-{b} ({what}): expected 0..{limit:g} "
                                f"degrees, found {value:g}", path=source, line=lineno2,
                                column=a + 1, expected=f"0..{limit:g}", found=value)
    if float(line2[52:63]) <= 0.0:
        raise ElementsError(f"{where}, columns 53-63 (mean motion): expected a positive number "
                            f"of revolutions per day, found {line2[52:63]!r}", path=source,
                            line=lineno2, column=53, expected="> 0", found=line2[52:63])


# --------------------------------------------------------------------------- OMM

#: OMM keys sgp4 needs; the rest have defaults (CelesTrak always sends them all).
_OMM_REQUIRED_NUMBERS = ("MEAN_MOTION", "ECCENTRICITY", "INCLINATION", "RA_OF_ASC_NODE",
                         "ARG_OF_PERICENTER", "MEAN_ANOMALY", "BSTAR", "MEAN_MOTION_DOT")
_OMM_DEFAULTS = {"CLASSIFICATION_TYPE": "U", "EPHEMERIS_TYPE": 0, "ELEMENT_SET_NO": 999,
                 "REV_AT_EPOCH": 0, "MEAN_MOTION_DDOT": 0.0, "OBJECT_ID": ""}
#: CelesTrak's OMM CSV column order
#: (celestrak.org/NORAD/documentation/gp-data-formats.php)
OMM_CSV_COLUMNS = ("OBJECT_NAME", "OBJECT_ID", "EPOCH", "MEAN_MOTION", "ECCENTRICITY",
                   "INCLINATION", "RA_OF_ASC_NODE", "ARG_OF_PERICENTER", "MEAN_ANOMALY",
                   "EPHEMERIS_TYPE", "CLASSIFICATION_TYPE", "NORAD_CAT_ID", "ELEMENT_SET_NO",
                   "REV_AT_EPOCH", "BSTAR", "MEAN_MOTION_DOT", "MEAN_MOTION_DDOT")
_EPOCH_RE = re.compile(r"(\d{4}-\d\d-\d\d)[T ](\d\d:\d\d:\d\d)(?:\.(\d+))?Z?\Z")


def parse_omm_json(text: str, source: str = "<string>") -> list[ElementSet]:
    """Element sets from CelesTrak OMM JSON (a list of objects, or one object)."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ElementsError(f"{source}:{exc.lineno}:{exc.colno}: expected OMM JSON, found "
                            f"invalid JSON ({exc.msg})", path=source, line=exc.lineno,
                            column=exc.colno, expected="JSON", found=exc.msg) from None
    if isinstance(data, dict):
        data = [data]
    if not isinstance(data, list):
        raise ElementsError(f"{source}: expected a JSON list of OMM objects, found "
                            f"{type(data).__name__}", path=source, expected="a list",
                            found=type(data).__name__)
    out = []
    for i, rec in enumerate(data, start=1):
        where = f"{source}: record {i}"
        if not isinstance(rec, dict):
            raise ElementsError(f"{where}: expected an OMM object, found {_short(repr(rec))}",
                                path=source, expected="an object", found=rec)
        out.append(_from_omm(rec, where, None, path=source))
    return out


def parse_omm_csv(text: str, source: str = "<string>") -> list[ElementSet]:
    """Element sets from CelesTrak OMM CSV (header line, one object per line)."""
    reader = csv.DictReader(io.StringIO(text))
    header = reader.fieldnames or []
    missing = [k for k in ("EPOCH", "NORAD_CAT_ID", *_OMM_REQUIRED_NUMBERS) if k not in header]
    if missing:
        raise ElementsError(f"{source}:1: OMM CSV header: expected the columns "
                            f"{', '.join(OMM_CSV_COLUMNS)}, missing {', '.join(missing)}",
                            path=source, line=1, expected=", ".join(OMM_CSV_COLUMNS),
                            found=",".join(header))
    out = []
    for row in reader:
        where = f"{source}:{reader.line_num}"
        if None in row:  # more cells than header columns
            raise ElementsError(f"{where}: expected {len(header)} columns as in the header, "
                                f"found {len(header) + len(row[None])}", path=source,
                                line=reader.line_num, expected=f"{len(header)} columns",
                                found=len(header) + len(row[None]))
        absent = [k for k in header if row.get(k) is None]
        if absent:
            raise ElementsError(f"{where}: truncated row: expected {len(header)} columns as "
                                f"in the header, found {len(header) - len(absent)} (no "
                                f"{', '.join(absent)})", path=source, line=reader.line_num,
                                expected=f"{len(header)} columns", found=len(header) - len(absent))
        if not any((v or "").strip() for v in row.values()):
            continue
        out.append(_from_omm(row, where, None, path=source, line=reader.line_num))
    return out


def _from_omm(rec: dict, where: str, name: str | None, *, path: str | None = None,
              line: int | None = None) -> ElementSet:
    fields = _omm_fields(rec, where, path=path, line=line)
    sat = Satrec()
    try:
        from sgp4.omm import initialize

        initialize(sat, fields)
    except ValueError as exc:
        raise ElementsError(f"{where}{_omm_who(rec)}: {exc}", path=path or where, line=line,
                            expected="valid OMM fields", found=str(exc)) from None
    name = name if name is not None else str(rec.get("OBJECT_NAME") or "").strip()
    keep = {k: v for k, v in rec.items() if k is not None}
    return ElementSet(name, fields["NORAD_CAT_ID"], _epoch_of(sat), sat,
                      path or where, None, keep)


def _omm_fields(rec: Mapping, where: str, *, path: str | None = None,
                line: int | None = None) -> dict[str, Any]:
    """The fields sgp4's OMM initialisation takes, every one checked (no Satrec built)."""
    def bad(key: str, expected: str, found: object) -> ElementsError:
        return ElementsError(f"{where}{_omm_who(rec)}: {key}: expected {expected}, found "
                             f"{_short(repr(found))}", path=path or where, line=line,
                             expected=expected, found=found)

    fields: dict[str, Any] = dict(_OMM_DEFAULTS)
    fields.update({k: v for k, v in rec.items() if v not in (None, "")})
    for key in ("EPOCH", "NORAD_CAT_ID", *_OMM_REQUIRED_NUMBERS):
        if key not in fields:
            raise bad(key, "a value (required)", None)
    for key in (*_OMM_REQUIRED_NUMBERS, "MEAN_MOTION_DDOT"):
        try:
            value = float(fields[key])
        except (TypeError, ValueError):
            raise bad(key, "a number", fields[key]) from None
        if not math.isfinite(value):
            raise bad(key, "a finite number", fields[key])
        fields[key] = value
    for key in ("NORAD_CAT_ID", "ELEMENT_SET_NO", "REV_AT_EPOCH", "EPHEMERIS_TYPE"):
        try:
            value = float(fields[key])
            if value != int(value) or value < 0:
                raise ValueError
        except (TypeError, ValueError, OverflowError):
            raise bad(key, "a whole number >= 0", fields[key]) from None
        fields[key] = int(value)
    if fields["NORAD_CAT_ID"] > 339999:
        raise bad("NORAD_CAT_ID", "a catalog number sgp4 can hold (<= 339999)",
                  fields["NORAD_CAT_ID"])
    if not 0.0 <= fields["ECCENTRICITY"] < 1.0:
        raise bad("ECCENTRICITY", "0 <= e < 1", fields["ECCENTRICITY"])
    if fields["MEAN_MOTION"] <= 0.0:
        raise bad("MEAN_MOTION", "a positive number of revolutions per day", fields["MEAN_MOTION"])
    m = _EPOCH_RE.match(str(fields["EPOCH"]).strip())
    if not m:
        raise bad("EPOCH", "a UTC time like '2024-01-01T12:00:00.000000'", fields["EPOCH"])
    fields["EPOCH"] = f"{m.group(1)}T{m.group(2)}.{(m.group(3) or '0')[:6]:0<6}"
    object_id = str(fields["OBJECT_ID"])
    if object_id and not re.match(r"\d{4}-\d{3}[A-Z ]*\Z", object_id):
        raise bad("OBJECT_ID", "an international designator like '1998-067A'", object_id)
    fields["CLASSIFICATION_TYPE"] = str(fields["CLASSIFICATION_TYPE"])[:1] or "U"
    fields["OBJECT_ID"] = object_id
    return fields


def _omm_who(rec: Mapping) -> str:
    bits = []
    if rec.get("NORAD_CAT_ID") not in (None, ""):
        bits.append(f"NORAD {rec['NORAD_CAT_ID']}")
    if rec.get("OBJECT_NAME"):
        bits.append(repr(str(rec["OBJECT_NAME"]).strip()))
    return f" ({' '.join(bits)})" if bits else ""


# --------------------------------------------------------------------------- files


def parse_elements(text: str, source: str = "<string>", *,
                   checksum: bool = True) -> list[ElementSet]:
    """Element sets from text in any supported format, recognised by its content."""
    stripped = text.lstrip("\ufeff \t\r\n")
    if stripped.startswith(("[", "{")):
        return parse_omm_json(stripped, source)
    first = stripped.split("\n", 1)[0]
    if "," in first and ("NORAD_CAT_ID" in first or "OBJECT_NAME" in first):
        return parse_omm_csv(stripped, source)
    if stripped.startswith("<"):
        raise ElementsError(f"{source}: expected TLE, OMM JSON or OMM CSV, found markup "
                            f"{_short(first)} (an HTML error page or OMM XML?)", path=source,
                            line=1, expected="TLE, OMM JSON or CSV", found=first)
    return parse_tle(text, source, checksum=checksum)


def _unreadable(source: str, exc: OSError) -> ElementsError:
    """The error for an element file that cannot be opened or read."""
    if isinstance(exc, FileNotFoundError):
        return ElementsError(f"{source}: no such file", path=source, expected="a file", found="nothing")
    return ElementsError(f"{source}: cannot read: {exc.strerror or exc}", path=source,
                         expected="a readable file", found=str(exc))


def load_elements(path: str | os.PathLike[str], *, checksum: bool = True) -> list[ElementSet]:
    """Read a TLE/3LE, OMM JSON or OMM CSV file."""
    source = os.fspath(path)
    try:
        raw = Path(source).read_bytes()
    except OSError as exc:
        raise _unreadable(source, exc) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        lineno = raw[:exc.start].count(b"\n") + 1
        raise ElementsError(f"{source}:{lineno}: expected text (ASCII/UTF-8), found byte "
                            f"0x{raw[exc.start]:02x}: a binary or corrupt file",
                            path=source, line=lineno, expected="text",
                            found=raw[exc.start:exc.start + 1]) from None
    sets = parse_elements(text, source, checksum=checksum)
    if not sets:
        raise ElementsError(f"{source}: expected at least one element set, found none",
                            path=source, expected="element sets", found="none")
    return sets


# --------------------------------------------------------------------------- catalog


@dataclass(frozen=True)
class MergeResult:
    """NORAD ids added, replaced by a newer epoch, or kept (the catalog's was as new)."""

    added: tuple[int, ...] = ()
    updated: tuple[int, ...] = ()
    kept: tuple[int, ...] = ()

    def __add__(self, other: MergeResult) -> MergeResult:
        return MergeResult(self.added + other.added, self.updated + other.updated,
                           self.kept + other.kept)


def _norm(name: str) -> str:
    return " ".join(name.casefold().split())


#: element sets a catalog keeps built (ElementSet and sgp4 Satrec), most recently used
CACHED_SETS = 64
#: the first line of a catalog file as write_catalog writes it (one record a line after it)
_CATALOG_HEAD = f'{{"format": "{_CATALOG_FORMAT}", "version": {_CATALOG_VERSION}, "sets": ['
_REBUILD = "re-import or `urc tle update --force` to rebuild it"


class _Packed:
    """The records of a catalog as read from its file, in a few large objects: their
    text end to end in one anonymous memory map, the NORAD ids sorted, where each
    record lies (arrays, or views of a memory map) and the names, one string. Small
    objects per set would stay in Python's allocator after the catalog is read again,
    and large malloc'd buffers in the C heap (glibc raises its mmap threshold after such
    a buffer is freed): RSS grew with each reload (issue 33). A memory map goes back to
    the system whole when the old catalog is dropped."""

    __slots__ = ("blob", "ids", "names", "starts", "stops")

    def __init__(self, blob: bytes | mmap.mmap = b"", ids: Sequence[int] | None = None,
                 starts: Sequence[int] | None = None, stops: Sequence[int] | None = None,
                 names: str | memoryview = ""):
        self.blob = blob
        self.ids = ids if ids is not None else array("q")
        self.starts = starts if starts is not None else array("q")
        self.stops = stops if stops is not None else array("q")
        self.names = names  # one a line, in the order of ids (a view: UTF-8)

    @property
    def size(self) -> int:
        """Bytes of the buffer its records lie in."""
        return max(self.stops) if len(self.stops) else 0

    def find(self, norad_id: int) -> int | None:
        i = bisect.bisect_left(self.ids, norad_id)
        return i if i < len(self.ids) and self.ids[i] == norad_id else None

    def record(self, i: int) -> bytes:
        return self.blob[self.starts[i]:self.stops[i]]

    def name_list(self) -> list[str]:
        if not len(self.ids):
            return []
        names = self.names if isinstance(self.names, str) else bytes(self.names).decode("utf-8")
        return names.split("\n")

    # -- to another process, through a file: everything in one memory map there

    def write(self, fh: IO[bytes]) -> tuple[int, int, int]:
        """Write it all; returns the layout :meth:`read` needs."""
        text = self.size
        names = (self.names if isinstance(self.names, str) else bytes(self.names).decode("utf-8")).encode("utf-8")
        fh.write(memoryview(self.blob)[:text] if text else b"")
        fh.write(b"\0" * (_aligned(text) - text))
        for column in (self.ids, self.starts, self.stops):
            fh.write(array("q", column).tobytes())
        fh.write(names)
        return text, len(self.ids), len(names)

    @classmethod
    def read(cls, fh: io.RawIOBase, layout: tuple[int, int, int]) -> _Packed:
        text, n, names = layout
        at = _aligned(text)
        total = at + 24 * n + names
        blob = mmap.mmap(-1, max(total, 1))
        view = memoryview(blob)
        got = 0
        while got < total:
            k = fh.readinto(view[got:total])
            if not k:
                raise OSError(f"read {got} of {total} bytes")
            got += k
        ids, starts, stops = (view[at + 8 * n * c:at + 8 * n * (c + 1)].cast("q") for c in range(3))
        return cls(blob, ids, starts, stops, view[at + 24 * n:total])


def _aligned(n: int) -> int:
    return (n + 7) & ~7


class _Packer:
    """Collects checked records as a file is read, then packs them (:class:`_Packed`)."""

    def __init__(self, size_hint: int) -> None:
        # (the file's size: its records' text fits; pages never written cost nothing)
        self.blob = mmap.mmap(-1, max(size_hint, mmap.PAGESIZE))
        self.used = 0
        self.ids = array("q")
        self.starts = array("q")
        self.names: list[str] = []

    def add(self, norad_id: int, name: str, record: bytes) -> None:
        if self.used + len(record) > len(self.blob):
            self.blob.resize(max(2 * len(self.blob), self.used + len(record)))
        self.ids.append(norad_id)
        self.starts.append(self.used)
        self.blob[self.used:self.used + len(record)] = record
        self.used += len(record)
        self.names.append(name.replace("\n", " "))

    def pack(self) -> _Packed:
        blob = self.blob
        stops = self.starts[1:] + array("q", [self.used])
        order = sorted(range(len(self.ids)), key=self.ids.__getitem__)  # (stable: file order among equals)
        kept: list[int] = []
        for i in order:
            if kept and self.ids[kept[-1]] == self.ids[i]:
                # the same satellite again: a newer epoch replaces it, as merge does
                if _record_epoch(json.loads(blob[self.starts[i]:stops[i]])) > \
                        _record_epoch(json.loads(blob[self.starts[kept[-1]]:stops[kept[-1]]])):
                    kept[-1] = i
                continue
            kept.append(i)
        return _Packed(blob, array("q", (self.ids[i] for i in kept)), array("q", (self.starts[i] for i in kept)),
                       array("q", (stops[i] for i in kept)), "\n".join(self.names[i] for i in kept))


class Catalog:
    """Element sets keyed by NORAD id, newest epoch wins; stored as one JSON file.

    Held compactly (issue 33: 100 000 sets grew urc run's I/O process by 500 MB, ~2 kB a
    set as an ElementSet with its sgp4 Satrec and Python objects): each set as the JSON
    text of its record (~300 bytes) and its name for look-ups, those read from the file
    packed in a few large objects (:class:`_Packed`), those merged since in a dict. A
    set's ElementSet and Satrec are built when it is asked for; the last CACHED_SETS
    built are kept. Every record is still checked when the catalog is read (columns,
    checksums, OMM fields), so a corrupt file is refused at load as before.
    """

    def __init__(self, sets: Iterable[ElementSet] = ()):
        self._packed = _Packed()
        self._record: dict[int, bytes] = {}  # merged after the file was read
        self._name: dict[int, str] = {}
        self._built: OrderedDict[int, ElementSet] = OrderedDict()
        self.merge(sets)

    @classmethod
    def _of_packed(cls, packed: _Packed) -> Catalog:
        cat = cls()
        cat._packed = packed
        return cat

    # -- storage --------------------------------------------------------------------

    @staticmethod
    def path_in(directory: str | os.PathLike[str]) -> Path:
        return Path(directory) / CATALOG_FILE

    @classmethod
    def load(cls, directory: str | os.PathLike[str]) -> Catalog:
        """The catalog stored in ``directory`` (empty if there is none yet). Read a record
        at a time when written one a line (never the whole file's objects at once)."""
        path = cls.path_in(directory)
        try:
            fh = open(path, encoding="utf-8")
        except FileNotFoundError:
            return cls()
        except OSError as exc:
            raise CatalogError(f"{path}: cannot read the catalog: {exc}") from None
        with fh:
            packer = _Packer(os.fstat(fh.fileno()).st_size)
            try:
                head = fh.readline()
                records = _record_lines(fh, path) if head.rstrip("\r\n") == _CATALOG_HEAD \
                    else ((rec, None) for rec in _whole_catalog(head + fh.read(), path))
                for i, (rec, text) in enumerate(records, start=1):
                    try:
                        packer.add(*_checked_record(rec, f"{path}: set {i}", text))
                    except (ElementsError, TypeError, KeyError, AttributeError, ValueError) as exc:
                        raise CatalogError(f"{path}: set {i}: corrupt record: {exc}") from None
            except (OSError, UnicodeDecodeError) as exc:
                raise CatalogError(f"{path}: cannot read the catalog: {exc}") from None
        return cls._of_packed(packer.pack())

    def save(self, directory: str | os.PathLike[str]) -> Path:
        """Write atomically (temporary file + rename) so a crash never leaves half a file."""
        return write_catalog(directory, (self._record_of(n).decode("utf-8") for n in self._ids()))

    def records(self) -> list[bytes]:
        """Every set's record (JSON text, by NORAD id): what a worker process rebuilds the
        sets from (:meth:`ElementSet.from_record`) without this process building them."""
        return [self._record_of(n) for n in self._ids()]

    # -- contents -------------------------------------------------------------------

    def merge(self, sets: Iterable[ElementSet]) -> MergeResult:
        """Add sets; a NORAD id already present is replaced only by a newer epoch."""
        added, updated, kept = [], [], []
        for es in sets:
            if es.norad_id not in self:
                added.append(es.norad_id)
            elif es.epoch > self._epoch(es.norad_id):
                updated.append(es.norad_id)
            else:
                kept.append(es.norad_id)
                continue
            self._record[es.norad_id] = json.dumps(es.to_record()).encode("utf-8")
            self._name[es.norad_id] = es.name
            self._keep(es)
        return MergeResult(tuple(added), tuple(updated), tuple(kept))

    def _ids(self) -> list[int]:
        """Every NORAD id, sorted."""
        if not self._record:
            return list(self._packed.ids)
        return sorted(set(self._packed.ids).union(self._record))

    def _record_of(self, norad_id: int) -> bytes:
        rec = self._record.get(norad_id)
        if rec is not None:
            return rec
        i = self._packed.find(norad_id)
        if i is None:
            raise KeyError(norad_id)
        return self._packed.record(i)

    def _names(self) -> list[tuple[int, str]]:
        """(NORAD id, name) of every set, by NORAD id."""
        packed = dict(zip(self._packed.ids, self._packed.name_list())) if self._record else None
        if packed is None:
            return list(zip(self._packed.ids, self._packed.name_list()))
        packed.update(self._name)
        return sorted(packed.items())

    def _keep(self, es: ElementSet) -> None:
        self._built[es.norad_id] = es
        self._built.move_to_end(es.norad_id)
        while len(self._built) > CACHED_SETS:
            self._built.popitem(last=False)

    def _epoch(self, norad_id: int) -> datetime:
        es = self._built.get(norad_id)
        return es.epoch if es is not None else _record_epoch(json.loads(self._record_of(norad_id)))

    def _set(self, norad_id: int, keep: bool = True) -> ElementSet:
        """The ElementSet of ``norad_id``, built from its record unless kept."""
        es = self._built.get(norad_id)
        if es is None:
            es = ElementSet.from_record(json.loads(self._record_of(norad_id)), CATALOG_FILE)
            if not keep:
                return es
        self._keep(es)
        return es

    def __len__(self) -> int:
        return len(self._packed.ids) + sum(1 for n in self._record if self._packed.find(n) is None)

    def __iter__(self) -> Iterator[ElementSet]:
        """Every set, by NORAD id (each built as it comes; the kept ones stay as they are)."""
        return (self._set(n, keep=False) for n in self._ids())

    def __contains__(self, norad_id: object) -> bool:
        if norad_id in self._record:
            return True
        return isinstance(norad_id, int) and not isinstance(norad_id, bool) and self._packed.find(norad_id) is not None

    def get(self, key: str | int) -> ElementSet:
        """By NORAD id (int or digits), else by name: exact (any case), else a unique prefix."""
        if isinstance(key, int) and not isinstance(key, bool):
            if key in self:
                return self._set(key)
            raise SatelliteNotFound(f"no satellite with NORAD id {key} in the catalog "
                                    f"({len(self)} sets)")
        text = str(key).strip()
        if text.isdigit() and int(text) in self:
            return self._set(int(text))
        want = _norm(text)
        if not want:
            raise SatelliteNotFound("expected a satellite name or NORAD id, found nothing")
        names = self._names()
        exact = [n for n, name in names if _norm(name) == want]
        if len(exact) == 1:
            return self._set(exact[0])
        if len(exact) > 1:
            raise self._ambiguous(text, [self._set(n, keep=False) for n in exact], "share the name")
        prefix = [n for n, name in names if _norm(name).startswith(want)]
        if len(prefix) == 1:
            return self._set(prefix[0])
        if len(prefix) > 1:
            raise self._ambiguous(text, [self._set(n, keep=False) for n in prefix], "start with")
        close = difflib.get_close_matches(text.upper(), [name.upper() for _, name in names], n=3)
        hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
        what = "NORAD id" if text.isdigit() else "name"
        raise SatelliteNotFound(f"no satellite with {what} {text!r} in the catalog "
                                f"({len(self)} sets){hint}")

    @staticmethod
    def _ambiguous(text: str, matches: list[ElementSet], how: str) -> AmbiguousSatellite:
        shown = ", ".join(f"{es.name!r} ({es.norad_id})" for es in matches[:8])
        more = f" and {len(matches) - 8} more" if len(matches) > 8 else ""
        return AmbiguousSatellite(f"{len(matches)} satellites {how} {text!r}: {shown}{more}; "
                                  "give more of the name or the NORAD id", tuple(matches))

    def select(self, keys: Iterable[str | int]) -> list[ElementSet]:
        """:meth:`get` for each key, in order."""
        return [self.get(k) for k in keys]


def _checked_record(rec: Any, source: str, text: str | None) -> tuple[int, str, bytes]:
    """(NORAD id, name, JSON text) of one record of a stored catalog (``text``: its JSON
    text, if at hand), checked as when its set was built, without building a Satrec."""
    if not isinstance(rec, dict):
        raise ElementsError(f"{source}: expected a record (an object), found {_short(repr(rec))}")
    if "omm" in rec:
        norad_id = _omm_fields(dict(rec["omm"]), source)["NORAD_CAT_ID"]
    elif "tle" in rec and len(rec["tle"]) == 2:
        l1, l2 = (str(x) for x in rec["tle"])
        _check_tle(l1, l2, source, 0, 0, True)
        norad_id = _tle_norad_id(l1)
    else:
        raise CatalogError(f"{source}: record for {rec.get('name', '?')!r}: expected a "
                           "'tle' pair or an 'omm' table, found neither")
    if not rec.get("source"):   # (as ElementSet.from_record names it)
        rec, text = dict(rec, source=source), None
    return norad_id, str(rec.get("name", "")), (text or json.dumps(rec)).encode("utf-8")


def _record_epoch(rec: Mapping[str, Any]) -> datetime:
    """A stored record's epoch: as written beside it (derived from its elements when it
    was built), else from the elements themselves."""
    try:
        epoch = datetime.fromisoformat(rec["epoch"])
    except (KeyError, TypeError, ValueError):
        return ElementSet.from_record(rec, CATALOG_FILE).epoch
    return epoch if epoch.tzinfo is not None else epoch.replace(tzinfo=timezone.utc)


def _record_lines(fh: IO[str], path: Path) -> Iterator[tuple[Any, str]]:
    """The records of a catalog written by write_catalog, one a line, after its head:
    (record, its JSON text)."""
    for lineno, raw in enumerate(fh, start=2):
        line = raw.strip()
        if line == "]}":
            rest = fh.read().strip()
            if rest:
                raise CatalogError(f"{path}:{lineno + 1}: corrupt catalog: text after its end: "
                                   f"{_short(rest)}; {_REBUILD}")
            return
        if not line:
            continue
        text = line[:-1] if line.endswith(",") else line
        try:
            rec = json.loads(text)
        except json.JSONDecodeError as exc:
            raise CatalogError(f"{path}:{lineno}:{exc.colno}: corrupt catalog: {exc.msg}; "
                               f"{_REBUILD}") from None
        yield rec, text
    raise CatalogError(f"{path}: corrupt catalog: it ends before its closing ']}}' (truncated); "
                       f"{_REBUILD}")


def _whole_catalog(raw: str, path: Path) -> list[Any]:
    """The records of a catalog in any other JSON layout, read whole."""
    try:
        data = json.loads(raw)
    except json.JSONDecodeError as exc:
        raise CatalogError(f"{path}:{exc.lineno}:{exc.colno}: corrupt catalog: {exc.msg}; "
                           f"{_REBUILD}") from None
    if not isinstance(data, dict) or data.get("format") != _CATALOG_FORMAT \
            or not isinstance(data.get("sets"), list):
        raise CatalogError(f"{path}: expected a urc catalog (format {_CATALOG_FORMAT!r}), "
                           "found something else")
    if data.get("version") != _CATALOG_VERSION:
        raise CatalogError(f"{path}: catalog version {data.get('version')!r}, this urc "
                           f"reads version {_CATALOG_VERSION}")
    return data["sets"]


def write_catalog(directory: str | os.PathLike[str], records: Iterable[str]) -> Path:
    """Write a catalog of JSON ``records`` (one per line, so it can be read as it goes),
    atomically (temporary file + rename): a crash never leaves half a file."""
    path = Catalog.path_in(directory)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write(f'{{"format": "{_CATALOG_FORMAT}", "version": {_CATALOG_VERSION}, "sets": [\n')
        first = True
        for rec in records:
            fh.write(("" if first else ",\n") + rec)
            first = False
        fh.write("\n]}\n")
    os.replace(tmp, path)
    return path


def _catalog_records(directory: str | os.PathLike[str]) -> Iterator[str]:
    """The records of the stored catalog as JSON text, one at a time (a catalog written
    one record per line is read as it goes; an older layout is read whole)."""
    path = Catalog.path_in(directory)
    try:
        fh = open(path, encoding="utf-8")
    except FileNotFoundError:
        return
    with fh:
        head = fh.readline()
        if head.startswith('{"format": "urc-catalog", "version": 1, "sets": ['):
            for line in fh:
                line = line.strip().rstrip(",")
                if line.startswith("{"):
                    yield line
            return
    for rec in Catalog.load(directory).records():  # (checks the format and says what is wrong)
        yield rec.decode("utf-8")


#: NORAD catalog numbers go to 339999 (Alpha-5: A0000..Z9999 above 99999)
_MAX_NORAD = 340000


class StreamingImport:
    """Merge element files into the stored catalog without holding either whole (a
    50 MB file of 350k sets peaked at 818 MB as ElementSets): each set is read,
    checked and written to a spill file; per NORAD id only the newest epoch and where its
    record lies are kept (arrays, ~5 MB); the catalog is then written from the spill."""

    def __init__(self, catalog_dir: str | os.PathLike[str]):
        import tempfile

        import numpy as np

        self.catalog_dir = Path(catalog_dir)
        self.catalog_dir.mkdir(parents=True, exist_ok=True)
        self._spill = tempfile.TemporaryFile(mode="w+b", dir=self.catalog_dir, prefix=".import-")
        self._epoch = np.full(_MAX_NORAD, np.nan)
        self._where = np.full(_MAX_NORAD, -1, dtype=np.int64)
        self._length = np.zeros(_MAX_NORAD, dtype=np.int32)
        for rec in _catalog_records(self.catalog_dir):
            data = json.loads(rec)
            self._put(int(data["norad_id"]), datetime.fromisoformat(data["epoch"]).timestamp(), rec)

    def _put(self, norad_id: int, epoch_unix_s: float, rec: str) -> str:
        """'added', 'updated' or 'kept' (the stored one is as new)."""
        if not 0 <= norad_id < _MAX_NORAD:
            raise ElementsError(f"NORAD id {norad_id} outside 0..{_MAX_NORAD - 1}",
                                expected="a NORAD id", found=norad_id)
        old = self._epoch[norad_id]
        if old == old and epoch_unix_s <= old:   # (old == old: not NaN, one is stored)
            return "kept"
        data = rec.encode("utf-8")
        self._where[norad_id] = self._spill.seek(0, os.SEEK_END)
        self._length[norad_id] = len(data)
        self._spill.write(data)
        self._epoch[norad_id] = epoch_unix_s
        return "added" if old != old else "updated"

    def merge(self, sets: Iterable[ElementSet]) -> MergeResult:
        got: dict[str, list[int]] = {"added": [], "updated": [], "kept": []}
        for es in sets:
            got[self._put(es.norad_id, es.epoch_unix_s, json.dumps(es.to_record()))].append(es.norad_id)
        return MergeResult(tuple(got["added"]), tuple(got["updated"]), tuple(got["kept"]))

    def __len__(self) -> int:
        return int((self._where >= 0).sum())

    def save(self) -> Path:
        import numpy as np

        def records() -> Iterator[str]:
            for norad_id in np.flatnonzero(self._where >= 0):
                self._spill.seek(int(self._where[norad_id]))
                yield self._spill.read(int(self._length[norad_id])).decode("utf-8")
        try:
            return write_catalog(self.catalog_dir, records())
        finally:
            self._spill.close()

    def close(self) -> None:
        self._spill.close()


def iter_elements(path: str | os.PathLike[str], *, checksum: bool = True) -> Iterator[ElementSet]:
    """The sets of an element file one at a time: TLE/3LE read as it goes (the big
    files); OMM JSON or CSV read whole (CelesTrak's group files are small)."""
    source = os.fspath(path)
    try:
        fh = open(source, "rb")
    except OSError as exc:
        raise _unreadable(source, exc) from None
    with fh:
        head = fh.read(4096)
        text_head = head.decode("utf-8", errors="replace").lstrip("\ufeff \t\r\n")
        first = text_head.split("\n", 1)[0]
        if text_head.startswith(("[", "{", "<")) or ("," in first and ("NORAD_CAT_ID" in first
                                                                          or "OBJECT_NAME" in first)):
            yield from load_elements(source, checksum=checksum)
            return
        fh.seek(0)

        def lines() -> Iterator[str]:
            for lineno, raw in enumerate(fh, start=1):
                try:
                    yield raw.decode("utf-8").lstrip("\ufeff") if lineno == 1 else raw.decode("utf-8")
                except UnicodeDecodeError as exc:
                    raise ElementsError(f"{source}:{lineno}: expected text (ASCII/UTF-8), found byte "
                                        f"0x{raw[exc.start]:02x}: a binary or corrupt file",
                                        path=source, line=lineno, expected="text",
                                        found=raw[exc.start:exc.start + 1]) from None
        count = 0
        for es in iter_tle(lines(), source, checksum=checksum):
            count += 1
            yield es
        if not count:
            raise ElementsError(f"{source}: expected at least one element set, found none",
                                path=source, expected="element sets", found="none")


def import_file(path: str | os.PathLike[str], catalog_dir: str | os.PathLike[str], *,
                checksum: bool = True) -> MergeResult:
    """Read an element file and merge it into the catalog stored in ``catalog_dir``
    (streaming: neither is held whole). Sets sgp4 cannot propagate are left out."""
    imp = StreamingImport(catalog_dir)
    try:
        result = imp.merge(es for es in iter_elements(path, checksum=checksum) if not es.sgp4_error)
    except BaseException:
        imp.close()
        raise
    imp.save()
    return result
