"""The pilot's inputs (Rover/radio.cpp, RC_Channel.cpp, GCS_Common.cpp's RC override and
MANUAL_CONTROL handling): the simulated radio (centred sticks, always valid) and the overrides
a ground station sends, each holding RC_OVERRIDE_TIME after its last refresh, turned into the
steering and throttle the pilot asks for.

Apart from the autopilot because every mode that reads the sticks shares it, and the RC rules
(who may override, what releases, what expires) are a concept of their own.

The channels and the pilot's (steering, throttle) are asked for in every control-loop pass but
change only when an override arrives, is released or expires, the radio changes or a parameter
is set, so both are kept until one of those happens (``invalidate()`` for parameters)."""

from __future__ import annotations

from collections.abc import MutableMapping, Sequence

from mavhelm.sitl.attitude_control import clamp


class RcInput:
    """RC channels 1-18: the radio's values and the ground station's overrides.

    Change the radio with ``set_radio`` and the overrides through the message handlers (or
    call ``invalidate()``), so the cached channels follow."""

    def __init__(self, params: MutableMapping[str, float]) -> None:
        self.params = params
        self.radio: tuple[int, ...] = (1500,) * 16  # SITL's radio: centred
        self.override: list[int | None] = [None] * 18
        self.override_time: list[float] = [0.0] * 18
        # rc_in's last answer, valid while no live override can have expired: the oldest live
        # override's refresh time and the RC_OVERRIDE_TIME it was judged by
        self._channels: list[int] | None = None
        self._oldest: float | None = None
        self._timeout = 0.0
        self._pilot: tuple[float, float] | None = None  # pilot_input's answer for _channels

    def invalidate(self) -> None:
        """Parameters, radio or overrides changed: recompute the channels when next asked."""
        self._channels = None
        self._pilot = None

    def set_radio(self, values: Sequence[int]) -> None:
        """The radio's 16 channels (PWM)."""
        self.radio = tuple(int(v) for v in values[:16])
        self.invalidate()

    def clear_overrides(self) -> None:
        """A failsafe drops every override (the radio takes back)."""
        self.override = [None] * 18
        self.invalidate()

    def override_msg(self, sysid: int, values: list[int], now: float) -> None:
        """RC_CHANNELS_OVERRIDE: only from MAV_GCS_SYSID; 0 releases ch1-8, UINT16_MAX ignores;
        ch9-18: 0 and UINT16_MAX ignore, UINT16_MAX-1 releases."""
        if sysid != int(self.params["MAV_GCS_SYSID"]):
            return
        self.invalidate()
        for i, v in enumerate(values[:18]):
            if i < 8:
                if v == 0xFFFF:
                    continue
                if v == 0:
                    self.override[i] = None
                    continue
            else:
                if v in (0, 0xFFFF):
                    continue
                if v == 0xFFFE:
                    self.override[i] = None
                    continue
            self.override[i] = int(v)
            self.override_time[i] = now

    def manual_control(self, sysid: int, y: int, z: int, now: float) -> None:
        """MANUAL_CONTROL: from MAV_GCS_SYSID only; y steers, z throttles (-1000..1000, INT16_MAX
        = no change), mapped onto the RCMAP channels as an override (GCS_MAVLINK::manual_override).
        """
        if sysid != int(self.params["MAV_GCS_SYSID"]):
            return
        self.invalidate()
        for ch, value in ((int(self.params["RCMAP_ROLL"]), y),
                          (int(self.params["RCMAP_THROTTLE"]), z)):
            if value == 0x7FFF:
                continue
            lo = self.params.get(f"RC{ch}_MIN", 1100)
            hi = self.params.get(f"RC{ch}_MAX", 1900)
            self.override[ch - 1] = int(lo + (hi - lo) * (value + 1000) / 2000.0)
            self.override_time[ch - 1] = now

    def rc_in(self, now: float) -> list[int]:
        """Effective RC input per channel (override while fresh, else the radio)."""
        return list(self._current(now))

    def _current(self, now: float) -> list[int]:
        """rc_in(now), shared: the cached channels while every live override is still fresh
        at now (the oldest one decides: now - t only grows as t falls), else recomputed, which
        drops the overrides that have expired."""
        channels, oldest, timeout = self._channels, self._oldest, self._timeout
        if channels is not None and (oldest is None or timeout < 0
                                     or now - oldest <= timeout):
            return channels
        timeout = self._timeout = self.params["RC_OVERRIDE_TIME"]
        out = []
        oldest = None
        for i in range(18):
            ov = self.override[i]
            if ov is not None and (timeout < 0 or now - self.override_time[i] <= timeout):
                out.append(ov)
                t = self.override_time[i]
                if oldest is None or t < oldest:
                    oldest = t
            else:
                if ov is not None:
                    self.override[i] = None
                out.append(self.radio[i] if i < 16 else 0)
        self._channels, self._oldest, self._pilot = out, oldest, None
        return out

    def norm(self, ch: int, pwm: int) -> float:
        """-1..1 with dead zone around trim, like RC_Channel::norm_input_dz."""
        lo = self.params.get(f"RC{ch}_MIN", 1100)
        hi = self.params.get(f"RC{ch}_MAX", 1900)
        trim = self.params.get(f"RC{ch}_TRIM", 1500)
        dz = self.params.get(f"RC{ch}_DZ", 0)
        if pwm > trim + dz:
            return clamp((pwm - trim - dz) / max(hi - trim - dz, 1), -1.0, 1.0)
        if pwm < trim - dz:
            return clamp((pwm - trim + dz) / max(trim - lo - dz, 1), -1.0, 1.0)
        return 0.0

    def pilot_input(self, now: float) -> tuple[float, float]:
        """(steering, throttle) in -1..1 from the mapped RC channels."""
        rc = self._current(now)
        if self._pilot is None:
            sch = int(self.params["RCMAP_ROLL"])
            tch = int(self.params["RCMAP_THROTTLE"])
            steer = self.norm(sch, rc[sch - 1])
            thr = self.norm(tch, rc[tch - 1])
            if self.params.get("PILOT_STEER_TYPE", 0) in (0, 1) and thr < 0:
                steer = -steer  # steering reverses when backing up
            self._pilot = (steer, thr)
        return self._pilot
