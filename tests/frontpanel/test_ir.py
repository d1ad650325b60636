"""IR remote keys through the Linux input subsystem's event interface.

/dev/uinput is not available in the test environment, so no real evdev device can be
created: the keys come from :class:`EmulatedKeys`, which implements evdev's
``InputDevice.read_one()``; key names are resolved with evdev's own ecodes table."""

from __future__ import annotations

import pytest

evdev = pytest.importorskip("evdev")
from evdev import ecodes  # noqa: E402

from urc.errors import CommandRejected  # noqa: E402
from urc.frontpanel.ir import DEFAULT_KEYS, EmulatedKeys, key_codes  # noqa: E402


def test_key_map_uses_evdev_names():
    codes = key_codes({"KEY_LEFT": "ccw", "KEY_VOLUMEUP": "up", "0x160": "stop"})
    assert codes == {ecodes.KEY_LEFT: "ccw", ecodes.KEY_VOLUMEUP: "up", 0x160: "stop"}
    with pytest.raises(ValueError):
        key_codes({"KEY_NOPE": "cw"})


def test_ir_key_held_jogs_and_key_up_stops(panel_rig):
    keys = EmulatedKeys()
    rig = panel_rig(ir=(keys, key_codes(DEFAULT_KEYS)))
    rig.rot.goto(100.0, 30.0)
    rig.settle()
    keys.press(ecodes.KEY_LEFT)
    rig.run(0.5)
    for _ in range(10):       # the remote's auto-repeat while held
        keys.repeat(ecodes.KEY_LEFT)
        rig.run(0.1)
    st = rig.rot.status()
    assert st.az.pos_deg < 95.0 and st.az.rate_deg_per_s < 0
    with pytest.raises(CommandRejected, match="CCW IR"):
        rig.rot.goto(10.0, 10.0)
    keys.release(ecodes.KEY_LEFT)
    st = rig.settle()
    at = st.az.pos_deg
    assert abs(rig.run(2.0).az.pos_deg - at) < 0.5
    rig.rot.goto(10.0, 10.0)  # released: the client commands again


def test_lost_receiver_stops_the_jog(panel_rig):
    class Vanishing(EmulatedKeys):
        gone = False

        def read_one(self):
            if self.gone:
                raise OSError(19, "No such device")
            return super().read_one()

    keys = Vanishing()
    rig = panel_rig(ir=(keys, key_codes(DEFAULT_KEYS)))
    rig.rot.goto(100.0, 30.0)
    rig.settle()
    keys.press(ecodes.KEY_RIGHT)
    rig.run(1.0)
    assert rig.rot.status().az.rate_deg_per_s > 0
    keys.gone = True          # unplugged while the key was held: no key-up will come
    st = rig.settle()
    assert st.local_control == () and "IR receiver lost" in rig.panel.ir.error
    assert abs(rig.run(2.0).az.pos_deg - st.az.pos_deg) < 0.5
