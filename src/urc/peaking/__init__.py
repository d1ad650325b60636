"""Peaking on a signal in the sky (issue 38): the cross-scan calibration the web hub runs
(:mod:`.procedure`), step-track during a pass (:mod:`.steptrack`) with the pass's
predicted track it corrects (:mod:`.prediction`), and the simulated sky source both
fly against on the simulator (:mod:`.simsource`).

They sit above tracking (a source is a tracking target: the Sun, the Moon, a satellite;
a prediction is a propagated orbit); what they build on, the sources of received power,
the error model, the scans and fits, is :mod:`urc.pointing`, below the hardware, which
applies the model. Tracking gets its step-track from the composition root
(``TrackingService(step_track=...)``): nothing below imports this package.
"""
