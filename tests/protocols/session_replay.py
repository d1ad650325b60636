"""Helpers shared by the line-protocol session tests: put the antenna somewhere, and
replay one script through a fresh session cut into pieces in different ways."""

from __future__ import annotations
from urc.testing.sessions import fed


def at(b, az: float, el: float) -> None:
    """Re-reference the (still) antenna so it reads exactly (az, el)."""
    b.rot.set_position(az, el)
    b.run(1.0)  # a few ticks at rest: the speed estimate settles, `moving` is False


def replay_splits(bench, cls, script: bytes, cuts: tuple[int, int]) -> list[tuple]:
    """``script`` fed whole, a byte at a time, and in three pieces cut at ``cuts``, each
    to a new session on a new rotator at (10, 10): [(replies, target az, target el)]."""
    a, c = cuts
    results = []
    for chunks in ([script], [script[i:i + 1] for i in range(len(script))],
                   [script[:a], script[a:c], script[c:]]):
        b = bench("tartu-urc")
        at(b, 10, 10)
        s = cls(b.rot)
        out = []
        for chunk in chunks:
            out += fed(s, chunk)
        b.run(0.5)
        st_ = b.rot.status()
        results.append((out, st_.target_az_deg, st_.target_el_deg))
    return results


def raises_nothing(test):
    """For fuzz tests (issue 12.21): a session answers an unexpected exception with its
    protocol's error reply, so replies alone cannot show one; fail every example in
    which a session counted one (urc.protocols.base.INTERNAL_ERRORS)."""
    import functools

    from urc.protocols.base import internal_error_count

    @functools.wraps(test)
    def checked(*args, **kwargs):
        before = internal_error_count()
        test(*args, **kwargs)
        assert internal_error_count() == before, "a session hit an unexpected exception (see the log)"
    return checked
