"""Calibration procedures: the one-shot steps run where the hardware is (the query
handlers of urc.rotator.queries call them), the long state machines (zero, pot,
magnetometer, homing, SARCNET's 12 directions) and their maths."""
