"""Tracking library: element sets and catalog, propagation, pass search, targets.

Public API (the submodules hold the details)::

    from urc.tracking import Catalog, load_elements, Station, NmeaStation
    from urc.tracking import look_angles, find_passes, SatelliteTarget, SunTarget

Everything is offline: skyfield's data comes from the ``skyfield-data`` package and only
:func:`urc.tracking.download.update_catalog` (given a fetch function) reaches the network.
"""

from .download import update_catalog
from .elements import Catalog, ElementSet, MergeResult, import_file, load_elements, \
    parse_elements, parse_omm_csv, parse_omm_json, parse_tle
from .errors import AmbiguousSatellite, CatalogError, ChecksumError, DownloadError, \
    ElementsError, OfflineError, SatelliteNotFound, StationError, TargetError, TrackingError
from .passes import Pass, PassSearch, find_passes, search_passes
from .propagate import LookAngles, look_angles, look_angles_many, moon_look_angles, \
    sun_look_angles
from .station import GpsFix, NmeaStation, Station
from .targets import FixedTarget, GeoPointTarget, MoonTarget, NmeaTarget, SatelliteTarget, \
    SunTarget, Target, parse_target

__all__ = [
    "AmbiguousSatellite", "Catalog", "CatalogError", "ChecksumError", "DownloadError",
    "ElementSet", "ElementsError", "FixedTarget", "GeoPointTarget", "GpsFix", "LookAngles",
    "MergeResult", "MoonTarget", "NmeaStation", "NmeaTarget", "OfflineError", "Pass",
    "PassSearch", "SatelliteNotFound", "SatelliteTarget", "Station", "StationError",
    "SunTarget", "Target", "TargetError", "TrackingError", "find_passes", "import_file",
    "load_elements", "look_angles", "look_angles_many", "moon_look_angles", "parse_elements",
    "parse_omm_csv", "parse_omm_json", "parse_target", "parse_tle", "search_passes",
    "sun_look_angles", "update_catalog",
]
