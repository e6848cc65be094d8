"""Shared memory of the pool: one anonymous mapping, one numpy array per field.

The mapping is created by the parent once worker 0 has reported the spaces (it cannot exist before:
the spaces come from an env, and envs only ever live in workers), and its file descriptor is handed
to each worker over its pipe. It has no name anywhere (``memfd_create``, or an unlinked temporary
file where that is missing), so nothing can leak in ``/dev/shm``: the memory is freed when the last
process that maps it exits, however it exits.

Fields are declared once, in `modelicagym.vector.wire.shared_fields` (``SHARED_FIELDS``: name, dtype,
shape, the C field a native slice fills from it): observations and actions (any space Gymnasium's
shared-memory helpers support), rewards, terminations, truncations, the masks, and per worker a
command slot, a reply slot, the index of the env being run (to name it when the worker dies),
timing counters and its two signals; and the step's barrier. Each field starts on a cache line of its own.

Spaces made of ``Box``/``Discrete``/``MultiDiscrete``/``MultiBinary`` (also nested in
``Dict``/``Tuple``) are read and written through numpy views made once; a top-level array space
(the common case) is a plain ``view[i] = value``. Other spaces (``Text``, ``OneOf``) go through
Gymnasium's ``read_from_shared_memory``/``write_to_shared_memory`` on every access. A space with no
shared-memory layout at all (a custom ``Space`` subclass, ``Graph``, ``Sequence``) is a :class:`PickledBatch`: its values
live in each process and travel pickled on the workers' pipes (see `modelicagym.vector.wire.protocol`).
"""

from __future__ import annotations

import copy
import ctypes
import itertools
import mmap
import os
import tempfile
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import Space
from gymnasium.error import CustomSpaceError
from gymnasium.spaces import Box, Dict, Discrete, MultiBinary, MultiDiscrete, Tuple
from gymnasium.vector.utils import (
    batch_space,
    concatenate,
    create_empty_array,
    create_shared_memory,
    iterate,
    read_from_shared_memory,
    write_to_shared_memory,
)

from modelicagym.errors import ArgumentError
from modelicagym.vector.wire.protocol import same_step_info
from modelicagym.vector.wire.shared_fields import CACHE_LINE, SHARED_FIELDS, Values

__all__ = ["BufferSpec", "PickledBatch", "SharedBatch", "SharedBuffers", "has_shared_layout"]

_ALIGNMENT = CACHE_LINE
_ARRAY_SPACES = (Box, Discrete, MultiDiscrete, MultiBinary)


def _has_static_views(space: Space) -> bool:
    """Whether ``read_from_shared_memory`` returns views that stay valid (no copies, no strings)."""
    if isinstance(space, _ARRAY_SPACES):
        return True
    if isinstance(space, Dict):
        return all(_has_static_views(sub) for sub in space.spaces.values())
    if isinstance(space, Tuple):
        return all(_has_static_views(sub) for sub in space.spaces)
    return False


def _item(batch: Any, index: int) -> Any:
    """Element ``index`` of a batch of static views, copied out of shared memory."""
    if isinstance(batch, np.ndarray):
        value = batch[index]
        return value.copy() if isinstance(value, np.ndarray) else value
    if isinstance(batch, dict):
        return {key: _item(sub, index) for key, sub in batch.items()}
    return tuple(_item(sub, index) for sub in batch)


def _put(batch: Any, index: int, value: Any) -> None:
    """Store ``value`` as element ``index`` of a batch of static views (what Gymnasium's
    ``write_to_shared_memory`` does, without its per-key buffer views: ~0.3 µs a key, not ~5)."""
    if type(batch) is np.ndarray:
        batch[index] = value
    elif isinstance(batch, dict):
        for key, sub in batch.items():
            _put(sub, index, value[key])
    else:
        for sub, item in zip(batch, value, strict=True):
            _put(sub, index, item)


