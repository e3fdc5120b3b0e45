"""The companion process: MAVLink bridge, the community that hosts nav and helm, logs."""
