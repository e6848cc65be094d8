/* A slice whose rewards or terminations are written in Python, stepped natively all the same.
 *
 * An FMUEnv on the native path may leave how its step ends to Python: an overridden reward or
 * termination, a callable in its config, or one written on arrays (modelicagym/env/endings.py).
 * Its FMU still steps in C; the pool's slice then takes three moves instead of mg_step_batch's one
 * (modelicagym/vector/slice/slice_endings.py):
 *
 *   1. mg_step_open: mg_step_batch without autoreset (in SAME_STEP the batch's mode is DISABLED,
 *      so that no env is reset before Python has seen how its step ended), and `open` marks the
 *      envs whose step Python must end: stepped here, no FMU error, not a reset;
 *   2. Python writes their rewards and terminations (one call on arrays per group of envs);
 *   3. mg_end_steps applies the pool's autoreset to them: NEXT_STEP marks the ended envs' next
 *      step as their reset, SAME_STEP keeps their final observation and resets them now, as
 *      mg_step_batch would have.
 */
#ifndef MG_ENDINGS_H
#define MG_ENDINGS_H

#include <stdint.h>

#include "slice.h"

/* Step the slice (mg_step_batch) and mark in open[i] the envs whose step Python must end;
 * returns how many are marked. */
int64_t mg_step_open(mg_batch *batch, uint8_t *open);

/* The autoreset of `autoreset_mode` (the pool's) for the envs marked in open[], from the
 * terminations and truncations the batch holds now (Python wrote the terminations); flags as
 * mg_step_batch sets them. Returns how many envs of the slice Python must finish, as
 * mg_step_batch does. */
int64_t mg_end_steps(mg_batch *batch, int32_t autoreset_mode, const uint8_t *open);

#endif
