"""A helm on a bus with a simulated clock, driven tick by tick as the community drives it;
shared by the helm's tests."""

from __future__ import annotations

from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from mavhelm.core.mission import Block, Entry
from mavhelm.tasks.helm import Helm

FILE = "helm.moos"


class Spec:
    """Builds Blocks with increasing line numbers, as the parser would."""

    def __init__(self) -> None:
        self.line = 1

    def block(self, kind: str, name: str, *pairs: tuple[str, str]) -> Block:
        start = self.line
        entries = [Entry(k, v, FILE, start + 1 + i) for i, (k, v) in enumerate(pairs)]
        self.line += len(pairs) + 3
        return Block(kind, name, FILE, start, entries)

    def task(self, kind: str, *pairs: tuple[str, str]) -> Block:
        return self.block("Task", kind, *pairs)


def safety(spec: Spec, timeout: str = "10000") -> list[Block]:
    return [
        spec.task(
            "OverallTimeOut",
            ("Name", "Overall"),
            ("TimeOut", timeout),
            ("FinishFlag", "EndMission"),
        ),
        spec.task("EndMission", ("Name", "Stop"), ("StartFlag", "EndMission")),
    ]


class Rig:
    """Drives a helm the way the community does: subscribe, post, mail, iterate."""

    def __init__(self, tasks: list[Block], spec: Spec, *helm_pairs: tuple[str, str]) -> None:
        self.clock = SimClock(1000.0)
        self.bus = Bus(self.clock)
        self.bus.subscribe("probe", ["*"])
        self.helm = Helm(self.bus, spec.block("ProcessConfig", "pHelm", *helm_pairs), tasks)

    def tick(self, dt: float = 1.0, **posts: float | str) -> list[Message]:
        """Advance, post ``posts`` at the new time, run one helm tick; return the helm's posts."""
        now = self.clock.advance(dt)
        self.bus.subscribe(self.helm.name, self.helm.subscriptions())
        for name, value in posts.items():
            self.bus.notify(name, value, "test")
        self.bus.fetch("probe")
        self.helm.on_mail(self.bus.fetch(self.helm.name), now)
        self.helm.iterate(now)
        return [m for m in self.bus.fetch("probe") if m.source == "pHelm"]


def values(out: list[Message], name: str) -> list[float | str]:
    return [m.value for m in out if m.name == name]


def one(out: list[Message], name: str) -> float | str:
    found = values(out, name)
    assert len(found) == 1, f"{name}: {found}"
    return found[0]
