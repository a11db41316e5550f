"""The RoboGen body space as pure data: parts, robot trees, validation, JSON, export, examples.

Nothing in this package imports a physics engine.
"""

from revolve_env.body.examples import EXAMPLES, example, resolve_robot
from revolve_env.body.export import BillOfMaterials, bill_of_materials, to_sdf, to_urdf
from revolve_env.body.geometry import Assembly, assemble, overlapping_boxes
from revolve_env.body.parts import PART_SPECS, SERVO, PartSpec, ServoSpec
from revolve_env.body.robot import (
    ACTIVATION_PARAMS,
    NEURON_PARAM_BOUNDS,
    WEIGHT_BOUNDS,
    Activation,
    Connection,
    Layer,
    Neuron,
    Node,
    PartType,
    Path,
    Robot,
)
from revolve_env.body.serialize import (
    SCHEMA,
    SCHEMA_VERSION,
    from_dict,
    from_json,
    load,
    save,
    to_dict,
    to_json,
)
from revolve_env.body.validate import Checked, Limits, RobotError, check, validate

__all__ = [
    "ACTIVATION_PARAMS",
    "EXAMPLES",
    "NEURON_PARAM_BOUNDS",
    "PART_SPECS",
    "SCHEMA",
    "SCHEMA_VERSION",
    "SERVO",
    "WEIGHT_BOUNDS",
    "Activation",
    "Assembly",
    "BillOfMaterials",
    "Checked",
    "Connection",
    "Layer",
    "Limits",
    "Neuron",
    "Node",
    "PartSpec",
    "PartType",
    "Path",
    "Robot",
    "RobotError",
    "ServoSpec",
    "assemble",
    "bill_of_materials",
    "check",
    "example",
    "from_dict",
    "from_json",
    "load",
    "overlapping_boxes",
    "resolve_robot",
    "save",
    "to_dict",
    "to_json",
    "to_sdf",
    "to_urdf",
    "validate",
]
