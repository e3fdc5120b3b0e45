"""What a mission written for MOOS holds that mavhelm has no use for, and why.

A MOOS mission file configures a whole community: the MOOSDB it talks through (``ServerHost``,
``ServerPort``, ``Community``), the launcher (``ProcessConfig = ANTLER``), every process's comms
rate (``CommsTick``) and processes mavhelm does not run (``iGPS``, ``pMOOSBridge``). mavhelm is
one process with its own bus, so these settings are accepted, checked like every setting, and
each one a mission gives is said once on the console with the reason (:func:`notes`). A setting
that would change what the vehicle does is never treated so: it is honoured or refused.

The SENSOR lines of pNav name the MOOS process that sends a sensor's data (``SENSOR_XY = iGPS
-> TheGPS @ …``); :data:`SOURCES` maps those process names to mavhelm's sources, the bus
variable prefixes its MAVLink bridge and serial instruments post (see :func:`source_of`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

from mavhelm.core.mission import Block, Mission
from mavhelm.core.params import Boolean, Choice, Number, Param, PathName, Schema, Text, Word

NO_MOOSDB: Final = "no MOOSDB: mavhelm runs its own bus inside one process"
ONE_TICK: Final = "every app of mavhelm ticks together, at pHelm's AppTick"

GLOBAL_LOG_PATH: Final = Param(
    "GlobalLogPath", PathName(folder=True), None, attr="global_log_path",
    doc="folder of the logs when pLogger gives no LogDir (the nav logs go beside the .alog)")
"""MOOS's GLOBALLOGPATH, which the original pLogger and pNav read: honoured by pLogger."""

GLOBAL_PARAMS: Final = (
    Param("ServerHost", Text(), None, unused=NO_MOOSDB, attr="server_host"),
    Param("ServerPort", Number(1, 65535, integer=True), None, unused=NO_MOOSDB,
          attr="server_port"),
    Param("Community", Word(), None, unused=f"{NO_MOOSDB}; the vehicle is named by iMAVLink's "
          "SystemID", attr="community"),
    Param("Simulator", Boolean(), None, attr="simulator",
          unused="mavhelm demo and mavhelm sim choose the simulator; the mission is the same "
          "for both"),
    Param("MOOSTimeWarp", Number(0.0, 1000.0, lo_open=True), None, attr="moos_time_warp",
          unused="mavhelm run keeps real time (or the autopilot's with --clock autopilot); "
          "mavhelm demo runs the simulator as fast as it can"),
    Param("Playback", Boolean(), None, attr="playback",
          unused="mavhelm nav replay plays a log back; the mission is the same"),
    Param("MagneticOffset", Number(-180.0, 180.0), None, "deg", attr="magnetic_offset",
          unused="the original ConstantHeading reads it but never applies it: headings are "
                 "true, the compass (the autopilot) corrects for variation"),
    GLOBAL_LOG_PATH,
)
"""Global keys of MOOS boilerplate (MOOSApp, MOOSDB, pHelm and pNav read them)."""

APP_PARAMS: Final = (
    Param("AppTick", Number(0.0, 1000.0, lo_open=True), None, "Hz", attr="moos_app_tick",
          unused=ONE_TICK),
    Param("MaxAppTick", Number(0.0, 1000.0), None, "Hz", attr="moos_max_app_tick",
          unused=ONE_TICK),
    Param("CommsTick", Number(0.0, 1000.0, lo_open=True), None, "Hz", attr="comms_tick",
          unused=NO_MOOSDB),
    Param("IterateMode", Number(0, 2, integer=True), None, attr="iterate_mode",
          unused=ONE_TICK),
    Param("UseMOOSComms", Choice(("TRUE",)), None, attr="use_moos_comms",
          unused=f"{NO_MOOSDB}; the apps always share it"),
    Param("SortMailByTime", Boolean(), None, attr="sort_mail_by_time",
          unused="mail reaches each app in the order it was posted"),
    Param("CatchCommandMessages", Boolean(), None, attr="catch_command_messages",
          unused=NO_MOOSDB),
    Param("Debug", Boolean(), None, attr="moos_debug",
          unused="the console prints every event; the .alog holds every variable"),
)
"""Keys every MOOS process reads in its own block (CMOOSApp). pHelm's AppTick is its own
setting (the companion's tick) and replaces the one here."""


@dataclass(frozen=True)
class Foreign:
    """A MOOS process mavhelm does not run, and what does its work instead."""

    name: str
    why: str


