"""The family of test FMUs in ``tests/fmus/``: what each member is and how it is built.

Four C models (see each folder's ``config.h``), compiled with the framework in
``modelicagym/models/csrc`` by `modelicagym.fmu.build.build_source_fmu` (cached on disk by content
hash, so only the first session pays for compilation), each for FMI 2.0 and 3.0 (the ball also
for FMI 1.0 model exchange, ``modelDescription_fmi1_me.xml``, built directly in ``test_fmi1.py``):

``probe``
    integer / enumeration / boolean inputs and outputs, FMI 3.0 arrays and Float32 / Int8 / UInt16 /
    (U)Int64 variables, a time-dependent output, fault injection in ``doStep`` (parameters ``fault``
    and ``fault_after``). Its variants (``probe_once``, ``probe_late``, ...) reproduce FMUs in the
    wild: once per process, no state snapshots, a non-zero start time, a buggy ``fmiReset``, inexact
    snapshots. A variant is the same C code with preprocessor definitions (which switch on lifecycle
    hooks of the C framework) plus a model description derived from ``modelDescription_fmi<v>.xml``
    by `derive_description`.
``ball``
    a bouncing ball with a state event and a time event, model exchange and co-simulation.
``staircase``
    a discrete staircase of time events (every third needing two event-iteration passes, an event
    at ``t_stop`` ending the simulation) driving a continuous state, with a Float64 input.
``stiff``
    a stiff linear model without events (eigenvalues ``-lambda = -1e4`` and -1), with a Float64
    input; its co-simulation RK4 runs at ``cs_step_size = 1e-5`` to stay stable.
``crashy``
    a first-order lag whose variants (``crashy_segfault``, ``crashy_exit``, ``crashy_abort``,
    ``crashy_hang``) crash, exit, abort or hang while loaded, for the load trial
    (``modelicagym/fmu/trial.py``); ``crashy`` itself is well behaved, ``crashy_tau_required``
    refuses to initialize until its parameter ``tau`` is set.

Tests get built members through the ``family_fmu(name, fmi_version)`` fixture of ``conftest.py``.
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from modelicagym.fmu import FMUDescription, open_fmu
from modelicagym.fmu.build import build_source_fmu
from modelicagym.fmu.description_edits import edited_description
from modelicagym.samples.writer import SAMPLES_DIR

FMUS_DIR = Path(__file__).resolve().parent / "fmus"
PROBE_DIR = FMUS_DIR / "probe"
BALL_DIR = FMUS_DIR / "ball"
STAIRCASE_DIR = FMUS_DIR / "staircase"
STIFF_DIR = FMUS_DIR / "stiff"
CRASHY_DIR = FMUS_DIR / "crashy"
FMI_VERSIONS = (2, 3)

# Names of the models' variables (the probe's per FMI version).
PROBE_INPUTS = ("gear", "mode", "enable", "boost", "force")
PROBE_OUTPUTS = ("position", "clock", "speed", "mode_out", "moving", "steps")
PROBE3_INPUTS = (*PROBE_INPUTS, "u", "trim", "tag")
PROBE3_OUTPUTS = (*PROBE_OUTPUTS, "y", "positive", "ticks", "thrust", "level", "tag_out")
BALL_OUTPUTS = ("h", "v", "bounces", "t_bounce", "t_switched", "e_now")
STAIRCASE_OUTPUTS = ("x", "level", "steps_taken", "t_last_event", "iterations", "stopped")
STIFF_OUTPUTS = ("x1", "x2")
FAULTS = {"none": 0, "terminate": 1, "error": 2, "crash": 3, "hang": 4}
MODES = {"off": 1, "heat": 2, "cool": 3}


@dataclass(frozen=True)
class Variant:
    """One member of the family: a model folder built with some options (for either FMI version)."""

    model_dir: Path
    defines: dict[str, object] = field(default_factory=dict)
    once_per_process: bool = False
    snapshots: bool = True
    start_time: float | None = None
    #: the FMI versions its folder has a model description for (the system tests' members have one each)
    fmi_versions: tuple[int, ...] = (2, 3)


def _probe(*flags: str, **options: object) -> Variant:
    return Variant(PROBE_DIR, {flag: None for flag in flags}, **options)  # type: ignore[arg-type]


VARIANTS: dict[str, Variant] = {
    # plain probe: every capability declared, snapshots work
    "probe": _probe(),
    # canBeInstantiatedOnlyOncePerProcess, and the C side refuses a second live instance
    "probe_once": _probe("ONCE_PER_PROCESS", once_per_process=True),
    # canGetAndSetFMUstate="false" (and getFMUstate really fails), startTime="10"
    "probe_late": _probe("NO_SNAPSHOTS", snapshots=False, start_time=10.0),
    # fmiReset forgets to reset the step counter; no snapshots, so "auto" starts at "reset"
    "probe_buggy": _probe("BUGGY_RESET", "NO_SNAPSHOTS", snapshots=False),
    # setFMUstate restores the position with a small error: "auto" starts at "snapshot"
    "probe_inexact": _probe("INEXACT_SNAPSHOTS"),
    # bouncing ball, model exchange + co-simulation
    "ball": Variant(BALL_DIR),
    # time events with event iteration and termination, model exchange + co-simulation
    "staircase": Variant(STAIRCASE_DIR),
    # stiff linear model, no events, model exchange + co-simulation
    "stiff": Variant(STIFF_DIR),
    # the shapes `modelicagym info` must turn into a working config (tests/test_info.py):
    # no inputs, a tunable restitution to act on (a bouncing ball)
    "noinputs": Variant(FMUS_DIR / "noinputs"),
    # no outputs, two continuous states declared as locals (a damped oscillator)
    "nooutputs": Variant(FMUS_DIR / "nooutputs"),
    # a structural parameter (FMI 3.0; FMI 2.0 leaves it out) the C code lets be set in configuration mode only
    "structural": Variant(FMUS_DIR / "structural"),
    # an input in Pa without min/max (start 101325) that breaks doStep far from it
    "unbounded": Variant(FMUS_DIR / "unbounded"),
    # a first-order lag that loads fine, and its variants that misbehave while loaded (tests/fmus/crashy/config.h)
    "crashy": Variant(CRASHY_DIR),
    "crashy_segfault": Variant(CRASHY_DIR, {"CRASH_IN_INSTANTIATE": None}),
    "crashy_segfault_printed": Variant(CRASHY_DIR, {"CRASH_IN_INSTANTIATE": None, "PRINT_TO_STDOUT": None}),
    "crashy_exit": Variant(CRASHY_DIR, {"EXIT_IN_INSTANTIATE": None}),
    "crashy_abort": Variant(CRASHY_DIR, {"ABORT_IN_INITIALIZE": None}),
    "crashy_hang": Variant(CRASHY_DIR, {"HANG_IN_INSTANTIATE": None}),
    "crashy_tau_required": Variant(CRASHY_DIR, {"TAU_REQUIRED": None}),
    # doStep calls exit(0), abort() or segfaults on request (co-simulation)
    "quitter": Variant(FMUS_DIR / "quitter"),
    # a lag with noise from a generator beside the FMU state (tests/fmus/leaky): every rung exact
    "leaky": Variant(FMUS_DIR / "leaky"),
    # ... whose snapshots leave the generator out (fmiReset re-seeds it): "snapshot" must be dropped
    "leaky_snapshot": Variant(FMUS_DIR / "leaky", {"LEAKY_SNAPSHOT": None}),
    # ... no snapshots, and fmiReset leaves the generator as it was: "reset" must be dropped
    "leaky_reset": Variant(FMUS_DIR / "leaky", {"LEAKY_RESET": None}, snapshots=False),
    # ... both leak: "snapshot" and "reset" must be dropped
    "leaky_both": Variant(FMUS_DIR / "leaky", {"LEAKY_SNAPSHOT": None, "LEAKY_RESET": None}),
    # a lag whose doStep logs warnings, and an error loop returning OK beyond |u| > u_max (tests/fmus/noisy)
    "noisy": Variant(FMUS_DIR / "noisy"),
    # a lag whose initialization spends init_seconds of CPU (tests/fmus/slowinit): the pool's init="once"
    "slowinit": Variant(FMUS_DIR / "slowinit"),
    # a lag whose co-simulation step costs 100x more while x > threshold (tests/fmus/moody): a pool's
    # load balance under step costs that vary with the state
    "moody": Variant(FMUS_DIR / "moody"),
    # a room heater, `modelicagym sample heater` and docs/train-own-fmu.md (modelicagym/samples/heater)
    "own_heater": Variant(SAMPLES_DIR / "heater"),
    # a cooling consumer in the shape of a third-party export (tests/fmus/consumer): six inputs without
    # declared ranges, in Pa, K and W or without a unit, one starting at 0 K; docs/train-own-fmu.md's multi-input guide
    "consumer": Variant(FMUS_DIR / "consumer"),
    # ... allowed one instance per process (one env per worker), its cost set by cs_step_size (and a
    # threshold no x reaches): a pool of such FMUs of a realistic cost (issue 32: ~100 us a step)
    "moody_once": Variant(FMUS_DIR / "moody", once_per_process=True),
    # for model exchange: Integer / Enumeration / Boolean / discrete Real inputs (FMI 3.0: Int64 and UInt8
    # too) that change the dynamics and the events, a stop input that ends the simulation in the inputs'
    # event, and a jam_gear parameter that makes an event update fail (tests/fmus/me_discrete)
    "me_discrete": Variant(FMUS_DIR / "me_discrete"),
    # the actuator and plant of the system tests (tests/system) and of `modelicagym sample system`
    # (modelicagym/samples): a torque motor with a lag and back-EMF whose speed input is in rpm (FMI 2.0),
    # and a shaft with friction reporting rad/s (FMI 3.0)
    "motor": Variant(SAMPLES_DIR / "motor", fmi_versions=(2,)),
    "inertia": Variant(SAMPLES_DIR / "inertia", fmi_versions=(3,)),
    # the loops of direct feedthrough (tests/system/test_loops.py): a gain with an offset (FMI 2.0 and 3.0),
    # a proportional controller (FMI 2.0), an integrator whose output feeds its input through (FMI 3.0)
    "gain": Variant(FMUS_DIR / "gain"),
    "pcontrol": Variant(SAMPLES_DIR / "pcontrol", fmi_versions=(2,)),
    "feedplant": Variant(SAMPLES_DIR / "feedplant", fmi_versions=(3,)),
    # a source without inputs whose tunable parameters set its signals, as a test bench's stimulus FMU
    # (OMSimulator's DC motor): a system it drives has nothing else to act on (tests/system/test_ssp_sources.py)
    "stimulus": Variant(FMUS_DIR / "stimulus", fmi_versions=(2,)),
}


def derive_description(variant: Variant, fmi_version: int) -> Path | None:
    """The variant's model description (`edited_description`, in the cache), or None for the base."""
    if not variant.once_per_process and variant.snapshots and variant.start_time is None:
        return None
    return edited_description(variant.model_dir / f"modelDescription_fmi{fmi_version}.xml",
                              once_per_process=variant.once_per_process, snapshots=variant.snapshots,
                              start_time=variant.start_time)


