"""Download CelesTrak element groups into the local catalog, politely.

CelesTrak refreshes its GP data every two hours and blocks clients that fetch the same
group more often, so a group downloaded less than ``max_age_s`` (2 h) ago is taken from
the cache unless forced. Each group's answer (OMM JSON) is kept as it came in
``<catalog>/celestrak/<group>.json`` beside a small metadata file; the catalog merges
them, newest epoch per NORAD id winning.

The network sits behind one injectable function, ``fetch(url, timeout_s) -> bytes``;
tests pass a fake one and nothing here touches the network by itself.
"""

from __future__ import annotations

import json
import os
import re
import socket
import time
import urllib.error
import urllib.parse
import urllib.request
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable, Iterable

from .elements import Catalog, ElementSet, MergeResult, parse_omm_json
from .errors import DownloadError, ElementsError, OfflineError

__all__ = ["CELESTRAK_GP_URL", "DEFAULT_GROUPS", "GroupUpdate", "UpdateReport", "fetch_url",
           "update_catalog"]

CELESTRAK_GP_URL = "https://celestrak.org/NORAD/elements/gp.php?GROUP={group}&FORMAT=json"
#: what `urc tle update` fetches with no group named.
DEFAULT_GROUPS = ("stations", "amateur", "weather", "noaa", "cubesat")
#: CelesTrak updates every 2 h and asks clients not to fetch more often.
MIN_INTERVAL_S = 2 * 3600.0
CACHE_DIR = "celestrak"
_GROUP_RE = re.compile(r"[a-z0-9][a-z0-9-]{0,39}\Z")

Fetch = Callable[[str, float], bytes]
Progress = Callable[[int, int, str], None]


def fetch_url(url: str, timeout_s: float) -> bytes:
    """GET ``url`` with urllib; network trouble becomes :class:`OfflineError`."""
    from .. import __version__

    req = urllib.request.Request(url, headers={"User-Agent": f"urc/{__version__}"})
    try:
        with urllib.request.urlopen(req, timeout=timeout_s) as resp:
            return resp.read()
    except urllib.error.HTTPError as exc:
        raise DownloadError(f"{url}: HTTP {exc.code} {exc.reason}"
                            + ("; CelesTrak refuses clients that download a group more "
                               "than once in 2 hours" if exc.code == 403 else "")) from None
    except (urllib.error.URLError, socket.timeout, TimeoutError, ConnectionError) as exc:
        reason = getattr(exc, "reason", exc)
        raise OfflineError(f"cannot reach {urllib.parse.urlparse(url).hostname}: {reason}"
                           ) from None


@dataclass(frozen=True)
class GroupUpdate:
    """What happened to one group: ``downloaded``, ``cached`` (fresh enough) or ``failed``."""

    group: str
    status: str
    count: int = 0
    fetched_unix_s: float | None = None
    error: str = ""


@dataclass
class UpdateReport:
    groups: list[GroupUpdate] = field(default_factory=list)
    merge: MergeResult = MergeResult()
    catalog_size: int = 0

    @property
    def failed(self) -> list[GroupUpdate]:
        return [g for g in self.groups if g.status == "failed"]


def _check_group(group: str) -> str:
    g = group.strip().lower()
    if not _GROUP_RE.match(g):
        raise DownloadError(f"group {group!r}: expected a CelesTrak group name like "
                            "'stations' or 'amateur' (letters, digits, '-')")
    return g


def _meta_path(cache: Path, group: str) -> Path:
    return cache / f"{group}.meta.json"


def _read_meta(cache: Path, group: str) -> dict | None:
    try:
        meta = json.loads(_meta_path(cache, group).read_text(encoding="utf-8"))
        return meta if isinstance(meta, dict) and "fetched_unix_s" in meta else None
    except (OSError, ValueError):
        return None


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def _parse_answer(group: str, url: str, raw: bytes) -> list[ElementSet]:
    text = raw.decode("utf-8", "replace").strip()
    # CelesTrak answers an unknown group with a line of text, not JSON
    if not text.startswith(("[", "{")):
        raise DownloadError(f"CelesTrak has no group {group!r} (it answered "
                            f"{text[:60]!r}); see celestrak.org/NORAD/elements/")
    try:
        return parse_omm_json(text, url)
    except ElementsError as exc:
        raise DownloadError(f"group {group!r}: the download is corrupt: {exc}") from None


