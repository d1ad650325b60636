"""``python -m urc`` is the ``urc`` command."""

from .entry import main

main()
