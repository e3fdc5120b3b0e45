"""Property: a mutated example mission either is refused with a located MissionError, or loads
into a plan whose every setting is finite and inside its declared range — never anything else.

Mutations are those a person or a corrupted file makes: a value replaced (by nan, inf, huge,
negative, zero, a word, nothing), a line deleted or doubled, a brace added or removed, bytes
flipped. Bounded so the whole file runs in a few seconds.
"""

from __future__ import annotations

import math
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mavhelm.companion.bridge import IMAVLINK_SCHEMA
from mavhelm.companion.companion import Plan
from mavhelm.core.clock import SimClock
from mavhelm.core.geodesy import GLOBAL_SCHEMA
from mavhelm.core.mission import MissionError
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
