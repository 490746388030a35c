"""Fork edits: changes applied at the resume step, recorded as that step's input, so that
"try again with a different gain" is one flag (``harness serve --from RUN --at K --set ...``).

An edit is ``KIND.TARGET=VALUE``:

- ``joint.NAME=POSITION``: a joint's position target (a Python ``command`` of the joint,
  recorded as a ``harness/python`` marker; a trajectory of the built-in command topics lets
  go of the joint; a ros2_control controller that claims the joint writes it again at its
  next update);
- ``param.CONTROLLER.NAME=VALUE``: a running controller's parameter, e.g.
  ``param.joint_trajectory_controller.constraints.joint1.trajectory=0.05`` (the JTC's
  tolerances: the goals that follow use them, as ros2_control's JTC re-reading its
  parameters) or ``param.diff_drive_controller.angular.z.max_velocity=0.5`` (a diff drive's
  speed limits, from its next update), recorded as a ``harness/python`` ``set_parameter``
  marker;
- ``noise.SENSOR=STDDEV``: a sensor's Gaussian noise (its ``noise_stddev``; the noise stream
  stays a function of seed, sensor and step), recorded as a ``set_sensor_noise`` marker;
- ``pose.BODY=X,Y,Z[,QW,QX,QY,QZ]``: an object's pose (a free body: a world object, a
  floating base), at rest, recorded as a ``set_body_pose`` marker and an epoch (reason
  ``pose``) holding the state the run continues from, as a reset is.

Each edit is applied at the step boundary after the resume step, before any live frame, and
is recorded there (the child replays it); the child's metadata lists them
(``resumed_edits``). A wrong edit is one :class:`~harness.resume.ForkEditError` line naming
it and what the run has.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from harness.errors import HarnessError
from harness.resume.errors import ForkEditError
from harness.session.core import SessionCore

__all__ = ["EDIT_KINDS", "Edit", "apply_edits", "parse_edit", "parse_edits"]

EDIT_KINDS = ("joint", "param", "noise", "pose")


@dataclass(frozen=True)
class Edit:
    """One fork edit: ``kind`` (one of :data:`EDIT_KINDS`), what it changes (``target``,
    dotted), the new ``value``."""

    kind: str
    target: str
    value: tuple[float, ...]

    def to_json(self) -> dict[str, object]:
        """The edit as the child's metadata lists it."""
        return {"kind": self.kind, "target": self.target, "value": list(self.value)}

    def __str__(self) -> str:
        return f"{self.kind}.{self.target}={','.join(repr(v) for v in self.value)}"


def parse_edit(text: str) -> Edit:
    """``KIND.TARGET=V[,V...]`` as an :class:`Edit` (:class:`ForkEditError` naming what is
    wrong)."""
    head, sep, values = text.partition("=")
    kind, dot, target = head.strip().partition(".")
    if not sep or not dot or not target:
        raise ForkEditError(
            f"fork edit {text!r} is not KIND.TARGET=VALUE (kinds: {', '.join(EDIT_KINDS)})"
        )
    if kind not in EDIT_KINDS:
        raise ForkEditError(
            f"fork edit {text!r}: unknown kind {kind!r} (kinds: {', '.join(EDIT_KINDS)})"
        )
    try:
        numbers = tuple(float(v) for v in values.split(","))
    except ValueError:
        raise ForkEditError(f"fork edit {text!r}: {values!r} is not a number") from None
    if not all(math.isfinite(v) for v in numbers):
        raise ForkEditError(f"fork edit {text!r}: the value must be finite")
    return Edit(kind, target.strip(), numbers)


def parse_edits(edits: Sequence[Edit | str]) -> list[Edit]:
    """Every edit parsed (strings) or as given."""
    return [e if isinstance(e, Edit) else parse_edit(e) for e in edits]


def apply_edits(core: SessionCore, edits: Sequence[Edit]) -> None:
    """Apply ``edits`` to ``core`` at its current step boundary, each recorded there."""
    for edit in edits:
        try:
            _apply(core, edit)
        except ForkEditError:
            raise
        except HarnessError as exc:
            raise ForkEditError(f"fork edit {edit}: {exc}") from None


def _apply(core: SessionCore, edit: Edit) -> None:
    if edit.kind == "joint":
        if edit.target not in core.sim.joint_names:
            raise ForkEditError(
                f"fork edit {edit}: no controllable joint {edit.target!r} (joints: "
                f"{', '.join(core.sim.joint_names)})"
            )
        if len(edit.value) != 1:
            raise ForkEditError(f"fork edit {edit}: a joint target is one position")
        core.command(edit.target, position=edit.value[0])
    elif edit.kind == "param":
        controller, dot, name = edit.target.partition(".")
        if not dot or not name or len(edit.value) != 1:
            raise ForkEditError(
                f"fork edit {edit}: a parameter edit is param.CONTROLLER.NAME=VALUE"
            )
        core.set_parameter(controller, name, edit.value[0])
    elif edit.kind == "noise":
        if len(edit.value) != 1:
            raise ForkEditError(f"fork edit {edit}: a noise edit is noise.SENSOR=STDDEV")
        core.set_sensor_noise(edit.target, edit.value[0])
    elif edit.kind == "pose":
        if len(edit.value) not in (3, 7):
            raise ForkEditError(f"fork edit {edit}: a pose is pose.BODY=X,Y,Z[,QW,QX,QY,QZ]")
        orientation = edit.value[3:] if len(edit.value) == 7 else None
        core.set_body_pose(edit.target, edit.value[:3], orientation)
