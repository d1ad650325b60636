"""Harnesses for tests and benchmarks: passes flown on the simulator and judged by its
truth (:mod:`.evaluate`), a bridged controller on the virtual clock (:mod:`.bridged_rig`).

Importable by tests/ and bench/ (shipped like gpiozero's mock pins), never by urc itself:
tests/test_layers.py checks that no library module imports this package.
"""
