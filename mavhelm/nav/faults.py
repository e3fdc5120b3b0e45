"""Faults made on a recorded log, so pNav can be scored on the world's bad days (spec 2.2.9).

Each fault turns the bus variables of a recording into those of the same run with one thing
gone wrong, deterministically (a seeded generator): what the navigator then does is replayed
(:func:`mavhelm.nav.replay.replay`) and scored against the recording's truth. The faults are
those real vehicles meet:

=====================  =======================================================================
``heading_wander``     the orientation sensor's bias wanders, a smooth random walk reaching 180°
                       over the run (a compass by a moving load)
``heading_drift``      an odometry-integrated heading: its error drifts 180° within five minutes
                       (a random walk of its rate) and the same instrument's yaw rate carries that
                       rate
``heading_scale``      an odometry-integrated heading whose yaw rate is 3–8 % off, as the same
                       instrument's yaw rate: its error grows with each turn, not with time
                       (an odometer's wheel base); only where one source gives both
``heading_offset``     the orientation sensor reads 90–180° (either way) off the true heading
                       from the start (a compass mounted turned, an odometer's heading counted
                       from its own zero)
``heading_jumps``      the heading jumps 30–90° for 5–20 s at a time, every minute or so (a
                       compass near a motor)
``heading_stuck``      the heading holds one value for five minutes (a frozen AHRS)
``ranges_gap``         60 s without any beacon range
``beacon_moved``       one beacon is 5 m from its surveyed position (its ranges say so)
``range_outliers``     5 % of the ranges wrong by 5–50 m (multipath, a second reply)
``ranges_long``        a fifth of the ranges 5–50 m long (a ray round an obstacle, NLOS: a
                       longer path, never a shorter one, so every outlier has one sign)
``gps_glitches``       the position sensor with 2 m of noise, and 30–60 m glitches of 5 s every
                       two minutes
``yaw_rate_reversed``  the body velocity sensors' yaw rate of the wrong sign (a gyro mounted
                       upside down, a rate logged clockwise-positive)
``heading_reversed``   the orientation sensor read the wrong way round, about an axis drawn at
                       random (a compass's clockwise heading given as an anticlockwise yaw)
``speed_scale``        the body velocity sensors' speeds 5–10 % long or short (a worn wheel, a
                       tyre's pressure, a DVL told the wrong sound speed)
=====================  =======================================================================

Faults join with ``+`` to be made on one log together (``heading_wander+heading_jumps``).
A fault that finds nothing to act on (no ranges, no position sensor) leaves the log as it was
and says so (``applies``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from mavhelm.core.bus import Message
from mavhelm.core.mission import Block
from mavhelm.nav.ekf import Beacon
from mavhelm.nav.navigator import NAV_SCHEMA
from mavhelm.nav.sensors import BEACON, SENSOR_TYPES

TRUTH = ("TRUTH_X", "TRUTH_Y")


@dataclass(frozen=True)
class Layout:
    """What a fault needs to know of the mission: its sensors' variable prefixes by type
    and the surveyed beacons."""

    orientation: tuple[str, ...]
    ranging: tuple[str, ...]
    position: tuple[str, ...]
    beacons: tuple[Beacon, ...]
    body_velocity: tuple[str, ...] = ()


def layout_of(block: Block) -> Layout:
    """The layout of a ``pNav`` block (read and checked by its schema)."""
    settings = NAV_SCHEMA.read(block)
    specs = [spec for kind in SENSOR_TYPES for spec in settings[f"sensor_{kind.lower()}"]]

    def sources(*types: str) -> tuple[str, ...]:
        return tuple(dict.fromkeys(s.source for s in specs if s.type in types))
    return Layout(sources("ORIENTATION"), sources("RANGE", "LBL"), sources("XY"),
                  tuple(settings[BEACON.attribute]), sources("BODY_VEL"))


FaultMaker = Callable[[list[Message], Layout, np.random.Generator], list[Message]]


def _is(m: Message, prefixes: Sequence[str], *suffixes: str) -> bool:
    return m.is_double and any(m.name == f"{p}_{s}" for p in prefixes for s in suffixes)


def _span(messages: list[Message]) -> tuple[float, float]:
    return messages[0].time, messages[-1].time


def _turn(m: Message, bias_deg: float) -> Message:
    """A heading (deg) or yaw (rad, yaw = −heading) reading turned clockwise by ``bias_deg``."""
    if m.name.endswith("_HEADING"):
        return m._replace(value=(m.double + bias_deg) % 360.0)
    return m._replace(value=math.remainder(m.double - math.radians(bias_deg), 2 * math.pi))


def _bias_walk(grid: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A smooth random walk on ``grid`` (1 s apart), in degrees: its rate is itself a random
    walk, clipped to ±2 (unscaled) degrees a second."""
    rate = np.cumsum(rng.normal(0.0, 0.05, grid.size))
    return np.cumsum(np.clip(rate, -2.0, 2.0))


