"""Topic names: one station's under its base topic, and the patterns a fleet view reads.

Each station owns ``<base>/...``; ``<base>`` is ``urc/<station>`` unless configured, so
``urc/+/status`` is every station's status on the broker.
"""

from __future__ import annotations

from dataclasses import dataclass

#: the payloads of ``<base>/availability`` (retained; "offline" is also the last will)
ONLINE = "online"
OFFLINE = "offline"


@dataclass(frozen=True)
class Topics:
    base: str

    @property
    def availability(self) -> str:
        return f"{self.base}/availability"

    @property
    def status(self) -> str:
        return f"{self.base}/status"

    @property
    def event(self) -> str:
        return f"{self.base}/event"

    @property
    def cmd(self) -> str:
        return f"{self.base}/cmd"

    @property
    def cmd_result(self) -> str:
        return f"{self.base}/cmd/result"


def fleet_patterns(prefix: str) -> dict[str, str]:
    """Subscriptions that see every station whose base topic is ``<prefix>/<station>``."""
    return {"availability": f"{prefix}/+/availability", "status": f"{prefix}/+/status"}


def station_of(topic: str, prefix: str) -> tuple[str, str] | None:
    """``urc/dish/status`` -> ("dish", "status") under prefix ``urc``; None if not a station's."""
    head = prefix.rstrip("/") + "/"
    if not topic.startswith(head):
        return None
    rest = topic[len(head):].split("/")
    if len(rest) != 2 or not rest[0]:
        return None
    return rest[0], rest[1]
