"""One live FMU instance: initialize, step, reset, snapshot — fast and hard to misuse.

`FMUInstance` is what the environment drives. Inputs and outputs move through preallocated
`ValueBuffer` arrays; ``step(dt)`` writes the inputs, advances the FMU (``doStep`` in
co-simulation, a solver in model exchange) and reads the outputs. Simulation time is
``origin + k * dt`` from an integer step count, so it does not drift.

Resets climb down the ladder of docs/design.md and remember the rung that worked:

``"snapshot"``
    restore the state saved right after initialization (``canGetAndSetFMUstate``), when the
    episode's values equal the snapshot's;
``"reset"``
    ``fmiReset``, re-apply parameters and start values, re-initialize;
``"reinstantiate"``
    free the instance and instantiate again from the same extraction and loaded library.

``reset_rung`` forces a rung (and those below it); ``"auto"`` starts at the best one the FMU
declares. Before a rung serves its first episode it must replay the first steps of a fresh
instance bit for bit (`modelicagym.fmu.reference`: the first episode is recorded); a rung that
gives other values is dropped with one warning naming the FMU, and the next one is checked the
same way: exporters ship broken ``fmiReset`` and snapshots that miss part of the state.

At ~700 lines this module is longer than most of ours, for a reason: stepping, the reset ladder,
saved states (``save_state`` / ``load_state`` / ``start_from``, `modelicagym.fmu.saved_state`) and
the choice of integrator all read and write the same few things (the binding, the value buffers,
the snapshot, the clock, the recording), and keeping them in one class keeps each of those owned
by one object.
The solver loops themselves live elsewhere (`modelicagym.fmu.model_exchange`,
`modelicagym.fmu.native_integrator`).
"""

from __future__ import annotations

import logging
import os
import time as _time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from modelicagym.errors import ConfigError
from modelicagym.fmu.binding import DISCARD, TERMINATED, WARNING, FMIBinding
from modelicagym.fmu.buffers import ValueBuffer
from modelicagym.fmu.clock import OnClock, StepClock
from modelicagym.fmu.description import FMUDescription, open_fmu
from modelicagym.fmu.errors import ErrorLoopError, FMUCallError, FMUError, StateMismatchError, UnsupportedFeatureError
from modelicagym.fmu.fmi1 import FMI1Binding
from modelicagym.fmu.fmi2 import FMI2Binding
from modelicagym.fmu.fmi3 import FMI3Binding
from modelicagym.fmu.logs import LOG_LIMITS
from modelicagym.fmu.model_exchange import ModelExchangeIntegrator
from modelicagym.fmu.native_integrator import NativeIntegrator, python_integrator_reason
from modelicagym.fmu.reference import WAIT, Reference, describe
from modelicagym.fmu.saved_state import FMUState

logger = logging.getLogger(__name__)

RUNGS = ("snapshot", "reset", "reinstantiate")
#: what each rung below the snapshot does at every reset, for the warning that drops to it
_RUNG_COSTS = {"reset": "fmiReset and a new initialization", "reinstantiate": "a new instance, initialized"}

_BINDINGS: dict[int, type[FMIBinding]] = {1: FMI1Binding, 2: FMI2Binding, 3: FMI3Binding}


def _freeze(values: Mapping[str, Any]) -> tuple:
    """A hashable key of ``values``: episodes with equal keys start from the same state."""
    return tuple(sorted((k, v if isinstance(v, (int, float, str)) else np.asarray(v).tobytes()) for k, v in values.items()))