def heading_wander(messages: list[Message], layout: Layout,
                   rng: np.random.Generator) -> list[Message]:
    t0, t1 = _span(messages)
    grid = np.arange(t0, t1 + 1.0, 1.0)
    walk = _bias_walk(grid, rng)
    walk *= 180.0 / max(float(np.max(np.abs(walk))), 1e-9)
    return [_turn(m, float(np.interp(m.time, grid, walk)))
            if _is(m, layout.orientation, "HEADING", "YAW") else m for m in messages]


DRIFT_WINDOW = 300
"""s: ``heading_drift`` moves 180° within this long (its widest swing over any such window)."""


def heading_drift(messages: list[Message], layout: Layout,
                  rng: np.random.Generator) -> list[Message]:
    t0, t1 = _span(messages)
    grid = np.arange(t0, t1 + 1.0, 1.0)
    walk = _bias_walk(grid, rng)
    window = min(DRIFT_WINDOW, grid.size)
    swing = float(np.ptp(np.lib.stride_tricks.sliding_window_view(walk, window), axis=1).max())
    walk *= 180.0 / max(swing, 1e-9)
    rate = np.radians(np.gradient(walk, grid)) if grid.size > 1 else np.zeros(grid.size)
    both = tuple(set(layout.orientation) & set(layout.body_velocity))
    out = []
    for m in messages:
        if _is(m, layout.orientation, "HEADING", "YAW"):
            m = _turn(m, float(np.interp(m.time, grid, walk)))
        elif _is(m, both, "YAW_VEL"):  # yaw = −heading: a clockwise drift is a negative rate
            m = m._replace(value=m.double - float(np.interp(m.time, grid, rate)))
        out.append(m)
    return out


def heading_scale(messages: list[Message], layout: Layout,
                  rng: np.random.Generator) -> list[Message]:
    k = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.03, 0.08))
    both = tuple(set(layout.orientation) & set(layout.body_velocity))
    last: dict[str, float] = {}
    turned: dict[str, float] = {}
    out = []
    for m in messages:
        if _is(m, both, "HEADING", "YAW"):
            heading = m.double if m.name.endswith("_HEADING") else -math.degrees(m.double)
            if m.name in last:  # the turn made good since the first reading, unwrapped
                turned[m.name] += math.remainder(heading - last[m.name], 360.0)
            last[m.name] = heading
            m = _turn(m, k * turned.setdefault(m.name, 0.0))
        elif _is(m, both, "YAW_VEL"):
            m = m._replace(value=(1.0 + k) * m.double)
        out.append(m)
    return out


def heading_offset(messages: list[Message], layout: Layout,
                   rng: np.random.Generator) -> list[Message]:
    offset = float(rng.choice([-1.0, 1.0]) * rng.uniform(90.0, 180.0))
    return [_turn(m, offset) if _is(m, layout.orientation, "HEADING", "YAW") else m
            for m in messages]


def heading_jumps(messages: list[Message], layout: Layout,
                  rng: np.random.Generator) -> list[Message]:
    t0, t1 = _span(messages)
    windows = []
    t = t0 + rng.uniform(30.0, 90.0)
    while t < t1:
        length = rng.uniform(5.0, 20.0)
        windows.append((t, t + length, rng.choice([-1.0, 1.0]) * rng.uniform(30.0, 90.0)))
        t += length + rng.uniform(40.0, 80.0)

    def bias(time: float) -> float:
        return next((b for a, e, b in windows if a <= time < e), 0.0)
    return [_turn(m, bias(m.time)) if _is(m, layout.orientation, "HEADING", "YAW") else m
            for m in messages]


