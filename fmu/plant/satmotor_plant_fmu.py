"""FMI 2.0 co-simulation slave: the saturated induction motor (glue around satmotor.interface.PlantUnit).

Variables, units and defaults: satmotor.interface (PLANT_*).  Equations: satmotor.machine.plant.
"""

from satmotor_fmu_glue import UnitSlave, pin_namespace

from satmotor.interface import (
    AUTHOR,
    PLANT_DESCRIPTION,
    PLANT_INPUTS,
    PLANT_OUTPUTS,
    PLANT_PARAMETERS,
    PlantUnit,
)


class SaturatedInductionMotor(UnitSlave):
    author = AUTHOR
    description = PLANT_DESCRIPTION
    VARIABLES = PLANT_INPUTS + PLANT_OUTPUTS + PLANT_PARAMETERS
    UNIT = PlantUnit
    FINGERPRINT = "@SATMOTOR_FINGERPRINT@"


pin_namespace(globals(), locals())  # see satmotor_fmu_glue.pin_namespace
