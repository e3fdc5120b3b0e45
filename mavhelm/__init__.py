"""mavhelm: the MOOS pHelm and pNav processes for ArduPilot boats and rovers, over MAVLink."""

__version__ = "0.1.0"