def heading_stuck(messages: list[Message], layout: Layout,
                  rng: np.random.Generator) -> list[Message]:
    t0, t1 = _span(messages)
    start = t0 + min(300.0, (t1 - t0) / 3)
    held: dict[str, float | str] = {}
    out = []
    for m in messages:
        if _is(m, layout.orientation, "HEADING", "YAW") and start <= m.time < start + 300.0:
            m = m._replace(value=held.setdefault(m.name, m.value))
        out.append(m)
    return out


def ranges_gap(messages: list[Message], layout: Layout,
               rng: np.random.Generator) -> list[Message]:
    t0, t1 = _span(messages)
    start = t0 + min(600.0, (t1 - t0) / 2)
    return [m for m in messages if not (_ranging(m, layout) and start <= m.time < start + 60.0)]


def _ranging(m: Message, layout: Layout) -> bool:
    return m.is_double and any(m.name.startswith((f"{p}_RANGE_", f"{p}_TWTT_"))
                               for p in layout.ranging)


MOVED_BY = 5.0
"""m: how far ``beacon_moved`` puts the beacon from its surveyed position."""


def beacon_moved(messages: list[Message], layout: Layout,
                 rng: np.random.Generator) -> list[Message]:
    if not layout.beacons:
        return messages
    beacon = layout.beacons[0]
    angle = rng.uniform(0.0, 2 * math.pi)
    moved = (beacon.x + MOVED_BY * math.cos(angle), beacon.y + MOVED_BY * math.sin(angle))
    tt, tx, ty = _truth(messages)
    if tt.size == 0:
        return messages
    out = []
    for m in messages:
        if _ranging(m, layout) and m.name.endswith(f"_RANGE_{beacon.name}"):
            x, y = np.interp(m.time, tt, tx), np.interp(m.time, tt, ty)
            dz2 = beacon.z ** 2
            shift = (math.sqrt((x - moved[0]) ** 2 + (y - moved[1]) ** 2 + dz2)
                     - math.sqrt((x - beacon.x) ** 2 + (y - beacon.y) ** 2 + dz2))
            m = m._replace(value=m.double + shift)
        out.append(m)
    return out


OUTLIER_SHARE = 0.05
"""The share of the ranges ``range_outliers`` makes wrong."""


def range_outliers(messages: list[Message], layout: Layout,
                   rng: np.random.Generator) -> list[Message]:
    return _spoil_ranges(messages, layout, rng, OUTLIER_SHARE, lambda z: max(
        z + rng.choice([-1.0, 1.0]) * rng.uniform(5, 50), 0.5))


LONG_SHARE = 0.2
"""The share of the ranges ``ranges_long`` makes long."""


def ranges_long(messages: list[Message], layout: Layout,
                rng: np.random.Generator) -> list[Message]:
    return _spoil_ranges(messages, layout, rng, LONG_SHARE, lambda z: z + rng.uniform(5, 50))


def _spoil_ranges(messages: list[Message], layout: Layout, rng: np.random.Generator,
                  share: float, spoiled: Callable[[float], float]) -> list[Message]:
    """Each range (not a travel time) drawn with probability ``share`` made ``spoiled(z)``."""
    out = []
    for m in messages:
        if (_ranging(m, layout) and m.name.rpartition("_RANGE_")[1]
                and rng.random() < share):
            m = m._replace(value=spoiled(m.double))
        out.append(m)
    return out


