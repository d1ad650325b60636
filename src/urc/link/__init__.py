"""The link between ``urc run``'s two processes: the codec, the shared status record, the
I/O process's client (RemoteRotator) and the control process's server and supervisor
(control_process), the instance locks they share and the adoption of a running control
process by a new ``urc run``."""
