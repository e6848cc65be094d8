"""An instance's state as a value: the FMU's serialized state and the importer's own bookkeeping.

`FMUInstance.save_state` makes an `FMUState`; `FMUInstance.load_state` puts one back, in this
process or another on a machine with the same FMU. What the FMU holds travels as the bytes of
``fmi2SerializeFMUstate`` / ``fmi3SerializeFMUState``; what the importer holds beside it travels
as plain fields: the clock (time as ``origin + steps * dt``, so it does not drift), whether the
model ended, and in model exchange what the solver needs to go on (the time event pending, which
FMUs announce only in event mode, and whether ``solver="cvode"`` switched to BDF).

A state is tied to one FMU by `FMUDescription.content_hash` (the GUID and the binary's SHA-256)
and its interface type: another FMU, or the same one rebuilt, refuses it (`StateMismatchError`),
since its bytes would be read as another layout.
"""

from __future__ import annotations

from dataclasses import dataclass

from modelicagym.fmu.errors import StateMismatchError

__all__ = ["FMUState"]


@dataclass(frozen=True)
class FMUState:
    """One instance's state, picklable: ``data`` (the FMU's serialized state) and what the
    importer keeps beside it."""

    fmu_name: str
    content_hash: str
    mode: str
    data: bytes
    time: float
    origin: float
    dt: float
    steps: int
    terminated: bool
    next_event_time: float | None = None
    stiff: bool = False

    def check_fits(self, fmu_name: str, content_hash: str, mode: str) -> None:
        """Refuse, with a line saying why, to load into an FMU other than the one saved from."""
        if content_hash != self.content_hash:
            raise StateMismatchError(
                f"{fmu_name}: this state was saved from {self.fmu_name} (content {self.content_hash}), not from "
                f"this FMU (content {content_hash}): a state loads only into the FMU it was saved from, unchanged")
        if mode != self.mode:
            raise StateMismatchError(f"{fmu_name}: this state was saved in mode {self.mode!r}, not {mode!r}")

    def __repr__(self) -> str:
        return f"FMUState({self.fmu_name}, mode={self.mode!r}, t={self.time}, {len(self.data):,} bytes)"
