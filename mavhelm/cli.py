"""The ``mavhelm`` command: ``run`` on the vehicle, ``sim`` a simulator, ``demo`` a mission."""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from pathlib import Path

from mavhelm.core.errors import LocatedError, SettingError


def _run(args: argparse.Namespace) -> int:
    from mavhelm.companion.alog import log_dir as mission_log_dir
    from mavhelm.companion.companion import Companion, Plan
    from mavhelm.companion.console import say
    from mavhelm.core.clock import AutopilotClock, WallClock

    if args.web_control and args.web is None:
        args.usage_error("--web-control needs --web [HOST:]PORT")
    clock = AutopilotClock() if args.clock == "autopilot" else WallClock()
    plan = Plan.from_mission(args.mission, clock, connect=args.connect)
    log_dir = Path(args.log_dir or mission_log_dir(plan.mission))
    try:
        log_dir.mkdir(parents=True, exist_ok=True)
    except (OSError, ValueError) as exc:
        setting = "--log-dir" if args.log_dir else "pLogger LogDir"
        raise SettingError(setting, f"the log folder {str(log_dir)!r}", exc) from None
    alog = log_dir / f"{Path(args.mission).stem}_{int(clock.now())}.alog"
    companion = Companion.build(plan.mission, clock, connect=args.connect, alog_path=alog,
                                echo=say,
                                tlog_path=alog.with_suffix(".tlog"))
    web = None
    try:
        print(f"mavhelm: {args.mission} on {companion.bridge.config.connect}; logging to "
              f"{alog} (and its MAVLink traffic to {alog.with_suffix('.tlog').name})",
              flush=True)
        web = _serve_web(companion, args)
        _tick_until_stopped(companion, clock, args.exit_at_end)
    except KeyboardInterrupt:
        print("mavhelm: stopped", flush=True)
    finally:
        if web is not None:
            web.stop()
        companion.close()
    return 0


def _serve_web(companion, args: argparse.Namespace):
    """``--web``: the live page (None without it)."""
    if args.web is None:
        return None
    from mavhelm.companion.console import say
    from mavhelm.companion.web.view import start_web

    try:
        return start_web(companion, args.web, control=args.web_control,
                         echo=say)
    except OSError as exc:
        raise SettingError("--web", f"the web view on {args.web}", exc) from None


def _tick_until_stopped(companion, clock, exit_at_end: bool) -> None:
    companion.run_until(clock, lambda: exit_at_end and companion.mission_over())
    print("mavhelm: mission over; exiting (--exit-at-end)", flush=True)


def _stop(signum, frame) -> None:
    """SIGTERM (systemd, a test harness) stops a command as Ctrl-C does: logs closed."""
    raise KeyboardInterrupt


def _stop_on_signals() -> None:
    """SIGINT and SIGTERM stop every command cleanly, whatever the parent left them as.

    A shell without job control starts background commands with SIGINT ignored, and Python
    then never raises KeyboardInterrupt: ``kill -INT`` on a companion started by a script or
    ``nohup ... &`` would be ignored and the logs never closed."""
    if threading.current_thread() is not threading.main_thread():
        return
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, _stop)


def _check(args: argparse.Namespace) -> int:
    from mavhelm.companion.bridge import BridgeConfig
    from mavhelm.companion.check import checklist, observe
    from mavhelm.companion.companion import Plan
    from mavhelm.companion.link import AutopilotLink, transport_for
    from mavhelm.companion.signing import KeyFileError, enable_signing, read_key
    from mavhelm.core.clock import WallClock

    config, origin, problem = BridgeConfig(), None, ""
    if args.mission:
        try:
            plan = Plan.from_mission(args.mission, WallClock(), connect=args.connect)
            config, origin = plan.link, plan.origin
        except LocatedError as exc:
            problem = str(exc)
    if args.connect:
        config.connect = args.connect
    try:
        transport_for(config.connect, config.baud)
    except ValueError as exc:
        print(f"mavhelm check: {exc}", file=sys.stderr)
        return 2
    print(f"mavhelm check: listening to {config.connect} for {args.listen:g} s ...", flush=True)
    link = AutopilotLink(config.connect, config.baud, config.system_id, config.component_id,
                         config.target_system, config.target_component)
    try:
        if config.signing_key_file is not None:
            enable_signing(link.mav, read_key(config.signing_key_file))
        seen = observe(link, config, args.listen)
    except KeyFileError as exc:
        print(f"mavhelm check: {exc}", file=sys.stderr)
        return 2
    finally:
        link.close()
    lines = checklist(seen, config, origin, problem)
    for line in lines:
        print(line)
    failed = sum(line.status == "FAIL" for line in lines)
    print(f"mavhelm check: {failed} problem{'s' if failed != 1 else ''}" if failed
          else "mavhelm check: ready")
    return 1 if failed else 0