def _copied(batch: Any) -> Any:
    """A batch of static views copied out of shared memory, same structure (a dict or tuple of
    arrays): what ``copy.deepcopy`` gives, at a quarter of its cost (it memoizes every node)."""
    if type(batch) is np.ndarray:
        return batch.copy()
    if isinstance(batch, dict):
        copied = {key: sub.copy() if type(sub) is np.ndarray else _copied(sub) for key, sub in batch.items()}
        return copied if type(batch) is dict else type(batch)(copied)
    return tuple(_copied(sub) for sub in batch)


def _observed(space: Space, batch: Any, index: int) -> Any:
    """Element ``index`` of a batch of static views as an env returns it (see `SharedBatch.read_observation`)."""
    if isinstance(space, Dict):
        return {key: _observed(sub, batch[key], index) for key, sub in space.spaces.items()}
    if isinstance(space, Discrete):
        return batch[index]
    return batch[index, ...].copy()


def _assign(batch: Any, values: Any) -> None:
    """Copy a batch of values into a batch of static views of the same structure."""
    if isinstance(batch, np.ndarray):
        array = np.asarray(values)
        if array.shape != batch.shape:
            raise ArgumentError(f"expected a batch of shape {batch.shape}, got {array.shape}")
        batch[...] = array
    elif isinstance(batch, dict):
        for key, sub in batch.items():
            _assign(sub, values[key])
    else:
        for sub, value in zip(batch, values, strict=True):
            _assign(sub, value)


class _Region:
    """A slice of the mapping, shaped like the ``multiprocessing.Array`` Gymnasium's helpers expect."""

    __slots__ = ("_buffer",)

    def __init__(self, buffer: memoryview | None) -> None:
        self._buffer = buffer

    def get_obj(self) -> memoryview | None:
        return self._buffer


