"""What recovery may know of a task, resolved from its env in one place (`IvmcFetchEnv.traits`): how the
task treats its object and, for a pushed one, how the fingers push it."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PushContact:
    """How closed fingers push the task's object (metres).

    Attributes:
        contact: grip point to the object's centre when the fingers touch a face, along x and along y.
        approach_gap: a push starts this far from contact.
        hover: travel height above the object's centre between pushes.
        speed: grip-point move per step while pushing.
    """

    contact: tuple[float, float]
    approach_gap: float
    hover: float
    speed: float


@dataclass(frozen=True)
class TaskTraits:
    """How a task treats its object.

    Attributes:
        object_picked: the object is picked up at all (else pushed).
        object_held_at_end: the task ends with the object still held (else resting at the goal).
        rest_height: the height of the object's centre resting on the table (metres).
        half_length: the object's longest half-size (metres).
        push_contact: how the fingers push it, for a pushed object; None where the task never pushes.
    """

    object_picked: bool
    object_held_at_end: bool
    rest_height: float
    half_length: float
    push_contact: PushContact | None = None
