"""Hamlib's NET rotctl wire format (protocols.md section 1): :mod:`.commands` holds the
command table and Hamlib's return codes, :mod:`.codec` reads argument words and writes
replies and requests. urc's rotctld server (:mod:`urc.protocols.rotctld`) and the
bridge's client to a ``rotctld`` both use it."""
