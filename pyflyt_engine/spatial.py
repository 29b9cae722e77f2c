"""A uniform grid over the horizontal plane: which of many points lie near a given one.

Used where every vehicle of a world asks about the others -- the downwash of the
rotorcraft above (:mod:`pyflyt_engine.atmosphere.rotors`), the neighbours a swarm agent
observes (:mod:`pyflyt_engine.envs.multi_agent.formation`) -- so that the work per vehicle
is bounded by its neighbourhood rather than by the number of vehicles.  The grid only
narrows the candidates: callers test each candidate exactly, so the answers are those of
an all-pairs search.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence


class PlanarGrid:
    """Points (vehicles, by index) binned by horizontal position, to find those near a point.

    Square cells of side ``cell`` [m] keyed by ``(floor(x / cell), floor(y / cell))``.
    :meth:`place` (re)bins one vehicle, O(1); :meth:`near` lists, in index order, the
    points in the cells that a disc of a given radius touches -- O(cells touched +
    points found), or O(points) when the disc covers more cells than are occupied.
    :attr:`top` is at least the height (z) of every point placed since :meth:`clear`.
    """

    def __init__(self, cell: float) -> None:
        if not cell > 0.0:
            raise ValueError(f"grid cell must be > 0 m, got {cell}")
        self.cell = cell
        self.cells: dict[tuple[int, int], list[int]] = {}
        self.where: dict[int, tuple[int, int]] = {}
        #: per point, the position object it was binned from (to notice a newer read)
        self.placed: dict[int, Sequence[float]] = {}
        self.top = -math.inf

    def clear(self) -> None:
        self.cells.clear()
        self.where.clear()
        self.placed.clear()
        self.top = -math.inf

    def place(self, index: int, position: Sequence[float]) -> None:
        """Bin point ``index`` at ``position`` (moving it out of its old cell)."""
        self.placed[index] = position
        z = position[2]
        if z > self.top:
            self.top = z
        key = (math.floor(position[0] / self.cell), math.floor(position[1] / self.cell))
        old = self.where.get(index)
        if old == key:
            return
        if old is not None:
            members = self.cells[old]
            members.remove(index)
            if not members:
                del self.cells[old]
        self.where[index] = key
        self.cells.setdefault(key, []).append(index)

    def near(self, x: float, y: float, radius: float) -> list[int]:
        """Points binned in the cells the disc of ``radius`` about ``(x, y)`` touches, ascending."""
        c = self.cell
        x0, x1 = math.floor((x - radius) / c), math.floor((x + radius) / c)
        y0, y1 = math.floor((y - radius) / c), math.floor((y + radius) / c)
        cells = self.cells
        found: list[int] = []
        if (x1 - x0 + 1) * (y1 - y0 + 1) > len(cells):
            for (cx, cy), members in cells.items():
                if x0 <= cx <= x1 and y0 <= cy <= y1:
                    found.extend(members)
        else:
            for cx in range(x0, x1 + 1):
                for cy in range(y0, y1 + 1):
                    held = cells.get((cx, cy))
                    if held:
                        found.extend(held)
        found.sort()
        return found

    def nearest(
        self,
        x: float,
        y: float,
        z: float,
        positions: Mapping[int, Sequence[float]],
        count: int,
        radius: float,
        skip: int,
    ) -> list[tuple[float, int]]:
        """The ``count`` points nearest to ``(x, y, z)`` within ``radius`` [m] (3-D distance),
        ``skip`` excluded, as ``(squared distance, index)`` ascending (ties by index).

        Searches rings of cells outwards from the point's cell and stops once the rings
        searched cover a disc holding ``count`` points nearer than its radius (or the whole
        ``radius``): the answer of an all-pairs search, from the cells near the point.
        ``positions`` gives each binned point's position.
        """
        c = self.cell
        cells = self.cells
        kx, ky = math.floor(x / c), math.floor(y / c)
        r2 = radius * radius
        found: list[tuple[float, int]] = []
        ring = 0
        limit = math.ceil(radius / c) + 1
        while ring <= limit:
            if ring == 0:
                keys = [(kx, ky)]
            else:
                keys = [(kx + dx, ky - ring) for dx in range(-ring, ring + 1)]
                keys += [(kx + dx, ky + ring) for dx in range(-ring, ring + 1)]
                keys += [(kx - ring, ky + dy) for dy in range(-ring + 1, ring)]
                keys += [(kx + ring, ky + dy) for dy in range(-ring + 1, ring)]
            for key in keys:
                members = cells.get(key)
                if members:
                    for j in members:
                        if j == skip:
                            continue
                        px, py, pz = positions[j]
                        d2 = (px - x) ** 2 + (py - y) ** 2 + (pz - z) ** 2
                        if d2 <= r2:
                            found.append((d2, j))
            # every point within ring * c of (x, y) horizontally lies in the rings searched
            covered = ring * c
            if covered >= radius:
                break
            if count and len(found) >= count:
                found.sort()
                if found[count - 1][0] < covered * covered:
                    break
            ring += 1
        found.sort()
        return found[:count]
