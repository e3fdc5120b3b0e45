"""The survey check (mavhelm.nav.survey_check): leave-one-out fits of a window of ranges
along the track made good single out the beacon off its survey, and none when every beacon
is where it was surveyed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavhelm.nav.ekf import Beacon
from mavhelm.nav.survey_check import MIN_BEACONS, SurveyCheck

BEACONS = {name: Beacon(name, x, y) for name, x, y in
           (("A", -40.0, 10.0), ("B", 10.0, -30.0), ("C", 25.0, 25.0), ("D", -15.0, 55.0))}
SCALE = 1.067
"""Ranges 6.7 % long, as on Plaza: the fits learn it."""


def _drive(check: SurveyCheck, moved: dict[str, tuple[float, float]], seconds: float,
           seed: int = 1, height: float = 0.0, told: float | None = None,
           warned: list[str] | None = None) -> list[tuple[float, str]]:
    """The vehicle goes round an oval at 1 m/s; the track made good it is told (its velocity)
    is turned 3° and 2 % long, the position it starts from 2 m off. Ranges at 2 Hz, to each
    beacon in turn, from where each truly is (``moved``), σ 0.3 m, heard ``height`` m up
    (the check is ``told`` that height, the same unless given). What ``review`` named,
    when; the misfit warnings into ``warned``."""
    rng = np.random.default_rng(seed)
    turn, stretch = math.radians(3.0), 1.02
    named = []
    dt = 0.1
    for k in range(int(seconds / dt)):
        t = k * dt
        a = t / 40.0
        x, y = 15.0 * math.cos(a), 20.0 + 25.0 * math.sin(a)
        vx, vy = -15.0 / 40.0 * math.sin(a), 25.0 / 40.0 * math.cos(a)
        vx, vy = (stretch * (math.cos(turn) * vx - math.sin(turn) * vy),
                  stretch * (math.sin(turn) * vx + math.cos(turn) * vy))
        check.move(t, x + 2.0, y - 1.0, vx, vy)
        if k % 5 == 0:
            name = "ABCD"[(k // 5) % len(check.beacons)]
            bx, by = moved.get(name, (check.beacons[name].x, check.beacons[name].y))
            dz = height - check.beacons[name].z
            z = SCALE * math.sqrt((x - bx) ** 2 + (y - by) ** 2 + dz**2) + rng.normal(0.0, 0.3)
            check.hear(t, name, z, 1.0, height if told is None else told)
            found = check.review(t)
            if found is not None:
                named.append((t, found))
            warning = check.misfit_warning(t)
            if warning is not None and warned is not None:
                warned.append(warning)
    return named


def test_every_beacon_where_surveyed_none_is_singled_out() -> None:
    for seed in (1, 2, 3):
        check = SurveyCheck(BEACONS)
        warned: list[str] = []
        assert _drive(check, {}, 900.0, seed, warned=warned) == []
        assert warned == []  # nor is the operator told of a misfit
        assert set(check.fits) == {None, "A", "B", "C", "D"}  # it did judge
        assert check.fits[None].chi2 < 0.2  # σ declared 1 m, 0.3 m heard


@pytest.mark.parametrize("name", list(BEACONS))
@pytest.mark.parametrize("bearing", [0.0, 2.0, 4.0])
def test_a_beacon_5_m_off_its_survey_is_singled_out(name, bearing) -> None:
    b = BEACONS[name]
    check = SurveyCheck(BEACONS)
    warned: list[str] = []
    named = _drive(check, {name: (b.x + 5 * math.cos(bearing), b.y + 5 * math.sin(bearing))},
                   400.0, warned=warned)
    assert named and {n for _, n in named} == {name}
    # told as a misfit no one beacon explains at most once, before it was singled out
    assert len(warned) <= 1 and all(f"beacons {name}" in w or f", {name}" in w
                                    for w in warned), warned
    assert named[0][0] <= 300.0
    # the fit without it puts the vehicle where it is, not where the start said
    fit = check.fits[name]
    a = fit.t / 40.0
    assert math.hypot(fit.x - 15.0 * math.cos(a), fit.y - 20.0 - 25.0 * math.sin(a)) < 1.0
    assert 0.0 < fit.sigma < 1.5


FAR = {name: Beacon(name, 1.5 * b.x, 1.5 * b.y) for name, b in BEACONS.items()}
"""The beacons half as far again from the oval: their bearings turn more slowly."""


def _found_far(name: str, bearing: float) -> list[tuple[float, str]]:
    b = FAR[name]
    return _drive(SurveyCheck(FAR), {name: (b.x + 5 * math.cos(bearing),
                                            b.y + 5 * math.sin(bearing))}, 400.0)


@pytest.mark.parametrize("name", list(FAR))
@pytest.mark.parametrize("bearing", [0.0, 2.0, 4.0])
def test_beacons_far_from_the_track_are_told_by_the_long_window(name, bearing) -> None:
    named = _found_far(name, bearing)
    assert named and {n for _, n in named} == {name}


def test_the_short_window_alone_tells_few_far_beacons(monkeypatch) -> None:
    """Why there are two windows: the 60 s one alone finds 2 of these 12 (the 120 s one all
    of them, measured), and neither names a beacon when every one is where surveyed."""
    from mavhelm.nav import survey_check

    draws = [(name, bearing) for name in FAR for bearing in (0.0, 2.0, 4.0)]
    both = sum(bool(_found_far(*draw)) for draw in draws)
    monkeypatch.setattr(survey_check, "WINDOWS", (60.0,))
    short = sum(bool(_found_far(*draw)) for draw in draws)
    assert both == len(draws) and short <= len(draws) // 2
    monkeypatch.undo()
    assert _drive(SurveyCheck(FAR), {}, 900.0) == []


SEABED = {name: Beacon(name, b.x, b.y, -50.0) for name, b in BEACONS.items()}
"""The beacons on a 50 m seabed, heard from a vehicle 30 m down."""


def test_a_vehicle_at_depth_is_judged_from_its_depth() -> None:
    check = SurveyCheck(SEABED)
    assert _drive(check, {}, 900.0, height=-30.0) == []
    assert check.fits[None].chi2 < 0.2
    surface = SurveyCheck(SEABED)  # judged as if at the surface: 30 m of height wrong
    assert _drive(surface, {}, 900.0, height=-30.0, told=0.0) != []  # beacons named wrongly
    assert surface.fits[None].chi2 > 2 * check.fits[None].chi2
    b = SEABED["C"]
    named = _drive(SurveyCheck(SEABED), {"C": (b.x + 5.0, b.y)}, 400.0, height=-30.0)
    assert named and {n for _, n in named} == {"C"}


def test_with_three_beacons_it_is_blind() -> None:
    three = {name: BEACONS[name] for name in "ABC"}
    check = SurveyCheck(three)
    assert check.blind and len(three) < MIN_BEACONS
    assert _drive(check, {"A": (-35.0, 10.0)}, 400.0) == [] and check.fits == {}


def test_a_still_vehicle_tells_nothing() -> None:
    """Still, every bearing stays put: the displaced beacon's error is a constant the shared
    offset and scale absorb as well as any other beacon's."""
    check = SurveyCheck(BEACONS)
    rng = np.random.default_rng(4)
    for k in range(4000):
        t = 0.1 * k
        check.move(t, 1.0, 21.0, 0.0, 0.0)
        if k % 5 == 0:
            name = "ABCD"[(k // 5) % 4]
            b = BEACONS[name]
            bx = b.x + (5.0 if name == "B" else 0.0)
            check.hear(t, name, SCALE * math.hypot(bx, 20.0 - b.y) + rng.normal(0.0, 0.3), 1.0)
            assert check.review(t) is None


def test_a_cleared_window_starts_again() -> None:
    check = SurveyCheck(BEACONS)
    _drive(check, {}, 100.0)
    assert check.heard
    check.clear()
    assert not check.heard
    check.hear(200.0, "A", 40.0, 1.0)  # no track yet: not heard
    assert not check.heard


@pytest.mark.parametrize("where", [(0.0, 0.0), (1e9, 1e9)])
def test_beacons_that_tell_nothing_name_nothing_and_raise_nothing(where) -> None:
    """Four beacons surveyed at one point (a mission typo), or absurdly far: no fit to
    trust, no beacon named, the navigator carries on."""
    same = {name: Beacon(name, *where) for name in "ABCD"}
    check = SurveyCheck(same)
    for k in range(2000):
        t = 0.1 * k
        check.move(t, 0.1 * t, 0.0, 1.0, 0.0)
        if k % 5 == 0:
            check.hear(t, "ABCD"[(k // 5) % 4], 10.0 + 0.01 * k, 1.0)
            assert check.review(t) is None
    assert all(math.isfinite(f.chi2) for f in check.fits.values())
