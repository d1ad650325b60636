"""Fixtures: a real Mosquitto per test, real ``urc run`` stations connected to it."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import pytest
from urc_process import UrcProcess

from .broker import Client, Mosquitto


@pytest.fixture
def broker(tmp_path):
    b = Mosquitto(tmp_path / "broker").start()
    yield b
    b.stop()


@pytest.fixture
def clients():
    made: list[Client] = []

    def make(port: int, **kw) -> Client:
        c = Client(port, **kw)
        made.append(c)
        return c
    yield make
    for c in made:
        c.close()


def mqtt_section(url: str, **keys) -> str:
    lines = ["[mqtt]", f'url = "{url}"'] + [f"{k} = {v!r}".replace("'", '"') if isinstance(v, str)
                                            else f"{k} = {str(v).lower()}" for k, v in keys.items()]
    return "\n".join(lines) + "\n"


@pytest.fixture
def station(tmp_path, urc_processes):
    """``station(name, url, **mqtt_keys)``: a started ``urc run`` named ``name`` whose
    [mqtt] points at ``url`` (``station_extra``: more config, e.g. a [station] position)."""
    made: list[UrcProcess] = []

    def make(name: str, url: str, station_extra: str = "", start: bool = True, **mqtt_keys) -> UrcProcess:
        work = tmp_path / name
        work.mkdir()
        u = urc_processes(work, extra=f'[station]\nname = "{name}"\n{station_extra}' + mqtt_section(url, **mqtt_keys))
        made.append(u)
        return u.start() if start else u
    yield make
    # (stopped together, not one after another as urc_processes would: each stop waits for
    # its axes to rest and its processes to end; urc_processes then finds them stopped)
    with ThreadPoolExecutor(max(len(made), 1)) as pool:
        list(pool.map(UrcProcess.stop, made))
