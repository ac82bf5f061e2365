"""World: the one object users hold to step a model and read or set its state.

    world.py     World: builds the arrays, holds them, steps (through pipeline/call.py)
    options.py   Options: how it steps (contact model, solver, ERP/CFM, PD mode, ...)
    state.py     State snapshots, set/get/save/load_state, set_body_state
    control.py   what users write between steps: forces, servo gains and targets, ctrl
    queries.py   what they read: contacts, rays, distances, frames, energy, momentum
"""
from .options import Options
from .queries import Contacts
from .state import State
from .world import World

__all__ = ["World", "State", "Options", "Contacts"]
