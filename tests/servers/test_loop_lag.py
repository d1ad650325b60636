"""The loop-lag probe (urc.servers.loop_lag): a blocked event loop shows as a late timer,
in the summary /api/status serves and in the opt-in log bench/loop_lag.py reads."""

from __future__ import annotations

import asyncio
import time

from urc.servers import loop_lag

#: how long the test holds the loop (the probe can only see it late by at least this)
BLOCK_S = 0.3


def test_a_blocked_loop_is_seen_late_by_at_least_the_block(tmp_path, monkeypatch):
    log = tmp_path / "lag.log"
    monkeypatch.setenv(loop_lag.LOG_ENV, str(log))
    monkeypatch.setattr(loop_lag, "_probe", None)

    async def main() -> tuple[dict, dict | None]:
        probe = loop_lag.start(period_s=0.02)
        assert loop_lag.start() is probe   # once per process
        while probe.samples < 3:
            await asyncio.sleep(0.01)
        time.sleep(BLOCK_S)                # a blocking call on the loop
        seen = probe.samples
        while probe.samples < seen + 2:
            await asyncio.sleep(0.01)
        out = loop_lag.summary()
        probe.task.cancel()
        await asyncio.gather(probe.task, return_exceptions=True)
        return out, loop_lag.summary()

    running, stopped = asyncio.run(main())
    assert running["max_ms"] >= BLOCK_S * 1000 - 20 and running["max_since_start_ms"] == running["max_ms"]
    assert running["p50_ms"] <= running["p99_ms"] <= running["max_ms"]
    assert running["samples"] >= 5 and running["period_s"] == 0.02
    assert stopped is None   # no probe running: /api/status says null
    lines = log.read_text().splitlines()
    assert len(lines) == running["samples"] or len(lines) == running["samples"] + 1
    assert max(float(line.split()[1]) for line in lines) >= BLOCK_S * 1000 - 20
