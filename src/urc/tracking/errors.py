"""Errors of the tracking library, all below :class:`urc.errors.UrcError`.

Messages name where the problem is (file, line, column or record), what was expected
and what was found, like :class:`urc.errors.ConfigError`.
"""

from __future__ import annotations

from ..errors import UrcError


class TrackingError(UrcError):
    """Root of the tracking errors."""


class ElementsError(TrackingError):
    """An element-set file (TLE/3LE, OMM JSON or CSV) is corrupt or not understood."""

    def __init__(self, message: str, *, path: str | None = None, line: int | None = None,
                 column: int | None = None, expected: str | None = None, found: object = None):
        self.path, self.line, self.column = path, line, column
        self.expected, self.found = expected, found
        super().__init__(message)


class ChecksumError(ElementsError):
    """A TLE line's checksum digit does not match its contents."""


class CatalogError(TrackingError):
    """The local catalog cannot be read or written, or a lookup failed."""


class SatelliteNotFound(CatalogError, LookupError):
    """No satellite in the catalog matches a name or NORAD id."""


class AmbiguousSatellite(CatalogError, LookupError):
    """A name matches more than one satellite; ``candidates`` lists them."""

    def __init__(self, message: str, candidates: tuple = ()):
        self.candidates = candidates
        super().__init__(message)


class DownloadError(TrackingError):
    """Downloading element sets failed (HTTP error, unexpected answer)."""


class OfflineError(DownloadError):
    """The element-set server could not be reached (no network, DNS, timeout)."""


class StationError(TrackingError):
    """The station position is missing or invalid (no GPS fix, bad coordinates)."""


class TargetError(TrackingError):
    """A target cannot give a position now (no report yet, stale report, decayed orbit)."""
