"""The native (C) FMUs' build: the toolchain (:mod:`.compiler`), the C tables and model descriptions
generated from :mod:`satmotor.interface` (:mod:`.tables`, :mod:`.model_description`), the co-simulation
and model-exchange FMUs (:mod:`.fmus`, :mod:`.model_exchange`), their sources (:mod:`.source_fmu`) and
the libcosim engine's row recorder (:mod:`.recorder_fmu`)."""
