"""Tracking library: element sets and catalog, propagation, pass search, targets.

Public API (the submodules hold the details)::

    from urc.tracking import Catalog, load_elements, Station, NmeaStation
    from urc.tracking import look_angles, find_passes, SatelliteTarget, SunTarget

Everything is offline: skyfield's data comes from the ``skyfield-data`` package and only
:func:`urc.tracking.download.update_catalog` (given a fetch function) reaches the network.
"""

# (lazy, PEP 562: the package is imported for urc.tracking.cycle by the web stack of
# every `urc run`, which must not pay numpy/skyfield/sgp4 when tracking is off)
_WHERE = {
    "update_catalog": "download",
    **dict.fromkeys(("Catalog", "ElementSet", "MergeResult", "import_file", "load_elements", "parse_elements",
                     "parse_omm_csv", "parse_omm_json", "parse_tle"), "elements"),
    **dict.fromkeys(("AmbiguousSatellite", "CatalogError", "ChecksumError", "DownloadError", "ElementsError",
                     "OfflineError", "SatelliteNotFound", "StationError", "TargetError", "TrackingError"),
                    "errors"),
    **dict.fromkeys(("Pass", "PassSearch", "find_passes", "search_passes"), "passes"),
    **dict.fromkeys(("LookAngles", "look_angles", "look_angles_many", "moon_look_angles", "sun_look_angles"),
                    "propagate"),
    **dict.fromkeys(("GpsFix", "NmeaStation", "Station"), "station"),
    **dict.fromkeys(("FixedTarget", "GeoPointTarget", "MoonTarget", "NmeaTarget", "SatelliteTarget", "SunTarget",
                     "Target", "parse_target"), "targets"),
}


def __getattr__(name: str):
    where = _WHERE.get(name)
    if where is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from importlib import import_module

    value = getattr(import_module(f"{__name__}.{where}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))


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