class _Allocator:
    """Hands out aligned regions of one buffer, in call order.

    It stands in for the ``ctx`` argument of Gymnasium's ``create_shared_memory`` (which only calls
    ``ctx.Array(typecode, size)``), so the same deterministic layout is computed in every process.
    Without a buffer it only measures the size.
    """

    def __init__(self, buffer: memoryview | None = None) -> None:
        self._buffer = buffer
        self.size = 0

    @property
    def measuring(self) -> bool:
        """Whether this allocator only measures (has no buffer)."""
        return self._buffer is None

    def Array(self, typecode: Any, size: int) -> _Region:
        itemsize = ctypes.sizeof(typecode) if isinstance(typecode, type) else np.dtype(typecode).itemsize
        start = -(-self.size // _ALIGNMENT) * _ALIGNMENT
        self.size = start + itemsize * size
        if self._buffer is None:
            return _Region(None)
        return _Region(self._buffer[start : self.size])

    def array(self, dtype: type, shape: tuple[int, ...]) -> np.ndarray:
        """A numpy array of ``dtype`` and ``shape`` in the next region."""
        region = self.Array(np.dtype(dtype).char, int(np.prod(shape)))
        if self._buffer is None:
            return np.zeros(shape, dtype=dtype)
        return np.frombuffer(region.get_obj(), dtype=dtype).reshape(shape)


def has_shared_layout(space: Space) -> bool:
    """Whether values of ``space`` can live in shared memory: Gymnasium knows a static layout for it
    (not for a custom ``Space`` subclass, nor for spaces of dynamic shape: ``Graph``, ``Sequence``)."""
    try:
        create_shared_memory(space, n=1, ctx=_Allocator())
    except (CustomSpaceError, TypeError):
        return False
    return True


class SharedBatch:
    """A batch of ``n`` values of ``space`` in shared memory; each process writes its own indices."""

    #: values travel in shared memory, not on the pipes
    pickled = False

    def __init__(self, space: Space, n: int, allocator: _Allocator) -> None:
        self.space = space
        self.n = n
        self._batch_space = batch_space(space, n)
        self._memory = create_shared_memory(space, n=n, ctx=allocator)
        static = not allocator.measuring and _has_static_views(space)
        self._views = read_from_shared_memory(space, self._memory, n=n) if static else None
        self._array = self._views if isinstance(self._views, np.ndarray) else None
        #: a Dict of one value per env and key (scalar entries, the FMUs' common case): its views, flat
        views = self._views
        scalars = type(views) is dict and all(type(view) is np.ndarray and view.ndim == 1 for view in views.values())
        self._scalar_views = list(views.items()) if scalars else None

    def write(self, index: int, value: Any) -> None:
        """Store the value of env ``index``."""
        if self._array is not None:
            self._array[index] = value
        elif self._scalar_views is not None:
            for key, view in self._scalar_views:
                view[index] = value[key]
        elif self._views is not None:
            _put(self._views, index, value)
        else:
            write_to_shared_memory(self.space, index, value, self._memory)

    def read(self, index: int) -> Any:
        """The value of env ``index``, copied out of shared memory."""
        if self._array is not None:
            value = self._array[index]
            return value.copy() if isinstance(value, np.ndarray) else value
        if self._scalar_views is not None:  # as `_item` gives it, a third of its cost
            return {key: view[index] for key, view in self._scalar_views}
        if self._views is not None:
            return _item(self._views, index)
        batch = read_from_shared_memory(self.space, self._memory, n=self.n)
        return copy.deepcopy(next(itertools.islice(iterate(self._batch_space, batch), index, None)))

    def read_rows(self, start: int, stop: int, dtype: np.dtype | None = None) -> Any:
        """The values of envs ``start..stop-1``, copied out of shared memory in one go: item ``i``
        is env ``start + i``'s value as `read` gives it, in ``dtype`` if given (which only a batch
        of one array has: `SharedBuffers.action_dtype`). For a loop over the envs of a slice."""
        if self._array is not None:
            rows = self._array[start:stop]
            return rows.copy() if dtype is None else rows.astype(dtype)
        return [self.read(index) for index in range(start, stop)]

    def targets(self) -> Any:
        """Where ``targets[index] = value`` stores the value of env ``index``, for a loop over the
        envs of a slice: the shared array itself for a batch of one array (the fastest), else this
        batch (`write`)."""
        return self if self._array is None else self._array

    __setitem__ = write

    def read_observation(self, index: int) -> Any:
        """The value of env ``index`` as an env returns it, copied out: a ``Discrete`` value as a
        numpy integer, a ``Box`` of shape ``()`` as a 0-d array (where `read` gives the scalar
        ``iterate`` would, as actions are handed to envs), a ``Dict`` as a dict of those."""
        if self._views is not None and isinstance(self.space, (Dict, *_ARRAY_SPACES)):
            return _observed(self.space, self._views, index)
        return self.read(index)

    def write_batch(self, values: Any) -> None:
        """Store a whole batch (an element of the batched space)."""
        array = self._array
        if array is not None and type(values) is np.ndarray and values.shape == array.shape:
            array[...] = values
        elif self._views is not None:
            _assign(self._views, values)
        else:
            for index, value in enumerate(iterate(self._batch_space, values)):
                write_to_shared_memory(self.space, index, value, self._memory)

    def read_batch(self, copy_out: bool) -> Any:
        """The whole batch; views of the shared memory unless ``copy_out``."""
        if self._array is not None:
            return self._array.copy() if copy_out else self._array
        if self._views is not None:
            return _copied(self._views) if copy_out else self._views
        return read_from_shared_memory(self.space, self._memory, n=self.n)


class PickledBatch:
    """A batch of ``n`` values of a space with no shared-memory layout, held in this process.

    Same interface as :class:`SharedBatch`; what one process writes reaches the other only as the
    pickled values the protocol carries (:meth:`values` on one side, :meth:`store` on the other).
    """

    pickled = True

    def __init__(self, space: Space, n: int) -> None:
        self.space = space
        self.n = n
        self._batch_space = batch_space(space, n)
        self._values: list[Any] = [None] * n

    def write(self, index: int, value: Any) -> None:
        """Store the value of env ``index``."""
        self._values[index] = value

    def read(self, index: int) -> Any:
        """The value of env ``index`` (a copy: the caller may keep it)."""
        return copy.deepcopy(self._values[index])

    def read_rows(self, start: int, stop: int, dtype: np.dtype | None = None) -> list[Any]:
        """The values of envs ``start..stop-1`` (copies; ``dtype`` is for a batch of one array)."""
        return [self.read(index) for index in range(start, stop)]

    def targets(self) -> PickledBatch:
        """Where ``targets[index] = value`` stores the value of env ``index``: this batch (`write`)."""
        return self

    __setitem__ = write

    def read_observation(self, index: int) -> Any:
        """The value of env ``index`` as an env returns it (as stored: a copy)."""
        return self.read(index)

    def write_batch(self, values: Any) -> None:
        """Store a whole batch (an element of the batched space)."""
        self._values[:] = list(iterate(self._batch_space, values))

    def read_batch(self, copy_out: bool) -> Any:
        """The whole batch, as Gymnasium's ``concatenate`` builds it."""
        values = copy.deepcopy(self._values) if copy_out else self._values
        return concatenate(self.space, values, create_empty_array(self.space, self.n))

    def values(self, indices: range) -> list[Any]:
        """The values of envs ``indices``, to send to the other side."""
        return self._values[indices.start : indices.stop]

    def store(self, first: int, values: list[Any]) -> None:
        """Take the values of envs ``first, first + 1, ...`` sent by the other side."""
        self._values[first : first + len(values)] = values


def action_storage_space(space: Space) -> Space:
    """How actions of ``space`` are kept in shared memory: a float ``Box`` as float64, so that
    an action given in float64 reaches its env unchanged, as ``SyncVectorEnv`` hands it over (see
    ``SharedBuffers.action_dtype``); any other space as itself."""
    if type(space) is Box and space.dtype.kind == "f" and space.dtype != np.float64:
        return Box(space.low.astype(np.float64), space.high.astype(np.float64), space.shape, np.float64)
    return space


def _batch(space: Space, n: int, allocator: _Allocator) -> SharedBatch | PickledBatch:
    """The batch for ``space``: in shared memory when it has a layout there, else pickled."""
    return SharedBatch(space, n, allocator) if has_shared_layout(space) else PickledBatch(space, n)


@dataclass(frozen=True)
class BufferSpec:
    """Everything needed to lay out the shared memory identically in every process."""

    observation_space: Space
    action_space: Space
    num_envs: int
    num_workers: int


class SharedBuffers:
    """All shared arrays of a pool, laid out in one mapping (see the module docstring): one
    attribute per field of `SHARED_FIELDS` (`modelicagym.vector.wire.shared_fields`), allocated in its
    order; a field of array values is a numpy array, one of observations or actions a
    :class:`SharedBatch` (or :class:`PickledBatch`)."""

    #: timing counters per worker: env time and FMU time of the last step, in nanoseconds
    ENV_NS, FMU_NS = 0, 1

    def __init__(self, spec: BufferSpec, buffer: memoryview | None) -> None:
        n, w = spec.num_envs, spec.num_workers
        allocator = _Allocator(buffer)
        self.spec = spec
        spaces = {Values.OBSERVATION: spec.observation_space, Values.ACTION: action_storage_space(spec.action_space)}
        for field in SHARED_FIELDS:
            if isinstance(field.dtype, Values):
                setattr(self, field.name, _batch(spaces[field.dtype], n, allocator))
            else:
                setattr(self, field.name, allocator.array(field.dtype, field.shape(n, w)))
        self.nbytes = allocator.size

    GO, DONE = 0, 1

    def take_final_ready(self, first: int = 0, stop: int | None = None) -> np.ndarray:
        """The indices among ``first..stop-1`` of the envs the native step reset in the last
        ``SAME_STEP`` step (their ``final_ready`` marks, which taking clears)."""
        ready = np.flatnonzero(self.final_ready[first:stop])
        if ready.size:
            ready += first
            self.final_ready[ready] = 0
        return ready

    def final_info(self, index: int) -> dict[str, Any]:
        """The info ``SyncVectorEnv`` reports for env ``index`` reset in a ``SAME_STEP`` step by
        the native step (`take_final_ready`): its final observation and its (empty) final info."""
        return same_step_info(self.final_observations.read_observation(index), {}, {})

    def signal_address(self, slot: int, which: int) -> int:
        """Where the ``GO`` or ``DONE`` signal of ``slot`` lives in this process."""
        return self.signals.ctypes.data + self.signals[slot, which].nbytes * (2 * slot + which)

    @property
    def barrier_address(self) -> int:
        """Where the step's barrier (``mg_barrier``) lives in this process."""
        return self.barrier.ctypes.data

    @staticmethod
    def size_of(spec: BufferSpec) -> int:
        """Bytes needed for ``spec``."""
        return max(SharedBuffers(spec, None).nbytes, 1)

    @classmethod
    def create(cls, spec: BufferSpec) -> tuple[SharedBuffers, int]:
        """Allocate zeroed shared memory for ``spec``; returns the buffers and the file descriptor
        to hand to the workers (the caller closes it)."""
        size = cls.size_of(spec)
        fd = _anonymous_fd()
        try:
            os.ftruncate(fd, size)
            buffers = cls.attach(spec, fd)
            buffers.step_mask[:] = 1
            return buffers, fd
        except BaseException:
            os.close(fd)
            raise

    @classmethod
    def attach(cls, spec: BufferSpec, fd: int) -> SharedBuffers:
        """Map the shared memory behind ``fd`` (the descriptor stays open; the caller owns it)."""
        return cls(spec, _map_shared(fd, cls.size_of(spec)))


class _Mapping:
    """A ``MAP_SHARED`` mapping made with libc's ``mmap``, unmapped when the last view of it goes.

    Python's ``mmap.mmap`` keeps a duplicate of the file descriptor until the object is garbage
    collected (which a traceback holding a view can delay indefinitely); a mapping needs no
    descriptor once made, so the pool's descriptor is the only one and closes when the pool does.
    """

    _libc = ctypes.CDLL(None, use_errno=True)
    _libc.mmap.restype = ctypes.c_void_p
    _libc.mmap.argtypes = (ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_long)
    _libc.munmap.argtypes = (ctypes.c_void_p, ctypes.c_size_t)

    def __init__(self, fd: int, size: int) -> None:
        address = self._libc.mmap(None, size, mmap.PROT_READ | mmap.PROT_WRITE, mmap.MAP_SHARED, fd, 0)
        if address in (None, ctypes.c_void_p(-1).value):
            error = ctypes.get_errno()
            raise OSError(error, f"mmap of the pool's shared memory failed: {os.strerror(error)}")
        self.address, self.size = address, size

    def __del__(self) -> None:
        self._libc.munmap(self.address, self.size)


def _map_shared(fd: int, size: int) -> memoryview:
    """A writable view of ``size`` bytes of ``fd``, mapped shared; the view keeps the mapping alive."""
    mapping = _Mapping(fd, size)
    data = (ctypes.c_char * size).from_address(mapping.address)
    data.mapping = mapping  # the view holds ``data``, ``data`` holds the mapping
    return memoryview(data).cast("B")


def _anonymous_fd() -> int:
    """A file descriptor of fresh memory-backed storage that has no name in any file system."""
    if hasattr(os, "memfd_create"):
        return os.memfd_create("modelicagym-pool", os.MFD_CLOEXEC)
    directory = "/dev/shm" if os.path.isdir("/dev/shm") else None
    fd, path = tempfile.mkstemp(prefix="modelicagym-pool-", dir=directory)
    os.unlink(path)
    return fd