class FMUInstance:
    """A live instance of an FMU, with inputs and outputs bound for fast stepping.

    Its time bookkeeping (``time``, ``steps``, ``fmu_time_ns``, ``terminated``, ``broken``, ...)
    lives in ``self.clock``, a C struct the native step path writes too (`modelicagym.fmu.clock`).

    Example::

        from modelicagym.fmu import FMUInstance
        from modelicagym.models.cartpole import cartpole_fmu

        fmu = FMUInstance(cartpole_fmu(), inputs=["f"], outputs=["x", "theta"])
        fmu.reset({"m_cart": 5.0})
        fmu.inputs.flat[:] = 10.0
        fmu.step(0.05)
        print(fmu.time, fmu.outputs.flat)

    Parameters:
        fmu: path of a ``.fmu`` file or extracted folder, or an opened `FMUDescription`.
        mode: ``"cs"`` (co-simulation) or ``"me"`` (model exchange); default: co-simulation if offered.
        inputs / outputs: variable names bound to ``self.inputs`` / ``self.outputs``.
        start_time: default: the model's ``defaultExperiment startTime``.
        reset_rung: ``"auto"``, or the best rung to use (``"snapshot"``, ``"reset"``, ``"reinstantiate"``).
        solver, tolerance, solver_step: model exchange only (see `ModelExchangeIntegrator`).
        integrator: model exchange only: ``"auto"`` runs the solver loop in C when it can
            (`NativeIntegrator`), ``"python"`` keeps it in Python (the reference path).
            ``integrator_path`` says which one runs, ``integrator_path_reason`` why.
        validate: validate ``modelDescription.xml`` against the schema.
        logging_on: ask the FMU for debug logging (routed to Python ``logging``, rate-limited:
            `modelicagym.fmu.logs.LOG_LIMITS`).
        step_size: the step the caller will take, for checking a reset rung when the first
            episode took no step (default: the model's ``defaultExperiment stepSize``).
        instances_per_process: for an FMU allowed one instance per process
            (``canBeInstantiatedOnlyOncePerProcess``): ``"copies"`` (default) loads a private copy
            of its binary for each further instance alive at once in this process
            (`modelicagym.fmu.library_copies`); ``"one"`` loads the binary itself, as the FMU
            asks (for an FMU whose restriction is not about globals, e.g. one writing fixed file
            names: then keep one instance per process).
    """

    time = OnClock()
    """Simulation time, ``origin + steps * dt``."""
    start_time = OnClock()
    steps = OnClock()
    fmu_time_ns = OnClock()
    """Nanoseconds spent in ``step`` inside FMU calls (and the solver, in model exchange), cumulative."""
    terminated = OnClock()
    broken = OnClock()
    _origin = OnClock()
    _dt = OnClock()

    def __init__(
        self,
        fmu: str | os.PathLike[str] | FMUDescription,
        *,
        mode: str | None = None,
        inputs: Sequence[str] = (),
        outputs: Sequence[str] = (),
        start_time: float | None = None,
        stop_time: float | None = None,
        reset_rung: str = "auto",
        solver: str = "cvode",
        tolerance: float | None = None,
        solver_step: float | None = None,
        integrator: str = "auto",
        instance_name: str | None = None,
        validate: bool = True,
        logging_on: bool = False,
        step_size: float | None = None,
        instances_per_process: str = "copies",
    ):
        self.description = description = open_fmu(fmu, validate=validate)
        self.clock = StepClock()
        self.mode = mode or description.default_mode()
        description.interface(self.mode)  # a clear error for a mode the FMU lacks
        self.input_variables = [description.input_variable(n) for n in inputs]
        self.output_variables = [description.observable_variable(n) for n in outputs]
        self.start_time = description.default_experiment.start_time if start_time is None else float(start_time)
        self.stop_time = stop_time
        self.tolerance = tolerance
        self.logging_on = logging_on
        self.step_size = step_size or description.default_experiment.step_size
        self.reset_rung = self._first_rung(reset_rung)

        self.binding = _BINDINGS[description.fmi_version](description, self.mode, instance_name, instances_per_process)
        self.binding.log.count_errors_in(self.clock)
        self.clock.log_error_limit = LOG_LIMITS.errors_per_step
        self.inputs = ValueBuffer(self.binding, self.input_variables)
        self.outputs = ValueBuffer(self.binding, self.output_variables)
        self._integrator: ModelExchangeIntegrator | None = None
        self.integrator_path: str | None = None
        self.integrator_path_reason: str | None = None
        # Model exchange sets discrete inputs (any non-float type, or variability "discrete")
        # in event mode only: continuous-time mode accepts continuous Real inputs alone.
        self._event_mode_inputs = self.mode == "me" and any(
            v.variability != "continuous" for v in self.input_variables
        )
        if self.mode == "me":
            integrator_class = self._choose_integrator(integrator, solver)
            self._integrator = integrator_class(
                self.binding,
                description.number_of_states,
                description.number_of_event_indicators,
                description.needs_completed_integrator_step(),
                solver=solver,
                tolerance=tolerance or 1e-10,
                step_size=solver_step,
            )

        self.time = self.start_time
        self.steps = 0
        self.terminated = False
        self.broken = False
        self.initialized = False
        self._origin = self.start_time
        self._dt = 0.0
        self._snapshot: Any = None
        self._snapshot_key: tuple | None = None
        self._snapshot_next_event: float | None = None
        self._written_inputs = b""  # model exchange: the input values of the last step
        self._reference: Reference | None = None  # what a rung must replay at its first use
        self._recording: Reference | None = None  # the reference the steps are recorded into now
        self._empty_episodes = 0  # recorded episodes that ended before their first step
        self._verified: set[str] = set()
        self._settable_names: set[str] = set()
        self._hash: str | None = None  # the FMU's content hash, for saved states
        self._initial: tuple[FMUState, tuple] | None = None  # `start_from`'s state and its values' key
        #: how many times the FMU's own initialization ran in this instance (`start_from` skips it)
        self.initializations = 0
        self._instantiate()

    def _choose_integrator(self, requested: str, solver: str) -> type[ModelExchangeIntegrator]:
        """The integrator class for ``requested`` (``"auto"`` or ``"python"``); records which and why."""
        if requested not in ("auto", "python"):
            raise ConfigError(f"integrator must be 'auto' or 'python', got {requested!r}")
        reason = "integrator='python' was asked for" if requested == "python" else python_integrator_reason(self.description.fmi_version, solver)
        if reason is None:
            self.integrator_path, self.integrator_path_reason = "native", "the solver loop runs in C"
            return NativeIntegrator
        self.integrator_path, self.integrator_path_reason = "python", reason
        return ModelExchangeIntegrator

    # -- public API ------------------------------------------------------------------------------

    @property
    def fmu_name(self) -> str:
        return self.description.name

    def reset(self, values: Mapping[str, Any] | None = None) -> None:
        """Start a new episode at ``start_time`` with parameters/start values ``values`` applied.

        Uses the cheapest working rung of the reset ladder (see the module docstring).
        """
        values = dict(values or {})
        self._check_settable(values)
        key = _freeze(values)
        if self._recording is not None:
            if self._recording_waits():
                self.inputs.fill_start_values()
                self._restart(values)  # a fresh episode again, recorded in its turn
                return
            self._finish_recording()
        rung = self._rung_for(key) if self.initialized and not self.broken else None
        if rung is not None and rung not in self._verified:
            self._check_rung(key)
            rung = self._rung_for(key) if self.initialized and not self.broken else None
        self.inputs.fill_start_values()
        if rung is None:
            self._restart(values)
        else:
            self._serve(rung, values)

    def _rung_for(self, key: tuple) -> str:
        """The rung that serves an episode whose values freeze to ``key``."""
        if self.reset_rung == "snapshot" and key == self._snapshot_key:
            return "snapshot"
        return "reset" if self.reset_rung in ("snapshot", "reset") else "reinstantiate"

    def _serve(self, rung: str, values: dict[str, Any]) -> str:
        """Start an episode with ``values`` on ``rung``; returns the rung that served it (a lower
        one when ``rung`` failed and was dropped)."""
        if rung == "snapshot":
            return self._restore_snapshot(values)
        if rung == "reset":
            return self._reset_and_initialize(values)
        self._restart(values)
        return "reinstantiate"

    def step(self, dt: float) -> bool:
        """Write inputs, advance by ``dt``, read outputs. Returns True if the model ended the episode.

        Raises `FMUCallError` when the FMU returns Error/Fatal (the instance is then ``broken``
        and the next `reset` re-instantiates it).
        """
        clock = self.clock
        if dt != clock.dt:
            clock.origin, clock.dt, clock.steps = clock.time, dt, 0
        now = clock.time
        target = clock.origin + (clock.steps + 1) * dt
        started = _time.perf_counter_ns()
        ended = self._in_event_mode(now, self._write_inputs) if self._event_mode_inputs else self._write_inputs()
        if ended:
            clock.terminated = True
        elif self._integrator is None:
            status = self._do_step(now, target - now)
            if status:
                self._step_status(status)
        else:
            self.note_written_inputs()
            try:
                clock.terminated = self._integrator.advance(now, target)
            except Exception:
                clock.broken = True
                raise
        clock.steps += 1
        clock.time = target
        status = self.outputs.read()
        clock.fmu_time_ns += _time.perf_counter_ns() - started
        if status > WARNING:
            self._broken_by("get outputs", status)
        if clock.log_errors:
            self._check_log_errors()
        if self._recording is not None:
            self._recording.record(dt, self.inputs, self.outputs)
        return bool(clock.terminated)

    def note_written_inputs(self) -> None:
        """Model exchange: restart the solver at the next step when the input values now in
        ``inputs`` differ, bit for bit, from the last step's (as `step` does). The native step path
        calls it when Python wrote the inputs and C takes the step; co-simulation: nothing to do."""
        if self._integrator is None:
            return
        written = self.inputs.snapshot()
        if written != self._written_inputs:
            self._integrator.continuous = False
            self._written_inputs = written

    def _check_log_errors(self) -> None:
        """An error loop (more error messages in a step than the limit) fails the step, as C does."""
        if self.clock.log_errors > self.clock.log_error_limit:
            raise self.error_loop()
        self.clock.log_errors = 0

    def error_loop(self) -> ErrorLoopError:
        """The error of a step in which the FMU logged more error messages than ``log_error_limit``
        while its calls returned OK; the instance is then ``broken`` (the next reset re-instantiates)."""
        clock = self.clock
        count, clock.log_errors = clock.log_errors, 0
        clock.broken = True
        return ErrorLoopError(f"{self.fmu_name} ({self.binding.instance_name})", count, clock.log_error_limit,
                              self.binding.log.take_recent())

    def _write_inputs(self) -> bool:
        status = self.inputs.write()
        if status > WARNING:
            self._broken_by("set inputs", status)
        return False

    def _in_event_mode(self, time: float, apply: Any) -> bool:
        """Model exchange: run ``apply`` in event mode (discrete inputs and tunable parameters
        may only be set there) and settle the event iteration; True if the model ended."""
        assert self._integrator is not None
        try:
            return self._integrator.event(time, apply)
        except FMUError:
            self.broken = True
            raise

    def restorable_snapshot(self, values: Mapping[str, Any]) -> int | None:
        """The address of the FMU state that `reset(values)` would simply restore, or ``None``.

        That is the case on the ``"snapshot"`` rung once it is verified, for the values the
        snapshot was taken with, on a healthy instance (in model exchange, one whose solver loop
        is native): the native step path then resets by restoring it itself.
        """
        if (
            self.reset_rung != "snapshot"
            or "snapshot" not in self._verified
            or self.broken
            or not self.initialized
            or (self._integrator is not None and self.native_integrator is None)
            or self._snapshot is None
            or _freeze(dict(values)) != self._snapshot_key
        ):
            return None
        return self._snapshot.value

    @property
    def snapshot_next_event_time(self) -> float | None:
        """Model exchange: the time event pending in the snapshot's state (FMUs announce it only in event mode)."""
        return self._snapshot_next_event if self._snapshot is not None else None

    @property
    def event_mode_inputs(self) -> bool:
        """Model exchange with discrete inputs (or tunable parameters as inputs): every step sets
        the inputs in event mode, the only mode FMI allows them in, and settles the event iteration."""
        return self._event_mode_inputs

    @property
    def native_integrator(self) -> NativeIntegrator | None:
        """Model exchange: the integrator when its solver loop runs in C (the native step path drives it)."""
        return self._integrator if isinstance(self._integrator, NativeIntegrator) else None

    @property
    def solver_method(self) -> str | None:
        """Model exchange with CVode: its method now, ``"adams"`` or ``"bdf"`` (``solver="cvode"``
        switches to BDF for good once the model proves stiff); ``None`` otherwise."""
        return self._integrator.method if self._integrator is not None else None

    def read_outputs(self) -> None:
        """Refresh ``self.outputs`` (after a reset, for the first observation)."""
        self.outputs.check(self.outputs.read(), "get outputs")

    def set_values(self, values: Mapping[str, Any]) -> None:
        """Set variables by name now (e.g. a tunable parameter mid-episode).

        In model exchange a running instance takes them in event mode (FMI allows tunable
        parameters and discrete variables nowhere else), followed by the event iteration.
        """
        values = dict(values)
        if self._recording is not None:
            self._recording.stop()  # a reset rung's check replays inputs, not these
        if self._integrator is not None and self.initialized and not self.broken:
            if self._in_event_mode(self.time, lambda: self.binding.set_values(values)):
                self.terminated = True
        else:
            self.binding.set_values(values)

    def save_state(self) -> FMUState:
        """The instance's state now, as a picklable value that `load_state` puts back, in this
        process or another (`modelicagym.fmu.saved_state`). In model exchange the solver restarts
        here at the next step, as after new input values, so this instance and one that loads the
        state go on alike. Raises `UnsupportedFeatureError` (one line) for an FMU that cannot
        serialize its state."""
        self._check_serializable()
        if not self.initialized or self.broken:
            raise FMUError(f"{self.fmu_name}: no state to save: the instance is "
                           f"{'broken' if self.broken else 'not initialized'}; reset it first")
        handle = self.binding.get_state()
        try:
            data = self.binding.serialize_state(handle)
        finally:
            self.binding.free_state(handle)
        clock, integrator = self.clock, self._integrator
        if integrator is not None:
            integrator.continuous = False
        return FMUState(
            self.fmu_name, self._content_hash(), self.mode, data, clock.time, clock.origin, clock.dt, clock.steps,
            bool(clock.terminated), integrator.next_event_time if integrator is not None else None,
            integrator is not None and integrator.stiff,
        )

    def load_state(self, state: FMUState, values: Mapping[str, Any] | None = None) -> None:
        """Put back a state `save_state` gave, here or in another process: the instance goes on
        from there exactly as the one it was saved from. A state of another FMU, or of this one
        changed, is refused (`StateMismatchError`) before anything changes. An instance that is not
        initialized (or broken) is first reset with ``values`` (the state then overwrites it).

        The reset ladder is untouched (its snapshot is a separate FMU state); a reference being
        recorded for its check stops here, since what follows is not a fresh episode."""
        self.check_state(state)
        if not self.initialized or self.broken:
            self.reset(values)
        if self._recording is not None:
            self._recording.stop()
        handle = self.binding.deserialize_state(state.data)
        try:
            self.binding.set_state(handle)
        except FMUError:
            self.broken = True
            raise
        finally:
            self.binding.free_state(handle)
        clock = self.clock
        clock.time, clock.origin, clock.dt, clock.steps = state.time, state.origin, state.dt, state.steps
        clock.terminated = state.terminated
        if self._integrator is not None:
            self._integrator.stiff = state.stiff
            self._integrator.restart(state.time, state.next_event_time)
            self._integrator.continuous = False  # as the instance saved from, which restarts there
        self.read_outputs()
        self.clock.log_errors = 0

    def start_from(self, state: FMUState, values: Mapping[str, Any] | None = None) -> None:
        """Initialize from ``state``, saved right after another instance of the same FMU was
        initialized with ``values`` (its first `reset`), instead of running the FMU's initialization:
        the pool's ``init="once"``. The instance keeps it: any later re-instantiation with the same
        values starts from it too, and the reset ladder works as after an initialization (the
        episode is recorded for the rungs' check, the snapshot is taken from it)."""
        values = dict(values or {})
        self.check_state(state)
        if state.steps or state.time != self.start_time:
            raise StateMismatchError(f"{self.fmu_name}: a state to start from must be saved right after a reset "
                                     f"(at t={self.start_time}, step 0), not at t={state.time}, step {state.steps}")
        self._check_settable(values)
        self._initial = (state, _freeze(values))
        if self._recording is not None:
            self._recording = self.clock.recorder = None  # the fresh episode starts below
        self._restart(values)

    def _initialize_from(self, state: FMUState, values: dict[str, Any]) -> None:
        """`_initialize`'s counterpart: the FMU's state loaded from ``state`` (see `start_from`)."""
        handle = self.binding.deserialize_state(state.data)
        try:
            self.binding.set_state(handle)
            if self._integrator is not None:
                self._integrator.stiff = state.stiff
                self._integrator.restart(state.time, state.next_event_time)
        except FMUError:
            self.broken = True
            raise
        finally:
            self.binding.free_state(handle)
        self.initialized = True
        self._after_initialization(values, take_snapshot=self.reset_rung == "snapshot")
        self.terminated = state.terminated

    def check_state(self, state: FMUState) -> None:
        """Refuse a state `load_state` would refuse, changing nothing: one of another FMU, of this
        one changed or in the other mode (`StateMismatchError`), or any state when this FMU cannot
        serialize (`UnsupportedFeatureError`). Cheap (no FMU call), so a pool checks every env's
        state before loading any."""
        self._check_serializable()
        state.check_fits(self.fmu_name, self._content_hash(), self.mode)

    def _check_serializable(self) -> None:
        refusal = self.description.serialize_refusal(self.mode)
        if refusal is not None:
            raise UnsupportedFeatureError(refusal)

    def _content_hash(self) -> str:
        if self._hash is None:
            self._hash = self.description.content_hash(self.mode)
        return self._hash

    def get_values(self, names: Sequence[str]) -> dict[str, Any]:
        """Read variables by name (slow path, for inspection)."""
        return self.binding.get_values(list(names))

    def close(self) -> None:
        """Free the instance. Safe to call twice."""
        binding = getattr(self, "binding", None)
        if binding is None:
            return
        self._free_snapshot()
        if self._integrator is not None:
            self._integrator.close()
        self._integrator = None
        binding.close()
        self.binding = None  # type: ignore[assignment]

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # never raise from a finalizer
            pass

    def __enter__(self) -> FMUInstance:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- the ladder ------------------------------------------------------------------------------

    def _first_rung(self, requested: str) -> str:
        can_snapshot = self.description.can_snapshot(self.mode)
        can_reset = self.description.can_reset(self.mode)
        if requested == "auto":
            return "snapshot" if can_snapshot else "reset" if can_reset else "reinstantiate"
        if requested not in RUNGS:
            raise ConfigError(f"reset_rung must be 'auto' or one of {RUNGS}, got {requested!r}")
        if requested == "snapshot" and not can_snapshot:
            why = "FMI 1.0 has no FMU state" if self.description.fmi_version == 1 else "canGetAndSetFMUstate is false"
            raise UnsupportedFeatureError(
                f"{self.fmu_name} cannot save and restore its state ({why}); "
                f"use reset_rung={'reset' if can_reset else 'reinstantiate'!r}" + (" or 'reinstantiate'" if can_reset else "")
            )
        if requested == "reset" and not can_reset:
            raise UnsupportedFeatureError(
                f"{self.fmu_name} has no reset function (FMI 1.0 model exchange); use reset_rung='reinstantiate'"
            )
        return requested

    def _demote(self, rung: str, reason: str) -> None:
        """Stop using ``rung`` (and any rung above it): it failed or gave wrong values. The warning
        says what a newcomer needs to judge it: results stay right (no rung serves an episode before
        it replays a fresh instance's, and re-instantiation is one), only resets cost more."""
        lower = RUNGS[RUNGS.index(rung) + 1]
        logger.warning("%s: reset rung %r %s; resets use %r (%s) from now on. Results are not affected: a rung "
                       "serves episodes only once it replays a fresh instance's exactly, and a fresh instance is "
                       "the reference; resets take longer, and reset_rung=%r in the config skips the check",
                       self.fmu_name, rung, reason, lower, _RUNG_COSTS[lower], lower)
        self.reset_rung = lower
        self._free_snapshot()

    def _restore_snapshot(self, values: dict[str, Any]) -> str:
        try:
            self.binding.set_state(self._snapshot)
        except FMUCallError as error:
            self._demote("snapshot", f"failed ({error})")
            self._restart(values)
            return "reinstantiate"
        self._after_initialization(values, take_snapshot=False)
        if self._integrator is not None:
            self._integrator.restart(self.time, self._snapshot_next_event)
        return "snapshot"

    def _reset_and_initialize(self, values: dict[str, Any]) -> str:
        try:
            self.binding.reset()
        except FMUCallError as error:
            self._demote("reset", f"failed ({error})")
            self._restart(values)
            return "reinstantiate"
        self._initialize(values)
        return "reset"

    def _restart(self, values: dict[str, Any]) -> None:
        """Re-instantiate (unless this is the first episode) and initialize: a fresh episode,
        recorded while a rung above re-instantiation waits for its check and no reference is
        complete (once a rung is checked, its resets may happen in C: the reference stays as it is)."""
        if self.initialized or self.broken:
            self._free_snapshot()
            self.binding.free_instance()
            self._instantiate()
        if self._initial is not None and self._initial[1] == _freeze(values):
            self._initialize_from(self._initial[0], values)
        else:
            self._initialize(values)
        if (self.reset_rung != "reinstantiate" and not self._verified
                and (self._reference is None or not self._reference.complete)):
            self._recording = Reference(values, _freeze(values), self.inputs, self.outputs)
            self.clock.recorder = self._recording.pointer

    def _recording_waits(self) -> bool:
        """Whether the reference waits for an episode that takes steps (then the recording is
        dropped): the user's inputs stir more of an FMU than its start values would. Up to
        `reference.WAIT` episodes of no step (as a checker's resets) each give way to a fresh one,
        with a re-instantiation."""
        if self._recording.count or self._empty_episodes >= WAIT or self.broken or not self.initialized:
            return False
        self._empty_episodes += 1
        self._recording = self.clock.recorder = None
        return True

    def _finish_recording(self) -> None:
        """End the recording of a fresh episode: continue it to `reference.STEPS` steps when it
        ended sooner (inputs held, on the same instance), and keep it if it is the longest yet."""
        reference = self._recording
        dt = float(reference.dts[reference.count - 1]) if reference.count else self.step_size
        self._written_inputs = self.inputs.snapshot()  # held, as the last step (maybe in C) wrote them
        try:
            while not reference.complete and dt and self.initialized and not self.broken and not self.terminated:
                self.step(dt)
        except FMUError as error:  # the reference ends here; the reset re-instantiates
            logger.debug("%s: the reference episode ended at step %d: %s", self.fmu_name, reference.count, error)
        finally:
            self._recording = self.clock.recorder = None
        if self._reference is None or reference.count > self._reference.count:
            self._reference = reference

    def _check_rung(self, key: tuple) -> None:
        """Before a rung serves its first episode, it must replay the reference; one that does not
        is dropped with a warning, and the next is checked, down to re-instantiation (exact)."""
        reference = self._reference
        while reference is not None and not self.broken:
            rung = self._rung_for(key)
            if rung == "reinstantiate" or rung in self._verified:
                return
            difference = self._replay(rung, reference)
            if RUNGS.index(self.reset_rung) > RUNGS.index(rung):
                continue  # it failed outright, and was dropped with its error
            if difference is None:
                self._verified.add(rung)
                return
            self._demote(rung, difference)

    def _replay(self, rung: str, reference: Reference) -> str | None:
        """Start an episode with the reference's values on ``rung`` and take its steps again: how
        it differs from the reference (for the warning), or None."""
        self.inputs.fill_start_values()  # as when the reference started
        if rung == "snapshot":
            if self._snapshot_key != reference.key and self._reset_and_initialize(reference.values) != "reset":
                return None
            served = self._restore_snapshot(reference.values)
        else:
            served = self._reset_and_initialize(reference.values)
        if served != rung:
            return None
        if self.outputs.snapshot() != reference.initial or self.time != self.start_time:
            return f"gave different initial outputs than a fresh instance ({describe(self.outputs)}; time {self.time})"
        for k in range(reference.count):
            self.inputs.load(reference.step_inputs(k))
            try:
                self.step(float(reference.dts[k]))
            except FMUError as error:
                return f"failed in step {k + 1} of {reference.count} that a fresh instance took ({error})"
            if not reference.equal_at(k, self.outputs):
                return (f"gave different outputs than a fresh instance in step {k + 1} of {reference.count} "
                        f"({describe(self.outputs)})")
        return None

    # -- lifecycle -------------------------------------------------------------------------------

    def _instantiate(self) -> None:
        self.binding.instantiate(self.logging_on)
        self.inputs.bind()
        self.outputs.bind()
        self._do_step = self.binding.do_step_call() if self.mode == "cs" else None
        self.broken = False
        self.initialized = False

    def _check_settable(self, values: Mapping[str, Any]) -> None:
        for name in values.keys() - self._settable_names:
            self.description.settable_variable(name)
            self._settable_names.add(name)

    def _initialize(self, values: dict[str, Any]) -> None:
        variables = self.description.variables
        structural = {n: v for n, v in values.items() if variables[n].causality == "structuralParameter"}
        rest = {n: v for n, v in values.items() if n not in structural}
        before = {n: v for n, v in rest.items() if variables[n].settable_before_initialization}
        during = {n: v for n, v in rest.items() if n not in before}
        try:
            if structural:  # FMI 3.0 only: they are set in configuration mode
                self.binding.configure(structural)
            self.binding.set_values(before)
            self.inputs.check(self.inputs.write(), "set inputs")
            self.initializations += 1
            self.binding.enter_initialization(self.start_time, self.stop_time, self.tolerance)
            self.binding.set_values(during)
            self.binding.exit_initialization()
            self.time = self.start_time
            terminated = self._integrator.start(self.time) if self._integrator is not None else False
        except FMUError:
            self.broken = True
            raise
        self.initialized = True
        self._after_initialization(values, take_snapshot=self.reset_rung == "snapshot")
        self.terminated = terminated

    def _after_initialization(self, values: dict[str, Any], take_snapshot: bool) -> None:
        self.time, self._origin, self._dt, self.steps = self.start_time, self.start_time, 0.0, 0
        self.terminated = False
        if take_snapshot:
            try:
                self._snapshot = self.binding.get_state(self._snapshot)
                self._snapshot_key = _freeze(values)
                self._snapshot_next_event = self._integrator.next_event_time if self._integrator else None
            except FMUCallError as error:
                self._demote("snapshot", f"failed ({error})")
        self.read_outputs()
        self.clock.log_errors = 0  # what initialization logged does not count against the first step

    def _free_snapshot(self) -> None:
        if self._snapshot is not None and self.binding is not None:
            self.binding.free_state(self._snapshot)
        self._snapshot = None
        self._snapshot_key = None

    # -- step outcomes ---------------------------------------------------------------------------

    def _step_status(self, status: int) -> None:
        if status == TERMINATED:
            self.terminated = True
            return
        self.broken = True
        raise self.binding.fail("fmiDoStep" if status != DISCARD else "fmiDoStep (discard without termination)", status)

    def _broken_by(self, what: str, status: int) -> None:
        self.broken = True
        raise self.binding.fail(what, status)
