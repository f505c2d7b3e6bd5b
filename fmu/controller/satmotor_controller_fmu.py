"""FMI 2.0 co-simulation slave: the backstepping speed and flux controller (glue around
satmotor.interface.ControllerUnit).  One sample per doStep; dt must equal Ts.

Variables, units and defaults: satmotor.interface (CONTROLLER_*).  Control law: satmotor.control.backstepping,
drive logic: satmotor.control.drive.
"""

from satmotor_fmu_glue import UnitSlave, pin_namespace

from satmotor.interface import (
    AUTHOR,
    CONTROLLER_DESCRIPTION,
    CONTROLLER_INPUTS,
    CONTROLLER_OUTPUTS,
    CONTROLLER_PARAMETERS,
    ControllerUnit,
)


class BacksteppingController(UnitSlave):
    author = AUTHOR
    description = CONTROLLER_DESCRIPTION
    VARIABLES = CONTROLLER_INPUTS + CONTROLLER_OUTPUTS + CONTROLLER_PARAMETERS
    UNIT = ControllerUnit
    FINGERPRINT = "@SATMOTOR_FINGERPRINT@"


pin_namespace(globals(), locals())  # see satmotor_fmu_glue.pin_namespace
