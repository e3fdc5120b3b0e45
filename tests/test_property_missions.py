"""Property: a mutated example mission either is refused with a located MissionError, or loads
into a plan whose every setting is finite and inside its declared range — never anything else.

Mutations are those a person or a corrupted file makes: a value replaced (by nan, inf, huge,
negative, zero, a word, nothing), a line deleted or doubled, a brace added or removed, bytes
flipped. Bounded so the whole file runs in a few seconds.
"""

from __future__ import annotations

import math
import random
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mavhelm.companion.alog import log_dir
from mavhelm.companion.bridge import IMAVLINK_SCHEMA
from mavhelm.companion.companion import Companion, Plan
from mavhelm.core.clock import SimClock
from mavhelm.core.errors import SettingError
from mavhelm.core.geodesy import GLOBAL_SCHEMA
from mavhelm.core.mission import MissionError
from mavhelm.core.names import POSTED_FAMILIES, posted_family
from mavhelm.nav.sensors import SENSOR_TYPES
from mavhelm.tasks.helm import HELM_SCHEMA

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.moos"))
TEXTS = [p.read_text() for p in EXAMPLES]

NASTY_VALUES = ["nan", "NaN", "inf", "-inf", "1e308", "-1e308", "1e999", "1e-320", "0", "-0",
                "-1", "-100", "100000", "256", "300", "0.5", "NEVER", "", "five", ",", "1,2",
                "nan,nan", "1e6,1e6", "GUIDED", "rc_override", "ON", "maybe", "@", "GPS @ nan"]

value = st.one_of(st.sampled_from(NASTY_VALUES),
                  st.floats(allow_nan=True, allow_infinity=True).map(repr),
                  st.integers(-10**6, 10**6).map(str),
                  st.text(max_size=12))


@st.composite
def mutated_text(draw) -> str:
    lines = draw(st.sampled_from(TEXTS)).splitlines()
    for _ in range(draw(st.integers(1, 3))):
        i = draw(st.integers(0, len(lines) - 1))
        kind = draw(st.sampled_from(["value", "value", "value", "delete", "double", "brace",
                                     "unbrace", "key"]))
        if kind == "value" and "=" in lines[i]:
            key = lines[i].split("=", 1)[0]
            lines[i] = f"{key}= {draw(value)}"
        elif kind == "delete":
            del lines[i]
        elif kind == "double":
            lines.insert(i, lines[i])
        elif kind == "brace":
            lines.insert(i, draw(st.sampled_from(["{", "}"])))
        elif kind == "unbrace":
            lines[i] = lines[i].replace("{", "").replace("}", "")
        elif kind == "key" and "=" in lines[i]:
            key, rest = lines[i].split("=", 1)
            lines[i] = f"{key.strip()[:-1] or 'X'} ={rest}"
        if not lines:
            lines = [""]
    return "\n".join(lines) + "\n"


def _check_plan(plan: Plan) -> None:
    """Every setting the plan holds is one its schema accepts: finite, in range."""
    for p in GLOBAL_SCHEMA.params:
        assert p.accepts(getattr(plan.origin, p.attribute)), p.name
    for p in HELM_SCHEMA.params:
        holder = plan.helm if p.attribute in ("app_tick",) else plan.helm.gains
        if hasattr(holder, p.attribute):
            assert p.accepts(getattr(holder, p.attribute)), p.name
    for p in IMAVLINK_SCHEMA.params:
        if hasattr(plan.link, p.attribute):
            assert p.accepts(getattr(plan.link, p.attribute)), p.name
    assert all(math.isfinite(r) and 0 <= r <= 50 for r in plan.link.streams.values())
    for task in plan.helm.tasks:
        for p in task.schema().params:
            assert p.accepts(getattr(task, p.attribute)), (task, p.name)
    for queue in plan.navigator.queues:
        assert all(math.isfinite(s.timeout) and s.timeout > 0 for s in queue.sources)


def _load(text: str | bytes, tmp_path: Path) -> None:
    path = tmp_path / "mutant.moos"
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    try:
        plan = Plan.from_mission(path, SimClock())
    except MissionError as err:
        assert err.file == str(path) and err.line >= 0
        assert str(err).startswith(f"{path}:{err.line}: ") and "\n" not in str(err)
        return
    _check_plan(plan)