FOREIGN: Final = (
    Foreign("ANTLER", "mavhelm is one process: nothing to launch"),
    Foreign("pAntler", "mavhelm is one process: nothing to launch"),
    Foreign("MOOSDB", NO_MOOSDB),
    Foreign("pMOOSBridge", f"{NO_MOOSDB}; a ground station talks MAVLink to the autopilot"),
    Foreign("pShare", f"{NO_MOOSDB}; a ground station talks MAVLink to the autopilot"),
    Foreign("iRemote", "mavhelm remote is the console: it talks MAVLink"),
    Foreign("uMS", "mavhelm remote shows the helm's state; the .alog holds every variable"),
    Foreign("uXMS", "mavhelm remote shows the helm's state; the .alog holds every variable"),
    Foreign("uProcessWatch", "mavhelm is one process: its console says when anything stops"),
    Foreign("pMarineViewer", "a ground station shows the vehicle; mavhelm remote the helm"),
    Foreign("pNodeReporter", "the autopilot reports the vehicle to the ground station"),
    Foreign("pMarinePID", "the autopilot turns the helm's demands into actuation"),
    Foreign("pHelmIvP", "mavhelm's helm is the MOOS pHelm: its Task blocks, not IvP "
            "behaviours"),
    Foreign("uPoke", "post flags from the ground station (iMAVLink RemoteFlag)"),
    Foreign("pScheduler", "the mission's tasks and their flags do the scheduling"),
    Foreign("iGPS", "the GPS arrives over MAVLink (GPS_RAW_INT) or from an iSerial_ block"),
    Foreign("iDVL", "a DVL is read by an iSerial_ block (PMVHDVL)"),
    Foreign("iDepth", "depth arrives from an iSerial_ block (DPT, DBT)"),
    Foreign("iCompass", "the heading arrives over MAVLink (ATTITUDE) or from an iSerial_ "
            "block (HDT)"),
    Foreign("iOrientation", "attitude arrives over MAVLink (ATTITUDE)"),
    Foreign("iINS", "attitude arrives over MAVLink (ATTITUDE)"),
    Foreign("iActuation", "the helm's demands go to the autopilot over MAVLink (iMAVLink)"),
    Foreign("iLBL", "LBL travel times arrive from an iSerial_ block (PMVHLBL)"),
    Foreign("iMatlab", "mavhelm has no MATLAB link; read the .alog"),
    Foreign("pSimulator", "mavhelm demo and mavhelm sim are the simulator"),
    Foreign("uMVS", "mavhelm demo and mavhelm sim are the simulator"),
    Foreign("pMarineSim", "mavhelm demo and mavhelm sim are the simulator"),
    Foreign("uSimMarine", "mavhelm demo and mavhelm sim are the simulator"),
)
"""ProcessConfig blocks of other MOOS processes: accepted whole (their keys are theirs), each
said once on the console with what does its work in mavhelm."""


def foreign(name: str) -> Foreign | None:
    """The MOOS process a ProcessConfig block configures, if mavhelm does not run it."""
    for process in FOREIGN:
        if process.name.lower() == name.lower():
            return process
    return None


@dataclass(frozen=True)
class Source:
    """What a MOOS process name on the left of a SENSOR line reads in mavhelm."""

    process: str
    source: str
    what: str


SOURCES: Final = (
    Source("iGPS", "GPS", "the autopilot's GPS over MAVLink (GPS_RAW_INT): GPS_X, GPS_Y"),
    Source("iINS", "INS", "the autopilot's attitude over MAVLink (ATTITUDE): INS_YAW"),
    Source("iCompass", "INS", "the autopilot's attitude over MAVLink (ATTITUDE): INS_YAW"),
    Source("iOrientation", "INS", "the autopilot's attitude over MAVLink (ATTITUDE): "
           "INS_YAW"),
    Source("iMAVLink", "AP", "the autopilot's own estimate (GLOBAL_POSITION_INT): AP_X, AP_Y, "
           "AP_YAW"),
)
"""MOOS process names → mavhelm sources (the prefix of the bus variables a sensor reads).
An ``iSerial_<label>`` block's own name stands for its ``Name``; any other word is a source
prefix as it stands (``GPS``, ``SGPS``)."""


def source_of(word: str, mission: Mission | None) -> tuple[str, str]:
    """The mavhelm source a SENSOR line's left side names, and how it was found (empty when
    the word is a source prefix as it stands)."""
    for source in SOURCES:
        if source.process.lower() == word.lower():
            return source.source, f"{source.process} is {source.what}"
    block = mission.process(word) if mission is not None else None
    if block is not None and word.lower().startswith("iserial"):
        name = block.get("Name")
        if name:
            return name.strip().upper(), f"{word} is the serial instrument {name.strip().upper()}"
    return word.upper(), ""


def notes(blocks: list[tuple[Block, Schema]], mission: Mission) -> list[str]:
    """One line per setting or block a mission gives that mavhelm does not use, with why: the
    keys of each (block, schema) the schema marks unused, then the foreign processes."""
    said: dict[str, list[str]] = {}
    for block, schema in blocks:
        for entry, param in schema.unused_entries(block):
            where = "" if block.kind == "Global" else f"{block.name} "
            said.setdefault(param.unused, []).append(f"{where}{entry.key}")
    lines = [f"{', '.join(dict.fromkeys(keys))}: {why}" for why, keys in said.items()]
    for name, block in mission.processes.items():
        process = foreign(name)
        if process is not None:
            lines.append(f"ProcessConfig = {block.name} (line {block.line}): not run; "
                         f"{process.why}")
    return lines
