"""Wire formats: pure functions from bytes to values and back, no state, no I/O.

Each module here is one controller protocol's format, both of its ends: the device side
that urc's protocol sessions (:mod:`urc.protocols`) serve, and the host side that the
bridge's dialects (:mod:`urc.hardware.bridge.dialects`) speak to a real controller. So
this package sits below both, and imports nothing of urc but :mod:`urc.errors` (their
parse errors are :class:`urc.errors.ProtocolError`s): a format never knows a rotator,
a status snapshot or a session. A protocol only urc serves keeps its codec beside its
session (``urc/protocols/<name>_codec.py``).
"""
