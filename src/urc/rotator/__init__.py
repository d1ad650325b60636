"""The control process's rotator: the single owner of both axes and their state, its
parts (axis, core, commands, guard, planning, records, program flight) and the control
loop, and the handlers of the hardware queries (imported here so that a rotator in this
process answers them: urc.model.effects.ask)."""

from . import queries as _queries  # noqa: F401 (registers the query handlers)
