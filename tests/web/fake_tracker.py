"""A stand-in tracker that honours the dashboard's tracking contract (for page tests)."""

from __future__ import annotations

from datetime import datetime, timedelta, timezone


#: a plan note as the planner words one (the page shows the plan's notes while tracking)
KEYHOLE_NOTE = ("keyhole: the sky track needs 26.8 deg/s in azimuth at culmination; the azimuth holds "
                "72.0 deg there, off the track for 14 s, while the elevation sweeps over the top")


class FakeTracker:
    def __init__(self):
        self.calls: list[tuple] = []
        self.active: dict | None = None
        now = datetime.now(timezone.utc).replace(microsecond=0)
        self.pass_list = [
            {"norad": 25544, "name": "ISS (ZARYA)", "aos": (now + timedelta(minutes=12)).isoformat(),
             "tca": (now + timedelta(minutes=17)).isoformat(), "los": (now + timedelta(minutes=22)).isoformat(),
             "max_el_deg": 63.2, "aos_az_deg": 221.0, "los_az_deg": 48.0},
            {"norad": 43017, "name": "<b>FOX-1B</b>", "aos": (now + timedelta(hours=2)).isoformat(),
             "tca": (now + timedelta(hours=2, minutes=6)).isoformat(),
             "los": (now + timedelta(hours=2, minutes=12)).isoformat(),
             "max_el_deg": 18.4, "aos_az_deg": 160.0, "los_az_deg": 20.0},
        ]

    def passes(self, hours: float, min_el_deg: float) -> list[dict]:
        self.calls.append(("passes", hours, min_el_deg))
        return self.pass_list

    def track(self, request: dict) -> None:
        self.calls.append(("track", request))
        self.active = {"target": request.get("name") or request["kind"], "az_deg": 120.0, "el_deg": 30.0,
                       "plan": None, "ground_track": None, "footprint_km": None}

    def track_pass(self, norad: int, aos: datetime) -> None:
        self.calls.append(("track_pass", norad, aos))
        start = aos
        track = []
        for i in range(61):  # a pass from SW, high over the station, to NE
            t = start + timedelta(seconds=10 * i)
            f = i / 60
            track.append([t.isoformat(), (221.0 + 187.0 * f) % 360.0, 63.2 * (1 - (2 * f - 1) ** 2)])
        ground = [[-40.0 + 1.4 * i, -60.0 + 3.0 * i] for i in range(61)]
        self.active = {"target": "ISS (ZARYA)", "az_deg": 221.0, "el_deg": 0.0,
                       "plan": {"aos": aos.isoformat(), "los": (aos + timedelta(minutes=10)).isoformat(),
                                "flip": False, "wrap_turns": 0, "track": track,
                                "notes": [KEYHOLE_NOTE]},
                       "ground_track": ground, "footprint_km": 2200.0,
                       "sat_lat_deg": 12.0, "sat_lon_deg": 20.0, "station": {"lat_deg": 59.4, "lon_deg": 24.7}}

    def stop(self) -> None:
        self.calls.append(("stop",))
        self.active = None

    def status(self) -> dict | None:
        return self.active
