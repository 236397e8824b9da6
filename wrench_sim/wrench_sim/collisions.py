"""Collisions: contacts of the arm's moving links with the ground and the stand, and of a held
object with the ground, looked up at each bookkeeping step (every 10 ms, never per physics
step). Each contact that begins is an event ``collision: ... touches ...`` (counted); its end
is an event ``... no longer touches ...``. The object on its stand and the fingers on the
object are not looked up.
"""

from __future__ import annotations

from collections.abc import Callable

from wrench_sim.scene import Scene

__all__ = ["CollisionWatch"]


class CollisionWatch:
    """Looks up the contacts of ``scene`` (see module); ``event`` records a line for the user
    (``ArmWorld.events``)."""

    def __init__(self, scene: Scene, event: Callable[[str], None]) -> None:
        self._scene = scene
        self._event = event
        self._touching: set[tuple[str, str]] = set()  # (what, obstacle) in contact
        self.count = 0
        """How many contacts have begun since the start."""

    def look(self, held: bool) -> None:
        """Record each contact that began or ended since the last look (the object ``held`` or
        not)."""
        scene = self._scene
        c, body = scene.client, scene.robot_body
        touching = set()
        for obstacle, name in ((scene.plane, "the ground"), (scene.stand, "the stand")):
            for point in c.getContactPoints(body, obstacle):
                if point[3] not in scene.base_links:
                    touching.add((f"link {scene.link_names[point[3]]}", name))
        if held and c.getContactPoints(scene.object_body, scene.plane):
            touching.add((f"the held {scene.object.shape}", "the ground"))
        if touching == self._touching:
            return
        for what, obstacle in sorted(touching - self._touching):
            self.count += 1
            self._event(f"collision: {what} touches {obstacle}")
        for what, obstacle in sorted(self._touching - touching):
            self._event(f"{what} no longer touches {obstacle}")
        self._touching = touching
