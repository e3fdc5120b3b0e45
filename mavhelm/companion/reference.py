"""The parameter reference, generated from the schemas the code reads missions with.

``mavhelm params`` prints it; ``docs/parameters.md`` is its output, and a test fails when the
two differ, so the documentation cannot drift from what a mission may say.
"""

from __future__ import annotations

from mavhelm.companion.alog import LOGGER_SCHEMA
from mavhelm.companion.bridge import IMAVLINK_SCHEMA
from mavhelm.companion.companion import PROCESSES
from mavhelm.companion.serial_instruments import INSTRUMENT_INTRO, INSTRUMENT_SCHEMA
from mavhelm.core.geodesy import GLOBAL_SCHEMA
from mavhelm.core.moos import APP_PARAMS, FOREIGN, GLOBAL_PARAMS, SOURCES
from mavhelm.core.params import Schema
from mavhelm.nav.navigator import NAV_SCHEMA
from mavhelm.tasks.base import BASE_PARAMS, Task
from mavhelm.tasks.helm import HELM_SCHEMA
from mavhelm.tasks.registry import NOT_SUPPORTED, TASK_TYPES, spelling

PROCESS_SCHEMAS: dict[str, tuple[Schema, str]] = {
    "iMAVLink": (IMAVLINK_SCHEMA, "The link to the autopilot."),
    "pNav": (NAV_SCHEMA, "The navigator: one priority queue per NAV_* key (spec 2.1). "
             "YAW is radians (yaw = −heading), HEADING degrees; configure one of the two."),
    "pHelm": (HELM_SCHEMA, "The helm's own settings; its `Task = Type { … }` blocks are below."),
    "pLogger": (LOGGER_SCHEMA, "The .alog of every bus variable (MOOS pLogger's format)."),
}
assert tuple(PROCESS_SCHEMAS) == PROCESSES


def _own_schema(cls: type[Task]) -> Schema:
    """A task type's settings beyond the base properties (a narrowed base one included)."""
    declared = []
    for klass in reversed(cls.__mro__):
        declared.extend(klass.__dict__.get("params", ()))
    return Schema(cls.keyword, tuple(declared))


def reference() -> str:
    """The whole reference as Markdown."""
    out = [
        "# Mission parameter reference",
        "",
        "Generated from the declarations in the code (`mavhelm params > docs/parameters.md`);",
        "a test fails when this file and the code disagree. Keys are case-insensitive. Every",
        "block refuses a key it does not know, a required key left out, a key given twice, and",
        "any value that is not finite or not in the range shown, with `file:line: reason`.",
        "",
        GLOBAL_SCHEMA.reference("Global settings", "Outside every block."),
    ]
    for name, (schema, intro) in PROCESS_SCHEMAS.items():
        out.append(schema.reference(f"ProcessConfig = {name}", intro))
    out.append(INSTRUMENT_SCHEMA.reference("ProcessConfig = iSerial_<label> (one per device)",
                                           INSTRUMENT_INTRO))
    out.append(Schema("every task", BASE_PARAMS).reference(
        "Base properties of every task (spec Table 1)",
        "A task type may narrow one of these; its own table then shows it."))
    seen: set[type[Task]] = set()
    for cls in TASK_TYPES.values():
        if cls in seen:
            continue
        seen.add(cls)
        aliases = sorted(spelling(k) for k, c in TASK_TYPES.items()
                         if c is cls and k != cls.keyword.lower())
        also = f" (also written {', '.join(aliases)})" if aliases else ""
        out.append(_own_schema(cls).reference(f"Task = {cls.keyword}{also}", cls.summary))
    out.append(_moos())
    return "\n".join(out).rstrip() + "\n"


def _moos() -> str:
    """The MOOS section: boilerplate, other processes' blocks, SENSOR process names."""
    out = [
        "## MOOS missions",
        "",
        "A mission written for MOOS loads as it is: the original pHelm, task and pNav keywords",
        "are the settings above (an alias is shown as \"also written\"), or are refused with the",
        "reason where mavhelm cannot honour them. The boilerplate below is accepted and checked;",
        "what a mission gives of it that mavhelm does not use is said once on the console, with",
        "why. `mavhelm convert FILE` prints what each line of a mission maps to.",
        "",
        Schema("MOOS globals", GLOBAL_PARAMS).reference(
            "MOOS boilerplate: global settings"),
        Schema("every ProcessConfig", APP_PARAMS).reference(
            "MOOS boilerplate: in every ProcessConfig block",
            "pHelm's `AppTick` is its own setting (the companion's tick), above."),
        "### ProcessConfig blocks of other MOOS processes",
        "",
        "Accepted whole and not run; the console says what does their work in mavhelm.",
        "",
        "| process | in mavhelm |",
        "| --- | --- |",
        *(f"| `{p.name}` | {p.why} |" for p in FOREIGN),
        "",
        "The original's `ProcessConfig = Acoustics` block (`Beacon = name`, then `[ POS = x,y,z",
        "TX = CHn TAT = s ]`) is read by pNav: each beacon is a `BEACON = n @ x,y,z TAT=s`, its",
        "id the reply channel n (its travel times are `<SOURCE>_TWTT_<n>`).",
        "",
        "### Task types of the original pHelm that mavhelm refuses",
        "",
        "| task | why |",
        "| --- | --- |",
        *(f"| `{name}` | {why} |" for name, why in NOT_SUPPORTED.values()),
        "",
        "### SENSOR sources",
        "",
        "The left side of a pNav `SENSOR_*` line names the MOOS process that sends the data.",
        "These process names stand for mavhelm's sources; an `iSerial_<label>` block's name",
        "stands for its `Name`; any other word is a source as it stands (its variables are",
        "`<SOURCE>_X`, `<SOURCE>_Y`, …).",
        "",
        "| process | source | what it reads |",
        "| --- | --- | --- |",
        *(f"| `{s.process}` | `{s.source}` | {s.what} |" for s in SOURCES),
        "",
    ]
    return "\n".join(out)
