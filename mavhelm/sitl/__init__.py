"""A vehicle simulator that speaks MAVLink the way ArduPilot Rover SITL does."""
