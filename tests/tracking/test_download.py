"""Catalog updates from CelesTrak with a fake network: caching, progress, offline errors."""

from __future__ import annotations

import json

import pytest

from urc.tracking.download import CELESTRAK_GP_URL, MIN_INTERVAL_S, fetch_url, update_catalog
from urc.tracking.elements import Catalog
from urc.tracking.errors import DownloadError, OfflineError

from .conftest import FIXTURES, T0_UNIX_S

OMM = json.loads((FIXTURES / "omm.json").read_text())


class FakeNet:
    """``fetch(url, timeout_s)`` answering from a dict of group -> bytes (or exception)."""

    def __init__(self, groups: dict):
        self.groups = groups
        self.calls: list[str] = []

    def __call__(self, url: str, timeout_s: float) -> bytes:
        assert timeout_s > 0
        self.calls.append(url)
        group = url.split("GROUP=")[1].split("&")[0]
        answer = self.groups[group]
        if isinstance(answer, Exception):
            raise answer
        return answer


class Clock:
    def __init__(self, t: float):
        self.t = t

    def __call__(self) -> float:
        return self.t


def groups():
    return {"stations": json.dumps(OMM[:1]).encode(), "weather": json.dumps(OMM[1:]).encode()}


def test_download_then_cache_then_refresh(tmp_path):
    net, clock = FakeNet(groups()), Clock(T0_UNIX_S)
    seen = []
    rep = update_catalog(["stations", "Weather"], tmp_path, fetch=net, now_unix_s=clock,
                         progress=lambda done, total, g: seen.append((done, total, g)))
    assert net.calls == [CELESTRAK_GP_URL.format(group="stations"),
                         CELESTRAK_GP_URL.format(group="weather")]
    assert seen == [(1, 2, "stations"), (2, 2, "weather")]
    assert [(g.group, g.status, g.count) for g in rep.groups] == [
        ("stations", "downloaded", 1), ("weather", "downloaded", 3)]
    assert len(rep.merge.added) == 4 and rep.catalog_size == 4
    assert Catalog.load(tmp_path).get("iss").norad_id == 25544
    assert (tmp_path / "celestrak" / "stations.json").exists()

    clock.t += MIN_INTERVAL_S - 60  # within 2 h: no network at all
    rep = update_catalog(["stations", "weather"], tmp_path, fetch=net, now_unix_s=clock)
    assert len(net.calls) == 2 and {g.status for g in rep.groups} == {"cached"}
    rep = update_catalog(["stations"], tmp_path, fetch=net, now_unix_s=clock, force=True)
    assert len(net.calls) == 3 and rep.groups[0].status == "downloaded"
    clock.t += MIN_INTERVAL_S + 1
    update_catalog(["weather"], tmp_path, fetch=net, now_unix_s=clock)
    assert len(net.calls) == 4


def test_offline_error_says_what_is_kept(tmp_path):
    net, clock = FakeNet(groups()), Clock(T0_UNIX_S)
    update_catalog(["stations"], tmp_path, fetch=net, now_unix_s=clock)
    clock.t += 5 * 3600.0
    net.groups["stations"] = OfflineError("cannot reach celestrak.org: [Errno -3] "
                                          "Temporary failure in name resolution")
    with pytest.raises(OfflineError) as info:
        update_catalog(["stations", "weather"], tmp_path, fetch=net, now_unix_s=clock)
    msg = str(info.value)
    assert msg.startswith("cannot download 1 of 2 CelesTrak group(s); the catalog keeps the "
                          "elements it had:")
    assert "stations: cannot reach celestrak.org" in msg
    assert "last downloaded 2024-01-01 12:00 UTC, 5.0 h ago" in msg
    report = info.value.report
    assert [g.status for g in report.groups] == ["failed", "downloaded"]
    assert len(Catalog.load(tmp_path)) == 4  # weather still went in


def test_offline_with_nothing_cached(tmp_path):
    net = FakeNet({"amateur": OfflineError("cannot reach celestrak.org: timed out")})
    with pytest.raises(OfflineError, match="the catalog is empty:\n  amateur: .*never "
                                           "downloaded"):
        update_catalog(["amateur"], tmp_path, fetch=net, now_unix_s=Clock(T0_UNIX_S))


def test_bad_answers(tmp_path):
    net = FakeNet({"nosuch": b"No GP data found", "broken": b'[{"OBJECT_NAME": "X"',
                   "stations": json.dumps(OMM[:1]).encode()})
    with pytest.raises(DownloadError, match="CelesTrak has no group 'nosuch'"):
        update_catalog(["nosuch"], tmp_path, fetch=net, now_unix_s=Clock(T0_UNIX_S))
    update_catalog(["stations"], tmp_path, fetch=net, now_unix_s=Clock(T0_UNIX_S))
    good = (tmp_path / "celestrak" / "stations.json").read_bytes()
    net.groups["stations"] = b'[{"OBJECT_NAME": "X"'  # truncated download
    with pytest.raises(DownloadError, match="the download is corrupt") as info:
        update_catalog(["stations"], tmp_path, fetch=net, now_unix_s=Clock(T0_UNIX_S),
                       force=True)
    assert not isinstance(info.value, OfflineError)
    assert (tmp_path / "celestrak" / "stations.json").read_bytes() == good  # cache untouched
    with pytest.raises(DownloadError, match="expected a CelesTrak group name"):
        update_catalog(["../etc"], tmp_path, fetch=net)
    with pytest.raises(DownloadError, match="no CelesTrak group"):
        update_catalog([], tmp_path, fetch=net)


def test_real_fetch_reports_offline_quickly():
    # a local port nobody listens on: connection refused, no outside network involved
    with pytest.raises(OfflineError, match="cannot reach 127.0.0.1"):
        fetch_url("http://127.0.0.1:9/gp.php?GROUP=stations", 2.0)
