"""The replay a record takes: the rig's (``replay.RigReplay``) or, when its sidecar's ``model``
names one, a machine scene's in closed loop (``machine_replay.MachineReplay``).

Above both modules, so that the general one (``replay``) does not import its specialisation.
"""
from __future__ import annotations

from ..data.datasets import Dataset
from .machine_replay import MachineReplay, prepare_machine_replay
from .replay import RIG_MODEL, RigReplay, prepare_rig_replay


def prepare_replay(dataset: Dataset, *,
                   substeps: int | None = None) -> RigReplay | MachineReplay:
    """Set a record up for replay in the rig (or in the machine its sidecar's ``model``
    names); InputError naming what is missing otherwise."""
    if dataset.metadata.model not in (None, RIG_MODEL):
        return prepare_machine_replay(dataset, substeps=substeps)
    return prepare_rig_replay(dataset, substeps=substeps)


__all__ = ["prepare_replay"]
