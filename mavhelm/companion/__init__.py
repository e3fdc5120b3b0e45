"""The companion process: bus, clock, mission files, MAVLink bridge, logs and the CLI."""