def gps_glitches(messages: list[Message], layout: Layout,
                 rng: np.random.Generator) -> list[Message]:
    t0, _ = _span(messages)
    glitch: dict[int, tuple[float, float]] = {}
    out = []
    for m in messages:
        if _is(m, layout.position, "X", "Y"):
            k = int((m.time - t0) // 120.0)
            phase = (m.time - t0) - 120.0 * k
            value = m.double + rng.normal(0.0, 2.0)
            if 60.0 <= phase < 65.0:
                if k not in glitch:
                    r, a = rng.uniform(30.0, 60.0), rng.uniform(0.0, 2 * math.pi)
                    glitch[k] = (r * math.cos(a), r * math.sin(a))
                value += glitch[k][0 if m.name.endswith("_X") else 1]
            m = m._replace(value=value)
        out.append(m)
    return out


def yaw_rate_reversed(messages: list[Message], layout: Layout,
                      rng: np.random.Generator) -> list[Message]:
    return [m._replace(value=-m.double) if _is(m, layout.body_velocity, "YAW_VEL") else m
            for m in messages]


def heading_reversed(messages: list[Message], layout: Layout,
                     rng: np.random.Generator) -> list[Message]:
    axis = rng.uniform(0.0, 360.0)  # the reading is ``axis`` less the true heading (deg)

    def mirrored(m: Message) -> Message:
        if m.name.endswith("_HEADING"):
            return m._replace(value=(axis - m.double) % 360.0)
        return m._replace(value=math.remainder(-m.double - math.radians(axis), 2 * math.pi))
    return [mirrored(m) if _is(m, layout.orientation, "HEADING", "YAW") else m
            for m in messages]


def speed_scale(messages: list[Message], layout: Layout,
                rng: np.random.Generator) -> list[Message]:
    k = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.05, 0.10))
    return [m._replace(value=(1.0 + k) * m.double)
            if _is(m, layout.body_velocity, "VX_BODY", "VY_BODY") else m for m in messages]


def _truth(messages: list[Message]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    xs = {m.time: m.double for m in messages if m.name == TRUTH[0] and m.is_double}
    ys = {m.time: m.double for m in messages if m.name == TRUTH[1] and m.is_double}
    t = sorted(set(xs) & set(ys))
    return (np.array(t), np.array([xs[k] for k in t]), np.array([ys[k] for k in t]))


FAULTS: dict[str, FaultMaker] = {
    "heading_wander": heading_wander,
    "heading_drift": heading_drift,
    "heading_scale": heading_scale,
    "heading_offset": heading_offset,
    "heading_jumps": heading_jumps,
    "heading_stuck": heading_stuck,
    "ranges_gap": ranges_gap,
    "beacon_moved": beacon_moved,
    "range_outliers": range_outliers,
    "ranges_long": ranges_long,
    "gps_glitches": gps_glitches,
    "yaw_rate_reversed": yaw_rate_reversed,
    "heading_reversed": heading_reversed,
    "speed_scale": speed_scale,
}
"""Every fault by name, in the order a report lists them."""


def parts(name: str) -> list[str]:
    """The faults a name makes: one, or several joined by ``+`` (``heading_wander+heading_jumps``:
    a compass both wandering and kicked by a motor; a real bad day seldom brings one fault)."""
    found = name.split("+")
    unknown = [part for part in found if part not in FAULTS]
    if unknown or len(set(found)) != len(found):
        raise ValueError(f"unknown or repeated fault in {name!r} (known: {', '.join(FAULTS)}; "
                         "join several with +)")
    return found


def applies(name: str, layout: Layout) -> bool:
    """Whether the fault (every one of a ``+`` joined name) has anything to act on in a
    mission of this layout."""
    return all(_applies(part, layout) for part in parts(name))


def _applies(name: str, layout: Layout) -> bool:
    if name == "heading_scale":
        return bool(set(layout.orientation) & set(layout.body_velocity))
    if name.startswith("heading"):
        return bool(layout.orientation)
    if name in ("ranges_gap", "range_outliers", "ranges_long"):
        return bool(layout.ranging)
    if name == "beacon_moved":
        return bool(layout.ranging and layout.beacons)
    if name in ("yaw_rate_reversed", "speed_scale"):
        return bool(layout.body_velocity)
    return bool(layout.position)


def with_fault(name: str, messages: list[Message], layout: Layout,
               seed: int = 1) -> list[Message]:
    """The recording ``messages`` (in time order) with the fault ``name`` made on it; the
    faults of a ``+`` joined name one after the other, each from its own stream of the seed
    (the first from the seed's own, as when made alone)."""
    ordered = sorted(messages, key=lambda m: m.time)
    for k, part in enumerate(parts(name)):
        if not ordered:
            break
        rng = np.random.default_rng(seed if k == 0 else [seed, k])
        ordered = FAULTS[part](ordered, layout, rng)
    return ordered
