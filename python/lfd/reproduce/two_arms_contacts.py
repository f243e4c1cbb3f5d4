"""The two arms' contacts with each other and with the table (:mod:`.two_arms`): which geoms
collide (:data:`ARM_BITS`, :func:`collision_bits`) and the first contact of each kind, naming
the arm and its link (:class:`Collision`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

ARM_BITS = {"right": 2, "left": 4}
"""Each arm's collision bit: its links collide with the table and the other arm (not with
the objects, nor with themselves); its gripper and fingers with those and the objects."""


def collision_bits(body: str, side: str) -> str:
    """``body`` (an arm's MJCF) with its links colliding with the table and the other arm
    (:data:`ARM_BITS`), its colliding geoms (gripper, pads) with the other arm too; the
    finger meshes stay seen only."""
    import xml.etree.ElementTree as ET

    mine = ARM_BITS.get(side, 0)
    others = sum(b for s, b in ARM_BITS.items() if s != side)
    root = ET.fromstring(f"<arm>{body}</arm>")
    for geom in root.iter("geom"):
        name = geom.get("name", "")
        if geom.get("contype") == "0":
            if "finger" in name:
                continue  # a finger's mesh: its flat pad collides
            geom.set("contype", str(mine))
            geom.set("conaffinity", str(others))
        else:
            geom.set("contype", str(1 | mine))
            geom.set("conaffinity", str(1 | others))
    return "".join(ET.tostring(el, encoding="unicode") for el in root)


@dataclass(frozen=True)
class Collision:
    """An arm touching the other arm or the table (its first tick)."""

    arm: str
    part: str
    """The arm's link (``upper_forearm_link``, ``gripper``, ...)."""
    other: str
    """``"table"`` or the other arm's side."""
    other_part: str
    t_s: float

    def describe(self) -> str:
        what = "the table" if self.other == "table" else f"the {self.other} arm's {self.other_part}"
        return f"{self.arm} arm: collision: its {self.part} touched {what} at {self.t_s:.1f} s"


class Contacts:
    """Which geoms belong to which arm (and its link), to find arm-arm and arm-table contacts."""

    def __init__(self, model: Any, sides: list[str]) -> None:
        self.owner: dict[int, tuple[str, str]] = {}
        for g in range(model.ngeom):
            name = model.geom(g).name
            body = model.body(model.geom_bodyid[g]).name
            if name == "table":
                self.owner[g] = ("table", "top")
            for side in sides:
                if body.startswith(f"{side}/"):
                    self.owner[g] = (side, body[len(side) + 1 :])
        self.seen: dict[str, Collision] = {}

    def check(self, data: Any, t_s: float) -> None:
        if not data.ncon:
            return
        for g1, g2 in zip(data.contact.geom1, data.contact.geom2, strict=True):
            a, b = self.owner.get(int(g1)), self.owner.get(int(g2))
            if a is None or b is None or a[0] == b[0]:
                continue
            if a[0] == "table":
                a, b = b, a
            key = f"{a[0]} table" if b[0] == "table" else "arms"
            if key not in self.seen:
                self.seen[key] = Collision(a[0], a[1], b[0], b[1], t_s)
