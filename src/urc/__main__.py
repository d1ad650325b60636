"""``python -m urc`` is the ``urc`` command."""

from .cli import main

main()
