"""Examples are templates: a save never writes into one.

``urc run --config examples/bigras.toml`` and then a save (the settings page, ``urc
settings set``) wrote into the git checkout, which then showed as modified. The first
save of a file that ships with urc (the checkout's ``examples/``, anything inside the
installed package) goes to a copy in the user's configuration directory
(``platformdirs.user_config_dir("urc")``, ``~/.config/urc`` on Linux), and from then on
``--config`` naming that example uses the copy.
"""

from __future__ import annotations

import os
from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parents[1]
#: the examples/ of the checkout the package runs from (src layout), if it is one
_CHECKOUT_EXAMPLES = _PACKAGE_DIR.parents[1] / "examples"


def is_example(path: str | os.PathLike) -> bool:
    """True for a file that ships with urc: the checkout's examples/, the package's own files."""
    where = Path(path).resolve()
    return any(where.is_relative_to(d) for d in (_CHECKOUT_EXAMPLES, _PACKAGE_DIR))


def user_copy(path: str | os.PathLike) -> Path:
    """Where the user's copy of the example ``path`` lives (whether or not it exists)."""
    import platformdirs

    return Path(platformdirs.user_config_dir("urc")) / Path(path).name


def in_use(path: str | os.PathLike) -> tuple[Path, str]:
    """The file ``--config path`` means, and a note when it is not ``path`` itself: an
    example a save already copied means the copy."""
    if is_example(path):
        copy = user_copy(path)
        if copy.is_file():
            return copy, (f"{path} is an example; using your copy {copy}, where the settings were saved "
                          f"(delete it to start from the example again)")
    return Path(path), ""