def build(name: str, fmi_version: int) -> Path:
    """Build (or fetch from the cache) the family member ``name`` for FMI ``fmi_version``.

    One build at a time: fmpy validates model descriptions with lxml, whose first XML-schema parse
    in a process races with a concurrent one ("XMLSchemaParseError: Internal error").
    """
    variant = VARIANTS[name]
    return build_source_fmu(
        variant.model_dir,
        fmi_version,
        model_description=derive_description(variant, fmi_version),
        defines=variant.defines,
    )


def probe_variables(fmu: Path | FMUDescription) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The probe's inputs and outputs for the FMI version its model description declares."""
    if open_fmu(fmu).fmi_version == 3:
        return PROBE3_INPUTS, PROBE3_OUTPUTS
    return PROBE_INPUTS, PROBE_OUTPUTS


def rewrite(
    source: Path,
    target: Path,
    rename: Callable[[str], str | None] = lambda name: name,
    edit_description: Callable[[str], str] = lambda text: text,
) -> Path:
    """A copy of the FMU ``source`` with entries renamed (None drops one) and the model description edited."""
    with zipfile.ZipFile(source) as old, zipfile.ZipFile(target, "w") as new:
        for item in old.infolist():
            name = rename(item.filename)
            if name is None:
                continue
            data = old.read(item)
            if name == "modelDescription.xml":
                data = edit_description(data.decode()).encode()
            new.writestr(name, data)
    return target
