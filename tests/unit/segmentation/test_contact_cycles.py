"""Contact rules on repeated pick-carry-place cycles (issue 41): every release (not only the last)
where the hand lets go; synthetic tracks with known contact times."""

from __future__ import annotations

import numpy as np
from lfd.contact import ContactParams, refine
from lfd.geometry import box_distance
from lfd.skills import Draft

SIZE = np.array([[0.06, 0.06, 0.06]])
REST = 0.03  # the cube's centre on the table


def _two_cycles(n: int = 400) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Two carries of one cube: lifted at 50 and set down by 110, the hand opening (thumb
    1 cm off the box) at 150 and leaving 3 cm up by 160, back on it at 200; lifted again at
    240, set down by 300, let go at 340."""
    t = np.arange(n)
    obj = np.zeros((1, n, 3))
    obj[0, :, 2] = REST
    for a in (50, 240):
        up = (t >= a) & (t < a + 60)
        obj[0, up, 2] += 0.12 * np.sin(np.pi * (t[up] - a) / 60)
    tcp = obj[0].copy()
    thumb = tcp.copy()
    for a, b in ((150, 200), (340, n)):
        off = (t >= a) & (t < b)
        thumb[off, 1] += 0.035 + 0.002 * np.minimum(t[off] - a, 10)  # thumb opens off the face
        tcp[off, 2] += 0.004 * np.minimum(t[off] - a, 15)  # the hand rises 6 cm
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (1, n, 1))
    return tcp, thumb, obj, quat


def test_every_release_ends_where_the_hand_lets_go() -> None:
    tcp, thumb, obj, quat = _two_cycles()
    d_thumb = box_distance(thumb, obj[0], quat[0], SIZE[0])
    let_go = int(np.argmax(d_thumb > d_thumb[120] + ContactParams().release_thumb_m))
    assert 150 <= let_go <= 155
    # a search whose first Place ends early (at 125, the hand still on the cube)
    drafts = [
        Draft("pick_up", 0, 50, 0),
        Draft("move_with", 50, 100, 0),
        Draft("place", 100, 125, 0),
        Draft("move", 125, 230, 0),
        Draft("pick_up", 230, 240, 0),
        Draft("move_with", 240, 290, 0),
        Draft("place", 290, 400, 0),
    ]
    out = refine(drafts, tcp, thumb, obj, quat, SIZE)
    skills = [d.skill for d in out]
    assert skills[skills.index("place") + 1] == "move"
    first = out[skills.index("place")]
    assert first.end == let_go  # the release between the cycles: where the hand lets go
    assert out[-1].skill == "move" and 340 <= out[-1].start <= 345  # and the last one
    # a Place that the search ended late (the hand gone at 151) ends there too
    drafts[2], drafts[3] = Draft("place", 100, 180, 0), Draft("move", 180, 230, 0)
    out = refine(drafts, tcp, thumb, obj, quat, SIZE)
    assert out[[d.skill for d in out].index("place")].end == let_go