def _request(args: argparse.Namespace) -> int:
    from mavhelm.companion.guest import GUEST_COMPONENT, send_request
    from mavhelm.companion.link import AutopilotLink
    from mavhelm.companion.signing import KeyFileError, enable_signing, read_key
    from mavhelm.core.thirdparty import RequestError, ThirdPartyRequest

    if not args.close and not args.task:
        args.usage_error("give a task type (and Key=Value properties) or --close")
    try:
        request = ThirdPartyRequest(args.job, args.client)
        if args.close:
            text = request.close()
        else:
            for key, value in args.properties:
                request.add_property(key, value)
            text = request.execute_task(args.task)
    except RequestError as exc:
        print(f"mavhelm request: {exc}", file=sys.stderr)
        return 2
    target, source = args.target, args.source
    link = AutopilotLink(args.connect, system_id=source[0], component_id=source[1] or
                         GUEST_COMPONENT, target_system=target[0], target_component=target[1])
    if args.key_file is not None:
        try:
            enable_signing(link.mav, read_key(args.key_file))
        except KeyFileError as exc:
            print(f"mavhelm request: {exc}", file=sys.stderr)
            return 2
    print(f"mavhelm request: {text}", flush=True)
    try:
        reply = send_request(link, text, (target[0], target[1]), args.wait)
    finally:
        link.close()
    if reply is None:
        print(f"mavhelm request: no answer from {target[0]}:{target[1]} in {args.wait:g} s",
              file=sys.stderr)
        return 1
    print(f"mavhelm request: {reply}")
    return 0 if ":DENIED:" not in reply else 1


