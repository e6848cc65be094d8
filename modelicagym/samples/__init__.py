"""Sample FMUs for newcomers: ``modelicagym sample NAME`` (or `write_sample`) writes a ready FMU and a
task file for it into a folder, to try every command on before your own FMU is at hand.

``heater``: a room heater (``heater.fmu``, ``heater_task.py``: hold 21 degC); ``drive``: a two-mass
drive (``drive.fmu``, ``drive_task.py``: bring the motor to a speed drawn per episode under a load drawn
per episode, with a PI controller to compare a trained policy with);
``system``: a motor and a shaft that connect as a system (``motor.fmu``, ``inertia.fmu``, a load
table ``load.csv``, the system as an SSP ``drive.ssp``, and ``system_task.py``); ``loop``: a controller
and a plant that close a loop through direct feedthrough (``controller.fmu``, ``plant.fmu``, ``loop_task.py``).

Each model folder here (``heater/``, ``drive/``, ``motor/``, ``inertia/``, ``pcontrol/``, ``feedplant/``) holds C sources written
with the framework in ``modelicagym/models/csrc`` and model descriptions; the FMUs are built from
them on first use and cached, as the bundled cart-pole is (a C compiler is needed once).
"""

from modelicagym.samples.writer import SAMPLES, SampleExistsError, sample_files, write_sample

__all__ = ["SAMPLES", "SampleExistsError", "sample_files", "write_sample"]