def _age_text(now_s: float, then_s: float | None) -> str:
    if then_s is None:
        return "never downloaded"
    when = datetime.fromtimestamp(then_s, tz=timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return f"last downloaded {when}, {(now_s - then_s) / 3600.0:.1f} h ago"


def update_catalog(groups: Iterable[str], catalog_dir: str | os.PathLike[str], *,
                   fetch: Fetch = fetch_url, force: bool = False,
                   max_age_s: float = MIN_INTERVAL_S, timeout_s: float = 30.0,
                   progress: Progress | None = None,
                   now_unix_s: Callable[[], float] = time.time,
                   url_template: str = CELESTRAK_GP_URL) -> UpdateReport:
    """Bring the catalog in ``catalog_dir`` up to date with CelesTrak ``groups``.

    A group fetched less than ``max_age_s`` ago is read from the cache (``force``
    downloads anyway). ``progress(done, total, group)`` is called after each group.
    Groups that download go into the catalog even if others fail; then, if any failed,
    :class:`OfflineError` (network) or :class:`DownloadError` is raised with the
    ``report`` attached and a message saying how old the elements still in use are.
    """
    names = [_check_group(g) for g in groups]
    if not names:
        raise DownloadError("no CelesTrak group to update; name one (e.g. 'stations')")
    root = Path(catalog_dir)
    cache = root / CACHE_DIR
    cache.mkdir(parents=True, exist_ok=True)
    report = UpdateReport()
    sets: list[ElementSet] = []
    offline: list[str] = []
    for i, group in enumerate(names, start=1):
        now = now_unix_s()
        meta = _read_meta(cache, group)
        data_path = cache / f"{group}.json"
        fresh = (meta is not None and data_path.exists()
                 and now - float(meta["fetched_unix_s"]) < max_age_s)
        if fresh and not force and meta is not None:
            try:
                got = _parse_answer(group, str(data_path), data_path.read_bytes())
                sets += got
                report.groups.append(GroupUpdate(group, "cached", len(got),
                                                 float(meta["fetched_unix_s"])))
                if progress:
                    progress(i, len(names), group)
                continue
            except (OSError, DownloadError):
                pass  # unreadable cache: download it again
        url = url_template.format(group=group)
        try:
            raw = fetch(url, timeout_s)
            got = _parse_answer(group, url, raw)
        except OfflineError as exc:
            offline.append(group)
            report.groups.append(GroupUpdate(group, "failed", error=str(exc),
                                             fetched_unix_s=(meta or {}).get("fetched_unix_s")))
        except (DownloadError, OSError) as exc:
            report.groups.append(GroupUpdate(group, "failed", error=str(exc),
                                             fetched_unix_s=(meta or {}).get("fetched_unix_s")))
        else:
            _write_atomic(data_path, raw)
            _write_atomic(_meta_path(cache, group), json.dumps(
                {"url": url, "fetched_unix_s": now, "count": len(got)}).encode())
            sets += got
            report.groups.append(GroupUpdate(group, "downloaded", len(got), now))
        if progress:
            progress(i, len(names), group)
    cat = Catalog.load(root)
    report.merge = cat.merge(sets)
    if sets:
        cat.save(root)
    report.catalog_size = len(cat)
    if report.failed:
        now = now_unix_s()
        lines = [f"  {g.group}: {g.error} ({_age_text(now, g.fetched_unix_s)})"
                 for g in report.failed]
        kept = ("the catalog keeps the elements it had" if len(cat) else
                "the catalog is empty")
        head = (f"cannot download {len(report.failed)} of {len(names)} CelesTrak group(s); "
                f"{kept}:")
        cls = OfflineError if offline and len(offline) == len(report.failed) else DownloadError
        err = cls("\n".join([head, *lines]))
        err.report = report  # type: ignore[attr-defined]
        raise err
    return report
