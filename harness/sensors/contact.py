"""Contact sensors: ``harness_msgs/ContactsState`` (the fields of Gazebo's
``gazebo_msgs/ContactsState``), one state per contact point of the sensor's geometry (the
``collision`` geom, or every geom of its link) at the step, positions, normals and forces in
the world frame; the force is the one acting on the sensor's geometry."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from lxml import etree  # type: ignore[import-untyped,unused-ignore]

from harness.sensors.base import F64, Mount, SensorTopic, View, find_object, quat_of
from harness.sensors.errors import SensorConfigError
from harness.sensors.messages import TYPE_CONTACTS, contact_state, header
from harness.sensors.options import SensorOptions
from harness.sensors.registry import Mounted, SensorKind, register_kind
from harness.sensors.sdf_values import element_text
from harness.sensors.spec import SensorSpec

__all__ = ["ContactOptions", "ContactSensor"]


@dataclass(frozen=True)
class ContactOptions(SensorOptions):
    """A contact sensor's options: ``collision``, the geom it watches (default: every geom of
    its link)."""

    collision: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.collision, str):
            raise SensorConfigError(f"collision must be a geom name, not {self.collision!r}")


class ContactSensor:
    """A contact sensor of ``spec`` at ``mount``."""

    def __init__(
        self,
        spec: SensorSpec,
        model: mujoco.MjModel,
        mount: Mount,
        topics: Mapping[str, str],
        frame_id: str,
        prefix: str = "",
    ) -> None:
        self.spec = spec
        self.mount = mount
        self.frame_id = frame_id
        self.outputs: tuple[SensorTopic, ...] = (
            SensorTopic("contacts", topics["contacts"], TYPE_CONTACTS),
        )
        collision = spec.options_as(ContactOptions).collision
        if collision:
            geom = find_object(model, mujoco.mjtObj.mjOBJ_GEOM, prefix + collision)
            if geom < 0:
                raise SensorConfigError(
                    f"sensor {spec.name!r}: the model has no collision {collision!r}"
                )
            geoms = [geom]
        else:
            geoms = [g for g in range(model.ngeom) if int(model.geom_bodyid[g]) == mount.body]
        self._geoms = frozenset(geoms)
        self._model = model

    def _name(self, geom: int) -> str:
        return mujoco.mj_id2name(self._model, mujoco.mjtObj.mjOBJ_GEOM, geom) or f"geom{geom}"

    def states(self, view: View) -> list[dict[str, Any]]:
        """One ``ContactState`` per contact point of the sensor's geometry."""
        data = view.data
        out = []
        force6 = np.zeros(6)
        for i in range(data.ncon):
            contact = data.contact[i]
            g1, g2 = int(contact.geom[0]), int(contact.geom[1])
            if g1 not in self._geoms and g2 not in self._geoms:
                continue
            mujoco.mj_contactForce(view.model, data, i, force6)
            frame = contact.frame.reshape(3, 3)
            world = frame.T @ force6[:3]  # on geom2, from geom1
            normal = frame[0].copy()
            if g1 in self._geoms:  # the force on geom1 is the opposite
                mine, other, world, normal = g1, g2, -world, -normal
            else:
                mine, other = g2, g1
            out.append(
                contact_state(
                    self._name(mine), self._name(other), world, contact.pos.copy(), normal,
                    max(0.0, -float(contact.dist)),
                )
            )  # fmt: skip
        return out

    def read(self, view: View) -> Mapping[str, Callable[[], dict[str, Any]]]:
        """The ``ContactsState`` builder at this step."""

        def contacts() -> dict[str, Any]:
            return {"header": header(view.sim_time_ns, "world"), "states": self.states(view)}

        return {"contacts": contacts}

    def static_frames(self) -> list[tuple[str, F64, F64]]:
        """The sensor frame in the mount link."""
        return [(self.frame_id, self.mount.position, quat_of(self.mount.rotation))]


def _params(sensor: etree._Element, where: str) -> dict[str, Any]:
    collision = element_text(sensor, "contact/collision")
    return {"collision": collision} if collision else {}


def _build(spec: SensorSpec, at: Mounted) -> ContactSensor:
    return ContactSensor(spec, at.model, at.mount, at.topics, at.frame_id, at.prefix)


register_kind(
    SensorKind(
        "contact",
        ("contacts",),
        100.0,
        _build,
        gazebo=("contact",),
        params=_params,
        options=ContactOptions,
    )
)
