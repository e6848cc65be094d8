"""The shared-memory ↔ C contract is one declaration (`SHARED_FIELDS`): the pool's buffers are
allocated from it, a native slice's ``mg_batch`` is filled from it, and a declaration that leaves a
C field unfilled (or fills one C does not have, or one twice) is refused with an error naming it."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import modelicagym
from modelicagym.errors import ModelicaGymError
from modelicagym.native.abi import MgBatch
from modelicagym.vector.slice.native_slice import SLICE_FIELDS, NativeBatch, check_batch_contract
from modelicagym.vector.wire.buffers import BufferSpec, SharedBuffers
from modelicagym.vector.wire.shared_fields import SHARED_FIELDS, Values


def without(c_field: str) -> tuple:
    """``SHARED_FIELDS`` with ``c_field`` filled from no field."""
    return tuple(dataclasses.replace(field, c_fields=tuple(name for name in field.c_fields if name != c_field))
                 for field in SHARED_FIELDS)


def test_the_packages_declaration_fills_every_c_field_once() -> None:
    check_batch_contract()
    filled = [name for field in SHARED_FIELDS for name in field.c_fields] + list(SLICE_FIELDS)
    assert sorted(filled) == sorted(name for name, _ in MgBatch._fields_)


@pytest.mark.parametrize("c_field", ["rewards", "timing", "final_obs", "obs_parts"])
def test_a_declaration_missing_a_c_field_is_refused_naming_it(c_field: str) -> None:
    with pytest.raises(ModelicaGymError, match=rf"mg_batch\.{c_field} is filled from no shared field"):
        check_batch_contract(without(c_field))


def test_a_declaration_filling_a_field_c_lacks_or_one_twice_is_refused_naming_it() -> None:
    rewards = next(field for field in SHARED_FIELDS if field.name == "rewards")
    extra = (*SHARED_FIELDS, dataclasses.replace(rewards, name="bonus", c_fields=("bonus",)))
    with pytest.raises(ModelicaGymError, match="'bonus' is filled but mg_batch has no such field"):
        check_batch_contract(extra)
    twice = (*SHARED_FIELDS, dataclasses.replace(rewards, name="rewards_again"))
    with pytest.raises(ModelicaGymError, match=r"mg_batch\.rewards is filled 2 times"):
        check_batch_contract(twice)


@contextmanager
def cartpole_buffers() -> Iterator[tuple[list, SharedBuffers]]:
    """Three cart-poles, and a pool's buffers for four envs in three slots."""
    envs = [modelicagym.make("cartpole") for _ in range(3)]
    spec = BufferSpec(envs[0].observation_space, envs[0].action_space, num_envs=4, num_workers=3)
    buffers, fd = SharedBuffers.create(spec)
    try:
        yield envs, buffers
    finally:
        os.close(fd)
        for env in envs:
            env.close()


def test_a_native_slice_is_not_built_from_a_declaration_that_leaves_a_c_field_unfilled() -> None:
    with cartpole_buffers() as (envs, buffers):
        with pytest.raises(ModelicaGymError, match=r"mg_batch\.needs_reset is filled from no shared field"):
            NativeBatch(envs, 1, AutoresetMode.NEXT_STEP, buffers, slot=2, caller=False, fields=without("needs_reset"))
        # each C field once, but one under a field that cannot fill it: named at the fill
        moved = tuple(dataclasses.replace(field, c_fields=(*field.c_fields, "scratch")) if field.name == "rewards"
                      else field for field in without("scratch"))
        with pytest.raises(ModelicaGymError, match="shared field 'rewards' declares mg_batch fields"):
            NativeBatch(envs, 1, AutoresetMode.NEXT_STEP, buffers, slot=2, caller=False, fields=moved)


def test_the_buffers_are_allocated_and_the_c_struct_filled_from_the_declaration() -> None:
    with cartpole_buffers() as (envs, buffers):
        spec = buffers.spec
        for field in SHARED_FIELDS:
            value = getattr(buffers, field.name)
            if isinstance(field.dtype, Values):
                value = value.read_batch(copy_out=False)
                assert value.shape[0] == spec.num_envs, field.name
            else:
                assert (value.dtype, value.shape) == (np.dtype(field.dtype), field.shape(4, 3)), field.name
        batch = NativeBatch(envs, 1, AutoresetMode.NEXT_STEP, buffers, slot=2, caller=False)
        for field in SHARED_FIELDS:
            if field.c_fields and not isinstance(field.dtype, Values):
                array = getattr(buffers, field.name)
                row = field.rows.row(first_env=1, slot=2)
                assert getattr(batch.state, field.c_fields[0]) == array.ctypes.data + row * array.strides[0], field.name
        observations = buffers.observations.read_batch(copy_out=False)
        assert batch.state.observations == observations[1:].ctypes.data
        assert batch.state.obs_stride == observations.strides[0]
        assert batch.state.final_obs == buffers.final_observations.read_batch(copy_out=False)[1:].ctypes.data
        assert batch.state.actions == buffers.actions.read_batch(copy_out=False)[1:].ctypes.data
