"""The models that ship with modelicagym, each in its own folder beside its environment.

A model folder holds the model's C sources (``model.c``, ``config.h``) and model descriptions,
built into a source FMU by `modelicagym.fmu.build` on first use; its ``__init__`` returns the
built FMU and names its variables; its ``env`` module is the ready environment on it
(``cartpole/``: the paper's Cart-Pole; ``pendulum/``: the motor-driven swing-up). ``csrc/`` is
the FMU framework every model is compiled with (see ``csrc/model.h``).
"""