def _link_address(text: str) -> str:
    """An autopilot link (``--connect``): tcp:HOST:PORT, udp:HOST:PORT or a serial device."""
    from mavhelm.companion.link import transport_for

    try:
        transport_for(text, 57600)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def _web_address(text: str) -> str:
    """``--web [HOST:]PORT``."""
    from mavhelm.companion.web.server import parse_address

    try:
        parse_address(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def _system_component(text: str) -> tuple[int, int]:
    """``SYSTEM:COMPONENT`` (``--target``, ``--source``)."""
    parts = text.split(":")
    try:
        ids = tuple(int(v) for v in parts)
    except ValueError:
        ids = ()
    if len(ids) != 2 or not all(0 <= v <= 255 for v in ids):
        raise argparse.ArgumentTypeError(f"expected SYSTEM:COMPONENT (0-255 each), not {text!r}")
    return ids[0], ids[1]


def _key_value(text: str) -> tuple[str, str]:
    """A third-party request's ``Key=Value`` property."""
    key, eq, value = text.partition("=")
    if not eq or not key.strip():
        raise argparse.ArgumentTypeError(f"expected Key=Value, not {text!r}")
    return key, value


def _sim(args: argparse.Namespace) -> int:
    from mavhelm.sitl import runner

    return runner.run(args)


def _instruments(args: argparse.Namespace) -> int:
    from mavhelm.sitl import instruments_runner

    return instruments_runner.run(args)


def _demo(args: argparse.Namespace) -> int:
    from mavhelm.demo import DEFAULT_MISSION, run_demo
    from mavhelm.sitl.faults import Scenario

    scenario = Scenario.from_file(args.scenario) if args.scenario else None
    result = run_demo(args.mission or DEFAULT_MISSION, args.out, model=args.model,
                      defaults=args.defaults,
                      fast_start=args.fast_start, scenario=scenario, seed=args.seed)
    return 0 if result.ended else 1


def _params(args: argparse.Namespace) -> int:
    from mavhelm.companion.reference import reference

    sys.stdout.write(reference())
    return 0


def _convert(args: argparse.Namespace) -> int:
    from mavhelm.companion.companion import Plan
    from mavhelm.companion.moos import convert, mission_notes
    from mavhelm.core.clock import WallClock
    from mavhelm.core.errors import LocatedError
    from mavhelm.core.mission import load_mission

    mission = load_mission(args.mission)
    for line in convert(mission):
        print(line)
    for note in mission_notes(mission):
        print(f"note: {note}")
    try:
        Plan.from_mission(mission, WallClock())
    except LocatedError as exc:
        print(f"mavhelm would refuse this mission: {exc}")
        return 1
    print(f"{args.mission}: loads as it is")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from mavhelm.sitl import runner

    parser = argparse.ArgumentParser(prog="mavhelm", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run the helm and navigator next to a real autopilot")
    run.add_argument("mission", help="mission file (.moos)")
    run.add_argument("--connect", type=_link_address,
                     help="autopilot link: tcp:HOST:PORT, udp:HOST:PORT or a "
                     "serial device such as /dev/ttyAMA0 (default: the mission's Connect)")
    run.add_argument("--log-dir", default=None,
                     help="where the .alog goes (default: the mission's pLogger LogDir, runs/)")
    run.add_argument("--exit-at-end", action="store_true",
                     help="exit once EndMission is active and any HandBack is settled "
                          "(default: keep running, holding the end values while online)")
    run.add_argument("--clock", choices=["wall", "autopilot"], default="wall",
                     help="pace the helm on the wall clock (a real vehicle) or on the "
                          "autopilot's time_boot_ms (a SITL run with --speedup)")
    run.add_argument("--web", metavar="[HOST:]PORT", type=_web_address, default=None,
                     help="serve the live map and helm state on this address (HOST defaults "
                          "to 127.0.0.1: give 0.0.0.0 to reach it from another computer)")
    run.add_argument("--web-control", action="store_true",
                     help="with --web: add ALL STOP, hand back, restart helm and remote flags "
                          "to the page, behind a token printed at start")
    run.set_defaults(func=_run, usage_error=run.error)

    check = sub.add_parser("check", help="pre-flight checklist: connect, read the streams and "
                           "parameters the companion needs, say what is wrong and how to fix it")
    check.add_argument("mission", nargs="?", default=None,
                       help="the mission to check against (origin, actuation, servos)")
    check.add_argument("--connect", type=_link_address,
                       help="autopilot link (default: the mission's Connect)")
    check.add_argument("--listen", type=runner.positive_number, default=8.0,
                       help="seconds to listen for streams and parameters (default 8)")
    check.set_defaults(func=_check)

    request = sub.add_parser("request", help="a guest's third-party request to the helm, over "
                             "MAVLink (spec 1.3)")
    request.add_argument("task", nargs="?", help="task type, e.g. GoToWayPoint")
    request.add_argument("properties", nargs="*", metavar="Key=Value", type=_key_value,
                         help="the task's settings, e.g. Location=10,20")
    request.add_argument("--connect", required=True, type=_link_address,
                         help="where to reach the vehicle")
    request.add_argument("--job", required=True)
    request.add_argument("--client", required=True)
    request.add_argument("--close", action="store_true", help="end this client's transaction")
    request.add_argument("--target", default="1:191", type=_system_component,
                         help="the companion (default 1:191)")
    request.add_argument("--source", default="1:25", type=_system_component,
                         help="this guest's system:component (default 1:25)")
    request.add_argument("--key-file", default=None,
                         help="sign the request (MAVLink 2 signing) with the passphrase in this "
                              "file (chmod 600), where the companion requires signing")
    request.add_argument("--wait", type=runner.positive_number, default=5.0,
                         help="seconds to wait for the answer")
    request.set_defaults(func=_request, usage_error=request.error)

    from mavhelm.companion import remote as remote_console

    remote = sub.add_parser("remote", help="the iRemote console: a terminal ground station "
                            "(space = ALL STOP, o = GUIDED/MANUAL, R = restart helm)")
    remote_console.add_arguments(remote)
    remote.set_defaults(func=remote_console.run)

    from mavhelm.companion import log_plot

    log = sub.add_parser("log", help="tools for a run's logs")
    log_sub = log.add_subparsers(dest="log_command", required=True)
    plot = log_sub.add_parser("plot", help="track, who steered, heading (unwrapped) and nav "
                              "error of a run's .alog or .tlog, as a PNG")
    log_plot.add_arguments(plot)
    plot.set_defaults(func=log_plot.run)

    from mavhelm.companion import fleet_console

    view = sub.add_parser("view", help="several vehicles on one screen: every MAV_SYSID heard "
                          "on a ground station's link, with its mode and the helm's task")
    fleet_console.add_arguments(view)
    view.set_defaults(func=fleet_console.run, usage_error=view.error)

    sim = sub.add_parser("sim", help="an ArduPilot-Rover-like simulator a ground station can use")
    runner.add_arguments(sim)
    sim.set_defaults(func=_sim)

    from mavhelm.companion import tune

    tune_parser = sub.add_parser("tune", help="identify the vehicle in GUIDED inside a box you "
                                 "confirm, and print (or write) the heading gains, MaxTurnRate "
                                 "and Lead that suit it")
    tune.add_arguments(tune_parser)
    tune_parser.set_defaults(func=tune.run)

    from mavhelm.sitl import instruments_runner

    instruments = sub.add_parser("instruments", help="the serial instruments (GPS, heading, "
                                 "depth, DVL, beacons) on ptys, driven by a real SITL's SIMSTATE")
    instruments_runner.add_arguments(instruments)
    instruments.set_defaults(func=_instruments)

    from mavhelm.companion import nav_replay

    nav = sub.add_parser("nav", help="pNav tools offline")
    nav_sub = nav.add_subparsers(dest="nav_command", required=True)
    nav_replay_parser = nav_sub.add_parser(
        "replay", help="run the mission's pNav over a recorded .alog or .tlog and score it "
        "against the log's truth (TRUTH_X, TRUTH_Y)")
    nav_replay.add_arguments(nav_replay_parser)
    nav_replay_parser.set_defaults(func=nav_replay.run)

    demo = sub.add_parser("demo", help="run a mission end to end in the built-in simulator")
    demo.add_argument("mission", nargs="?", default=None,
                      help="mission file (default: the demo mission shipped with mavhelm, "
                      "examples/demo.moos in the repository)")
    demo.add_argument("--out", default="runs", help="output folder (default runs/)")
    from mavhelm.sitl.models import DEFAULT_MODEL, MODEL_NAMES

    demo.add_argument("--model", default=DEFAULT_MODEL, choices=MODEL_NAMES, metavar="NAME",
                      help=f"vehicle model: {', '.join(MODEL_NAMES)} (default {DEFAULT_MODEL})")
    demo.add_argument("--defaults", default=None, metavar="FILE[,FILE...]",
                      help="ArduPilot .parm files applied over the parameter table")
    demo.add_argument("--fast-start", action="store_true",
                      help="compress the autopilot's start-up timeline")
    demo.add_argument("--scenario", help="fault scenario file (.scn)")
    demo.add_argument("--seed", type=int, default=0)
    demo.set_defaults(func=_demo)
    params = sub.add_parser("params", help="print the reference of every mission setting "
                            "(Markdown: names, units, defaults, accepted ranges)")
    params.set_defaults(func=_params)
    convert = sub.add_parser("convert", help="print what each line of a MOOS mission file maps "
                             "to in mavhelm (honoured, accepted and not used, or refused)")
    convert.add_argument("mission", help="mission file (.moos)")
    convert.set_defaults(func=_convert)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    _stop_on_signals()
    try:
        return args.func(args)
    except (LocatedError, SettingError) as exc:
        print(f"mavhelm: {exc}", file=sys.stderr)
        return 2
    except FileNotFoundError as exc:
        print(f"mavhelm: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"mavhelm: cannot open the autopilot link: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("mavhelm: stopped while starting", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