def test_the_examples_themselves_load(tmp_path):
    for text in TEXTS:
        path = tmp_path / "example.moos"
        path.write_text(text)
        _check_plan(Plan.from_mission(path, SimClock()))


@settings(max_examples=300, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=mutated_text())
def test_a_mutated_mission_is_refused_where_it_is_or_loads_sane(text, tmp_path):
    _load(text, tmp_path)


@settings(max_examples=100, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_flipped_bytes_are_refused_where_they_are_or_load_sane(data, tmp_path):
    raw = bytearray(data.draw(st.sampled_from(TEXTS)).encode())
    for _ in range(data.draw(st.integers(1, 4))):
        i = data.draw(st.integers(0, len(raw) - 1))
        raw[i] = data.draw(st.integers(0, 255))
    _load(bytes(raw), tmp_path)


# ---------------------------------------------------------------------------- pNav, iSerial and
# log settings at their extremes: generated, loaded, their logs opened and the navigator ticked

DEMO_TEXT = next(t for p, t in zip(EXAMPLES, TEXTS, strict=True) if p.name == "demo.moos")
NOISES = ["1e-12", "1e-300", "0", "-1", "nan", "1e-6", "0.001", "0.01", "0.3", "3", "1e4",
          "1e5"]
SOURCES = ["GPS", "INS", "RNG", "LBL", "DVL", "DEPTH", "S1", "EKF", "LSQ", "WHEEL", "AP"]
INSTRUMENT_NAMES = [*POSTED_FAMILIES, "ekf", "Lsq", "NAV_X", "EKF_SIGMA", "SGPS", "RNG", "DVL"]
FOLDERS = ["{tmp}/logs", "{file}", "{file}/below", "/dev/null", "/dev/null/x", "a\x00b",
           "{tmp}/" + "y" * 300, "{tmp}/a\x1bb"]
STEMS = ["pNav", "x" * 200, "x" * 300, "a b", "..", "a.b-c_d"]


SANE_NOISES = ["0.01", "0.3", "3", "1e4"]
TINY_NOISES = ["1e-12", "1e-9", "1e-300"]
noise = st.one_of(st.sampled_from(SANE_NOISES), st.sampled_from(TINY_NOISES),
                  st.sampled_from(NOISES))
folder = st.one_of(st.just("{tmp}/logs"), st.sampled_from(FOLDERS))
UNITS = {"BODY_VEL": 3}


@st.composite
def pnav_lines(draw) -> list[str]:
    lines = []
    kinds = draw(st.lists(st.sampled_from(["XY", "RANGE", *SENSOR_TYPES]), max_size=4))
    for k, kind in enumerate(kinds):
        noises = draw(st.lists(noise, min_size=0, max_size=UNITS.get(kind, 1)))
        lever = draw(st.sampled_from(["", " @ 0,0,0", " @ 0,1.5,2", " @ 0,0,0,90"]))
        tail = f" ~ {', '.join(noises)}" if noises else ""
        lines.append(f"SENSOR_{kind} = {draw(st.sampled_from(SOURCES))} -> s{k}{lever}{tail}")
    ranging = any(kind in ("LBL", "RANGE") for kind in kinds)
    for k in range(draw(st.integers(3 if ranging else 0, 4 if kinds else 0))):
        x, y = [(50, 0), (0, 50), (-50, 0), (0, -50)][k]
        lines.append(f"BEACON = b{k} @ {x},{y},{draw(st.sampled_from(['0', '-5']))}")
    for key in draw(st.lists(st.sampled_from(["FIXEDDEPTH", "FIXEDHEADING", "FIXEDSIDESLIP",
                                              "EKF_SIGMA_XY", "EKF_SIGMA_HEADING",
                                              "EKF_SIGMA_Z"]), max_size=2, unique=True)):
        sigma = draw(noise)
        lines.append(f"{key} = 0 @ {sigma}" if key.startswith("FIXED") else f"{key} = {sigma}")
    if draw(st.booleans()):
        lines.append(f"NAV_LOG_PATH = {draw(folder)}")
    if draw(st.booleans()):
        lines.append(f"NAV_LOG_STEM = {draw(st.sampled_from(STEMS))}")
    return lines


@st.composite
def extreme_mission(draw) -> str:
    text = DEMO_TEXT.replace("ProcessConfig = pNav\n{\n",
                             "ProcessConfig = pNav\n{\n" + "".join(
                                 f"    {line}\n" for line in draw(pnav_lines())), 1)
    for k in range(draw(st.integers(0, 2))):
        text += (f"\nProcessConfig = iSerial_{k}\n{{\n"
                 f"    Name = {draw(st.sampled_from(INSTRUMENT_NAMES))}\n"
                 f"    Port = /dev/ttyUSB{k + 90}\n    Sentences = GGA\n}}\n")
    if draw(st.booleans()):
        text += f"\nProcessConfig = pLogger\n{{\n    LogDir = {draw(folder)}\n}}\n"
    return text


def _readings(names: list[str], beacons: dict[str, tuple[float, float, float]], k: int,
              rng: random.Random) -> dict[str, float]:
    """Tick ``k``'s sensor values, noisy as real ones: the vehicle creeps east from (1, 2);
    positions every 5th tick, ranges every 3rd, the rest every tick."""
    x, y = 1.0 + 0.1 * k, 2.0
    out = {}
    for name in names:
        for suffix, scale in (("_RANGE_", 1.0), ("_TWTT_", 2.0 / 1500.0)):
            if suffix in name and k % 3 == 0:
                bx, by, bz = beacons[name.rsplit(suffix, 1)[1]]
                out[name] = scale * (math.sqrt((x - bx) ** 2 + (y - by) ** 2 + bz ** 2)
                                     + rng.gauss(0.0, 0.3))
        for suffix, value, sigma in (("_X", x, 0.5), ("_Y", y, 0.5), ("_YAW", 0.0, 0.03),
                                     ("_HEADING", 0.0, 2.0), ("_DEPTH", 1.0, 0.05),
                                     ("_ALTITUDE", 5.0, 0.05), ("_VX_BODY", 0.5, 0.05),
                                     ("_VY_BODY", 0.0, 0.05), ("_YAW_VEL", 0.0, 0.01)):
            if name.endswith(suffix) and (k % 5 == 0 or suffix not in ("_X", "_Y")):
                out[name] = value + rng.gauss(0.0, sigma)
    return out


def _open_and_tick(path: Path, tmp: Path, seed: int = 0) -> None:
    """Load; every instrument's variables stay out of other apps' families; the logs open
    (or say which setting they cannot open with); the navigator ticks through its sensors'
    data without an exception and posts nothing non-finite."""
    try:
        plan = Plan.from_mission(path, SimClock())
    except MissionError as err:
        assert str(err).startswith(f"{path}:{err.line}: ") and "\n" not in str(err)
        return
    for instrument in plan.instruments:
        assert posted_family(instrument.prefix) is None, instrument.prefix
    clock = SimClock(0.0)
    folder = tmp / log_dir(plan.mission)  # relative: under tmp, as `mavhelm run` from there
    try:
        companion = Companion.build(path, clock, alog_path=folder / "m.alog",
                                    alog_opened_on=0.0)
    except SettingError:
        return
    try:
        nav, bus = companion.navigator, companion.bus
        beacons = {b.name: (b.x, b.y, b.z) for b in
                   (nav.fusion.config.beacons if nav.fusion is not None else ())}
        names = sorted(nav.subscriptions())
        bus.subscribe(nav.name, names)
        bus.subscribe("probe", ["*"])
        rng = random.Random(seed)
        for k in range(60):
            now = 0.2 * k
            clock.set(now)
            for name, value in _readings(names, beacons, k, rng).items():
                bus.notify(name, value, "probe", now)
            nav.on_mail(bus.fetch(nav.name), now)
            nav.iterate(now)
            for m in bus.fetch("probe"):
                assert not m.is_double or math.isfinite(m.double), m
    finally:
        companion.close()


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=extreme_mission(), seed=st.integers(0, 2**16))
def test_pnav_iserial_and_log_settings_at_their_extremes_load_open_and_tick(text, seed,
                                                                             tmp_path):
    existing = tmp_path / "a_file"
    existing.write_text("")
    text = text.replace("{tmp}", str(tmp_path)).replace("{file}", str(existing))
    path = tmp_path / "extreme.moos"
    path.write_text(text)
    _open_and_tick(path, tmp_path, seed)
