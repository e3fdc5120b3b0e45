"""The systemd unit under deploy/: its command is one ``mavhelm run`` accepts with the settings
its environment file gives, and it restarts and stops the way the README says."""

from __future__ import annotations

import configparser
import shlex
from pathlib import Path

from mavhelm.cli import build_parser

DEPLOY = Path(__file__).resolve().parents[1] / "deploy"


def environment() -> dict[str, str]:
    values = {}
    for line in (DEPLOY / "mavhelm.env").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            key, _, value = line.partition("=")
            values[key] = value
    return values


def test_the_unit_runs_mavhelm_run_with_its_settings():
    unit = configparser.ConfigParser(strict=False, interpolation=None)
    unit.optionxform = str  # type: ignore[assignment]
    unit.read(DEPLOY / "mavhelm.service")
    service = unit["Service"]
    assert service["Restart"] == "always" and service["KillSignal"] == "SIGTERM"
    env = environment()
    command = service["ExecStart"]
    for key, value in env.items():
        command = command.replace(f"${{{key}}}", value).replace(f"${key}", value)
    argv = shlex.split(command)
    assert argv[0] == "/opt/mavhelm/venv/bin/mavhelm"
    args = build_parser().parse_args(argv[1:])
    assert (args.command, args.mission, args.connect, args.web) == \
        ("run", env["MAVHELM_MISSION"], env["MAVHELM_CONNECT"], "127.0.0.1:8080")
    args = build_parser().parse_args([*argv[1:], "--web-control"])
    assert args.web_control
