"""The data both processes share: the status (Status, AxisStatus), the rotator's
settings, the link's messages, a pass program, and the request effects a protocol
session yields. Protocols and the front panel import only this of the rotator; it
imports nothing of the control process, the link or the procedures (.importlinter)."""
