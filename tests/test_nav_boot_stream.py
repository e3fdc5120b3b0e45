"""The stream of LSQ fixes that boots the EKF: repeatable fixes, one stray held aside."""

from __future__ import annotations

from mavhelm.nav.boot_stream import BOOT_AGREEMENT, BOOT_FIXES, BootStream
from mavhelm.nav.lsq import Fix


def _fix(t: float, x: float, y: float = 0.0) -> Fix:
    return Fix(t=t, x=x, y=y, sigma=1.0, rms=0.5, n=4, beacons=("a", "b", "c", "d"))


def _fed(*xs: float) -> BootStream:
    stream = BootStream()
    for k, x in enumerate(xs):
        stream.add(_fix(float(k), x))
    return stream


def test_three_fixes_that_agree_boot_from_the_newest() -> None:
    assert _fed(0.0, 2.0).ready is None
    ready = _fed(0.0, 2.0, 4.0).ready
    assert ready is not None and ready.x == 4.0
    assert BOOT_FIXES == 3 and BOOT_AGREEMENT == 10.0


def test_a_moving_vehicle_may_drift_further_than_the_agreement_over_the_stream() -> None:
    """Each fix is held against the stream's last, not its first."""
    assert _fed(0.0, 8.0, 16.0).ready is not None


def test_one_stray_between_good_fixes_does_not_break_the_stream() -> None:
    stream = _fed(0.0, 1.0, 45.0, 2.0)
    ready = stream.ready
    assert ready is not None and ready.x == 2.0
    assert stream.strays == 1


def test_a_stray_never_boots_the_filter() -> None:
    """Strays between two good fixes are dropped whatever their number in a row, and never
    counted towards the stream."""
    stream = _fed(0.0, 45.0, -30.0, 80.0)
    assert stream.ready is None and stream.stream[-1].x == 0.0 and stream.strays == 2


def test_two_fixes_that_agree_with_each_other_but_not_the_stream_start_a_new_one() -> None:
    """The vehicle was not where the old stream said (a stream of strays, or it moved while
    the LSQ was silent): the two agreeing fixes are the new stream."""
    stream = _fed(0.0, 1.0, 50.0, 51.0)
    assert [f.x for f in stream.stream] == [50.0, 51.0] and stream.ready is None
    stream.add(_fix(4.0, 52.0))
    ready = stream.ready
    assert ready is not None and ready.x == 52.0


def test_clear_forgets_the_stream_and_the_stray() -> None:
    stream = _fed(0.0, 1.0, 45.0)
    stream.clear()
    stream.add(_fix(3.0, 46.0))
    assert [f.x for f in stream.stream] == [46.0] and stream.stray is None
