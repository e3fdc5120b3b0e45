import pytest

from mavhelm.core.mission import Entry, MissionError
from mavhelm.nav.priority_queue import DEFAULT_TIMEOUT, PriorityQueue, Source


def queue(value: str, key: str = "X") -> PriorityQueue:
    return PriorityQueue.parse(Entry(key, value, "m.moos", 7))


def test_parses_the_spec_example_with_spaces_and_trailing_comma() -> None:
    q = queue("GPS @ 2.0 , EKF @ 2.5 ,LSQ @ 5.0 ,")
    assert q.key == "X"
    assert q.sources == [Source("GPS", 2.0), Source("EKF", 2.5), Source("LSQ", 5.0)]


def test_entry_without_timeout_uses_the_default() -> None:
    q = queue("ekf @2.0 ,LSQ@5, depth", key="Depth")
    assert q.key == "DEPTH"
    assert q.sources == [Source("EKF", 2.0), Source("LSQ", 5.0), Source("DEPTH", 3.0)]
    assert DEFAULT_TIMEOUT == 3.0


@pytest.mark.parametrize(
    "value", ["GPS @ soon", "GPS @ -1", "GPS @ 0", "GPS @", "GPS @ nan", "GPS @ inf"]
)
def test_bad_timeout_is_a_located_error(value: str) -> None:
    with pytest.raises(MissionError) as info:
        queue(value)
    assert str(info.value).startswith("m.moos:7: ")
    assert "timeout of GPS" in info.value.reason


@pytest.mark.parametrize("value", ["", " , ", "INS Speed = EKF", "GPS 2.0", "@ 2", "GPS, gps"])
def test_malformed_queue_is_a_located_error(value: str) -> None:
    with pytest.raises(MissionError) as info:
        queue(value)
    assert (info.value.file, info.value.line) == ("m.moos", 7)


def test_preferred_source_wins_while_fresh() -> None:
    q = queue("GPS @ 2, EKF @ 2.5")
    assert q.offer("GPS", 1.0, 10.0)
    assert not q.offer("EKF", 1.1, 10.5)
    assert q.current_source(11.9) == "GPS"
    assert q.offer("GPS", 1.2, 11.0)


def test_falls_back_when_preferred_goes_quiet_and_pops_back() -> None:
    q = queue("GPS @ 2, EKF @ 2.5, LSQ @ 5")
    assert q.offer("GPS", 1.0, 10.0)
    assert not q.offer("EKF", 1.0, 11.0)
    assert q.current_source(12.0) == "GPS"
    assert q.current_source(12.01) == "EKF"
    assert q.offer("EKF", 2.0, 12.5)
    assert not q.offer("LSQ", 2.0, 12.6)
    assert q.offer("GPS", 3.0, 13.0)
    assert q.current_source(13.0) == "GPS"
    assert not q.offer("EKF", 3.1, 13.1)


def test_lowest_source_only_while_every_higher_is_stale() -> None:
    q = queue("GPS @ 2, EKF @ 2.5, LSQ @ 5")
    q.offer("GPS", 0.0, 0.0)
    q.offer("EKF", 0.0, 1.0)
    assert not q.offer("LSQ", 0.0, 2.0)
    assert not q.offer("LSQ", 0.0, 3.5)
    assert q.offer("LSQ", 0.0, 3.51)
    assert q.current_source(3.51) == "LSQ"


def test_all_stale_means_no_source() -> None:
    q = queue("GPS @ 2, EKF")
    assert q.current_source(0.0) is None
    q.offer("EKF", 0.0, 1.0)
    assert q.current_source(4.0) == "EKF"
    assert q.current_source(4.01) is None


def test_unknown_source_and_time_going_backwards_are_not_published() -> None:
    q = queue("GPS @ 2")
    assert not q.offer("DVL", 1.0, 1.0)
    assert "DVL" not in q
    assert q.offer("GPS", 1.0, 5.0)
    assert not q.offer("GPS", 0.5, 4.0)
    assert q.last_value("GPS") == 1.0
